"""Classic analytic models: Lambert, Phong (Lewis), Blinn-Phong, Ward, Cook-Torrance.

All in the local frame (z = normal, x = tangent); colours are RGB triples.
"""

import numpy as np

from . import fresnel
from .base import BRDF, register
from .microfacet import beckmann_d, reflect_about, sample_beckmann_h
from .params import Param
from .vectors import around_axis, broadcast_wo_u, cosine_hemisphere, dot, half_vector, reflect

__all__ = ["Lambert", "Phong", "BlinnPhong", "Ward", "CookTorrance", "Velvet"]


def _cos_power_sample(axis, u, exponent):
    """Directions about ``axis`` with density (n + 1) / (2 pi) cos^n (whole sphere cap)."""
    cos_theta = np.power(1.0 - u[..., 0], 1.0 / (exponent + 1.0))
    return around_axis(axis, cos_theta, 2.0 * np.pi * u[..., 1])


def _cos_power_pdf(cos_angle, exponent):
    return np.where(cos_angle > 0, (exponent + 1.0) / (2.0 * np.pi)
                    * np.power(np.clip(cos_angle, 0.0, 1.0), exponent), 0.0)


def _specular_weights(params):
    """(specular, diffuse) sampling probabilities from the mean ks and kd."""
    ks = float(np.mean(params["ks"]))
    kd = float(np.mean(params.get("kd", 0.0)))
    total = ks + kd
    return (1.0, 0.0) if total == 0 else (ks / total, kd / total)


def _mixture_sample(wo, u, spec, sample_lobe):
    """Pick the specular lobe with probability ``spec`` (else a cosine direction),
    reusing the uniform; returns wi (..., 3)."""
    pick = u[..., 0] < spec
    u0 = np.where(pick, u[..., 0] / max(spec, 1e-300), (u[..., 0] - spec) / max(1 - spec, 1e-300))
    uu = np.stack([np.clip(u0, 0.0, 1.0 - 1e-16), u[..., 1]], -1)
    diffuse, _ = cosine_hemisphere(uu)
    return np.where(pick[..., None], sample_lobe(wo, uu), diffuse)


@register
class Lambert(BRDF):
    """f = color / pi (Cycles' Diffuse BSDF with Roughness 0)."""

    name = "lambert"
    PARAMS = (Param("color", 0.8, 0.0, 1.0, "diffuse reflectance", rgb=True),)

    def _f(self, wi, wo):
        return np.asarray(self.params["color"]) / np.pi + 0.0 * wi[..., :1]


@register
class Phong(BRDF):
    """Lewis' physically plausible Phong (Heidrich eq. 16), plus an optional diffuse term.

    f = kd / pi + ks (n + 2) / (2 pi) cos^n(alpha), alpha the angle between wi
    and the mirror direction of wo. Energy conserving for kd + ks <= 1.
    """

    name = "phong"
    PARAMS = (
        Param("n", 50.0, 0.0, 1e6, "Phong exponent"),
        Param("ks", 1.0, 0.0, 1.0, "specular reflectance", rgb=True),
        Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True),
    )

    def _lobe_cos(self, wi, wo):
        return dot(wi, reflect(wo))

    def _f(self, wi, wo):
        n = self.params["n"]
        lobe = (n + 2.0) / (2.0 * np.pi) * np.power(np.clip(self._lobe_cos(wi, wo), 0, 1), n)
        return (lobe[..., None] * np.asarray(self.params["ks"])
                + np.asarray(self.params["kd"]) / np.pi)

    def _weights(self):
        return _specular_weights(self.params)

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        wi = _mixture_sample(wo, u, self._weights()[0], self._sample_lobe)
        return wi, self.pdf(wi, wo)

    def _sample_lobe(self, wo, u):
        return _cos_power_sample(reflect(wo), u, self.params["n"])

    def _lobe_pdf(self, wi, wo):
        return _cos_power_pdf(self._lobe_cos(wi, wo), self.params["n"])

    def pdf(self, wi, wo):
        spec, diff = self._weights()
        wi = np.asarray(wi, dtype=np.float64)
        cosine = np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0)
        return spec * self._lobe_pdf(wi, np.asarray(wo, dtype=np.float64)) + diff * cosine


