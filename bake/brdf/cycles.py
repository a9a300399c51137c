"""Cycles' Glossy BSDF distributions and Principled metallic, exactly as CYCLES.md states.

Parameters take Blender's node values (``roughness``, ``anisotropy``,
``rotation``, ``color``) or explicit ``alpha`` / ``ax``, ``ay``:

- alpha = clamp(roughness, 0, 1)^2; anisotropy A is clamped to [-0.99, 0.99]
  and ignored when |A| <= 1e-4; A > 0: ax = alpha (1 - A), ay = alpha / (1 - A);
  A < 0: ax = alpha / (1 + A), ay = alpha (1 + A); then ax, ay are clamped to
  [0, 1] ([1e-4, 1] for Ashikhmin-Shirley).
- ax acts along the tangent X of the local frame after it is turned about the
  normal by 2 pi rotation, counter-clockwise seen from +n.
- No Fresnel (Color is a plain tint); height-correlated Smith
  G2 = 1 / (1 + Lambda(v) + Lambda(l)); Beckmann uses Cycles' rational Lambda.

Roughness below 0.01 is refused: Cycles renders roughness below about 0.004
as a perfect mirror, which a BRDF function cannot represent.
"""

import numpy as np

from . import fresnel
from .base import BRDF, register
from .microfacet import (
    beckmann_d,
    beckmann_lambda_cycles,
    ggx_d,
    ggx_lambda,
    reflect_about,
    sample_beckmann_h,
    sample_ggx_vndf,
)
from .params import Param, SpecError
from .vectors import broadcast_wo_u, dot, half_vector, rotate_z

__all__ = ["GGX", "Beckmann", "AshikhminShirley", "PrincipledMetallic", "cycles_alphas"]

_MIN_ALPHA = 1e-7

ROUGHNESS_PARAMS = (
    Param("roughness", None, 0.01, 1.0, "Blender's Roughness; alpha = roughness^2"),
    Param("anisotropy", 0.0, -1.0, 1.0, "Blender's Anisotropy"),
    Param("rotation", 0.0, 0.0, 1.0, "Blender's Rotation, in turns about the normal"),
    Param("alpha", None, 1e-4, 1.0, "isotropic alpha, instead of roughness"),
    Param("ax", None, 1e-4, 1.0, "alpha along the tangent, instead of roughness"),
    Param("ay", None, 1e-4, 1.0, "alpha along the bitangent, instead of roughness"),
    Param("color", 1.0, 0.0, 1.0, "tint (Color socket)", rgb=True),
)


def cycles_alphas(roughness, anisotropy, low=0.0):
    """(ax, ay) from Glossy BSDF node values, as Cycles' closure setup computes them."""
    alpha = float(np.clip(roughness, 0.0, 1.0)) ** 2
    a = float(np.clip(anisotropy, -0.99, 0.99))
    if abs(a) <= 1e-4:
        ax = ay = alpha
    elif a > 0:
        ax, ay = alpha * (1.0 - a), alpha / (1.0 - a)
    else:
        ax, ay = alpha / (1.0 + a), alpha * (1.0 + a)
    return float(np.clip(ax, low, 1.0)), float(np.clip(ay, low, 1.0))


class _Glossy(BRDF):
    """Shared parameter handling and frame rotation of Cycles' glossy closures."""

    PARAMS = ROUGHNESS_PARAMS
    _alpha_floor = 0.0

    @classmethod
    def _derive(cls, params, given):
        forms = [name for name in ("roughness", "alpha", "ax") if name in given]
        if "ay" in given and "ax" not in given or "ax" in given and "ay" not in given:
            raise SpecError(f"{cls.name}: ax and ay go together")
        if len(forms) > 1:
            both = " and ".join(forms)
            raise SpecError(f"{cls.name}: give roughness, alpha or ax/ay, not {both}")
        if not forms:
            params = {"roughness": 0.5, **params}
        if forms and forms[0] != "roughness" and "anisotropy" in given:
            raise SpecError(f"{cls.name}: anisotropy goes with roughness, not with alpha or ax/ay")
        if forms and forms[0] != "roughness":
            params.pop("anisotropy", None)
        order = [p.name for p in cls.PARAMS]
        return {k: params[k] for k in order if k in params}

    def _setup(self):
        p = self.params
        if "roughness" in p:
            self.ax, self.ay = cycles_alphas(p["roughness"], p.get("anisotropy", 0.0),
                                             self._alpha_floor)
        elif "alpha" in p:
            self.ax = self.ay = float(np.clip(p["alpha"], self._alpha_floor, 1.0))
        else:
            self.ax, self.ay = float(p["ax"]), float(p["ay"])
        self.ax, self.ay = max(self.ax, _MIN_ALPHA), max(self.ay, _MIN_ALPHA)
        self.isotropic = self.ax == self.ay
        self.angle = 2.0 * np.pi * p.get("rotation", 0.0)
        self.color = np.asarray(p.get("color", (1.0, 1.0, 1.0)), dtype=np.float64)

    def _to_lobe(self, v):
        return rotate_z(v, -self.angle) if self.angle else v

    def _from_lobe(self, v):
        return rotate_z(v, self.angle) if self.angle else v

    def _f(self, wi, wo):
        return self._f_lobe(self._to_lobe(wi), self._to_lobe(wo))

    def sample(self, wo, u):
        wo, u = broadcast_wo_u(wo, u)
        local_wo = self._to_lobe(wo)
        with np.errstate(all="ignore"):
            m = self._sample_m(local_wo, u)
            wi = reflect_about(local_wo, m)
            pdf = self._pdf_lobe(wi, local_wo)
        return self._from_lobe(wi), np.nan_to_num(pdf)

    def pdf(self, wi, wo):
        with np.errstate(all="ignore"):
            return np.nan_to_num(self._pdf_lobe(self._to_lobe(np.asarray(wi, dtype=float)),
                                                self._to_lobe(np.asarray(wo, dtype=float))))


