"""bake.colour_response: a metal's BRDF at any base colour from two single-scatter
BRDFs and a view-only energy factor, against the Principled model evaluated at
that colour (bake.brdf.principled, itself checked against Cycles)."""

import numpy as np
import pytest

from bake import brdf, colour_response


def _directions(rng, n):
    w = rng.normal(size=(n, 3))
    w[:, 2] = np.abs(w[:, 2])
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def _worst(extra, roughness, n=200, parameter="base_color", base="metallic=1"):
    """Largest |combine - truth| over random directions and colours, over the peak."""
    rng = np.random.default_rng(7)
    wi, wo = _directions(rng, n), _directions(rng, n)
    colours = rng.uniform(0.0, 1.0, (n, 3))
    fixed = "base_color=0.3," if parameter != "base_color" else ""
    model = brdf.parse(f"principled:{fixed}{parameter}=0.3,{base},roughness={roughness}{extra}")
    found = colour_response.response(model, parameter)
    low = brdf.parse(found.low).f(wi, wo)
    high = brdf.parse(found.high).f(wi, wo)
    truth = np.stack([
        brdf.parse(f"principled:{fixed}{parameter}={'/'.join(f'{x:.9g}' for x in c)},{base},"
                   f"roughness={roughness}{extra}").f(a, b)
        for a, b, c in zip(wi, wo, colours, strict=True)])
    coat = brdf.parse(found.coat).f(wi, wo) if found.coat else None
    got = found.combine(low, high, colours, wo[:, 2], coat)
    return np.abs(got - truth).max() / truth.max()


@pytest.mark.parametrize("roughness", [0.1, 0.5, 0.9])
def test_single_scatter_metal_is_affine_in_its_base_colour(roughness):
    # Without Multiscatter the F82 Fresnel is affine in F0: exact to rounding.
    assert _worst(",multiscatter=0", roughness) < 1e-6


@pytest.mark.parametrize("extra", ["", ",anisotropy=0.5,rotation=0.2",
                                   ",coat_weight=1,coat_roughness=0.1",
                                   ",coat_weight=0.6,coat_roughness=0.3,coat_tint=0.8/0.6/0.4"])
@pytest.mark.parametrize("roughness", [0.1, 0.5, 0.9])
def test_multiscatter_metal_splits_into_two_maps_and_a_view_factor(extra, roughness):
    # The only approximation is E(mu) read from 33 knots (measured: 3.5e-4 of
    # the peak at roughness 0.5); a wrong Fss or E_avg is off by percents.
    assert _worst(extra, roughness) < 2e-3


@pytest.mark.parametrize("base, bound", [
    ("metallic=1", 0.02),  # the F82 clamp at dark tints on a dark base (as below)
    ("metallic=0,ior=1.5,diffuse=0", 2e-3),
    ("metallic=0,ior=1.45,specular_ior_level=0.8,diffuse=0", 2e-3)])
@pytest.mark.parametrize("roughness", [0.1, 0.5])
def test_specular_tint_splits_like_the_base_colour(base, bound, roughness):
    # A metal's F82 edge tint and a dielectric's F0 tint are affine in the tint:
    # exact up to the E(mu) knots. The dielectric's glossy part alone (diffuse=0,
    # as bake.brdf.split bakes it): its diffuse layer is the diffuse part's.
    assert _worst("", roughness, parameter="specular_tint", base=base) < bound


def test_a_coloured_specular_tint_stays_within_the_f82_clamp():
    # A dark tint on dark base colours clamps the F82 Fresnel at 0 at grazing
    # half-vectors (module docstring): measured 1.2% of the peak at roughness 0.9.
    assert _worst(",specular_tint=0.9/0.6/0.3", 0.9) < 0.02


def test_the_coat_map_is_the_coat_alone():
    # A coated metal's coat map: the same coat over nothing (Metallic 0, IOR 1).
    model = brdf.parse("principled:base_color=0.5,metallic=1,roughness=0.4,coat_weight=1")
    coat = brdf.parse(colour_response.response(model).coat)
    assert coat.metallic == 0.0 and coat.eta == 1.0 and coat.coat == 1.0
    found = colour_response.response(model)
    assert "coat_weight=0" in found.low and "coat_weight=0" in found.high
    assert found.under.shape == (colour_response.MU_KNOTS, 3)
    assert np.all((found.under > 0.0) & (found.under <= 1.0))


def test_energy_factor_is_one_without_multiscatter_and_largest_where_the_albedo_is_least():
    model = brdf.parse("principled:base_color=0.5,metallic=1,roughness=0.6")
    found = colour_response.response(model)
    m = found.energy(np.full((found.mu.size, 3), 0.5), found.mu)[:, 0]
    assert np.all(m > 1.0) and np.argmax(m) == np.argmin(found.albedo)
    # A white metal's Fss is 1, so Fms = 1 and m = 1 / E (Cycles' white Multiscatter).
    white = found.energy(np.ones((found.mu.size, 3)), found.mu)[:, 0]
    assert white == pytest.approx(1.0 / found.albedo, rel=1e-9)
    off = colour_response.response(brdf.parse(model.spec.replace("multiscatter=1",
                                                                 "multiscatter=0")))
    assert np.all(off.energy(np.full(3, 0.5), 0.3) == 1.0)


