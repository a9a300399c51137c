"""Cycles' Principled BSDF (Blender 4.x/5.0) as one reflectance model: coat, metal,
dielectric specular and diffuse, layered as Cycles layers them.

Source: Cycles v5.0 ``kernel/svm/closure.h`` (the Principled case),
``kernel/closure/bsdf_microfacet.h`` (Fresnel models, energy preservation and
the albedo estimate that weights the lower layers). Every quantity is in the
local shading frame (z = normal, x = the anisotropy tangent before
``rotation``); ``wo`` is the view (Cycles' ``sd->wi``), mu = wo_z, and every
GGX lobe is Cycles' single-scatter GGX with height-correlated Smith G2.

The layers, from the top (W is the weight left for the layers below, 1 at
first; ``saturate`` clamps to [0, 1]; max_c is the largest RGB channel):

1. Coat (``coat_weight`` > 0): isotropic GGX, alpha_c = coat_roughness^2,
   exact dielectric Fresnel F(h.wo, coat_ior), always energy-preserving:
   f_coat = coat_weight f_GGX F (1 + Fms (1 - E) / E). Below it
   W = saturate(1 - coat_weight (E + Fms (1 - E)) mix(F0, 1, s(mu))) times
   mix(1, coat_tint^(1 / cos theta_t), coat_weight) with
   cos theta_t = sqrt(1 - (1 - mu^2) / coat_ior^2).
2. Metal (weight metallic W): GGX (alpha = roughness^2 and the Principled
   anisotropy, aspect = sqrt(1 - 0.9 A), ax = alpha / aspect, ay = alpha aspect)
   with the F82-tint Fresnel of PrincipledMetallic (F0 = base_color,
   F82 tint = specular_tint); then W *= 1 - metallic. With ``conductor_ior`` n
   and ``conductor_extinction`` k (both RGB, given together) the metal's Fresnel
   is instead the exact unpolarized Fresnel of a conductor of index n + i k
   (bake.brdf.fresnel.conductor), and its Fss that of the F82 model through the
   conductor's values at c = 1 and c = 1/7: Cycles' Metallic BSDF with Fresnel
   Type Physical Conductor (``kernel/closure/bsdf_util.h``,
   ``fresnel_conductor`` and ``fresnel_conductor_Fss``). Its F82 Tint type is
   this model's metal as is (Edge Tint = specular_tint).
3. Specular (weight W): the same GGX with the generalized-Schlick Fresnel of
   an IOR adjusted by ``specular_ior_level`` (F0 = F0(ior) 2 level, eta from that
   F0): F = mix(F0 tint, 1, saturate((F_real(h.wo, eta) - F0(eta)) / (1 - F0(eta)))).
   Below it W *= saturate(1 - max_c(k mix(F0 tint, 1, s(mu)))), k = E + Fms (1 - E)
   with Multiscatter GGX, 1 with GGX.
4. Diffuse: W base_color / pi (Lambert; Diffuse Roughness 0).

Multiscatter GGX (``multiscatter=1``, the node's default) multiplies a lobe by
1 + Fms (1 - E(mu)) / E(mu) with Fms = Fss E_avg / (1 - Fss (1 - E_avg)), Fss the
hemispherical average of the lobe's Fresnel (dielectric: 2 int F(mu) mu dmu;
F82: mix(F0, 1, 1/21) - B / 126); the coat always does.

E(mu) is the single-scatter albedo of isotropic GGX with alpha = sqrt(ax ay)
and s(mu) = E_F(mu) / E(mu) the lobe's average of the Fresnel blend factor,
both integrated here by sampling visible normals (4096 points per node, 64
nodes in mu, linear interpolation). Cycles reads them from its own 32 x 32 and
16^3 tables: the two differ by about 1e-3 (the Cycles tests in
tests/blender/test_principled_reader.py measure it). The weights below the
top layer depend on the view only, so the model is not reciprocal.

Ignored here (glossy_addon.node_reader lists them): transmission, subsurface,
sheen, thin film, emission, alpha, a diffuse roughness above 0 (Cycles'
Oren-Nayar) and a coat normal other than the normal.
"""

