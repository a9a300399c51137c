"""The BRDF interface, the model registry and numerical directional albedo.

Every model works in the local shading frame (vectors.py) on arrays of any
leading shape: ``f(wi, wo)`` returns f_r (1/sr, no cosine) as (..., 3) RGB and
is zero when either direction is below the horizon; ``sample(wo, u)`` maps
uniforms u (..., 2) in [0, 1) to directions wi (..., 3) with their
probability density ``pdf(wi, wo)`` (1/sr, over the whole sphere; samples
below the horizon carry zero BRDF); ``albedo(wo)`` is the directional albedo
rho(wo) = integral of f(wi, wo) cos(theta_i) d omega_i, (..., 3).
"""

import hashlib
from collections import OrderedDict

import numpy as np

from .params import Param, SpecError, format_value, parse_pairs
from .vectors import cosine_hemisphere

__all__ = ["BRDF", "REGISTRY", "register", "hammersley", "SpecError", "Param"]

REGISTRY: dict = {}
_ALBEDO_CACHE: OrderedDict = OrderedDict()
_ALBEDO_CACHE_SIZE = 512


def register(cls):
    """Class decorator: make a model available to ``parse`` under ``cls.name``."""
    REGISTRY[cls.name] = cls
    return cls


def hammersley(n: int, shift=(0.5, 0.5)) -> np.ndarray:
    """n 2D low-discrepancy points in [0, 1)^2, (n, 2), with a fixed toroidal shift."""
    i = np.arange(n, dtype=np.uint64)
    bits = i.copy()
    bits = ((bits << np.uint64(16)) | (bits >> np.uint64(16))) & np.uint64(0xFFFFFFFF)
    for shift_bits, mask in ((1, 0x55555555), (2, 0x33333333), (4, 0x0F0F0F0F), (8, 0x00FF00FF)):
        m = np.uint64(mask)
        s = np.uint64(shift_bits)
        bits = ((bits & m) << s) | ((bits >> s) & m)
    radical = bits.astype(np.float64) / 2.0**32
    points = np.stack([(i.astype(np.float64) + 0.5) / n, radical], -1)
    return np.mod(points + np.asarray(shift), 1.0)


