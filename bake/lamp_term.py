"""Glossy's lamp term in NumPy: the twin of the attached material's lamp nodes.

For every lamp (every cell of an area lamp, bake.lamp_spread.area_cells)
the material adds f(l, v) E max(n.l, 0), with l the unit vector to the
lamp's centre (a sun: its +Z), E the irradiance a surface facing it receives
and f the separable factors' lookup (bake.separable.atlas_lookup) with the
lamp's angular radius alpha as its spread:

- point and spot, colour C (W, the Color x Power x 2^Exposure the driver
  computes), radius r at distance d: E = C / (4 pi (d^2 + r^2)), alpha =
  atan(r / d) (Cycles' soft-falloff disc facing the point), or E = C / (4 pi
  d^2), alpha = asin(min(r / d, 1)) (a sphere, Soft Falloff off); a spot
  times Cycles' smoothstep of its cone;
- sun, strength C (W/m^2): E = C, alpha = its angle / 2;
- area, colour C (W), a cell of area A_c and share s of the lamp at
  distance d, cos a = l . Z (the lamp shines along -Z): E = C s cos a /
  (pi d^2), alpha = atan(sqrt(A_c cos a / pi) / d) (the cap of the cell's
  projected area).

Lamps are bake.lamp_reference.Lamp (world space), the same description the
validation's reference integrates exactly. Frames: the BRDF's x axis is the
tangent made orthogonal to n (Y = normalize(n x T), X = Y x n), as the nodes
build it.
"""

import math

import numpy as np

from .lamp_reference import _spot_factor
from .lamp_spread import area_cells
from .separable import atlas_lookup

__all__ = ["lamp_directions", "radiance"]


def lamp_directions(lamp, positions, sized=True):
    """[(l (N, 3) unit vectors to the lamp or cell, E (N, 3) W/m^2, alpha (N,) rad)]
    for one lamp at world points ``positions`` (N, 3): one entry, or one per
    area cell. sized=False: the lamp term before stop 54 (an area lamp one
    point at its centre, a sphere lamp with the disc's irradiance)."""
    positions = np.asarray(positions, np.float64).reshape(-1, 3)
    colour = np.asarray(lamp.colour, np.float64)
    axes = np.asarray(lamp.axes, np.float64)
    count = len(positions)
    if lamp.kind == "SUN":
        l = np.broadcast_to(axes[2] / np.linalg.norm(axes[2]), (count, 3))
        return [(l, np.broadcast_to(colour, (count, 3)), np.full(count, lamp.angle / 2.0))]
    if lamp.kind in ("POINT", "SPOT"):
        offset = np.asarray(lamp.position, np.float64) - positions
        distance2 = np.sum(offset * offset, axis=1)
        distance = np.sqrt(np.maximum(distance2, 1e-30))
        l = offset / distance[:, None]
        # a sphere: P / (4 pi d^2) (sized=False: the disc's, as before stop 54)
        disc = 0.0 if lamp.sphere and sized else lamp.radius ** 2
        irradiance = colour[None, :] / (4.0 * math.pi * (distance2 + disc))[:, None]
        if lamp.kind == "SPOT":
            irradiance = irradiance * _spot_factor(lamp, positions)[:, None]
        ratio = lamp.radius / distance
        alpha = np.arcsin(np.minimum(ratio, 1.0)) if lamp.sphere else np.arctan(ratio)
        return [(l, irradiance, alpha)]
    width, height = lamp.size
    area = width * height * (math.pi / 4.0 if lamp.shape in ("DISK", "ELLIPSE") else 1.0)
    out = []
    cells = area_cells(lamp.shape, width, height) if sized else [(0.0, 0.0, 1.0)]
    for u, v, share in cells:
        centre = np.asarray(lamp.position) + u * width * axes[0] + v * height * axes[1]
        offset = centre - positions
        distance2 = np.sum(offset * offset, axis=1)
        distance = np.sqrt(np.maximum(distance2, 1e-30))
        l = offset / distance[:, None]
        cos_a = np.maximum(l @ axes[2], 0.0)
        irradiance = colour[None, :] * (share * cos_a / (math.pi * distance2))[:, None]
        alpha = np.arctan(np.sqrt(area * share * cos_a / math.pi) / distance)
        out.append((l, irradiance, alpha))
    return out


def _frames(normals, tangents):
    y = np.cross(normals, tangents)
    y /= np.maximum(np.linalg.norm(y, axis=1, keepdims=True), 1e-30)
    return np.stack([np.cross(y, normals), y, normals], axis=1)


def radiance(image, meta, lamps, positions, normals, views, tangents, sized=True):
    """(N, 3) the lamp term toward the viewer at world points (N, 3) with unit
    normals, unit directions to the viewer and tangents (all (N, 3), world),
    from the lamp atlas (image, meta: bake.separable.pack) and ``lamps``
    (bake.lamp_reference.Lamp). sized=False takes every lamp as a point
    (Glossy's lamp term before lamps had a size)."""
    positions = np.asarray(positions, np.float64).reshape(-1, 3)
    normals = np.asarray(normals, np.float64).reshape(-1, 3)
    views = np.asarray(views, np.float64).reshape(-1, 3)
    frames = _frames(normals, np.asarray(tangents, np.float64).reshape(-1, 3))
    wo = np.einsum("pij,pj->pi", frames, views)
    out = np.zeros((len(positions), 3))
    for lamp in lamps:
        for l, irradiance, alpha in lamp_directions(lamp, positions, sized):
            wi = np.einsum("pij,pj->pi", frames, l)
            f = atlas_lookup(image, meta, wi, wo, spread=alpha if sized else None)
            out += f * irradiance * np.maximum(wi[:, 2], 0.0)[:, None]
    return out
