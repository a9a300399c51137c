"""Multi-lobe models: Kurt et al. 2010 (anisotropic Beckmann) and Lafortune cosine lobes.

Both take up to three lobes; keys of lobe 2 and 3 carry the suffix 2 or 3
(``ks2``, ``mx2``, ...), and a lobe exists when its weight is given.
"""

import numpy as np

from . import fresnel
from .base import BRDF, register
from .microfacet import beckmann_d, reflect_about, sample_beckmann_h
from .params import Param
from .vectors import around_axis, broadcast_wo_u, dot, half_vector, normalize

__all__ = ["Kurt", "Lafortune"]

MAX_LOBES = 3


def _suffix(k):
    return "" if k == 0 else str(k + 1)


def _lobe_params(template):
    params = []
    for k in range(MAX_LOBES):
        for p in template:
            default = p.default if k == 0 else None
            params.append(Param(p.name + _suffix(k), default, p.low, p.high, p.doc, p.rgb))
    return tuple(params)


class _Mixture(BRDF):
    """Sampling by choosing diffuse or lobe k with probability proportional to its weight."""

    def _lobe_count(self):
        return sum(1 for k in range(MAX_LOBES) if self._weight_key(k) in self.params)

    def _weights(self):
        weights = [float(np.mean(self.params.get("kd", 0.0)))]
        weights += [float(np.mean(self.params[self._weight_key(k)]))
                    for k in range(self._lobe_count())]
        total = sum(weights)
        if total <= 0:
            return np.array([1.0] + [0.0] * (len(weights) - 1))
        return np.asarray(weights) / total

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        weights = self._weights()
        edges = np.cumsum(weights)
        choice = np.minimum(np.searchsorted(edges, u[..., 0], side="right"), len(weights) - 1)
        low = np.concatenate([[0.0], edges[:-1]])[choice]
        width = np.maximum(weights[choice], 1e-300)
        uu = np.stack([np.clip((u[..., 0] - low) / width, 0.0, 1.0 - 1e-16), u[..., 1]], -1)
        r = np.sqrt(uu[..., 0])
        phi = 2.0 * np.pi * uu[..., 1]
        wi = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - uu[..., 0])], -1)
        for k in range(self._lobe_count()):
            wi = np.where((choice == k + 1)[..., None], self._sample_lobe(k, wo, uu), wi)
        return wi, self.pdf(wi, wo)

    def pdf(self, wi, wo):
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        weights = self._weights()
        total = weights[0] * np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0)
        for k in range(self._lobe_count()):
            with np.errstate(all="ignore"):
                total = total + weights[k + 1] * np.nan_to_num(self._lobe_pdf(k, wi, wo))
        return total


@register
class Kurt(_Mixture):
    """Kurt, Szirmay-Kalos & Krivanek 2010, as the regular-sampling paper uses it (eqs. 1-5).

    f = kd / pi + sum_k ks_k F_k(wo.h) D_k(h) / (4 (wo.h) (cos theta_i cos theta_o)^alpha_k)
    with D_k the anisotropic Beckmann distribution of slopes mx_k, my_k and
    F_k Schlick's Fresnel with F0 = f0_k. Reciprocal for every alpha.
    Sampling (eqs. 6, 7): phi_h = atan(my/mx tan(2 pi u2)),
    theta_h = atan(sqrt(-ln u1 / (cos^2 phi_h / mx^2 + sin^2 phi_h / my^2)));
    pdf (eq. 10): D(h) (n.h) / (4 wo.h), mixed over lobes by weight.
    """

    name = "kurt"
    isotropic = False
    PARAMS = (Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True),) + _lobe_params((
        Param("ks", 1.0, 0.0, 10.0, "lobe weight", rgb=True),
        Param("mx", 0.2, 1e-3, 1.0, "Beckmann slope along the tangent"),
        Param("my", 0.2, 1e-3, 1.0, "Beckmann slope along the bitangent"),
        Param("f0", 1.0, 0.0, 1.0, "Schlick F0"),
        Param("alpha", 0.5, 0.0, 1.0, "exponent of the cosine normalization"),
    ))

    @classmethod
    def _derive(cls, params, given):
        from .params import SpecError

        for k in range(1, MAX_LOBES):
            keys = [name + _suffix(k) for name in ("ks", "mx", "my", "f0", "alpha")]
            present = [key for key in keys if key in given]
            if present and keys[0] not in given:
                raise SpecError(f"kurt: {present[0]} given without ks{_suffix(k)}")
            if keys[0] in given:
                defaults = {"mx": 0.2, "my": 0.2, "f0": 1.0, "alpha": 0.5}
                for name, value in defaults.items():
                    params.setdefault(name + _suffix(k), value)
            if k == 2 and keys[0] in given and "ks2" not in given:
                raise SpecError("kurt: lobe 3 needs lobe 2")
        order = [p.name for p in cls.PARAMS]
        return {key: params[key] for key in order if key in params}

    @staticmethod
    def _weight_key(k):
        return "ks" + _suffix(k)

    def _setup(self):
        self.isotropic = all(self.params["mx" + _suffix(k)] == self.params["my" + _suffix(k)]
                             for k in range(self._lobe_count()))

    def _lobe(self, k):
        p, s = self.params, _suffix(k)
        return np.asarray(p["ks" + s]), p["mx" + s], p["my" + s], p["f0" + s], p["alpha" + s]

    def _f(self, wi, wo):
        h = half_vector(wi, wo)
        cos_h = dot(wo, h)
        total = np.asarray(self.params["kd"]) / np.pi + 0.0 * wi
        for k in range(self._lobe_count()):
            ks, mx, my, f0, alpha = self._lobe(k)
            f = fresnel.schlick(cos_h, f0)
            value = f * beckmann_d(h, mx, my) / (4.0 * cos_h
                                                 * (wi[..., 2] * wo[..., 2]) ** alpha)
            total = total + value[..., None] * ks
        return total

    def _sample_lobe(self, k, wo, u):
        _, mx, my, _, _ = self._lobe(k)
        return reflect_about(wo, sample_beckmann_h(u, mx, my))

    def _lobe_pdf(self, k, wi, wo):
        _, mx, my, _, _ = self._lobe(k)
        h = half_vector(wi, wo)
        value = beckmann_d(h, mx, my) * h[..., 2] / (4.0 * dot(wo, h))
        return np.where(dot(wo, h) > 0, value, 0.0)


