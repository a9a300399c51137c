"""A model split into what a glossy map bakes and a view-weighted diffuse part.

``split(model)`` returns (glossy model or None, diffuse weight function): the
model equals glossy + D(mu_o) / pi, D (..., 3) the diffuse layer's reflectance
seen at view cosine mu_o (Lambert parts, the Principled diffuse layer under
its coat, metal and specular weights, and these inside scale / sum /
fresnel_mix). ``diffuse_curve`` samples D on knots for the irradiance bake and
the attached material's view curve.
"""

import numpy as np

from .classic import Lambert
from .combine import FresnelMix, Scale, Sum
from .principled import Principled

__all__ = ["split", "diffuse_curve"]


def _zero(mu):
    return np.zeros(np.shape(mu) + (3,))


def split(model):
    """(glossy model or None, D(mu) -> (..., 3)) with model = glossy + D(mu_o) / pi."""
    if isinstance(model, Lambert):
        colour = np.asarray(model.params["color"], dtype=np.float64)
        return None, lambda mu: np.broadcast_to(colour, np.shape(mu) + (3,)).copy()
    if isinstance(model, Principled) and model.params["diffuse"] == 1.0:
        from .principled import Principled as _P

        params = dict(model.params)
        params["diffuse"] = 0.0
        glossy = _P(**params)
        return glossy, lambda mu: model.lower_weights(mu)[1] * model.diffuse_colour()
    if isinstance(model, Scale):
        glossy, diffuse = split(model.parts[0])
        k = model.k
        return (None if glossy is None else Scale(k, glossy)), lambda mu: k * diffuse(mu)
    if isinstance(model, Sum):
        pieces = [split(part) for part in model.parts]
        glossy = [g for g, _ in pieces if g is not None]
        model_glossy = None if not glossy else glossy[0] if len(glossy) == 1 else Sum(glossy)
        return model_glossy, lambda mu: sum(d(mu) for _, d in pieces)
    if isinstance(model, FresnelMix):
        (g1, d1), (g2, d2) = (split(part) for part in model.parts)
        if g1 is None and g2 is None:
            glossy = None
        else:
            black = Lambert(color=0.0)
            glossy = FresnelMix(model.ior, g1 or black, g2 or black)

        def diffuse(mu):
            f = model.weight(np.asarray(mu, dtype=np.float64))[..., None]
            return (1.0 - f) * d1(mu) + f * d2(mu)

        return glossy, diffuse
    return model, _zero


def diffuse_curve(model, knots: int = 33):
    """(colour (3,), mu (K,), weight (K, 3)): D(mu) = colour * weight(mu) with
    weight in [0, 1] and colour the per-channel maximum of D over mu in [0, 1] (a
    black colour: no diffuse part). Knots are uniform in sqrt(mu), dense at grazing
    views where D falls fastest; linear interpolation between 33 of them is within
    2e-3 of D for the Principled layering (tests/bake/test_principled.py)."""
    _, diffuse = split(model)
    mu = np.linspace(0.0, 1.0, knots) ** 2
    values = diffuse(mu)
    colour = values.max(axis=0)
    weight = np.where(colour > 0, values / np.where(colour > 0, colour, 1.0), 0.0)
    return colour, mu, np.clip(weight, 0.0, 1.0)
