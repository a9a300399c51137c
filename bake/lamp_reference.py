"""Light from Blender's lamps, integrated exactly: the lamps' part of the NumPy reference.

A probe holds the world and the scene around the object, never the lamps
(Cycles hides them from the capture's camera rays, and Glossy's materials add
them through their own lamp term), so the validation's reference is the
probe's integral (:mod:`bake.reference`) plus this: for each pixel (world
point x, normal n, view v) and each lamp,

    L_o = integral over the lamp's extent of f(w_i, v) max(n.w_i, 0) L_e(w_i) dw_i,

with the true BRDF in the pixel's local frame, unshadowed (a caller passes a
visibility factor per pixel and lamp: glossy.validate casts a shadow ray to
the lamp's centre).

The emitters are Cycles 5.0's (intern/cycles/kernel/light; the powers as
glossy_addon.lamps converts them, measured against Cycles there):

- point and spot of power P and radius r: with Soft Falloff (Blender's
  default) a disc of radius r facing the shaded point, of uniform radiance
  L = P / (4 pi^2 r^2), so that a surface facing it receives
  E = P / (4 pi (d^2 + r^2)); without it, the sphere of radius r (a cone of
  half-angle asin(r / d)) of the same radiance. r = 0: a point of intensity
  P / (4 pi).
- spot: that light times smoothstep(0, 1, (cos a - cos(s / 2)) /
  ((1 - cos(s / 2)) b)) for the angle a between the lamp's -Z and the
  direction to the point, spot size s and blend b (a step where b = 0).
- sun of strength S and angle A: a cone of half-angle A / 2 about the lamp's
  +Z (light travels along -Z) of uniform radiance S / (pi sin^2(A / 2)), so a
  surface facing it receives E = S; A = 0: a direction.
- area of power P: a one-sided Lambertian emitter on its -Z side, radiance
  P / (pi A) over its area A (square, rectangle, disk or ellipse, the lamp
  object's scale applied).

The integral is estimated by multiple importance sampling: SAMPLES points
uniform over the emitter (its solid angle for cones) and SAMPLES directions
from the BRDF's own sampler, combined by the balance heuristic, each set a
Hammersley pattern shifted per pixel (an R2 sequence), so the estimate is
deterministic and its error varies from pixel to pixel instead of forming a
pattern. The emitter's samples integrate a wide lobe under a small lamp, the
BRDF's a near-mirror lobe under a large one. Checked against closed forms
(tests/bake/test_lamp_reference.py) and against Cycles through glossy.validate
(tests/blender/test_validate_lamps.py).
"""

import functools
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .brdf.base import hammersley
from .reference import _frames, pixel_arrays

__all__ = ["Lamp", "radiance", "shadow_rays", "aimed_axes", "SAMPLES", "SHADOW_RAYS", "KINDS",
           "AREA_SHAPES"]

#: Samples per pixel and lamp from each technique (emitter, BRDF).
SAMPLES = 512
#: Shadow rays per pixel toward a lamp with extent (one toward a lamp without):
#: the visibility a caller passes is the fraction of them unblocked.
SHADOW_RAYS = 16
#: Pixels per batch (bounds memory: batch x SAMPLES x 3 doubles per array, a
#: few batches at once on the worker threads).
BATCH = 512
KINDS = ("POINT", "SPOT", "SUN", "AREA")
AREA_SHAPES = ("SQUARE", "RECTANGLE", "DISK", "ELLIPSE")
#: R2 sequence (Roberts 2018): per-pixel shifts of the Hammersley points.
_R2 = (0.7548776662466927, 0.5698402909980532)


@dataclass(frozen=True)
class Lamp:
    """One Blender lamp in world space.

    kind: one of KINDS. colour: (3,) linear RGB times the power in W (point, spot,
    area) or the strength in W/m^2 (sun). position: (3,) world location. axes:
    (3, 3) rows the lamp's world X, Y and Z unit axes (it shines along -Z).
    radius: a point or spot lamp's radius (m); sphere: True where Soft Falloff is
    off. angle: a sun's angular diameter (rad). shape, size: an area lamp's shape
    (AREA_SHAPES) and its full extents along X and Y in world units (the side,
    or the diameter). spot_size (rad) and spot_blend: a spot's cone.
    """

    kind: str
    colour: tuple
    position: tuple = (0.0, 0.0, 0.0)
    axes: tuple = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    radius: float = 0.0
    sphere: bool = False
    angle: float = 0.0
    shape: str = "SQUARE"
    size: tuple = (1.0, 1.0)
    spot_size: float = np.pi
    spot_blend: float = 0.0
    name: str = ""

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"lamp kind must be one of {', '.join(KINDS)}, not {self.kind!r}")
        if self.kind == "AREA" and self.shape not in AREA_SHAPES:
            raise ValueError(f"area lamp shape must be one of {', '.join(AREA_SHAPES)}, "
                             f"not {self.shape!r}")

    @property
    def delta(self) -> bool:
        """True for a lamp of no extent (a radius or angle of 0): one direction."""
        if self.kind == "SUN":
            return self.angle <= 0.0
        if self.kind == "AREA":
            return False
        return self.radius <= 0.0


