"""Sums of models and Fresnel-weighted layers (a clear coat over a base).

Specs: ``sum(A; B; ...)``, ``layer(ior=1.5; TOP; BASE)``, ``scale(k=0.5; A)``
(``k`` one number or r/g/b: a Mix Shader's factor) and
``fresnel_mix(ior=1.5; A; B)`` (a Mix Shader driven by Blender's Fresnel node)
where A, B, TOP and BASE are any specs (nesting allowed).
"""

import numpy as np

from . import fresnel
from .base import BRDF
from .params import SpecError
from .vectors import broadcast_wo_u, dot, half_vector

__all__ = ["Sum", "Layer", "Scale", "FresnelMix"]


class _Composite(BRDF):
    PARAMS = ()

    def _mixture_weights(self):
        weights = np.array([max(float(np.mean(p.albedo(np.array([0.0, 0.0, 1.0]), 256))), 1e-6)
                            for p in self.parts])
        return weights / weights.sum()

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        weights = self._weights
        edges = np.cumsum(weights)
        choice = np.minimum(np.searchsorted(edges, u[..., 0], side="right"), len(weights) - 1)
        low = np.concatenate([[0.0], edges[:-1]])[choice]
        uu = np.stack([np.clip((u[..., 0] - low) / weights[choice], 0.0, 1.0 - 1e-16),
                       u[..., 1]], -1)
        wi = np.zeros(wo.shape)
        for index, part in enumerate(self.parts):
            sampled, _ = part.sample(wo, uu)
            wi = np.where((choice == index)[..., None], sampled, wi)
        return wi, self.pdf(wi, wo)

    def pdf(self, wi, wo):
        return sum(w * part.pdf(wi, wo) for w, part in zip(self._weights, self.parts, strict=True))


class Sum(_Composite):
    """f = sum of the parts' f (e.g. diffuse + specular)."""

    name = "sum"

    def __init__(self, parts):
        if len(parts) < 1:
            raise SpecError("sum: needs at least one part")
        self.parts = list(parts)
        self.params = {}
        self.reciprocal = all(p.reciprocal for p in self.parts)
        self.isotropic = all(p.isotropic for p in self.parts)
        self._weights = self._mixture_weights()

    @property
    def spec(self):
        return "sum(" + "; ".join(p.spec for p in self.parts) + ")"

    def _f(self, wi, wo):
        return sum(part.f(wi, wo) for part in self.parts)


class Layer(_Composite):
    """A dielectric coat of relative index ``ior`` over a base (Heidrich 3.1.1 Fresnel blend).

    f = F(wo.h) f_top + (1 - F(cos theta_i)) (1 - F(cos theta_o)) f_base, F
    the exact dielectric Fresnel: the top lobe reflects what the coat's
    facets reflect; the base sees light transmitted in and out of the coat.
    Reciprocal when both parts are.
    """

    name = "layer"

    def __init__(self, ior, top, base):
        if not 1.0 <= ior <= 10.0:
            raise SpecError(f"layer: ior={ior:g} is out of range [1, 10]")
        self.ior = float(ior)
        self.parts = [top, base]
        self.params = {"ior": self.ior}
        self.reciprocal = top.reciprocal and base.reciprocal
        self.isotropic = top.isotropic and base.isotropic
        self._weights = self._mixture_weights()

    @property
    def spec(self):
        from .params import format_value

        return f"layer(ior={format_value(self.ior)}; {self.parts[0].spec}; {self.parts[1].spec})"

    def _f(self, wi, wo):
        top, base = self.parts
        f_top = fresnel.dielectric(dot(half_vector(wi, wo), wo), self.ior)[..., None]
        through = ((1.0 - fresnel.dielectric(wi[..., 2], self.ior))
                   * (1.0 - fresnel.dielectric(wo[..., 2], self.ior)))[..., None]
        return f_top * top.f(wi, wo) + through * base.f(wi, wo)


class Scale(_Composite):
    """f = k f_A, k one number or RGB (a Mix or Add Shader's constant weight)."""

    name = "scale"

    def __init__(self, k, part):
        k = np.broadcast_to(np.asarray(k, dtype=np.float64), (3,)).copy()
        if not np.all(np.isfinite(k)) or np.any(k < 0.0) or np.any(k > 1e3):
            raise SpecError(f"scale: k={k.tolist()} must be finite and in [0, 1000]")
        self.k = k
        self.parts = [part]
        self.params = {"k": tuple(float(v) for v in k)}
        self.reciprocal = part.reciprocal
        self.isotropic = part.isotropic
        self._weights = np.ones(1)

    @property
    def spec(self):
        from .params import format_value

        return f"scale(k={format_value(self.params['k'])}; {self.parts[0].spec})"

    def _f(self, wi, wo):
        return self.k * self.parts[0].f(wi, wo)


class FresnelMix(_Composite):
    """f = (1 - F(n.wo)) f_A + F(n.wo) f_B, F the exact dielectric Fresnel of ``ior``
    at the view's cosine: a Mix Shader whose factor is Blender's Fresnel node (A the
    first shader socket, B the second). Not reciprocal (the weight follows the view)."""

    name = "fresnel_mix"

    def __init__(self, ior, first, second):
        if not 1.0 < ior <= 10.0:
            raise SpecError(f"fresnel_mix: ior={ior:g} is out of range (1, 10]")
        self.ior = float(ior)
        self.parts = [first, second]
        self.params = {"ior": self.ior}
        self.reciprocal = False
        self.isotropic = first.isotropic and second.isotropic
        self._weights = self._mixture_weights()

    @property
    def spec(self):
        from .params import format_value

        return (f"fresnel_mix(ior={format_value(self.ior)}; {self.parts[0].spec}; "
                f"{self.parts[1].spec})")

    def weight(self, mu):
        """F(mu), the second part's weight at view cosines ``mu`` (...)."""
        return fresnel.dielectric(mu, self.ior)

    def _f(self, wi, wo):
        f = self.weight(wo[..., 2])[..., None]
        return (1.0 - f) * self.parts[0].f(wi, wo) + f * self.parts[1].f(wi, wo)