import functools

import numpy as np

from ..envmap.grid import gauss_legendre
from . import fresnel
from .base import BRDF, register
from .microfacet import ggx_d, ggx_lambda, reflect_about, sample_ggx_vndf
from .params import Param
from .vectors import broadcast_wo_u, cosine_hemisphere, dot, half_vector, rotate_z

__all__ = ["Principled", "ggx_albedo_tables", "dielectric_hemispherical_average"]

_MIN_ALPHA = 1e-7
_MU = np.linspace(0.0, 1.0, 65)[1:]  # 64 nodes, mu = 1/64 ... 1
_TABLES: dict = {}


@functools.lru_cache(maxsize=256)
def dielectric_hemispherical_average(eta: float) -> float:
    """Fss = 2 int_0^1 F_dielectric(mu, eta) mu dmu (64-node Gauss-Legendre; cached per
    eta, as every evaluation of a Principled BRDF asks for it)."""
    mu, w = gauss_legendre(64)
    return float(2.0 * np.sum(w * fresnel.dielectric(mu, float(eta)) * mu))


def _channel(value, k):
    """Channel k of a factor that is a scalar, (..., 1) or (..., 3); a multiplier's
    (Fms (3,), q (...)) parts give 1 + Fms_k q."""
    if isinstance(value, tuple):
        if isinstance(value[0], str):  # ("darkening", Fms, E)
            _, fms, e = value
            return e + fms[k] * (1.0 - e)
        fms, q = value
        return 1.0 + fms[k] * q
    if np.ndim(value) == 0:
        return value
    return value[..., 0] if value.shape[-1] == 1 else value[..., k]


def _channel_max(channel):
    """The largest of channel(0), channel(1), channel(2) (...), element by element
    (the (..., 3) array's max over its last axis, without building it)."""
    return np.maximum(np.maximum(channel(0), channel(1)), channel(2))


def _times(a, b):
    """a * b, skipping a product with the scalar 1.0 (the same value)."""
    if isinstance(a, float) and a == 1.0:
        return b
    if isinstance(b, float) and b == 1.0:
        return a
    return a * b


def _blend_factor(cos_hv, eta):
    """saturate((F_real - F0) / (1 - F0)): the generalized-Schlick blend of Cycles'
    exponent < 0 case (the real dielectric curve rescaled to F0 ... 1)."""
    f0 = float(fresnel.f0_from_ior(eta))
    return np.clip((fresnel.dielectric(cos_hv, eta) - f0) / max(1.0 - f0, 1e-12), 0.0, 1.0)


def ggx_albedo_tables(alpha: float, eta: float | None):
    """(mu (64,), E (64,), s (64,), E_avg) for isotropic GGX of ``alpha``.

    E(mu): single-scatter directional albedo (F = 1); s(mu): E_F / E with F the
    blend factor of ``eta`` (None: s = 1); E_avg = 2 int E mu dmu. Integrated
    by sampling visible normals (estimator G2 / G1, 4096 Hammersley points per
    node); cached per (alpha, eta).
    """
    key = (round(float(alpha), 9), None if eta is None else round(float(eta), 9))
    if key in _TABLES:
        return _TABLES[key]
    from .base import hammersley

    alpha = max(float(alpha), 1e-4)
    u = hammersley(4096)
    wo = np.stack([np.sqrt(1.0 - _MU**2), np.zeros_like(_MU), _MU], -1)[:, None, :]
    m = sample_ggx_vndf(np.broadcast_to(wo, (len(_MU), len(u), 3)), u[None], alpha, alpha)
    wi = reflect_about(np.broadcast_to(wo, m.shape), m)
    with np.errstate(all="ignore"):
        lam_o = ggx_lambda(wo, alpha, alpha)
        lam_i = ggx_lambda(wi, alpha, alpha)
        weight = np.where(wi[..., 2] > 0, (1.0 + lam_o) / (1.0 + lam_o + lam_i), 0.0)
    e = weight.mean(axis=1)
    if eta is None:
        s = np.ones_like(e)
    else:
        blend = _blend_factor(np.sum(wo * m, axis=-1), eta)
        s = (weight * blend).mean(axis=1) / np.maximum(e, 1e-12)
    nodes = np.concatenate([[0.0], _MU])
    e_full = np.concatenate([[e[0]], e])
    values = 2.0 * e_full * nodes
    e_avg = float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(nodes)))
    _TABLES[key] = (_MU, e, s, e_avg)
    return _TABLES[key]


