"""A Principled BSDF's reflection as a function of a colour that varies per pixel:
a metal's base colour, or the specular tint of a metal or a dielectric.

A metallic Principled BSDF (Metallic = 1, Cycles' F82-tint Fresnel with F0 =
Base Color, bake.brdf.principled) is not linear in its base colour c: toward
grazing angles its Fresnel goes to white, not to a scaled colour, so a map
baked at one colour and scaled by c / mean per pixel is wrong wherever c is
far from the mean (benchmarks/colour_response.py, worst over the bundled
HDRIs, grey texture of mean 0.5, roughness 0.1-0.6: 65-70% relative RMS for a
texel of 0.05, 19-25% at 0.2, 6-10% at 0.8 and 0.95). Per channel, with the
Specular Tint fixed, the reflection splits exactly into (c the base colour;
the specular tint is handled alike, see :func:`response`)

    f(c) = f_ss(c) m(c, mu),
    f_ss(c) = f_ss(0) + c (f_ss(1) - f_ss(0))   (the F82 Fresnel is affine in F0),
    m(c, mu) = 1 + Fms(c) (1 - E(mu)) / E(mu)   (Multiscatter GGX; 1 with GGX),
    Fms(c) = Fss(c) E_avg / (1 - Fss(c) (1 - E_avg)),  Fss(c) = a + b c,

where mu is the view cosine, E(mu) the single-scatter albedo of the lobe and
E_avg its hemispherical average. m depends on the view only (not on the light
direction), so it leaves the reflection integral: the reflected radiance is
R(c) = (R_0 + c (R_1 - R_0)) m(c, mu) with R_0 and R_1 the maps of the
single-scatter BRDF baked at c = 0 and c = 1. The attached lookup reads the
user's colour per pixel and evaluates exactly this (glossy_addon.nodes);
:meth:`ColourResponse.combine` is its NumPy twin.

Exact as far as the F82 clamp to [0, 1] is inactive (always with a white
Specular Tint; a dark tint on a dark base can clamp at grazing half-vectors:
1.2% of the peak at roughness 0.9, tests/bake/test_colour_response.py), up to
the E(mu) curve's 33 knots (3e-4 of the peak). A coat on top (Coat Weight >
0) does not depend on c and is not scaled by m, and the layers below it are
weighted by a function of the view only, W(mu) (the coat's transmission and
its tint, bake.brdf.principled's lower_weights): with R_0 and R_1 baked
without the coat and a third map C of the coat alone (the same Principled
with Metallic 0 and IOR 1, whose only layer is then the coat),
R(c) = C + W(mu) (R_0 + c (R_1 - R_0)) m(c, mu), exact as well; and each map
holds one lobe shape, which a one-lobe fit follows better than the sum of a
narrow coat and a wider metal.
"""

from dataclasses import dataclass

import numpy as np

from .brdf.cycles import GGX, MultiscatterGGX
from .brdf.principled import Principled

__all__ = ["ColourResponse", "response", "with_metallic", "coat_alone", "coat_tint_factor",
           "MU_KNOTS", "PARAMETERS"]

#: The Principled inputs the split applies to (:func:`response`).
PARAMETERS = ("base_color", "specular_tint")
#: Knots of the E(mu) curve, uniform in sqrt(mu) (dense at grazing views, where E
#: changes fastest), as bake.brdf.split.diffuse_curve places its knots.
MU_KNOTS = 33


@dataclass
class ColourResponse:
    """The two single-scatter specs and the energy terms of the module docstring.

    ``low`` / ``high``: canonical bake.brdf specs at base colour 0 and 1
    (Multiscatter off; ``low`` None: a black map, as for a Glossy BSDF);
    ``mu`` (K,) view cosines and ``albedo`` (K,) E(mu) there; ``average``:
    E_avg; ``offset`` / ``slope`` (3,): Fss(c) = offset + slope c
    per channel; ``multiscatter``: False makes m = 1; ``coat``: the spec of the
    coat alone and ``under`` (K, 3) W(mu) at ``mu`` (None: no coat).
    """

    low: str | None
    high: str
    mu: np.ndarray
    albedo: np.ndarray
    average: float
    offset: np.ndarray
    slope: np.ndarray
    multiscatter: bool
    coat: str | None = None
    under: np.ndarray | None = None

    def energy(self, colour, mu) -> np.ndarray:
        """m(c, mu) (..., 3) for colours (..., 3) in [0, 1] and view cosines mu (...)."""
        colour = np.clip(np.asarray(colour, dtype=np.float64), 0.0, 1.0)
        if not self.multiscatter:
            return np.ones(np.broadcast_shapes(colour.shape, np.shape(mu) + (3,)))
        e = np.interp(np.clip(mu, 0.0, 1.0), self.mu, self.albedo)
        e = np.maximum(e, 1e-6)[..., None]
        fss = self.offset + self.slope * colour
        fms = fss * self.average / (1.0 - fss * (1.0 - self.average))
        return 1.0 + fms * (1.0 - e) / e

    def combine(self, low, high, colour, mu, coat=None) -> np.ndarray:
        """C + W(mu) (low + c (high - low)) m(c, mu): the reflection at colour c
        (..., 3) from the maps' values ``low`` / ``high`` (and ``coat``, C, where
        :attr:`coat` is set; else C = 0 and W = 1) (..., 3) at view cosines mu (...)."""
        colour = np.clip(np.asarray(colour, dtype=np.float64), 0.0, 1.0)
        low = 0.0 if low is None else low
        value = (low + colour * (high - low)) * self.energy(colour, mu)
        if self.coat is None:
            return value
        mu = np.clip(mu, 0.0, 1.0)
        under = np.stack([np.interp(mu, self.mu, self.under[:, k]) for k in range(3)], -1)
        return coat + under * value


