"""Brute-force reflected radiance: the ground truth prefiltered maps are measured against.

L_o(n, v) = sum over the probe's texels of L(l) f(l, v) max(n.l, 0) omega(l),
with the true BRDF evaluated in a local frame at each normal. Isotropic
BRDFs do not depend on the tangent chosen; anisotropic ones use the tangent
``tangent_hint`` projected onto the surface.
"""

import numpy as np

from .envmap import get_layout

__all__ = ["reflected_radiance"]


def reflected_radiance(model, probe, layout, normals, views, tangent_hint=(0.3, 0.5, 0.8)):
    """(N, 3) radiance for world-space unit normals and views (surface to viewer), (N, 3) each.

    probe: (H, W, 3) environment in ``layout`` (any of bake.envmap's layouts).
    """
    layout = get_layout(layout)
    shape = probe.shape[:2]
    directions = layout.texel_directions(shape).reshape(-1, 3)
    values = np.asarray(probe, dtype=np.float64).reshape(-1, probe.shape[2])[:, :3]
    omega = layout.solid_angles(shape).reshape(-1)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    views = np.asarray(views, dtype=np.float64).reshape(-1, 3)
    out = np.empty((len(normals), 3))
    for index, (n, v) in enumerate(zip(normals, views, strict=True)):
        t = np.cross(n, tangent_hint)
        t /= np.linalg.norm(t)
        frame = np.stack([np.cross(t, n), t, n])  # x = tangent, y, z = normal
        wi = directions @ frame.T
        wo = np.broadcast_to(frame @ v, wi.shape)
        weight = model.f(wi, wo) * np.clip(wi[:, 2:3], 0, None) * omega[:, None]
        out[index] = np.sum(weight * values, axis=0)
    return out