class _SmithMicrofacet(_Glossy):
    """f = D(h) G2 / (4 cv cl), G2 = 1 / (1 + Lambda(v) + Lambda(l))."""

    def _d(self, h):
        raise NotImplementedError

    def _lambda(self, w):
        raise NotImplementedError

    def _f_lobe(self, wi, wo):
        h = half_vector(wi, wo)
        g2 = 1.0 / (1.0 + self._lambda(wi) + self._lambda(wo))
        value = self._d(h) * g2 / (4.0 * wi[..., 2] * wo[..., 2])
        return value[..., None] * self.color


@register
class GGX(_SmithMicrofacet):
    """Cycles' GGX (Trowbridge-Reitz) with height-correlated Smith shadowing."""

    name = "ggx"

    def _d(self, h):
        return ggx_d(h, self.ax, self.ay)

    def _lambda(self, w):
        return ggx_lambda(w, self.ax, self.ay)

    def _sample_m(self, wo, u):
        return sample_ggx_vndf(wo, u, self.ax, self.ay)

    def _pdf_lobe(self, wi, wo):
        """Visible-normal density G1(wo) D(h) / (4 wo_z) where wo.h > 0."""
        h = half_vector(wi, wo)
        g1 = 1.0 / (1.0 + self._lambda(wo))
        value = g1 * self._d(h) / (4.0 * wo[..., 2])
        return np.where((dot(wo, h) > 0) & (wo[..., 2] > 0), value, 0.0)


@register
class Beckmann(_SmithMicrofacet):
    """Cycles' Beckmann with its rational Smith Lambda approximation."""

    name = "beckmann"

    def _d(self, h):
        return beckmann_d(h, self.ax, self.ay)

    def _lambda(self, w):
        return beckmann_lambda_cycles(w, self.ax, self.ay)

    def _sample_m(self, wo, u):
        return sample_beckmann_h(u, self.ax, self.ay)

    def _pdf_lobe(self, wi, wo):
        """D(h) h_z / (4 |wo.h|)."""
        h = half_vector(wi, wo)
        value = self._d(h) * h[..., 2] / (4.0 * np.abs(dot(wo, h)))
        return np.where(dot(wo, h) > 0, value, 0.0)


@register
class AshikhminShirley(_Glossy):
    """Cycles' Ashikhmin-Shirley glossy lobe: no Fresnel, no shadowing.

    n = 2 / alpha^2 - 2 per axis; f = sqrt((nx + 1)(ny + 1)) / (8 pi)
    ch^((nx hX^2 + ny hY^2) / (1 - ch^2)) / (|h.v| max(cv, cl)), cv, cl >= 1e-6.
    """

    name = "ashikhmin_shirley"
    _alpha_floor = 1e-4

    def _setup(self):
        super()._setup()
        self.ax, self.ay = max(self.ax, 1e-4), max(self.ay, 1e-4)
        self.nx = 2.0 / self.ax**2 - 2.0
        self.ny = 2.0 / self.ay**2 - 2.0

    def _exponent(self, h):
        sin2 = np.clip(1.0 - h[..., 2] ** 2, 0.0, None)
        with np.errstate(divide="ignore", invalid="ignore"):
            e = (self.nx * h[..., 0] ** 2 + self.ny * h[..., 1] ** 2) / sin2
        return np.where(sin2 > 1e-12, e, 0.5 * (self.nx + self.ny))

    def _f_lobe(self, wi, wo):
        h = half_vector(wi, wo)
        cv = np.maximum(wo[..., 2], 1e-6)
        cl = np.maximum(wi[..., 2], 1e-6)
        norm = np.sqrt((self.nx + 1.0) * (self.ny + 1.0)) / (8.0 * np.pi)
        lobe = np.power(np.clip(h[..., 2], 0.0, 1.0), self._exponent(h))
        value = norm * lobe / (np.abs(dot(h, wo)) * np.maximum(cv, cl))
        return value[..., None] * self.color

    def _sample_m(self, wo, u):
        """Ashikhmin & Shirley 2000 half-vector sampling, one quadrant then mirrored."""
        quarter = np.floor(4.0 * u[..., 0])
        v = 4.0 * u[..., 0] - quarter
        phi = np.arctan(np.sqrt((self.nx + 1.0) / (self.ny + 1.0)) * np.tan(0.5 * np.pi * v))
        phi = np.select([quarter == 0, quarter == 1, quarter == 2],
                        [phi, np.pi - phi, np.pi + phi], default=2.0 * np.pi - phi)
        exponent = self.nx * np.cos(phi) ** 2 + self.ny * np.sin(phi) ** 2
        cos_theta = np.power(1.0 - u[..., 1], 1.0 / (exponent + 1.0))
        sin_theta = np.sqrt(np.clip(1.0 - cos_theta**2, 0.0, None))
        return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], -1)

    def _pdf_lobe(self, wi, wo):
        h = half_vector(wi, wo)
        norm = np.sqrt((self.nx + 1.0) * (self.ny + 1.0)) / (2.0 * np.pi)
        pdf_h = norm * np.power(np.clip(h[..., 2], 0.0, 1.0), self._exponent(h))
        value = pdf_h / (4.0 * np.abs(dot(wo, h)))
        return np.where((dot(wo, h) > 0) & (h[..., 2] > 0), value, 0.0)


