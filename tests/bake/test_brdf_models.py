"""Every BRDF model: reciprocity, albedo, sampler density, importance vs uniform sampling."""

import numpy as np
import pytest

from bake import brdf
from tests.bake.reference import direction, reference_albedo, sphere_quadrature

SPECS = [
    "lambert:color=0.9/0.5/0.2",
    "phong:n=80,ks=0.7,kd=0.2",
    "blinn_phong:n=120,ks=0.8",
    "ward:alpha=0.1,ks=0.9",
    "ward:ax=0.06,ay=0.2,ks=0.8,kd=0.1",
    "cook_torrance:m=0.25,ior=1.5,kd=0.3",
    "ggx:roughness=0.3",
    "ggx:roughness=0.5,anisotropy=0.6,rotation=0.1",
    "ggx:roughness=0.45,anisotropy=-0.5,rotation=0.3",
    "beckmann:roughness=0.4",
    "beckmann:roughness=0.5,anisotropy=0.5,rotation=0.2",
    "ashikhmin_shirley:roughness=0.35",
    "ashikhmin_shirley:roughness=0.5,anisotropy=0.4",
    "principled_metallic:roughness=0.35,base_color=0.9/0.6/0.2,specular_tint=0.5",
    "ggx_multiscatter:roughness=0.6",
    "kurt:kd=0.1,ks=0.6,mx=0.15,my=0.3,f0=0.8,alpha=0.3,ks2=0.3,mx2=0.4,my2=0.4",
    "lafortune:kd=0.1,rho=3,cx=-1,cy=-0.8,cz=0.9,n=15",
    "sum(lambert:color=0.3; ggx:roughness=0.35)",
    "layer(ior=1.5; ggx:roughness=0.2; lambert:color=0.6)",
]
VIEWS = [0.0, 35.0, 65.0, 80.0]


def random_pairs(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2]) + 1e-3
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@pytest.mark.parametrize("spec", SPECS)
def test_reciprocity_where_it_holds(spec):
    model = brdf.parse(spec)
    wi, wo = random_pairs()
    forward, backward = model.f(wi, wo), model.f(wo, wi)
    assert np.all(np.isfinite(forward)) and forward.min() >= 0.0
    if model.reciprocal:
        np.testing.assert_allclose(forward, backward, rtol=1e-6, atol=1e-12)
    else:
        # Multiscatter GGX divides by E(cos theta_o): swapping the directions
        # changes it wherever the two cosines differ.
        assert np.max(np.abs(forward - backward) / (forward + 1e-9)) > 0.01


@pytest.mark.parametrize("spec", SPECS)
def test_albedo_matches_independent_quadrature(spec):
    model = brdf.parse(spec)
    for theta in VIEWS:
        wo = direction(theta, 20.0)
        reference = reference_albedo(model, wo)
        # 0.5%: the bound. The QMC estimate is far better for smooth
        # lobes; the quadrature converges to ~1e-5 at n = 400.
        np.testing.assert_allclose(model.albedo(wo), reference, rtol=5e-3, atol=1e-4,
                                   err_msg=f"{spec} at {theta} deg")


def test_closed_form_albedos():
    lam = brdf.parse("lambert:color=0.9/0.5/0.2")
    np.testing.assert_allclose(lam.albedo(direction(50.0)), [0.9, 0.5, 0.2], rtol=1e-9)
    # Lewis' Phong reflects exactly ks at normal incidence (Heidrich eq. 16).
    phong = brdf.parse("phong:n=60,ks=0.7")
    np.testing.assert_allclose(phong.albedo(direction(0.0)), 0.7, rtol=2e-3)
    # Ward's lobe normalizes to ks at normal incidence for small alpha
    # (Ward 1992: exact in the small-slope limit).
    ward = brdf.parse("ward:alpha=0.02,ks=0.8")
    np.testing.assert_allclose(ward.albedo(direction(0.0)), 0.8, rtol=5e-3)


@pytest.mark.parametrize("spec", SPECS)
def test_sampler_density_integrates_to_one(spec):
    model = brdf.parse(spec)
    for theta in (10.0, 60.0):
        wo = direction(theta, 40.0)
        axis = np.array([-wo[0], -wo[1], wo[2]])
        total = sphere_quadrature(lambda wi, wo=wo: model.pdf(wi, np.broadcast_to(wo, wi.shape)),
                                  axis=axis)
        assert abs(total - 1.0) < 0.01, (spec, theta, total)


