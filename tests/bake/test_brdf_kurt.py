"""The Kurt et al. 2010 model as the regular-sampling paper writes it (eqs. 1-7, 10)."""

import math

import numpy as np

from bake import brdf


def kurt_scalar(wi, wo, kd, lobes):
    """Eq. 1-5 written out for one direction pair (independent of bake.brdf)."""
    h = [a + b for a, b in zip(wi, wo, strict=True)]
    norm = math.sqrt(sum(c * c for c in h))
    h = [c / norm for c in h]
    k_h = sum(a * b for a, b in zip(wo, h, strict=True))
    total = kd / math.pi
    for ks, mx, my, f0, alpha in lobes:
        tan2 = (h[0] ** 2 + h[1] ** 2) / h[2] ** 2
        cos2_phi = h[0] ** 2 / (h[0] ** 2 + h[1] ** 2)
        d = math.exp(-tan2 * (cos2_phi / mx**2 + (1 - cos2_phi) / my**2)) / (
            math.pi * mx * my * h[2] ** 4)
        fresnel = f0 + (1 - f0) * (1 - k_h) ** 5
        total += ks * fresnel * d / (4 * k_h * (wi[2] * wo[2]) ** alpha)
    return total


def test_kurt_matches_the_papers_equations():
    model = brdf.parse("kurt:kd=0.2,ks=0.7,mx=0.12,my=0.35,f0=0.6,alpha=0.25,"
                       "ks2=0.4,mx2=0.3,my2=0.3,f02=1,alpha2=0.75")
    lobes = [(0.7, 0.12, 0.35, 0.6, 0.25), (0.4, 0.3, 0.3, 1.0, 0.75)]
    rng = np.random.default_rng(9)
    for _ in range(50):
        v = rng.normal(size=(2, 3))
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        expected = kurt_scalar(v[0].tolist(), v[1].tolist(), 0.2, lobes)
        np.testing.assert_allclose(model.f(v[0], v[1]), expected, rtol=1e-10)


def test_kurt_half_vector_sampler_follows_eqs_6_and_7():
    """Sampled half vectors have the azimuth law of eq. 6: P(phi_h < x) in closed form."""
    model = brdf.parse("kurt:ks=1,mx=0.1,my=0.3,f0=1,alpha=0.5")
    n = 200_000
    wo = np.broadcast_to([0.0, 0.0, 1.0], (n, 3))
    u = np.random.default_rng(2).random((n, 2))
    wi, _ = model.sample(wo, u)
    h = wi + wo
    phi = np.mod(np.arctan2(h[:, 1], h[:, 0]), 2 * np.pi)
    # Eq. 6: phi_h = atan(my/mx tan(2 pi u)) => in the first quadrant
    # P(phi_h < x) = atan(mx/my tan x) / (pi/2), by symmetry in each quadrant.
    x = np.radians([10.0, 30.0, 45.0, 60.0, 80.0])
    folded = np.where(phi > np.pi, 2 * np.pi - phi, phi)
    folded = np.where(folded > np.pi / 2, np.pi - folded, folded)
    empirical = (folded[:, None] < x).mean(0)
    expected = np.arctan(0.1 / 0.3 * np.tan(x)) / (np.pi / 2)
    np.testing.assert_allclose(empirical, expected, atol=4 * math.sqrt(0.25 / n))