@register
class PrincipledMetallic(GGX):
    """Principled BSDF with Metallic = 1, single-scatter GGX (CYCLES.md).

    Its own anisotropy mapping (aspect = sqrt(1 - 0.9 A), ax = alpha / aspect,
    ay = alpha aspect) and the F82-tint Fresnel at c = h.v with F0 = base
    color: B = (F0 + (1 - F0)(6/7)^5) 7 / (6/7)^6 (1 - specular_tint),
    F = clamp(F0 + (1 - F0)(1 - c)^5 - B c (1 - c)^6, 0, 1).
    """

    name = "principled_metallic"
    PARAMS = (
        Param("roughness", 0.5, 0.01, 1.0, "Roughness; alpha = roughness^2"),
        Param("anisotropy", 0.0, 0.0, 1.0, "Anisotropic"),
        Param("rotation", 0.0, 0.0, 1.0, "Anisotropic Rotation, in turns"),
        Param("base_color", 0.8, 0.0, 1.0, "Base Color (F0)", rgb=True),
        Param("specular_tint", 1.0, 0.0, 1.0, "Specular Tint (F82 tint)", rgb=True),
    )

    @classmethod
    def _derive(cls, params, given):
        return params

    def _setup(self):
        p = self.params
        alpha = p["roughness"] ** 2
        aspect = np.sqrt(1.0 - 0.9 * p["anisotropy"])
        self.ax, self.ay = max(alpha / aspect, _MIN_ALPHA), max(alpha * aspect, _MIN_ALPHA)
        self.isotropic = p["anisotropy"] == 0.0
        self.angle = 2.0 * np.pi * p["rotation"]
        self.color = np.ones(3)
        self.f0 = np.asarray(p["base_color"], dtype=np.float64)
        tint = np.asarray(p["specular_tint"], dtype=np.float64)
        mu = 6.0 / 7.0
        self.b = (self.f0 + (1.0 - self.f0) * mu**5) * 7.0 / mu**6 * (1.0 - tint)

    def fresnel(self, cos_hv):
        c = np.clip(np.asarray(cos_hv, dtype=np.float64), 0.0, 1.0)[..., None]
        schlick = fresnel.schlick(c[..., 0], self.f0)
        return np.clip(schlick - self.b * c * (1.0 - c) ** 6, 0.0, 1.0)

    def _f_lobe(self, wi, wo):
        h = half_vector(wi, wo)
        return super()._f_lobe(wi, wo) * self.fresnel(dot(h, wo))


@register
class MultiscatterGGX(GGX):
    """Cycles' Multiscatter GGX (the Glossy node's default).

    f = f_GGX color (1 + Fms (1 - E(cv)) / E(cv)) with Fms = color E_avg / (1 - color
    (1 - E_avg)) (Kulla & Conty, as Cycles' constant-Fresnel energy preservation):
    for a white Color f_GGX / E(cv). E(mu) is the single-scatter directional albedo
    of isotropic GGX with alpha = sqrt(ax ay) and E_avg = 2 int E mu dmu, integrated
    numerically (bake.brdf.principled.ggx_albedo_tables). It depends on the view
    cosine only, so it is not reciprocal.
    """

    name = "ggx_multiscatter"
    reciprocal = False

    def _setup(self):
        super()._setup()
        from .principled import ggx_albedo_tables

        self.e_mu, self.e_value, _, self.e_avg = ggx_albedo_tables(
            float(np.sqrt(self.ax * self.ay)), None)

    def _f_lobe(self, wi, wo):
        e = np.maximum(np.interp(wo[..., 2], self.e_mu, self.e_value), 1e-6)[..., None]
        fms = self.color * self.e_avg / (1.0 - self.color * (1.0 - self.e_avg))
        return super()._f_lobe(wi, wo) * (1.0 + fms * (1.0 - e) / e)
