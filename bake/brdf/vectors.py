"""Vector helpers for BRDFs in the local shading frame.

Local frame (DESIGN.md): z is the normal, x the tangent, y = z cross x.
Directions are unit vectors of shape (..., 3), float64, pointing away from
the surface; every function broadcasts over leading axes.
"""

import numpy as np

__all__ = ["broadcast_wo_u", "dot", "normalize", "half_vector", "reflect", "rotate_z",
           "cosine_hemisphere", "around_axis", "spherical"]


def broadcast_wo_u(wo, u):
    """Broadcast directions (..., 3) and uniforms (..., 2) to one leading shape."""
    wo = np.asarray(wo, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    shape = np.broadcast_shapes(wo.shape[:-1], u.shape[:-1])
    return np.broadcast_to(wo, (*shape, 3)), np.broadcast_to(u, (*shape, 2))


def dot(a, b):
    """Dot product over the last axis: (..., 3), (..., 3) -> (...).

    Three vectors' components are multiplied and added in the order np.sum takes
    them (the same float64 result), without the (..., 3) temporary and the
    reduction over a length-3 axis, which cost about five times as much."""
    a, b = np.asarray(a), np.asarray(b)
    if a.shape[-1:] != (3,) or b.shape[-1:] != (3,):
        return np.sum(a * b, axis=-1)
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def normalize(v):
    """Unit vectors (..., 3); zero vectors stay zero (the same float64 result as
    dividing by np.linalg.norm, whose sum of squares this spells out)."""
    v = np.asarray(v, dtype=np.float64)
    if v.shape[-1:] != (3,):
        norm = np.linalg.norm(v, axis=-1, keepdims=True)
        return v / np.where(norm > 0, norm, 1.0)
    norm = np.sqrt(v[..., 0] * v[..., 0] + v[..., 1] * v[..., 1] + v[..., 2] * v[..., 2])
    safe = np.where(norm > 0, norm, 1.0)
    out = np.empty(v.shape)
    for k in range(3):  # component by component: long loops, not a (..., 1) broadcast
        np.divide(v[..., k], safe, out=out[..., k])
    return out


def half_vector(wi, wo):
    """Normalized wi + wo, (..., 3)."""
    return normalize(np.asarray(wi) + np.asarray(wo))


def reflect(wo):
    """Mirror direction of wo about the normal z: (-x, -y, z)."""
    wo = np.asarray(wo, dtype=np.float64)
    return np.stack([-wo[..., 0], -wo[..., 1], wo[..., 2]], -1)


def rotate_z(v, angle):
    """Rotate vectors (..., 3) about +z by ``angle`` radians (counter-clockwise seen from +z)."""
    v = np.asarray(v, dtype=np.float64)
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1], v[..., 2]], -1)


def spherical(cos_theta, phi):
    """Unit vectors from polar cosine and azimuth (radians), (...) -> (..., 3)."""
    cos_theta, phi = np.broadcast_arrays(np.asarray(cos_theta, dtype=np.float64),
                                         np.asarray(phi, dtype=np.float64))
    sin_theta = np.sqrt(np.clip(1.0 - cos_theta * cos_theta, 0.0, None))
    return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), cos_theta], -1)


def cosine_hemisphere(u):
    """Cosine-weighted directions about +z from uniforms u (..., 2): (wi, pdf = cos/pi)."""
    u = np.asarray(u, dtype=np.float64)
    cos_theta = np.sqrt(1.0 - u[..., 0])
    wi = spherical(cos_theta, 2.0 * np.pi * u[..., 1])
    return wi, cos_theta / np.pi


def basis(axis):
    """Orthonormal (t, b) completing unit ``axis`` (..., 3) to a right-handed frame."""
    axis = np.asarray(axis, dtype=np.float64)
    sign = np.where(axis[..., 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + axis[..., 2])
    b = axis[..., 0] * axis[..., 1] * a
    t = np.stack([1.0 + sign * axis[..., 0] ** 2 * a, sign * b, -sign * axis[..., 0]], -1)
    s = np.stack([b, sign + axis[..., 1] ** 2 * a, -axis[..., 1]], -1)
    return t, s


def around_axis(axis, cos_theta, phi):
    """Directions at polar cosine ``cos_theta`` and azimuth ``phi`` about unit ``axis``."""
    local = spherical(cos_theta, phi)
    t, s = basis(axis)
    axis = np.asarray(axis, dtype=np.float64)
    return local[..., :1] * t + local[..., 1:2] * s + local[..., 2:] * axis