def _ior_from_f0(f0):
    root = np.sqrt(np.clip(f0, 0.0, 0.99))
    return (1.0 + root) / (1.0 - root)


@register
class Principled(BRDF):
    """Cycles' Principled BSDF: coat, metal, dielectric specular and diffuse (no transmission)."""

    name = "principled"
    reciprocal = False
    PARAMS = (
        Param("base_color", 0.8, 0.0, 1.0, "Base Color", rgb=True),
        Param("metallic", 0.0, 0.0, 1.0, "Metallic"),
        Param("roughness", 0.5, 0.01, 1.0, "Roughness; alpha = roughness^2 (below 0.01 "
              "Cycles renders a mirror)"),
        Param("ior", 1.5, 1.0, 10.0, "IOR of the dielectric specular layer"),
        Param("specular_ior_level", 0.5, 0.0, 1.0, "Specular IOR Level (0.5: the IOR as is)"),
        Param("specular_tint", 1.0, 0.0, 1.0, "Specular Tint", rgb=True),
        Param("anisotropy", 0.0, 0.0, 1.0, "Anisotropic"),
        Param("rotation", 0.0, 0.0, 1.0, "Anisotropic Rotation, in turns"),
        Param("coat_weight", 0.0, 0.0, 1.0, "Coat Weight"),
        Param("coat_roughness", 0.03, 0.01, 1.0, "Coat Roughness"),
        Param("coat_ior", 1.5, 1.0, 10.0, "Coat IOR"),
        Param("coat_tint", 1.0, 0.0, 1.0, "Coat Tint", rgb=True),
        Param("multiscatter", 1.0, 0.0, 1.0, "1: Multiscatter GGX (the node's default), "
              "0: GGX"),
        Param("diffuse", 1.0, 0.0, 1.0, "1: with the diffuse layer, 0: the glossy layers "
              "alone (what a map bakes; the diffuse goes to the irradiance map)"),
        # Absent unless given (the spec of an F82 metal stays as it was).
        Param("conductor_ior", None, 0.0, 100.0, "Physical conductor: the real part n of the "
              "metal's index (Metallic BSDF IOR)", rgb=True),
        Param("conductor_extinction", None, 0.0, 100.0, "Physical conductor: the imaginary "
              "part k of the metal's index (Metallic BSDF Extinction)", rgb=True),
    )

    @classmethod
    def _derive(cls, params, given):
        for flag in ("multiscatter", "diffuse"):
            if params[flag] not in (0.0, 1.0):
                from .params import SpecError

                raise SpecError(f"principled: {flag} is 0 or 1, not {params[flag]:g}")
        if ("conductor_ior" in params) != ("conductor_extinction" in params):
            from .params import SpecError

            raise SpecError("principled: conductor_ior and conductor_extinction are given "
                            "together (a physical conductor's n and k)")
        return params

    def _setup(self):
        p = self.params
        alpha = p["roughness"] ** 2
        aspect = np.sqrt(1.0 - 0.9 * p["anisotropy"])
        self.ax = float(np.clip(alpha / aspect, _MIN_ALPHA, 1.0))
        self.ay = float(np.clip(alpha * aspect, _MIN_ALPHA, 1.0))
        self.isotropic = p["anisotropy"] == 0.0 or p["metallic"] == 0.0 and \
            self._specular_eta() == 1.0
        self.angle = 2.0 * np.pi * p["rotation"]
        self.base = np.asarray(p["base_color"], dtype=np.float64)
        self.metallic = float(p["metallic"])
        self.multiscatter = p["multiscatter"] == 1.0
        # Metal: F82 tint.
        tint = np.asarray(p["specular_tint"], dtype=np.float64)
        mu82 = 6.0 / 7.0
        self.b82 = (self.base + (1.0 - self.base) * mu82**5) * 7.0 / mu82**6 * (1.0 - tint)
        self.conductor = None  # (n, k) (3,) each of a physical conductor
        if "conductor_ior" in p:
            n = np.asarray(p["conductor_ior"], dtype=np.float64)
            k = np.asarray(p["conductor_extinction"], dtype=np.float64)
            self.conductor = (n, k)
            # Fss through the F82 model fitted at c = 1 and c = 1/7 (as Cycles).
            f0 = fresnel.conductor(1.0, n, k)
            f82 = fresnel.conductor(1.0 / 7.0, n, k)
            schlick82 = f0 + (1.0 - f0) * mu82**5
            self._conductor_fss = np.clip(
                f0 + (1.0 - f0) / 21.0 - 7.0 / mu82**6 * (schlick82 - f82) / 126.0, 0.0, 1.0)
        # Dielectric specular: the adjusted IOR.
        self.eta = self._specular_eta()
        f0 = float(fresnel.f0_from_ior(p["ior"]))
        if p["specular_ior_level"] != 0.5:
            f0 *= 2.0 * p["specular_ior_level"]
        self.spec_f0 = np.clip(f0 * tint, 0.0, 1.0)
        rough = np.sqrt(np.sqrt(self.ax * self.ay))
        self._main = ggx_albedo_tables(rough**2, self.eta if self.eta != 1.0 else None)
        self.coat = float(p["coat_weight"])
        self.coat_alpha = max(p["coat_roughness"] ** 2, _MIN_ALPHA)
        self.coat_ior = float(p["coat_ior"])
        self.coat_tint = np.asarray(p["coat_tint"], dtype=np.float64)
        if self.coat > 0.0:
            self._coat = ggx_albedo_tables(self.coat_alpha,
                                           self.coat_ior if self.coat_ior > 1.0 else None)

    def _specular_eta(self) -> float:
        p = self.params
        if p["specular_ior_level"] == 0.5:
            return float(p["ior"])
        f0 = float(fresnel.f0_from_ior(p["ior"])) * 2.0 * p["specular_ior_level"]
        return float(_ior_from_f0(f0)) if f0 > 0.0 else 1.0

    # --- pieces --------------------------------------------------------------------------
    @staticmethod
    def _table(table, mu):
        """(E(mu), s(mu)) (...) each: linear interpolation between the table's nodes
        (uniform, mu = 1/64 ... 1: an index, not np.interp's search; the end
        nodes' values beyond them), as np.interp gives to rounding."""
        nodes, e, s, _ = table
        step = (nodes[-1] - nodes[0]) / (len(nodes) - 1)
        t = (np.asarray(mu, dtype=np.float64) - nodes[0]) / step
        index = np.clip(np.floor(t), 0, len(e) - 2).astype(np.intp)
        frac = np.clip(t - index, 0.0, 1.0)
        return (e[index] + (e[index + 1] - e[index]) * frac,
                s[index] + (s[index + 1] - s[index]) * frac)

    @staticmethod
    def _fms(fss, e_avg):
        fss = np.asarray(fss, dtype=np.float64)
        return fss * e_avg / (1.0 - fss * (1.0 - e_avg))

    def _ggx(self, wi, wo, ax, ay):
        """Single-scatter GGX f = D G2 / (4 cos_i cos_o), (...)."""
        h = half_vector(wi, wo)
        g2 = 1.0 / (1.0 + ggx_lambda(wi, ax, ay) + ggx_lambda(wo, ax, ay))
        return ggx_d(h, ax, ay) * g2 / (4.0 * wi[..., 2] * wo[..., 2]), dot(h, wo)

    def _metal_fss(self):
        if self.conductor is not None:
            return self._conductor_fss
        return self.base + (1.0 - self.base) / 21.0 - self.b82 / 126.0

    def metal_fresnel(self, cos_hv):
        """The metal layer's Fresnel (..., 3) at c = h.v (...): F82 tint, or the
        physical conductor's."""
        c = np.clip(np.asarray(cos_hv, dtype=np.float64), 0.0, 1.0)
        if self.conductor is not None:
            return fresnel.conductor(c, *self.conductor)
        t = 1.0 - c
        t3 = t * t * t
        tail = (c * (t3 * t3))[..., None]  # c (1 - c)^6, by products (not pow() per element)
        return np.clip(fresnel.schlick(c, self.base) - self.b82 * tail,
                       0.0, 1.0)

    def _spec_fss(self):
        fss_real = dielectric_hemispherical_average(self.eta)
        f0 = float(fresnel.f0_from_ior(self.eta))
        s = np.clip((fss_real - f0) / max(1.0 - f0, 1e-12), 0.0, 1.0)
        return self.spec_f0 + (1.0 - self.spec_f0) * s

    def _darkening(self, table, fss, looked, always=False):
        """E + Fms (1 - E), the layer's albedo with multiple scattering over its
        single-scatter E, as (Fms (3,), E (...)) for :func:`_channel` (channel k:
        E + Fms_k (1 - E)), or the scalar 1.0 (see :meth:`_multiplier_parts`)."""
        if not (self.multiscatter or always):
            return 1.0
        e = np.maximum(looked[0], 1e-6)
        return "darkening", self._fms(np.broadcast_to(fss, (3,)), table[3]), e

    def lower_weights(self, mu, main=None, coat=None):
        """(weight under the coat (..., 3), weight of the diffuse layer (..., 3)) at
        view cosines ``mu`` (...): the W of the module docstring before the metal
        and at the diffuse layer. main, coat: ``self._table`` of the main and coat
        tables at these mu, when the caller has them."""
        mu = np.clip(np.asarray(mu, dtype=np.float64), 0.0, 1.0)
        shape = mu.shape + (3,)
        return tuple(np.array(np.broadcast_to(w, shape)) for w in
                     self._lower_weights(mu, main, coat))

    def _lower_weights(self, mu, main, coat):
        """:meth:`lower_weights` before broadcasting: each weight a scalar, (..., 1)
        or (..., 3) (f's inner loop multiplies by them as they are)."""
        weight = 1.0
        if self.coat > 0.0:
            coat = coat if coat is not None else self._table(self._coat, mu)
            _, s = coat
            fss = dielectric_hemispherical_average(self.coat_ior)
            darkening = self._darkening(self._coat, fss, coat, always=True)
            f0 = float(fresnel.f0_from_ior(self.coat_ior))
            # max over channels of coat darkening (f0 + (1 - f0) s)[..., None]
            albedo = _channel_max(lambda k: (self.coat * _channel(darkening, k)) *
                                  (f0 + (1.0 - f0) * s))
            weight = np.clip(1.0 - albedo, 0.0, 1.0)[..., None]
            if not np.all(self.coat_tint == 1.0):
                cos_t = np.sqrt(1.0 - (1.0 - mu**2) / self.coat_ior**2)[..., None]
                tinted = np.power(self.coat_tint, 1.0 / cos_t)
                weight = weight * (1.0 + self.coat * (tinted - 1.0))
        under_coat = weight
        weight = weight * (1.0 - self.metallic)
        if self.eta != 1.0 and self.metallic < 1.0:  # (a whole metal: the weight is 0)
            main = main if main is not None else self._table(self._main, mu)
            _, s = main
            darkening = self._darkening(self._main, self._spec_fss(), main)
            f0 = self.spec_f0
            # max over channels of darkening (spec_f0 + (1 - spec_f0) s[..., None])
            albedo = _channel_max(lambda k: _times(_channel(darkening, k),
                                                   f0[k] + (1.0 - f0[k]) * s))
            weight = weight * np.clip(1.0 - albedo, 0.0, 1.0)[..., None]
        return under_coat, weight

    def diffuse_colour(self):
        """The diffuse layer's colour before its view-dependent weight: base_color (3,)."""
        return self.base.copy()

    def _f(self, wi, wo):
        # Every term is a per-pair scalar (...) times per-channel constants: it is
        # summed channel by channel into the (..., 3) result, each channel a run of
        # long 1D loops (NumPy's broadcast of (..., 1) against (3,) runs an inner
        # loop of 3, several times slower), in the order the (..., 3) expressions
        # in the comments give, so the values are theirs to the last bit.
        mu = np.clip(wo[..., 2], 0.0, 1.0)
        main = self._table(self._main, mu)  # looked up once for every term below
        coat = self._table(self._coat, mu) if self.coat > 0.0 else None
        under_coat, diffuse_weight = self._lower_weights(mu, main, coat)
        shape = np.broadcast_shapes(wi.shape, wo.shape)[:-1]
        parts = []  # (per-pair factor, [per-channel callables]) in the order summed
        if self.coat > 0.0:
            lobe, cos_hv = self._ggx(wi, wo, self.coat_alpha, self.coat_alpha)
            fss = dielectric_hemispherical_average(self.coat_ior)
            # (coat lobe F_coat)[..., None] * (1 + Fms (1 - E) / E)
            weighted = self.coat * lobe * fresnel.dielectric(cos_hv, self.coat_ior)
            energy = self._multiplier_parts(self._coat, fss, coat, always=True)
            parts.append(lambda k, w=weighted, m=energy: _times(w, _channel(m, k)))
        lw, lo = self._unrotated(wi, -self.angle), self._unrotated(wo, -self.angle)
        lobe, cos_hv = self._ggx(lw, lo, self.ax, self.ay)
        c = np.clip(cos_hv, 0.0, 1.0)
        if self.metallic > 0.0:
            # under_coat * (metallic lobe)[..., None] * metal_fresnel(c) * multiplier
            energy = self._multiplier_parts(self._main, self._metal_fss(), main)
            fresnel_channel = self._metal_fresnel_channels(c)
            weighted = self.metallic * lobe
            parts.append(lambda k, w=weighted, m=energy, f=fresnel_channel: _times(
                _times(_times(_channel(under_coat, k), w), f(k)), _channel(m, k)))
        if self.eta != 1.0 and self.metallic < 1.0:  # (a whole metal: weight 0)
            # under_coat * ((1 - metallic) lobe)[..., None] * f_spec * multiplier
            blend = _blend_factor(c, self.eta)
            energy = self._multiplier_parts(self._main, self._spec_fss(), main)
            weighted = (1.0 - self.metallic) * lobe
            f0 = self.spec_f0
            parts.append(lambda k, w=weighted, m=energy, b=blend: _times(_times(_times(
                _channel(under_coat, k), w), f0[k] + (1.0 - f0[k]) * b), _channel(m, k)))
        if self.params["diffuse"] == 1.0 and self.metallic < 1.0:  # (weight 0 under metal)
            albedo = self.base / np.pi
            parts.append(lambda k: _times(_channel(diffuse_weight, k), albedo[k]))
        total = np.zeros(shape + (3,))
        if not parts:
            return total
        for k in range(3):
            value = parts[0](k)
            for part in parts[1:]:
                value = value + part(k)
            total[..., k] = value
        return total

    def _multiplier_parts(self, table, fss, looked, always=False):
        """The multiple-scattering multiplier of the single-scatter lobe, 1 + Fms
        (1 - E) / E, as (Fms (3,), (1 - E) / E (...)) for :func:`_channel`
        (channel k: 1 + Fms_k (1 - E) / E), or the scalar 1.0 where none is added
        (``always``: the coat's, added whatever the main lobe does). looked:
        ``self._table(table, mu)`` at the view cosines."""
        if not (self.multiscatter or always):
            return 1.0
        e = np.maximum(looked[0], 1e-6)
        return self._fms(np.broadcast_to(fss, (3,)), table[3]), (1.0 - e) / e

    def _metal_fresnel_channels(self, c):
        """k -> channel k (...) of :meth:`metal_fresnel` at clipped cosines c (...)."""
        if self.conductor is not None:
            values = fresnel.conductor(c, *self.conductor)
            return lambda k: values[..., k]
        t = 1.0 - c
        t2 = t * t
        t5 = t2 * t2 * t
        t3 = t * t * t
        tail = c * (t3 * t3)
        base, b82 = self.base, self.b82
        return lambda k: np.clip(base[k] + (1.0 - base[k]) * t5 - b82[k] * tail, 0.0, 1.0)

    # --- sampling: main lobe, coat lobe and cosine, mixed ----------------------------------
    def _mixture(self):
        weights = [1.0, 0.5 * self.coat, 0.5 if self.params["diffuse"] == 1.0 else 0.0]
        total = sum(weights)
        return [w / total for w in weights]

    def _unrotated(self, v, angle):
        """rotate_z(v, angle), or v itself where the lobe is not rotated."""
        return rotate_z(v, angle) if self.angle else v

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        w_main, w_coat, _ = self._mixture()
        choice = np.where(u[..., 0] < w_main, 0, np.where(u[..., 0] < w_main + w_coat, 1, 2))
        low = np.select([choice == 0, choice == 1], [0.0, w_main], w_main + w_coat)
        width = np.select([choice == 0, choice == 1], [w_main, w_coat],
                          max(1.0 - w_main - w_coat, 1e-12))
        uu = np.stack([np.clip((u[..., 0] - low) / np.maximum(width, 1e-12), 0.0, 1.0 - 1e-12),
                       u[..., 1]], -1)

        def main(wo, uu):
            local = self._unrotated(wo, -self.angle)
            return self._unrotated(
                reflect_about(local, sample_ggx_vndf(local, uu, self.ax, self.ay)), self.angle)

        def coat(wo, uu):
            return reflect_about(wo, sample_ggx_vndf(wo, uu, self.coat_alpha, self.coat_alpha))

        def diffuse(wo, uu):
            return cosine_hemisphere(uu)[0]

        # Each branch only where it was chosen (the same values as computing all
        # three everywhere and selecting).
        wi = np.zeros(wo.shape)
        with np.errstate(all="ignore"):
            for index, branch in enumerate((main, coat, diffuse)):
                chosen = choice == index
                if chosen.all():
                    wi = np.array(branch(wo, uu), dtype=np.float64)
                elif chosen.any():
                    wi[chosen] = branch(wo[chosen], uu[chosen])
        return wi, self.pdf(wi, wo)

    def pdf(self, wi, wo):
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        w_main, w_coat, w_diffuse = self._mixture()

        def vndf(wi, wo, ax, ay):
            h = half_vector(wi, wo)
            g1 = 1.0 / (1.0 + ggx_lambda(wo, ax, ay))
            value = g1 * ggx_d(h, ax, ay) / (4.0 * wo[..., 2])
            return np.where((dot(wo, h) > 0) & (wo[..., 2] > 0), value, 0.0)

        with np.errstate(all="ignore"):
            total = w_main * vndf(self._unrotated(wi, -self.angle),
                                  self._unrotated(wo, -self.angle),
                                  self.ax, self.ay)
            if w_coat:
                total = total + w_coat * vndf(wi, wo, self.coat_alpha, self.coat_alpha)
            total = total + w_diffuse * np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0)
        return np.nan_to_num(total)