def response(model, parameter="base_color") -> ColourResponse | None:
    """The ColourResponse of a glossy part ``model`` (a bake.brdf model) to its
    ``parameter`` ("base_color" or "specular_tint", the colour c of the module
    docstring; a Multiscatter GGX Glossy BSDF's Color for "base_color"), or None
    where the split does not apply: anything but a Principled BSDF, for the
    base colour a partly or not metallic one (Metallic < 1: the base colour
    also weights the diffuse layer), for the specular tint
    a partly metallic one (the metal and the dielectric layers would need two
    energy terms) or a dielectric without a specular layer (IOR 1).

    The specular tint enters the F82 Fresnel of a metal (B is affine in it) and
    the dielectric's F0 tint (F = mix(F0 tint, 1, blend), affine too), and Fss
    in the same way, so both are exact as the base colour is. A dielectric's
    diffuse layer below depends on the tint too (its weight 1 - max_c of the
    specular albedo): that is the diffuse part's, not this split's."""
    if isinstance(model, MultiscatterGGX) and parameter == "base_color":
        # A Multiscatter Glossy BSDF: f = c f_GGX m(c, mu) with Fss = c (its Color is
        # its Fresnel): the single-scatter white map times c, then m.
        white = GGX(**{**model.params, "color": 1.0}).spec
        mu = np.linspace(0.0, 1.0, MU_KNOTS) ** 2
        return ColourResponse(None, white, mu, np.interp(mu, model.e_mu, model.e_value),
                              float(model.e_avg), np.zeros(3), np.ones(3), True)
    if not isinstance(model, Principled) or model.conductor is not None:
        return None  # (a physical conductor's metal takes neither colour)
    if parameter == "base_color" and model.metallic != 1.0:
        return None
    if parameter == "specular_tint" and (model.metallic not in (0.0, 1.0) or
                                         model.metallic == 0.0 and model.eta == 1.0):
        return None
    params = dict(model.params)
    params["diffuse"] = 0.0
    ends = [Principled(**{**params, parameter: value}) for value in (0.0, 1.0)]
    fss = [end._metal_fss() if model.metallic == 1.0 else end._spec_fss() for end in ends]
    fss = [np.broadcast_to(np.asarray(f, dtype=np.float64), (3,)) for f in fss]
    below = {**params, "coat_weight": 0.0, "multiscatter": 0.0}  # the layers below a coat
    low, high = (Principled(**{**below, parameter: value}).spec for value in (0.0, 1.0))
    nodes, e, _, average = model._main
    mu = np.linspace(0.0, 1.0, MU_KNOTS) ** 2
    albedo = np.interp(mu, nodes, e)
    coat = under = None
    if model.coat > 0.0:
        coat = coat_alone(model)
        under = model.lower_weights(mu)[0]
    return ColourResponse(low, high, mu, albedo, float(average), fss[0].copy(),
                          fss[1] - fss[0], model.multiscatter, coat, under)


def with_metallic(model, metallic: float):
    """The Principled glossy part ``model`` at Metallic ``metallic``, or None for
    any other model. The Principled BSDF is affine in Metallic (the metal's
    weight is metallic, the specular and diffuse layers' 1 - metallic, under
    a coat that does not depend on it), so maps at 0 and 1 mixed per pixel
    give any metallic exactly."""
    if not isinstance(model, Principled):
        return None
    return Principled(**{**model.params, "metallic": float(metallic)})


def coat_alone(model) -> str | None:
    """The spec of a coated Principled glossy part's coat alone (the same coat over
    Metallic 0 and IOR 1, which leave no layer below it), or None without a coat."""
    if not isinstance(model, Principled) or model.coat <= 0.0:
        return None
    return Principled(**{**model.params, "metallic": 0.0, "ior": 1.0, "specular_tint": 1.0,
                         "base_color": 0.0, "multiscatter": 0.0, "diffuse": 0.0}).spec


def coat_tint_factor(tint, mean, mu, coat: float, ior: float) -> np.ndarray:
    """T(tint, mu) / T(mean, mu) (..., 3): how a coat tint ``tint`` (..., 3) changes
    everything below a coat baked at tint ``mean`` (3,), at view cosines mu (...).

    Cycles weights the layers below a coat by T = 1 + coat (tint^(1 / cos_t) - 1)
    with cos_t = sqrt(1 - (1 - mu^2) / ior^2) (bake.brdf.principled), a function of
    the view alone, so with a map C of the coat alone the reflection at any tint
    is C + T(tint) / T(mean) (R - C), R the map baked at the mean, and the diffuse
    part scales by the same factor: exact (the nodes evaluate this per pixel)."""
    mu = np.clip(np.asarray(mu, dtype=np.float64), 0.0, 1.0)[..., None]
    cos_t = np.sqrt(np.maximum(1.0 - (1.0 - mu**2) / ior**2, 1e-12))

    def weight(t):
        t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)
        return 1.0 + coat * (np.power(t, 1.0 / cos_t) - 1.0)

    return weight(tint) / np.maximum(weight(mean), 1e-6)