@register
class BlinnPhong(Phong):
    """Normalized Blinn-Phong: f = kd / pi + ks (n + 8) / (8 pi) (n.h)^n."""

    name = "blinn_phong"

    def _lobe_cos(self, wi, wo):
        return half_vector(wi, wo)[..., 2]

    def _f(self, wi, wo):
        n = self.params["n"]
        lobe = (n + 8.0) / (8.0 * np.pi) * np.power(np.clip(self._lobe_cos(wi, wo), 0, 1), n)
        return (lobe[..., None] * np.asarray(self.params["ks"])
                + np.asarray(self.params["kd"]) / np.pi)

    def _sample_lobe(self, wo, u):
        m = _cos_power_sample(np.array([0.0, 0.0, 1.0]), u, self.params["n"])
        return reflect_about(wo, m)

    def _lobe_pdf(self, wi, wo):
        h = half_vector(wi, wo)
        pdf_h = _cos_power_pdf(h[..., 2], self.params["n"])
        with np.errstate(divide="ignore", invalid="ignore"):
            value = pdf_h / (4.0 * dot(wo, h))
        return np.where(dot(wo, h) > 0, np.nan_to_num(value), 0.0)


class _HalfVectorSampled(BRDF):
    """Models sampled by Beckmann-like half vectors with density D(h) h_z."""

    def _weights(self):
        return _specular_weights(self.params)

    def _sample_lobe(self, wo, u):
        return reflect_about(wo, sample_beckmann_h(u, self.ax, self.ay))

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        wi = _mixture_sample(wo, u, self._weights()[0], self._sample_lobe)
        return wi, self.pdf(wi, wo)

    def pdf(self, wi, wo):
        spec, diff = self._weights()
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        h = half_vector(wi, wo)
        with np.errstate(divide="ignore", invalid="ignore"):
            lobe = beckmann_d(h, self.ax, self.ay) * h[..., 2] / (4.0 * dot(wo, h))
        lobe = np.where(dot(wo, h) > 0, np.nan_to_num(lobe), 0.0)
        return spec * lobe + diff * np.where(wi[..., 2] > 0, wi[..., 2] / np.pi, 0.0)


@register
class Ward(_HalfVectorSampled):
    """Ward 1992 (an)isotropic BRDF, sampled with Walter's (2005) corrected density.

    f = kd / pi + ks exp(-tan^2(theta_h) (cos^2 phi_h / ax^2 + sin^2 phi_h / ay^2))
        / (4 pi ax ay sqrt(cos theta_i cos theta_o)).
    Walter showed that Ward's half-vector sampling has density
    D(h) h_z / (4 wo.h) with the Beckmann-normalized D (not Ward's stated one);
    ``pdf`` uses that corrected density, so importance-sampled estimates are unbiased.
    """

    name = "ward"
    PARAMS = (
        Param("alpha", None, 1e-3, 1.0, "isotropic roughness (RMS slope)"),
        Param("ax", None, 1e-3, 1.0, "roughness along the tangent"),
        Param("ay", None, 1e-3, 1.0, "roughness along the bitangent"),
        Param("ks", 1.0, 0.0, 1.0, "specular reflectance", rgb=True),
        Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True),
    )

    @classmethod
    def _derive(cls, params, given):
        from .params import SpecError

        if "alpha" in given and ("ax" in given or "ay" in given):
            raise SpecError("ward: give alpha or ax/ay, not both")
        if ("ax" in given) != ("ay" in given):
            raise SpecError("ward: ax and ay go together")
        if "alpha" not in given and "ax" not in given:
            params = {"alpha": 0.1, **params}
        order = [p.name for p in cls.PARAMS]
        return {k: params[k] for k in order if k in params}

    def _setup(self):
        p = self.params
        self.ax = p.get("ax", p.get("alpha"))
        self.ay = p.get("ay", p.get("alpha"))
        self.isotropic = self.ax == self.ay

    def _f(self, wi, wo):
        h = half_vector(wi, wo)
        e = ((h[..., 0] / self.ax) ** 2 + (h[..., 1] / self.ay) ** 2) / h[..., 2] ** 2
        lobe = np.exp(-e) / (4.0 * np.pi * self.ax * self.ay * np.sqrt(wi[..., 2] * wo[..., 2]))
        return (lobe[..., None] * np.asarray(self.params["ks"])
                + np.asarray(self.params["kd"]) / np.pi)