@pytest.mark.parametrize("spec", SPECS)
def test_sampler_histogram_matches_its_pdf(spec):
    """Counts of 400k samples in solid-angle bins against the pdf integrated over each bin."""
    model = brdf.parse(spec)
    wo = direction(40.0, 30.0)
    rng = np.random.default_rng(7)
    n = 400_000
    wi, pdf = model.sample(np.broadcast_to(wo, (n, 3)), rng.random((n, 2)))
    np.testing.assert_allclose(pdf, model.pdf(wi, np.broadcast_to(wo, (n, 3))), rtol=1e-6)
    # Bins in (cos theta, phi) over the sphere: 20 x 24.
    edges_c = np.linspace(-1, 1, 21)
    edges_p = np.linspace(-np.pi, np.pi, 25)
    counts, _, _ = np.histogram2d(wi[:, 2], np.arctan2(wi[:, 1], wi[:, 0]), [edges_c, edges_p])
    # Expected: the pdf integrated over each bin with a fine midpoint grid.
    m = 24
    c = edges_c[:-1, None] + (np.arange(m) + 0.5)[None, :] * (2 / 20 / m)
    p = edges_p[:-1, None] + (np.arange(m) + 0.5)[None, :] * (2 * np.pi / 24 / m)
    cc, pp = np.meshgrid(c.reshape(-1), p.reshape(-1), indexing="ij")
    s = np.sqrt(np.clip(1 - cc**2, 0, None))
    d = np.stack([s * np.cos(pp), s * np.sin(pp), cc], -1)
    density = model.pdf(d, np.broadcast_to(wo, d.shape)) * (2 / 20 / m) * (2 * np.pi / 24 / m)
    expected = density.reshape(20, m, 24, m).sum(axis=(1, 3)) * n
    big = expected > 2000
    # Poisson noise on >= 2000 counts is <= 2.2%; allow 4 sigma plus the
    # midpoint rule's error on the bin integrals (~1% for sharp bins).
    deviation = np.abs(counts[big] - expected[big]) / expected[big]
    assert deviation.max() < 4.0 / np.sqrt(2000) + 0.01, (spec, deviation.max())
    assert abs(counts.sum() - expected.sum()) / n < 0.01


@pytest.mark.parametrize("spec", SPECS)
def test_importance_sampling_agrees_with_uniform_sampling(spec):
    model = brdf.parse(spec)
    wo = direction(50.0, 10.0)
    rng = np.random.default_rng(11)
    n = 1 << 19
    wi, pdf = model.sample(np.broadcast_to(wo, (n, 3)), rng.random((n, 2)))
    weight = np.where(pdf > 0, np.clip(wi[:, 2], 0, None) / np.where(pdf > 0, pdf, 1), 0.0)
    importance = model.f(wi, np.broadcast_to(wo, wi.shape)) * weight[:, None]
    # Uniform hemisphere directions, pdf 1 / (2 pi).
    u = rng.random((n, 2))
    z = u[:, 0]
    r = np.sqrt(1 - z**2)
    uni = np.stack([r * np.cos(2 * np.pi * u[:, 1]), r * np.sin(2 * np.pi * u[:, 1]), z], -1)
    uniform = model.f(uni, np.broadcast_to(wo, uni.shape)) * (z * 2 * np.pi)[:, None]
    a, b = importance.mean(0), uniform.mean(0)
    sigma = np.sqrt(importance.var(0) / n + uniform.var(0) / n)
    assert np.all(np.abs(a - b) <= 5 * sigma + 1e-4), (spec, a, b, sigma)


@pytest.mark.parametrize("spec", SPECS + [
    "principled:base_color=0.9/0.5/0.2,metallic=0.4,roughness=0.3,anisotropy=0.5,rotation=0.2,"
    "coat_weight=0.8,coat_roughness=0.05,coat_tint=0.9/0.6/0.3"])
def test_a_view_given_once_for_many_lights_is_the_same_as_one_view_per_light(spec):
    # BRDF.f hands wi (M, K, 3) and wo (M, 1, 3) to the model unbroadcast, so terms of
    # the view alone are computed once per view (the reference renderer's speed):
    # the values must be those of wo repeated per light, bit for bit, and both
    # directions below the horizon must still give 0.
    model = brdf.parse(spec)
    rng = np.random.default_rng(4)
    wi = rng.normal(size=(50, 6, 3))
    wo = rng.normal(size=(50, 1, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    once = model.f(wi, wo)
    repeated = model.f(wi, np.repeat(wo, 6, axis=1))
    assert once.shape == (50, 6, 3)
    np.testing.assert_array_equal(once, repeated)
    below = (wi[..., 2] <= 0) | (wo[..., 2] <= 0)
    assert below.any() and not np.any(once[below])
    assert np.any(once[~below])