class BRDF:
    """Base class of every model. Subclasses set ``name``, ``PARAMS`` and ``_f``."""

    name = ""
    PARAMS: tuple = ()
    #: f(wi, wo) == f(wo, wi); models that break it say so (Cycles' A-S, multiscatter).
    reciprocal = True
    isotropic = True
    albedo_samples = 4096

    def __init__(self, **values):
        self.params = self._resolve(values)
        self._setup()

    # --- construction ----------------------------------------------------
    @classmethod
    def _resolve(cls, values: dict) -> dict:
        known = {p.name: p for p in cls.PARAMS}
        unknown = [k for k in values if k not in known]
        if unknown:
            allowed = ", ".join(known) or "none"
            raise SpecError(f"{cls.name}: unknown key {unknown[0]!r} (allowed: {allowed})")
        params = {}
        for p in cls.PARAMS:
            if p.name in values:
                params[p.name] = p.convert(cls.name, values[p.name])
            elif p.default is not None:
                params[p.name] = p.convert(cls.name, p.default)
        return cls._derive(params, set(values))

    @classmethod
    def _derive(cls, params: dict, given: set) -> dict:
        """Hook: check combinations, fill derived values. Returns the params."""
        missing = [p.name for p in cls.PARAMS if p.name not in params]
        if missing:
            raise SpecError(f"{cls.name}: missing {missing[0]}")
        return params

    def _setup(self):
        """Hook: precompute arrays from self.params."""

    @classmethod
    def from_pairs(cls, text: str):
        return cls(**parse_pairs(text, cls.name))

    # --- identity ----------------------------------------------------------
    @property
    def spec(self) -> str:
        """Canonical spec string: parses back to an equal model."""
        body = ",".join(f"{k}={format_value(v)}" for k, v in self.params.items())
        return f"{self.name}:{body}" if body else self.name

    def spec_hash(self) -> str:
        """Stable hex digest of the canonical spec (for caches and file metadata)."""
        return hashlib.sha256(self.spec.encode()).hexdigest()[:16]

    def __repr__(self):
        return f"<BRDF {self.spec}>"

    def __eq__(self, other):
        return isinstance(other, BRDF) and other.spec == self.spec

    def __hash__(self):
        return hash(self.spec)

    # --- evaluation --------------------------------------------------------
    def f(self, wi, wo) -> np.ndarray:
        """f_r(wi, wo), (..., 3) float64; 0 where wi or wo is below the horizon.

        wi and wo broadcast against each other; ``_f`` gets them as given, so
        terms of one direction alone (a view's Fresnel and energy tables, say)
        are computed once per view when wo is (M, 1, 3) against wi (M, K, 3)."""
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        shape = np.broadcast_shapes(wi.shape, wo.shape)
        above = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        with np.errstate(all="ignore"):
            value = np.asarray(self._f(wi, wo), dtype=np.float64)
        value = np.broadcast_to(value, shape)
        return np.where(above[..., None] & np.isfinite(value), value, 0.0)

    def _f(self, wi, wo):
        raise NotImplementedError

    # --- sampling ------------------------------------------------------------
    def sample(self, wo, u):
        """Directions wi (..., 3) and their pdf (...) from uniforms u (..., 2).

        The default samples the cosine-weighted hemisphere; models with a lobe
        override it (and ``pdf``).
        """
        wo = np.asarray(wo, dtype=np.float64)
        u = np.asarray(u, dtype=np.float64)
        wi, pdf = cosine_hemisphere(u)
        shape = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
        return np.broadcast_to(wi, (*shape, 3)), np.broadcast_to(pdf, shape)

    def pdf(self, wi, wo):
        """Density (1/sr) with which ``sample(wo, .)`` produces wi."""
        wi = np.asarray(wi, dtype=np.float64)
        return np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0) + 0.0 * np.asarray(wo)[..., 0]

    # --- albedo ------------------------------------------------------------------
    def albedo(self, wo, samples: int | None = None) -> np.ndarray:
        """Directional albedo rho(wo) (..., 3), by numerical integration (cached).

        Multiple importance sampling (balance heuristic) of the model's own
        sampler and the cosine hemisphere, each with ``samples`` Hammersley
        points: accurate for sharp lobes (own sampler) and for flat or
        tabulated models (cosine).
        """
        wo = np.asarray(wo, dtype=np.float64)
        n = int(samples or self.albedo_samples)
        key = (self.spec, n, wo.shape, wo.tobytes())
        if key in _ALBEDO_CACHE:
            _ALBEDO_CACHE.move_to_end(key)
            return _ALBEDO_CACHE[key].copy()
        flat = wo.reshape(-1, 3)
        out = np.empty((flat.shape[0], 3))
        u = hammersley(n)
        chunk = max(1, (1 << 20) // n)
        for start in range(0, flat.shape[0], chunk):
            w = flat[start:start + chunk, None, :]
            out[start:start + chunk] = self._mis_albedo(w, u)
        result = out.reshape(*wo.shape[:-1], 3)
        _ALBEDO_CACHE[key] = result.copy()
        if len(_ALBEDO_CACHE) > _ALBEDO_CACHE_SIZE:
            _ALBEDO_CACHE.popitem(last=False)
        return result

    def _mis_albedo(self, wo, u):
        n = u.shape[0]
        total = 0.0
        wi_own, _ = self.sample(wo, u)
        wi_cos, _ = cosine_hemisphere(u[:, ::-1])
        wi_cos = np.broadcast_to(wi_cos, wi_own.shape)
        for wi in (wi_own, wi_cos):
            with np.errstate(all="ignore"):
                density = self.pdf(wi, wo) + np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0)
                weight = np.where(density > 0, np.clip(wi[..., 2], 0, None) / density, 0.0)
            total = total + np.sum(self.f(wi, wo) * weight[..., None], axis=-2)
        return total / n


def parse_model(spec: str) -> BRDF:
    """One ``name:key=value,...`` model (no composition)."""
    spec = spec.strip()
    name, _, body = spec.partition(":")
    name = name.strip().lower()
    if name not in REGISTRY:
        known = ", ".join(sorted(REGISTRY))
        raise SpecError(f"unknown BRDF {name!r} (known: {known})")
    return REGISTRY[name].from_pairs(body)
