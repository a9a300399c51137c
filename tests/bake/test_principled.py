"""bake.brdf.principled, scale / fresnel_mix and bake.brdf.split against closed forms."""

import numpy as np
import pytest

from bake import brdf
from bake.brdf.split import diffuse_curve, split


def _directions(count, seed):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(count, 3))
    v[:, 2] = np.abs(v[:, 2]) + 1e-3
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("roughness", [0.2, 0.5, 0.9])
@pytest.mark.parametrize("kind", ["metal", "dielectric", "coated"])
def test_multiscatter_white_furnace_is_one(roughness, kind):
    """Energy preservation: with a white base (and white F0 for the metal) every
    layer passes on exactly what the one above does not reflect, so the albedo
    is 1 at every view (Kulla & Conty; Cycles' furnace reads 1.000)."""
    extra = {"metal": "metallic=1", "dielectric": "metallic=0",
             "coated": "metallic=0,coat_weight=1,coat_roughness=0.3"}[kind]
    model = brdf.parse(f"principled:base_color=1,roughness={roughness},{extra}")
    for mu in (1.0, 0.6, 0.25):
        wo = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
        # 1 << 15 Hammersley points: the quadrature is good to ~3e-4 here.
        np.testing.assert_allclose(model.albedo(wo, 1 << 15), 1.0, atol=2e-3)


def test_metallic_single_scatter_equals_principled_metallic():
    a, b = _directions(2000, 1), _directions(2000, 2)
    colours = "base_color=0.9/0.5/0.3,specular_tint=0.7/0.8/0.9,roughness=0.4,anisotropy=0.5"
    full = brdf.parse(f"principled:metallic=1,multiscatter=0,rotation=0.1,{colours}")
    metal = brdf.parse(f"principled_metallic:rotation=0.1,{colours}")
    np.testing.assert_allclose(full.f(a, b), metal.f(a, b), rtol=1e-12, atol=1e-14)


def test_specular_level_half_is_the_real_dielectric_fresnel():
    """At Specular IOR Level 0.5 and a white tint the blend factor gives back the
    exact dielectric Fresnel: f_spec = f_GGX F(h.v, ior) (the diffuse dropped)."""
    a, b = _directions(2000, 3), _directions(2000, 4)
    spec = brdf.parse("principled:base_color=0,roughness=0.3,ior=1.7,multiscatter=0,diffuse=0")
    ggx = brdf.parse("ggx:roughness=0.3")
    h = (a + b) / np.linalg.norm(a + b, axis=1, keepdims=True)
    fresnel = brdf.fresnel.dielectric(np.sum(h * b, axis=1), 1.7)
    np.testing.assert_allclose(spec.f(a, b), ggx.f(a, b) * fresnel[:, None], rtol=1e-10,
                               atol=1e-14)


def test_split_adds_back_to_the_model():
    a, b = _directions(1000, 5), _directions(1000, 6)
    for spec in ["principled:base_color=0.8/0.3/0.2,roughness=0.4,coat_weight=0.5,"
                 "coat_roughness=0.1,coat_tint=0.9/0.8/0.7",
                 "fresnel_mix(ior=1.45; lambert:color=0.3/0.5/0.2; beckmann:roughness=0.4)",
                 "sum(scale(k=0.6; lambert:color=0.6/0.3/0.2); scale(k=0.4; ggx:roughness=0.3))"]:
        model = brdf.parse(spec)
        glossy, diffuse = split(model)
        rebuilt = glossy.f(a, b) + diffuse(b[:, 2]) / np.pi
        np.testing.assert_allclose(model.f(a, b), rebuilt, rtol=1e-12, atol=1e-14)
        colour, mu, weight = diffuse_curve(model)
        fine = np.linspace(0.0, 1.0, 4001)
        interpolated = colour * np.stack([np.interp(fine, mu, weight[:, c]) for c in range(3)],
                                         -1)
        assert np.abs(interpolated - diffuse(fine)).max() < 2e-3


def test_composite_specs_round_trip_and_refuse_bad_values():
    text = "fresnel_mix(ior=1.45; lambert:color=0.2; scale(k=0.5/0.6/0.7; ggx:roughness=0.3))"
    model = brdf.parse(text)
    assert brdf.parse(model.spec) == model
    with pytest.raises(brdf.SpecError, match="fresnel_mix"):
        brdf.parse("fresnel_mix(ior=0.5; lambert:color=0.2; ggx:roughness=0.3)")
    with pytest.raises(brdf.SpecError, match="scale"):
        brdf.parse("scale(k=-1; ggx:roughness=0.3)")
    with pytest.raises(brdf.SpecError, match="multiscatter"):
        brdf.parse("principled:multiscatter=0.5")
