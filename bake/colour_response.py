"""A metal's reflection as a function of a base colour that varies per pixel.

A metallic Principled BSDF (Metallic = 1, Cycles' F82-tint Fresnel with F0 =
Base Color, bake.brdf.principled) is not linear in its base colour c: toward
grazing angles its Fresnel goes to white, not to a scaled colour, so a map
baked at one colour and scaled by c / mean per pixel is wrong wherever c is
far from the mean (benchmarks/colour_response.py measures it: 10-48% relative
RMS for dark texels). Per channel, with the Specular Tint fixed, the reflection
splits exactly into

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
the E(mu) curve's 33 knots (3e-4 of the peak). A coated metal is left out
(:func:`response` gives None): the coat does not depend on c but would be
scaled by m too, off by up to a third of the peak at roughness 0.9 (it would
need a third map of the coat alone).
"""

from dataclasses import dataclass

import numpy as np

from .brdf.principled import Principled

__all__ = ["ColourResponse", "response", "MU_KNOTS"]

#: Knots of the E(mu) curve, uniform in sqrt(mu) (dense at grazing views, where E
#: changes fastest), as bake.brdf.split.diffuse_curve places its knots.
MU_KNOTS = 33
_MU82 = 6.0 / 7.0


@dataclass
class ColourResponse:
    """The two single-scatter specs and the energy terms of the module docstring.

    ``low`` / ``high``: canonical bake.brdf specs at base colour 0 and 1
    (Multiscatter off); ``mu`` (K,) view cosines and ``albedo`` (K,) E(mu) there;
    ``average``: E_avg; ``offset`` / ``slope`` (3,): Fss(c) = offset + slope c
    per channel; ``multiscatter``: False makes m = 1.
    """

    low: str
    high: str
    mu: np.ndarray
    albedo: np.ndarray
    average: float
    offset: np.ndarray
    slope: np.ndarray
    multiscatter: bool

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

    def combine(self, low, high, colour, mu) -> np.ndarray:
        """(low + c (high - low)) m(c, mu): the reflection at colour c (..., 3) from
        the two maps' values ``low`` / ``high`` (..., 3) at view cosines mu (...)."""
        colour = np.clip(np.asarray(colour, dtype=np.float64), 0.0, 1.0)
        return (low + colour * (high - low)) * self.energy(colour, mu)


def response(model) -> ColourResponse | None:
    """The ColourResponse of a glossy part ``model`` (a bake.brdf model) to its base
    colour, or None where the module's split does not apply: anything but an
    uncoated Principled BSDF with Metallic = 1 (whose diffuse layer has weight 0)."""
    if not isinstance(model, Principled) or model.metallic != 1.0 or model.coat > 0.0:
        return None
    params = dict(model.params)
    params.update(multiscatter=0.0, diffuse=0.0)
    low = Principled(**{**params, "base_color": 0.0}).spec
    high = Principled(**{**params, "base_color": 1.0}).spec
    # Fss(c) = c + (1 - c) / 21 - B(c) / 126 with B(c) = (c + (1 - c) mu82^5) 7 / mu82^6
    # (1 - tint) (bake.brdf.principled._metal_fss), affine in c.
    tint = np.broadcast_to(np.asarray(model.params["specular_tint"], dtype=np.float64), (3,))
    scale = 7.0 / _MU82**6 * (1.0 - tint) / 126.0
    offset = 1.0 / 21.0 - _MU82**5 * scale
    slope = 1.0 - 1.0 / 21.0 - (1.0 - _MU82**5) * scale
    nodes, e, _, average = model._main
    mu = np.linspace(0.0, 1.0, MU_KNOTS) ** 2
    albedo = np.interp(mu, nodes, e)
    return ColourResponse(low, high, mu, albedo, float(average), offset, slope,
                          model.multiscatter)