def aimed_axes(position, target=(0.0, 0.0, 0.0)):
    """Lamp axes (rows X, Y, Z, world) of a lamp at ``position`` whose -Z points
    at ``target``, X horizontal (perpendicular to world Z; the aim must not be
    vertical)."""
    z = np.asarray(position, np.float64) - np.asarray(target, np.float64)
    z /= np.linalg.norm(z)
    x = np.cross([0.0, 0.0, 1.0], z)
    x /= np.linalg.norm(x)
    return (tuple(x), tuple(np.cross(z, x)), tuple(z))


def _smoothstep(x):
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _spot_factor(lamp, points):
    """(N,) a spot's cone factor at world points (N, 3); ones for other kinds."""
    if lamp.kind != "SPOT":
        return np.ones(len(points))
    axes = np.asarray(lamp.axes, dtype=np.float64)
    to_point = points - np.asarray(lamp.position)
    to_point /= np.maximum(np.linalg.norm(to_point, axis=1, keepdims=True), 1e-300)
    cos_a = to_point @ -axes[2]
    cos_half = np.cos(0.5 * lamp.spot_size)
    smooth = (1.0 - cos_half) * lamp.spot_blend
    if smooth <= 0.0:
        return (cos_a >= cos_half).astype(np.float64)
    return _smoothstep((cos_a - cos_half) / smooth)