@register
class CookTorrance(_HalfVectorSampled):
    """Cook-Torrance 1982 with the Beckmann distribution.

    f = F(h.wo) D(h) G / (4 cos theta_i cos theta_o), D Beckmann with RMS slope
    m, G = min(1, 2 (n.h)(n.wo)/(wo.h), 2 (n.h)(n.wi)/(wo.h)) (V-cavities), F the
    exact dielectric Fresnel of ``ior``; plus kd / pi.
    """

    name = "cook_torrance"
    PARAMS = (
        Param("m", 0.3, 1e-3, 1.0, "Beckmann RMS slope"),
        Param("ior", 1.5, 1.0, 10.0, "relative index of refraction of the Fresnel term"),
        Param("ks", 1.0, 0.0, 1.0, "specular weight", rgb=True),
        Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True),
    )

    def _setup(self):
        self.ax = self.ay = self.params["m"]

    def _f(self, wi, wo):
        h = half_vector(wi, wo)
        cos_h = dot(wo, h)
        g = np.minimum(1.0, np.minimum(2.0 * h[..., 2] * wo[..., 2] / cos_h,
                                       2.0 * h[..., 2] * wi[..., 2] / cos_h))
        f = fresnel.dielectric(cos_h, self.params["ior"])
        lobe = f * beckmann_d(h, self.ax, self.ay) * g / (4.0 * wi[..., 2] * wo[..., 2])
        return (lobe[..., None] * np.asarray(self.params["ks"])
                + np.asarray(self.params["kd"]) / np.pi)


@register
class Velvet(BRDF):
    """Velvet: Ashikhmin & Premoze's inverted-Gaussian distribution (2007), a
    cloth-like BRDF that rises toward grazing angles (the kind Kautz & McCool
    1999 found best factored in the incident/view parameterization).

    D(h) = (1 + 4 exp(-cot^2 theta_h / sigma^2) / sin^4 theta_h) / (pi (1 + 4 sigma^2)),
    f = ks D(h) / (4 (cos theta_i + cos theta_o - cos theta_i cos theta_o)) + kd / pi.
    """

    name = "velvet"
    PARAMS = (Param("sigma", 0.5, 0.05, 2.0, "width of the inverted Gaussian"),
              Param("ks", 1.0, 0.0, 10.0, "sheen weight", rgb=True),
              Param("kd", 0.0, 0.0, 1.0, "diffuse reflectance", rgb=True))

    def _f(self, wi, wo):
        sigma = self.params["sigma"]
        h = half_vector(wi, wo)
        cos_h = np.clip(h[..., 2], 0.0, 1.0)
        sin2 = np.maximum(1.0 - cos_h * cos_h, 1e-12)
        cot2 = cos_h * cos_h / sin2
        d = (1.0 + 4.0 * np.exp(-cot2 / sigma**2) / (sin2 * sin2)) / \
            (np.pi * (1.0 + 4.0 * sigma**2))
        ci, co = wi[..., 2], wo[..., 2]
        denominator = 4.0 * (ci + co - ci * co)
        return (np.asarray(self.params["ks"]) * (d / denominator)[..., None]
                + np.asarray(self.params["kd"]) / np.pi)