@register
class Lafortune(_Mixture):
    """Lafortune et al. 1997 generalized cosine lobes.

    f = kd / pi + sum_k rho_k (cx_k wi_x wo_x + cy_k wi_y wo_y + cz_k wi_z wo_z)^n_k
    (0 where the base is negative). Lobe k is sampled as cos^n about the axis
    normalize(cx wo_x, cy wo_y, cz wo_z).
    """

    name = "lafortune"
    isotropic = False
    PARAMS = (Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True),) + _lobe_params((
        Param("rho", 1.0, 0.0, 1e6, "lobe weight", rgb=True),
        Param("cx", -1.0, -100.0, 100.0, "x coefficient (-1: mirror-like)"),
        Param("cy", -1.0, -100.0, 100.0, "y coefficient"),
        Param("cz", 1.0, -100.0, 100.0, "z coefficient"),
        Param("n", 20.0, 0.0, 1e5, "lobe exponent"),
    ))

    @classmethod
    def _derive(cls, params, given):
        for k in range(1, MAX_LOBES):
            if "rho" + _suffix(k) in given:
                for name, value in {"cx": -1.0, "cy": -1.0, "cz": 1.0, "n": 20.0}.items():
                    params.setdefault(name + _suffix(k), value)
        order = [p.name for p in cls.PARAMS]
        return {key: params[key] for key in order if key in params}

    @staticmethod
    def _weight_key(k):
        return "rho" + _suffix(k)

    def _setup(self):
        self.isotropic = all(self.params["cx" + _suffix(k)] == self.params["cy" + _suffix(k)]
                             for k in range(self._lobe_count()))

    def _lobe(self, k):
        p, s = self.params, _suffix(k)
        return (np.asarray(p["rho" + s]), np.array([p["cx" + s], p["cy" + s], p["cz" + s]]),
                p["n" + s])

    def _f(self, wi, wo):
        total = np.asarray(self.params["kd"]) / np.pi + 0.0 * wi
        for k in range(self._lobe_count()):
            rho, c, n = self._lobe(k)
            base = np.sum(wi * wo * c, axis=-1)
            total = total + (np.power(np.clip(base, 0.0, None), n))[..., None] * rho
        return total

    def _sample_lobe(self, k, wo, u):
        _, c, n = self._lobe(k)
        axis = normalize(wo * c)
        cos_theta = np.power(1.0 - u[..., 0], 1.0 / (n + 1.0))
        return around_axis(axis, cos_theta, 2.0 * np.pi * u[..., 1])

    def _lobe_pdf(self, k, wi, wo):
        _, c, n = self._lobe(k)
        cos = np.sum(wi * normalize(wo * c), axis=-1)
        return np.where(cos > 0, (n + 1.0) / (2.0 * np.pi) * np.power(np.clip(cos, 0, 1), n), 0.0)