def _orthonormal(axis):
    """(x, y) (N, 3) each, unit and perpendicular to the unit ``axis`` (N, 3)."""
    hint = np.where(np.abs(axis[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    x = np.cross(hint, axis)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return x, np.cross(axis, x)


class _Emitter:
    """One lamp seen from a batch of points: ``sample(u)`` -> directions (N, M, 3),
    their solid-angle density (N, M) and radiance (N, M, 3); ``hit(directions)`` ->
    the density with which sample() would give each direction and the radiance
    along it (0 where the direction misses the lamp)."""

    def __init__(self, lamp, points):
        self.lamp = lamp
        self.points = points
        colour = np.asarray(lamp.colour, dtype=np.float64)
        spot = _spot_factor(lamp, points)[:, None]
        axes = np.asarray(lamp.axes, dtype=np.float64)
        centre = np.asarray(lamp.position, dtype=np.float64)
        self.kind = "cone"
        if lamp.kind == "SUN":
            self.axis = np.broadcast_to(axes[2], points.shape).copy()
            self.half = 0.5 * lamp.angle
            self.radiance = (colour / (np.pi * np.sin(self.half) ** 2))[None] * spot
        elif lamp.kind in ("POINT", "SPOT"):
            offset = points - centre
            distance = np.linalg.norm(offset, axis=1)
            self.radiance = (colour / (4.0 * np.pi ** 2 * lamp.radius ** 2))[None] * spot
            if lamp.sphere:
                self.axis = -offset / distance[:, None]
                self.half = np.arcsin(np.clip(lamp.radius / distance, 0.0, 1.0))
            else:  # a disc facing the point, its normal toward it
                self.kind = "disc"
                self.centre = np.broadcast_to(centre, points.shape)
                self.normal = offset / distance[:, None]
                self.x, self.y = _orthonormal(self.normal)
                self.extent = (lamp.radius, lamp.radius)
                self.round = True
                self.area = np.pi * lamp.radius ** 2
        else:
            self.kind = "disc"
            self.centre = np.broadcast_to(centre, points.shape)
            self.normal = np.broadcast_to(-axes[2], points.shape)  # its emitting side
            self.x = np.broadcast_to(axes[0], points.shape)
            self.y = np.broadcast_to(axes[1], points.shape)
            self.extent = (0.5 * lamp.size[0], 0.5 * lamp.size[1])
            self.round = lamp.shape in ("DISK", "ELLIPSE")
            self.area = (np.pi if self.round else 4.0) * self.extent[0] * self.extent[1]
            self.radiance = (colour / (np.pi * self.area))[None] * spot
        if self.kind == "cone":
            self.half = np.broadcast_to(np.asarray(self.half, dtype=np.float64),
                                        (len(points),))
            self.cos_half = np.cos(self.half)
            self.density = 1.0 / (2.0 * np.pi * np.maximum(1.0 - self.cos_half, 1e-300))

    def sample(self, u):
        if self.kind == "cone":
            cos_t = 1.0 - u[..., 0] * (1.0 - self.cos_half)[:, None]
            sin_t = np.sqrt(np.maximum(1.0 - cos_t ** 2, 0.0))
            phi = 2.0 * np.pi * u[..., 1]
            x, y = _orthonormal(self.axis)
            wi = (sin_t[..., None] * (np.cos(phi)[..., None] * x[:, None]
                                      + np.sin(phi)[..., None] * y[:, None])
                  + cos_t[..., None] * self.axis[:, None])
            density = np.broadcast_to(self.density[:, None], cos_t.shape)
            return wi, density, np.broadcast_to(self.radiance[:, None], wi.shape)
        if self.round:
            r = np.sqrt(u[..., 0])
            phi = 2.0 * np.pi * u[..., 1]
            a, b = r * np.cos(phi), r * np.sin(phi)
        else:
            a, b = 2.0 * u[..., 0] - 1.0, 2.0 * u[..., 1] - 1.0
        on_lamp = (self.centre[:, None] + (a * self.extent[0])[..., None] * self.x[:, None]
                   + (b * self.extent[1])[..., None] * self.y[:, None])
        offset = on_lamp - self.points[:, None]
        distance = np.linalg.norm(offset, axis=-1)
        wi = offset / np.maximum(distance, 1e-300)[..., None]
        cos_l = -np.einsum("nmk,nk->nm", wi, self.normal)
        lit = cos_l > 1e-9
        density = np.where(lit, distance ** 2 / (self.area * np.where(lit, cos_l, 1.0)), 0.0)
        radiance = np.where(lit[..., None], self.radiance[:, None], 0.0)
        return wi, density, radiance

    def distance(self, wi):
        """(N, M) distance from each point along directions ``wi`` (N, M, 3) to the
        lamp's surface (its plane for a disc or area lamp, the near side of a
        sphere lamp; inf for a sun)."""
        if self.kind == "cone":
            if self.lamp.kind == "SUN":
                return np.full(wi.shape[:2], np.inf)
            offset = np.asarray(self.lamp.position) - self.points
            along = np.einsum("nmk,nk->nm", wi, offset)
            across_sq = np.sum(offset * offset, axis=1)[:, None] - along ** 2
            return np.maximum(along - np.sqrt(np.maximum(self.lamp.radius ** 2 - across_sq,
                                                         0.0)), 0.0)
        depth = np.einsum("nk,nk->n", self.centre - self.points, -self.normal)
        cos_l = -np.einsum("nmk,nk->nm", wi, self.normal)
        return depth[:, None] / np.maximum(cos_l, 1e-9)

    def hit(self, wi):
        if self.kind == "cone":
            inside = np.einsum("nmk,nk->nm", wi, self.axis) >= self.cos_half[:, None]
            density = np.where(inside, self.density[:, None], 0.0)
            return density, np.where(inside[..., None], self.radiance[:, None], 0.0)
        cos_l = -np.einsum("nmk,nk->nm", wi, self.normal)
        facing = cos_l > 1e-9
        depth = np.einsum("nk,nk->n", self.centre - self.points, -self.normal)
        t = np.where(facing, depth[:, None] / np.where(facing, cos_l, 1.0), -1.0)
        on_plane = self.points[:, None] + t[..., None] * wi - self.centre[:, None]
        a = np.einsum("nmk,nk->nm", on_plane, self.x) / self.extent[0]
        b = np.einsum("nmk,nk->nm", on_plane, self.y) / self.extent[1]
        inside = (a * a + b * b <= 1.0) if self.round else \
            (np.abs(a) <= 1.0) & (np.abs(b) <= 1.0)
        inside &= facing & (t > 0.0)
        density = np.where(inside, t ** 2 / (self.area * np.where(facing, cos_l, 1.0)), 0.0)
        return density, np.where(inside[..., None], self.radiance[:, None], 0.0)


def _reaches(lamp, points, normals):
    """(N,) False where none of the lamp's light can arrive: it lies wholly below
    the tangent plane, or outside a spot's cone (a conservative test)."""
    axes = np.asarray(lamp.axes, dtype=np.float64)
    spot = _spot_factor(lamp, points) > 0.0
    if lamp.kind == "SUN":
        return spot & (normals @ axes[2] > -np.sin(0.5 * lamp.angle) - 1e-9)
    if lamp.kind == "AREA":
        half = (0.5 * lamp.size[0], 0.5 * lamp.size[1])
        corners = [np.asarray(lamp.position) + a * half[0] * axes[0] + b * half[1] * axes[1]
                   for a in (-1.0, 1.0) for b in (-1.0, 1.0)]
        height = np.stack([np.sum((c - points) * normals, axis=1) for c in corners], 1)
        return spot & (height.max(axis=1) > -1e-9)
    offset = np.asarray(lamp.position) - points
    return spot & (np.sum(offset * normals, axis=1) > -lamp.radius - 1e-9)


def _delta(model, lamp, points, frames, wo_local):
    """(N, 3) f cos E of a lamp without extent (one direction per point)."""
    colour = np.asarray(lamp.colour, dtype=np.float64)
    if lamp.kind == "SUN":
        wi = np.broadcast_to(np.asarray(lamp.axes, dtype=np.float64)[2], points.shape)
        irradiance = np.broadcast_to(colour, points.shape)
    else:
        offset = np.asarray(lamp.position) - points
        distance_sq = np.sum(offset * offset, axis=1)
        wi = offset / np.sqrt(distance_sq)[:, None]
        irradiance = (colour[None] / (4.0 * np.pi * distance_sq[:, None])
                      * _spot_factor(lamp, points)[:, None])
    local = np.einsum("nij,nj->ni", frames, wi)
    return model.f(local, wo_local) * np.clip(local[:, 2:3], 0.0, None) * irradiance


def _shifted(points, pixels):
    """(P, M, 2) the Hammersley ``points`` (M, 2) shifted for each of ``pixels`` (P,)
    (their indices: the shift depends on the pixel alone, not on the batch)."""
    index = np.asarray(pixels, dtype=np.float64)[:, None]
    shift = np.mod(index * np.asarray(_R2), 1.0)
    return np.mod(points[None] + shift[:, None, :], 1.0)


def _extended(model, lamp, points, frames, wo_local, pixels, samples, unblocked=None):
    """(N, 3) the balance-heuristic estimate for a lamp with extent; ``unblocked``:
    None or a function (points (N, 3), directions (N, M, 3), distances (N, M)) ->
    (N, M) 1 where the ray reaches the lamp, 0 where something blocks it."""
    emitter = _Emitter(lamp, points)
    count = len(points)
    wo = np.broadcast_to(wo_local[:, None, :], (count, samples, 3))
    wi_light, pdf_light, radiance_light = emitter.sample(
        _shifted(hammersley(samples, shift=(0.37, 0.61)), pixels))
    with np.errstate(all="ignore"):
        local_brdf, _ = model.sample(wo, _shifted(hammersley(samples, shift=(0.13, 0.83)),
                                                  pixels + 7919))
    local_brdf = np.nan_to_num(np.asarray(local_brdf, dtype=np.float64))
    wi_brdf = np.einsum("nji,nmj->nmi", frames, local_brdf)
    wi_brdf /= np.maximum(np.linalg.norm(wi_brdf, axis=-1, keepdims=True), 1e-300)
    pdf_hit, radiance_hit = emitter.hit(wi_brdf)
    total = np.zeros((count, 3))
    for wi, pdf_emitter, radiance_in in ((wi_light, pdf_light, radiance_light),
                                         (wi_brdf, pdf_hit, radiance_hit)):
        local = np.einsum("nij,nmj->nmi", frames, wi)
        with np.errstate(all="ignore"):
            pdf_model = np.nan_to_num(np.asarray(model.pdf(local, wo), dtype=np.float64))
        density = samples * (pdf_emitter + pdf_model)
        keep = (density > 0.0) & (local[..., 2] > 0.0) & (radiance_in.max(axis=-1) > 0.0)
        weight = np.where(keep, local[..., 2] / np.where(keep, density, 1.0), 0.0)
        if unblocked is not None:
            weight = weight * unblocked(points, wi, np.where(keep, emitter.distance(wi), 0.0))
        value = model.f(local, wo_local[:, None, :])  # the view's terms once per pixel
        total += np.sum(value * radiance_in * weight[..., None], axis=1)
    return total


def shadow_rays(lamp, positions, count=SHADOW_RAYS):
    """(directions (N, K, 3), distances (N, K)): rays from world points (N, 3) to K
    points spread over ``lamp`` (stratified as its samples are; K = 1 toward a
    lamp without extent; a sun's distances are inf). The fraction of them that
    reach the lamp is the visibility :func:`radiance` takes, a soft shadow's
    penumbra included."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if lamp.delta:
        if lamp.kind == "SUN":
            direction = np.broadcast_to(np.asarray(lamp.axes, dtype=np.float64)[2],
                                        positions.shape)
            return direction[:, None].copy(), np.full((len(positions), 1), np.inf)
        offset = np.asarray(lamp.position) - positions
        distance = np.linalg.norm(offset, axis=1)
        return (offset / np.maximum(distance, 1e-300)[:, None])[:, None], distance[:, None]
    emitter = _Emitter(lamp, positions)
    u = _shifted(hammersley(int(count), shift=(0.37, 0.61)), np.arange(len(positions)))
    directions, _, _ = emitter.sample(u)
    return directions, emitter.distance(directions)


def _test_rays(test, index, normals, points, directions, distances):
    return test(index, points, normals, directions, distances)


def radiance(model, lamps, positions, normals, views, *, tangents=None,
             tangent_hint=(0.3, 0.5, 0.8), visibility=None, unblocked=None, samples=SAMPLES,
             threads=None):
    """(N, 3) radiance toward the viewer reflected from ``lamps`` (a sequence of Lamp).

    positions, normals, views: (N, 3) world points, unit normals and unit
    directions toward the viewer; tangents: (N, 3) or None (the BRDF frame as
    bake.reference builds it). visibility: (N, len(lamps)) factor per pixel and
    lamp (1 lit, 0 shadowed, between: in a penumbra; :func:`shadow_rays`), or
    None (unshadowed). unblocked: None, or a function (lamp index, points
    (P, 3), normals (P, 3), directions (P, M, 3), distances (P, M)) -> (P, M)
    0 / 1 that tests
    each sample's ray; where given, pixels whose visibility is strictly between
    0 and 1 have every sample tested (the penumbra weighed by the lobe, not by
    the lamp's area), the others take the factor. samples: per technique.
    threads: worker threads for the arithmetic (default two, or one on one core).
    """
    normals, views, tangents = pixel_arrays(normals, views, tangents)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    if positions.shape != normals.shape:
        raise ValueError(f"positions {positions.shape} and normals {normals.shape} differ")
    if visibility is not None:
        visibility = np.asarray(visibility, dtype=np.float64).reshape(len(normals), len(lamps))
    out = np.zeros((len(normals), 3))
    # The arithmetic runs on two worker threads (NumPy releases the GIL in it);
    # ``unblocked`` (Blender's ray casts) only ever on the calling thread.
    pool = ThreadPoolExecutor(max_workers=threads or min(2, os.cpu_count() or 1))
    pending = []
    try:
        for start in range(0, len(normals), BATCH):
            stop = min(start + BATCH, len(normals))
            frames = _frames(normals[start:stop], None if tangents is None
                             else tangents[start:stop], tangent_hint)
            wo_local = np.einsum("pij,pj->pi", frames, views[start:stop])
            points = positions[start:stop]
            for index, lamp in enumerate(lamps):
                reach = _reaches(lamp, points, normals[start:stop])
                if visibility is not None:
                    reach &= visibility[start:stop, index] > 0.0
                if not reach.any():
                    continue
                at = np.flatnonzero(reach)
                factor = np.ones(len(at)) if visibility is None else \
                    visibility[start + at, index]
                if lamp.delta:
                    part = _delta(model, lamp, points[at], frames[at], wo_local[at])
                    out[start + at] += part * factor[:, None]
                    continue
                penumbra = (factor < 1.0) if unblocked is not None else \
                    np.zeros(len(at), bool)
                free = at[~penumbra]
                if len(free):
                    pending.append((start + free, factor[~penumbra], pool.submit(
                        _extended, model, lamp, points[free], frames[free], wo_local[free],
                        start + free, int(samples))))
                if penumbra.any():
                    pick = at[penumbra]
                    ray_test = functools.partial(_test_rays, unblocked, index,
                                                 normals[start + pick])
                    out[start + pick] += _extended(model, lamp, points[pick], frames[pick],
                                                   wo_local[pick], start + pick, int(samples),
                                                   ray_test)
        for where, factor, future in pending:
            out[where] += future.result() * factor[:, None]
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return out
