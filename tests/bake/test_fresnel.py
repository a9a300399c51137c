"""Fresnel terms against Snell's-law s/p reflectances and published normal-incidence values."""

import numpy as np

from bake.brdf import fresnel


def snell_reflectance(cos_i, n):
    sin_t = np.sqrt(1 - cos_i**2) / n
    cos_t = np.sqrt(1 - sin_t**2)
    rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)) ** 2
    rp = ((n * cos_i - cos_t) / (n * cos_i + cos_t)) ** 2
    return 0.5 * (rs + rp)


def test_dielectric_matches_snell_and_limits():
    c = np.linspace(0.01, 1.0, 200)
    for n in (1.33, 1.5, 2.4):
        np.testing.assert_allclose(fresnel.dielectric(c, n), snell_reflectance(c, n), rtol=1e-10)
        assert fresnel.dielectric(1.0, n) == np.float64(((n - 1) / (n + 1)) ** 2).item() or \
            abs(fresnel.dielectric(1.0, n) - ((n - 1) / (n + 1)) ** 2) < 1e-15
    assert fresnel.dielectric(0.0, 1.5) == 1.0
    # Inside glass beyond the critical angle: total internal reflection.
    assert fresnel.dielectric(np.cos(np.radians(60)), 1 / 1.5) == 1.0


def test_conductor_reduces_to_dielectric_and_matches_gold():
    c = np.linspace(0.05, 1, 50)
    np.testing.assert_allclose(fresnel.conductor(c, 1.5, 0.0), fresnel.dielectric(c, 1.5),
                               rtol=1e-10)
    # Gold near 550 nm: n = 0.42, k = 2.35; F0 = ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    n, k = 0.42, 2.35
    assert abs(fresnel.conductor(1.0, n, k) - ((n - 1) ** 2 + k**2) / ((n + 1) ** 2 + k**2)) < 1e-12
    eta, k = np.array([0.2, 0.9, 1.1]), np.array([3.9, 2.4, 1.8])
    rgb = fresnel.conductor(np.array([1.0, 0.5]), eta, k)
    assert rgb.shape == (2, 3) and np.all((rgb > 0) & (rgb <= 1))
    assert np.all(fresnel.conductor(0.0, 0.42, 2.35) == 1.0)


def test_schlick_and_blend():
    f0 = fresnel.f0_from_ior(1.5)
    assert abs(f0 - 0.04) < 1e-12
    c = np.linspace(0, 1, 101)
    # Schlick is exact at normal incidence and at grazing; in between it is
    # known to undershoot glass by up to about 0.036 (near 80 degrees).
    error = np.abs(fresnel.schlick(c, f0) - fresnel.dielectric(c, 1.5))
    assert error[[0, -1]].max() < 1e-12 and error.max() < 0.04
    assert fresnel.schlick(c, [0.9, 0.5, 0.1]).shape == (101, 3)
    np.testing.assert_allclose(fresnel.blend(0.25, 8.0, 4.0), 5.0)
