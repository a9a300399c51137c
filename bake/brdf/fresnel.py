"""Fresnel reflectance: exact dielectric (Heidrich eq. 13), Schlick, conductors, blend.

All functions take cos(theta) of the angle between the direction and the
(micro)normal, shape (...), and return reflectance in [0, 1] of the same
shape (or (..., 3) when a parameter is RGB).
"""

import numpy as np

__all__ = ["dielectric", "schlick", "conductor", "blend", "f0_from_ior"]


def dielectric(cos_theta, ior):
    """Unpolarized reflectance of a dielectric interface, relative index ``ior``.

    Heidrich eq. 13: with c = cos(theta) and g^2 = ior^2 - 1 + c^2,
    F = (g - c)^2 / (2 (g + c)^2) * (1 + ((c (g + c) - 1) / (c (g - c) + 1))^2);
    total internal reflection (g^2 < 0, ior < 1) gives 1.
    """
    c = np.clip(np.abs(np.asarray(cos_theta, dtype=np.float64)), 0.0, 1.0)
    ior = np.asarray(ior, dtype=np.float64)
    g2 = ior * ior - 1.0 + c * c
    g = np.sqrt(np.clip(g2, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        first = (g - c) ** 2 / (2.0 * (g + c) ** 2)
        second = 1.0 + ((c * (g + c) - 1.0) / (c * (g - c) + 1.0)) ** 2
        value = first * second
    return np.where(g2 <= 0.0, 1.0, np.where(np.isfinite(value), value, 1.0))


def f0_from_ior(ior):
    """Normal-incidence reflectance ((ior - 1) / (ior + 1))^2."""
    ior = np.asarray(ior, dtype=np.float64)
    return ((ior - 1.0) / (ior + 1.0)) ** 2


def schlick(cos_theta, f0):
    """Schlick's approximation F0 + (1 - F0)(1 - cos)^5; f0 scalar or RGB (3,)."""
    c = np.clip(np.abs(np.asarray(cos_theta, dtype=np.float64)), 0.0, 1.0)
    f0 = np.asarray(f0, dtype=np.float64)
    t = 1.0 - c
    t2 = t * t
    weight = t2 * t2 * t  # (1 - c)^5 by products: NumPy's power calls pow() per element
    if f0.ndim:
        weight = weight[..., None]
    return f0 + (1.0 - f0) * weight


def conductor(cos_theta, eta, k):
    """Exact unpolarized reflectance of a conductor with complex index eta + i k.

    eta, k: scalars or RGB (3,); the result gains a last axis of 3 if either is RGB.
    """
    c = np.clip(np.abs(np.asarray(cos_theta, dtype=np.float64)), 0.0, 1.0)
    eta = np.asarray(eta, dtype=np.float64)
    k = np.asarray(k, dtype=np.float64)
    if eta.ndim or k.ndim:
        c = c[..., None]
    c2 = c * c
    s2 = 1.0 - c2
    t0 = eta * eta - k * k - s2
    a2b2 = np.sqrt(t0 * t0 + 4.0 * eta * eta * k * k)
    a = np.sqrt(np.clip(0.5 * (a2b2 + t0), 0.0, None))
    rs = (a2b2 - 2.0 * a * c + c2) / (a2b2 + 2.0 * a * c + c2)
    t1 = a2b2 * c2 + s2 * s2
    t2 = 2.0 * a * c * s2
    rp = rs * (t1 - t2) / (t1 + t2)
    return np.clip(0.5 * (rs + rp), 0.0, 1.0)


def blend(fresnel, mirror, diffuse):
    """Heidrich 3.1.1: F * L_mirror + (1 - F) * L_diffuse (broadcasting)."""
    fresnel = np.asarray(fresnel, dtype=np.float64)
    return fresnel * np.asarray(mirror) + (1.0 - fresnel) * np.asarray(diffuse)
