"""Spherical harmonics (bake.sh) and the SH reflection path (bake.sh_reflection)
against exact identities, re-projection and the brute-force integral."""

import math
import subprocess
import sys

import numpy as np
import pytest

from bake import brdf, bumpbrdf, envmap, prefilter, reference, sh
from bake import sh_reflection as shr
from tests.conftest import ROOT

LUM = np.array([0.2126, 0.7152, 0.0722])


def _random_rotations(rng, count):
    out = []
    for _ in range(count):
        q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
        out.append(q * np.sign(np.linalg.det(q)))
    # The Euler angles' special cases: identity, half turns about z and about x.
    return np.array(out + [np.eye(3), np.diag([-1.0, -1.0, 1.0]), np.diag([1.0, -1.0, -1.0])])


def test_order_two_is_the_classic_nine_polynomials():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(40, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    x, y, z = d.T
    classic = np.stack([np.full_like(x, 0.5 / math.sqrt(math.pi)),
                        math.sqrt(3 / (4 * math.pi)) * y, math.sqrt(3 / (4 * math.pi)) * z,
                        math.sqrt(3 / (4 * math.pi)) * x,
                        0.5 * math.sqrt(15 / math.pi) * x * y,
                        0.5 * math.sqrt(15 / math.pi) * y * z,
                        0.25 * math.sqrt(5 / math.pi) * (3 * z * z - 1),
                        0.5 * math.sqrt(15 / math.pi) * x * z,
                        0.25 * math.sqrt(15 / math.pi) * (x * x - y * y)], -1)
    assert np.allclose(sh.basis(d, 2), classic, atol=1e-14)


def test_projection_of_a_band_limited_function_is_exact():
    order = 16
    coefficients = np.random.default_rng(2).normal(size=(sh.count(order), 3))
    again = sh.project_function(lambda d: sh.evaluate(coefficients, d, order), order)
    assert np.abs(again - coefficients).max() < 1e-10
    d, w = sh.quadrature(2 * order)  # orthonormality, on a finer exact rule
    y = sh.basis(d, order)
    assert np.abs((y * w[:, None]).T @ y - np.eye(sh.count(order))).max() < 1e-10


def test_rotation_matches_re_projection():
    order = 16
    rng = np.random.default_rng(3)
    coefficients = rng.normal(size=(sh.count(order), 2))
    for rotation in _random_rotations(rng, 3):
        direct = sh.rotate(coefficients, rotation, order)
        # f(R^-1 d) with d as rows: R^-1 d = R^T d -> d @ R.
        projected = sh.project_function(
            lambda d, r=rotation: sh.evaluate(coefficients, d @ r, order), order)
        assert np.abs(direct - projected).max() < 1e-10


def test_many_rotations_by_euler_angles_equal_the_quadrature_matrices():
    order = 12
    rng = np.random.default_rng(4)
    rotations = _random_rotations(rng, 6)
    vectors = rng.normal(size=(len(rotations), sh.count(order)))
    fast = sh.rotate_many(vectors, rotations, order)
    exact = np.array([sh.rotation_matrix(r, order) @ v
                      for r, v in zip(rotations, vectors, strict=True)])
    assert np.abs(fast - exact).max() < 1e-10


@pytest.fixture(scope="module")
def sphere_case(forest):
    probe = envmap.convert(forest, "latlong", "cube", 32)
    normals, views, mask = reference.sphere_buffers(32)
    normals, views = normals[mask], views[mask]
    spec = "ggx:roughness=0.5"
    truth = reference.render(brdf.parse(spec), probe, "cube", normals, views)
    return probe, spec, normals, views, truth


def _relative_rms(values, truth):
    difference = (values - truth) @ LUM
    return float(np.sqrt(np.sum(difference**2) / np.sum((truth @ LUM) ** 2)))


def test_the_sh_render_converges_to_brute_force(sphere_case):
    """GGX 0.5 (alpha 0.25) sphere in forest.exr: measured 26% / 14% / 3.6% / 0.6%
    at M = 2 / 4 / 8 / 16 (benchmarks/prefilter.py section 7); the band-limited
    lobe is the only approximation, so the error must fall with M."""
    probe, spec, normals, views, truth = sphere_case
    errors = [_relative_rms(prefilter.prefilter(probe, spec, "sh", order=order)
                            .shade(normals, views), truth) for order in (4, 8, 16)]
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[1] < 0.06 and errors[2] < 0.015, errors


def test_one_view_fourier_series_equals_per_pixel_rotation(sphere_case):
    """Eq. 8 (g_m per view, spline in alpha, Fourier sum in beta) and the per-pixel
    rotation evaluate the same expansion: equal to rounding."""
    probe, spec, normals, _, _ = sphere_case
    order = 8
    reflection = shr.SHReflection(sh.project(probe, "cube", order),
                                  shr.lobe_coefficients(brdf.parse(spec), order))
    view = np.array([0.2, -0.3, 0.93])
    one = reflection.shade_one_view(normals, view)
    alpha, rotations = shr.view_frames(normals, np.broadcast_to(view, normals.shape))
    lobes = shr.catmull_rom(reflection.lobe, alpha)[..., 0]
    per_pixel = sh.rotate_many(lobes, rotations, order) @ reflection.environment
    assert np.abs(one - per_pixel).max() < 1e-10 * np.abs(per_pixel).max()


def test_facet_coefficients_of_a_gaussian_surface_are_beckmann_s():
    """Section 8: a_lm from the facets' beams directly, against the quadrature of
    Beckmann + Smith at alpha = sqrt(2) sigma (F = 1). Measured on 256^2: 1-2% of
    the coefficient vector's norm up to 70 degrees; here 128^2 (four times fewer
    bumps, so about twice the noise): bound 5%."""
    sigma, order = 0.2, 6
    surface = bumpbrdf.BumpSurface(bumpbrdf.gaussian_surface(128, sigma, 4.0, 0), mirror=True)
    facets = shr.facet_coefficients(surface, order, alphas=5, azimuths=4)[..., 0]
    model = brdf.parse(f"beckmann:alpha={math.sqrt(2) * sigma}")
    exact = shr.lobe_coefficients(model, order, alphas=5)[..., 0]
    for j, alpha in enumerate(shr.alpha_nodes(5)):
        if alpha > math.radians(70):
            continue
        assert np.linalg.norm(facets[j] - exact[j]) < 0.05 * np.linalg.norm(exact[j]), j


def test_the_command_line_writes_an_sh_map_that_shades(tmp_path, sphere_case):
    from bake import exr

    probe, spec, normals, views, truth = sphere_case
    exr.write(tmp_path / "probe.exr", probe.astype(np.float32), {"layout": "cube"})
    result = subprocess.run([sys.executable, "-m", "bake", "prefilter", str(tmp_path / "probe.exr"),
                             "--mode", "sh", "--order", "12", "--brdf", spec, "-o",
                             str(tmp_path / "sh.exr")], cwd=ROOT, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    baked = prefilter.load(tmp_path / "sh.exr")
    assert baked.mode == "sh" and baked.meta["order"] == 12
    assert _relative_rms(baked.shade(normals, views), truth) < 0.03
    bad = subprocess.run([sys.executable, "-m", "bake", "prefilter", str(tmp_path / "probe.exr"),
                          "--mode", "sh", "--brdf", "ggx:roughness=0.3,anisotropy=0.8", "-o",
                          str(tmp_path / "bad.exr")], cwd=ROOT, capture_output=True, text=True)
    assert bad.returncode != 0 and "isotropic" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1 and not (tmp_path / "bad.exr").exists()
