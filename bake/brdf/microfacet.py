"""Microfacet building blocks shared by several models (local frame, z = normal)."""

import numpy as np

from .vectors import dot, normalize

__all__ = ["ggx_d", "beckmann_d", "ggx_lambda", "beckmann_lambda_cycles", "slope_s",
           "sample_ggx_vndf", "sample_beckmann_h", "reflect_about"]


def slope_s(w, ax, ay):
    """s = (ax^2 wx^2 + ay^2 wy^2) / wz^2 of CYCLES.md (the Smith Lambda argument)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return (ax * ax * w[..., 0] ** 2 + ay * ay * w[..., 1] ** 2) / (w[..., 2] ** 2)


def ggx_d(h, ax, ay):
    """Anisotropic GGX D(h) = 1 / (pi ax ay (hx^2/ax^2 + hy^2/ay^2 + hz^2)^2); 0 for hz <= 0."""
    t = (h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2 + h[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        d = 1.0 / (np.pi * ax * ay * t * t)
    return np.where(h[..., 2] > 0, d, 0.0)


def beckmann_d(h, ax, ay):
    """Anisotropic Beckmann D(h) = exp(-(hx^2/ax^2 + hy^2/ay^2)/hz^2) / (pi ax ay hz^4)."""
    hz2 = h[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = ((h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2) / hz2
        d = np.exp(-e) / (np.pi * ax * ay * hz2 * hz2)
    return np.where(h[..., 2] > 0, np.nan_to_num(d), 0.0)


def ggx_lambda(w, ax, ay):
    """Smith Lambda of GGX: (sqrt(1 + s) - 1) / 2."""
    return 0.5 * (np.sqrt(1.0 + slope_s(w, ax, ay)) - 1.0)


def beckmann_lambda_cycles(w, ax, ay):
    """Cycles' rational Beckmann Lambda: 0 for s < 0.39, else with a = 1/sqrt(s)
    (1 - 1.259 a + 0.396 a^2) / (3.535 a + 2.181 a^2)."""
    s = slope_s(w, ax, ay)
    with np.errstate(divide="ignore", invalid="ignore"):
        a = 1.0 / np.sqrt(s)
        value = (1.0 - 1.259 * a + 0.396 * a * a) / (3.535 * a + 2.181 * a * a)
    return np.where(s < 0.39, 0.0, value)


def reflect_about(wo, m):
    """Reflect wo about unit microfacet normals m: 2 (wo.m) m - wo."""
    return 2.0 * dot(wo, m)[..., None] * m - wo


def sample_ggx_vndf(wo, u, ax, ay):
    """Heitz 2018: microfacet normals distributed as the visible normals of GGX.

    wo (..., 3) with wo_z > 0, u (..., 2). Returns m (..., 3).
    """
    v = normalize(np.stack([ax * wo[..., 0], ay * wo[..., 1], wo[..., 2]], -1))
    lensq = v[..., 0] ** 2 + v[..., 1] ** 2
    inv = np.where(lensq > 0, 1.0 / np.sqrt(np.where(lensq > 0, lensq, 1.0)), 0.0)
    t1 = np.stack([np.where(lensq > 0, -v[..., 1] * inv, 1.0),
                   np.where(lensq > 0, v[..., 0] * inv, 0.0), np.zeros_like(lensq)], -1)
    t2 = np.cross(v, t1)
    r = np.sqrt(u[..., 0])
    phi = 2.0 * np.pi * u[..., 1]
    p1 = r * np.cos(phi)
    p2 = r * np.sin(phi)
    s = 0.5 * (1.0 + v[..., 2])
    p2 = (1.0 - s) * np.sqrt(np.clip(1.0 - p1 * p1, 0.0, None)) + s * p2
    nh = (p1[..., None] * t1 + p2[..., None] * t2
          + np.sqrt(np.clip(1.0 - p1 * p1 - p2 * p2, 0.0, None))[..., None] * v)
    return normalize(np.stack([ax * nh[..., 0], ay * nh[..., 1],
                               np.clip(nh[..., 2], 0.0, None)], -1))


def sample_beckmann_h(u, ax, ay):
    """Normals m with density D_Beckmann(m) m_z (Walter/Ward half-vector sampling)."""
    phi = np.arctan2(ay * np.sin(2.0 * np.pi * u[..., 1]), ax * np.cos(2.0 * np.pi * u[..., 1]))
    c, s = np.cos(phi), np.sin(phi)
    slopes = c * c / (ax * ax) + s * s / (ay * ay)
    tan2 = -np.log1p(-np.clip(u[..., 0], 0.0, 1.0 - 1e-16)) / slopes
    cos_theta = 1.0 / np.sqrt(1.0 + tan2)
    sin_theta = np.sqrt(np.clip(1.0 - cos_theta**2, 0.0, None))
    return np.stack([sin_theta * c, sin_theta * s, cos_theta], -1)