@pytest.mark.parametrize("spec", [
    "ggx:roughness=0.3",
    "principled:base_color=0.5,metallic=0.5,roughness=0.3",
    "principled:base_color=0.5,metallic=0,roughness=0.3",
])
def test_only_metals_get_the_base_colour_split(spec):
    assert colour_response.response(brdf.parse(spec)) is None


@pytest.mark.parametrize("spec", [
    "principled:metallic=0.5,roughness=0.3",
    "principled:metallic=0,ior=1,roughness=0.3",
])
def test_the_tint_split_needs_one_layer(spec):
    assert colour_response.response(brdf.parse(spec), "specular_tint") is None


@pytest.mark.parametrize("roughness", [0.2, 0.6])
def test_a_multiscatter_glossy_bsdf_s_colour_is_a_white_map_times_c_and_m(roughness):
    rng = np.random.default_rng(3)
    wi, wo = _directions(rng, 300), _directions(rng, 300)
    colours = rng.uniform(0.0, 1.0, (300, 3))
    found = colour_response.response(
        brdf.parse(f"ggx_multiscatter:roughness={roughness},color=0.5"))
    assert found.low is None
    high = brdf.parse(found.high).f(wi, wo)
    truth = np.stack([brdf.parse(f"ggx_multiscatter:roughness={roughness},color="
                                 f"{'/'.join(f'{x:.9g}' for x in c)}").f(a, b)
                      for a, b, c in zip(wi, wo, colours, strict=True)])
    got = found.combine(None, high, colours, wo[:, 2])
    # Exact up to E(mu) at 33 knots; the c / mean factor is off by up to 10%
    # (benchmarks/colour_response.py).
    assert np.abs(got - truth).max() / truth.max() < 2e-3


@pytest.mark.parametrize("below", ["metallic=1,base_color=0.7/0.5/0.3",
                                   "metallic=0,base_color=0.2/0.6/0.3,diffuse=1"])
def test_a_coat_tint_scales_what_lies_below_the_coat_alone(below):
    # C + T(t) / T(mean) (R(mean) - C) against the model at tint t (diffuse layer
    # included: it lies below the coat too): exact.
    rng = np.random.default_rng(5)
    wi, wo = _directions(rng, 300), _directions(rng, 300)
    spec = f"principled:{below},roughness=0.4,coat_weight=0.8,coat_roughness=0.1,coat_ior=1.6"
    mean = np.array([0.5, 0.6, 0.7])
    model = brdf.parse(f"{spec},coat_tint=0.5/0.6/0.7")
    coat = brdf.parse(colour_response.coat_alone(model)).f(wi, wo)
    tints = rng.uniform(0.0, 1.0, (300, 3))
    truth = np.stack([brdf.parse(f"{spec},coat_tint={'/'.join(f'{x:.9g}' for x in t)}").f(a, b)
                      for a, b, t in zip(wi, wo, tints, strict=True)])
    got = coat + colour_response.coat_tint_factor(tints, mean, wo[:, 2], 0.8, 1.6) * (
        model.f(wi, wo) - coat)
    assert np.abs(got - truth).max() / truth.max() < 1e-8
    assert colour_response.coat_alone(brdf.parse("principled:roughness=0.3")) is None


def test_a_bake_takes_each_knot_s_high_map_before_its_low_one():
    """glossy_addon.spatial.split_order: map_variants lists a knot's maps as Metallic 0,
    colour 0, colour 1, coat; the bake filters colour 1 first so colour 0 may take its
    lobes (bake.prefilter.Companion), everything else in the listed order.
    split_share: the split input's mean, its smallest channel (0 without a mean)."""
    from types import SimpleNamespace

    from glossy_addon.spatial import HIGH, LOW, split_order, split_share

    variants = [(0.2, "dielectric"), (0.2, LOW), (0.2, HIGH), (0.2, "coat"),
                (0.4, "dielectric"), (0.4, LOW), (0.4, HIGH), (None, "metal")]
    assert split_order(variants) == [0, 2, 1, 3, 4, 6, 5, 7]
    assert split_order([(None, HIGH), (None, LOW)]) == [0, 1]
    assert split_order([(None, LOW)]) == [0]
    colour = {"split": True, "mean": [0.5, 0.375, 0.35]}
    assert split_share(SimpleNamespace(spatial={"colour": colour})) == 0.35
    assert split_share(SimpleNamespace(spatial={"tint": {"split": True}})) == 0.0
    assert split_share(None) == 0.0
