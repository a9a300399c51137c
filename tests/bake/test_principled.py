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


def test_physical_conductor_is_the_exact_conductor_fresnel():
    """A conductor's metal: f = the single-scatter GGX lobe times the exact Fresnel of
    n + i k (a closed form, checked at normal incidence against ((n-1)^2 + k^2) /
    ((n+1)^2 + k^2)); its Fss is the F82 model's through the conductor's values at
    c = 1 and 1/7. With n = 1 and k = 0 the Fresnel is 0 (nothing reflects)."""
    n, k = np.array([0.143, 0.374, 1.442]), np.array([3.983, 2.385, 1.603])
    spec = "principled:metallic=1,roughness=0.4,multiscatter=0,anisotropy=0.5,rotation=0.1"
    gold = brdf.parse(f"{spec},conductor_ior=0.143/0.374/1.442,"
                      f"conductor_extinction=3.983/2.385/1.603")
    white = brdf.parse(f"{spec},base_color=1")  # F = 1 everywhere: the bare lobe
    a, b = _directions(2000, 3), _directions(2000, 4)
    h = a + b
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    c = np.sum(h * b, axis=1)
    from bake.brdf import fresnel

    np.testing.assert_allclose(gold.f(a, b), white.f(a, b) * fresnel.conductor(c, n, k),
                               rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(fresnel.conductor(1.0, n, k),
                               ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2), rtol=1e-12)
    f0, f82 = fresnel.conductor(1.0, n, k), fresnel.conductor(1 / 7, n, k)
    b82 = 7 / (6 / 7) ** 6 * (f0 + (1 - f0) * (6 / 7) ** 5 - f82)
    np.testing.assert_allclose(gold._metal_fss(), f0 + (1 - f0) / 21 - b82 / 126, rtol=1e-12)
    air = brdf.parse(f"{spec},conductor_ior=1,conductor_extinction=0")
    assert np.abs(air.f(a, b)).max() < 1e-12
    # The F82 metal's spec is unchanged by the conductor's keys (absent unless given).
    assert "conductor" not in brdf.parse("principled:metallic=1").spec
    with pytest.raises(brdf.SpecError, match="given together"):
        brdf.parse("principled:metallic=1,conductor_ior=2")


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
