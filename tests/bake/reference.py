"""Independent numerical references for BRDF tests (no code shared with bake.brdf).

``sphere_quadrature`` integrates a function of direction over the whole sphere
with a product rule in polar coordinates about a chosen axis: Gauss-Legendre
in t with theta = pi t^2 (dense near the axis, where glossy lobes peak) and the
trapezoid rule in azimuth (exact for trigonometric polynomials).
"""

import numpy as np


def _frame(axis):
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t = np.cross(axis, helper)
    t /= np.linalg.norm(t)
    return t, np.cross(axis, t), axis


def sphere_quadrature(function, axis=(0.0, 0.0, 1.0), n_t=400, n_phi=400):
    """Integral over the unit sphere of function(directions (N, 3)) -> (N,) or (N, C)."""
    nodes, weights = np.polynomial.legendre.leggauss(n_t)
    t = 0.5 * (nodes + 1.0)
    w_t = 0.5 * weights
    theta = np.pi * t**2
    d_theta = 2.0 * np.pi * t * w_t  # d theta / dt * weight
    phi = (np.arange(n_phi) + 0.5) * 2.0 * np.pi / n_phi
    tx, ty, tz = _frame(axis)
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    d = (st * np.cos(phi))[..., None] * tx + (st * np.sin(phi))[..., None] * ty + ct[..., None] * tz
    weight = (np.sin(theta) * d_theta)[:, None] * (2.0 * np.pi / n_phi) * np.ones_like(phi)
    values = np.asarray(function(d.reshape(-1, 3)))
    weight = weight.reshape(-1)
    if values.ndim == 1:
        return float(np.sum(values * weight))
    return np.sum(values * weight[:, None], axis=0)


def mirror(wo):
    wo = np.asarray(wo, dtype=np.float64)
    return np.array([-wo[0], -wo[1], wo[2]])


def reference_albedo(model, wo, n=400):
    """rho(wo) by quadrature about the mirror direction (lobes peak near it)."""
    wo = np.asarray(wo, dtype=np.float64)

    def integrand(wi):
        return model.f(wi, np.broadcast_to(wo, wi.shape)) * np.clip(wi[:, 2:3], 0.0, None)

    return sphere_quadrature(integrand, axis=mirror(wo), n_t=n, n_phi=n)


def direction(theta_deg, phi_deg=0.0):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)])
