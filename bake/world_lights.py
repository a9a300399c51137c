"""A World Only probe's lights, re-measured on the world's own lat-long texels.

bake.probe_lights takes a probe's small bright lights out of the *cube* the
world was resampled to. The cube is already a filtered copy of the world:
a sun one or two texels of the HDRI wide is spread over the cube's texels,
split between a core tile and satellite tiles, and its energy and centroid
move with the cube's grid. :func:`from_world` keeps the cube's decisions
(the threshold and which lights there are) and measures each light again on
the texels of the image the probe was resampled from: every lat-long texel
brighter than the same threshold (times the *world's* mean luminance, by
solid angle) within REACH_SPREADS of a light's spread plus REACH_TEXELS of
the cube's texels from its direction belongs to the nearest light, whose
irradiance, direction and spread are recomputed from those texels; the
texels are clamped to the threshold (hue kept) in the world's residual,
which the caller resamples to the cube as the probe was. The split is exact
in energy on the world: residual + lights = world, texel by texel. A cube
light that no world texel reaches is dropped (its energy is still in the
residual).

Each light's extent (what widens its highlight: probe_lights.Light.extent)
is the RMS angle of its texel centres plus TENT_MOMENTS times its texels'
own omega / 6: a lamp of one world texel is the tent Cycles' bilinear
lookup makes of it, not a point.

Measured (a one-off script, out/p46/variants2.py; docs/HISTORY.md "Stop 46": the
Hybrid of bake.hybrid with 19 samples, a 64^2 px sphere of 2 x 2 sub-pixels,
against the integral over the HDRI's bilinear reconstruction, i.e. what
Cycles renders, each bundled HDRI at the face Auto captures for it): against
the cube's lights the geometric mean of the error is 0.71x / 0.72x / 0.76x /
0.86x at GGX 0.2 / 0.3 / 0.45 / 0.6, lower on 30 of the 32 cases (sunrise at
GGX 0.2 0.90% -> 0.15%, studio at 0.3 1.58% -> 0.69%); higher for city at
0.45 (0.74% -> 0.76%) and night at 0.2 (4.0% -> 5.5%). With the lamps as
points (TENT_MOMENTS 0) night at 0.2 measured 15.5%, the error of a few rim
pixels where a lamp's highlight is sharper than a sub-pixel; its other cases
within 0.1 point of the tent's except night at 0.3 (1.7% against 2.3%) and
studio at 0.2 (1.3% against 1.5%). In EEVEE against Cycles the two were
level on night at 0.2 and 0.3 and on sunrise at 0.2. Not at GGX 0.1 (3 of 8
better in stop 45's measurement): there a tile (a quarter of alpha, 0.0025
rad) is smaller than the HDRI's texel (0.006 rad), several of the cube's
tiles share one world texel and lights are lost. :func:`resolves` is that
rule: use the world's texels only where the lobe's tiles are at least the
world's texel.

glossy.bake_materials calls :func:`split_for` for a World Only probe whose
header records the digest (:func:`digest`) and Mapping of the world image
the scene still shows.

Directions are world space (bake.envmap's axes); ``to_texture`` (3, 3) maps a
world direction to the direction the Environment Texture looks up (a
rotation-only Mapping node: bake.world_mapping), identity by default.
"""

import hashlib
import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import probe_lights
from .envmap import convert, get_layout
from .envmap.convert import CHECK_TEXELS, CHECK_TOLERANCE, LOCAL_SHARE, reduction_count
from .errors import BakeError

__all__ = ["from_world", "lowered", "reduced_world", "reduced_residual", "residual_cube",
           "resolves", "rotation_of", "split_for", "split_latlong", "digest", "REACH_SPREADS",
           "REACH_TEXELS"]

#: A world texel belongs to a light within this many of the light's spreads ...
REACH_SPREADS = 2.0
#: ... plus this many of the cube's largest texel's angle.
REACH_TEXELS = 1.5
LUMINANCE = probe_lights.LUMINANCE
#: A light's extent (probe_lights.Light.extent: what widens its highlight) is the
#: RMS angle of its texel centres plus this many of its texels' own omega / 6:
#: 0 shades a one-texel lamp as a point, 2 as the tent Cycles' bilinear
#: lookup makes of a texel (second moment 2 omega / 6 about its centre).
TENT_MOMENTS = 2.0
#: Bright texels compared with the lights at a time (bounds the (chunk, lights) product).
CHUNK = 65536
#: A lobe's lights are measured on a box-reduced level of a large world when its
#: tiles still span this many of that level's texels (measured_level).
TILE_TEXELS = 8.0
#: split_latlong finds the lights on a copy of a larger image with this many rows.
EXTRACT_ROWS = 1024


def resolves(world_shape, alpha) -> bool:
    """Whether a GGX lobe of smallest alpha ``alpha`` tiles at least as coarsely as
    the world's texel (lat-long (H, 2H)): probe_lights.tile_radius_for(alpha) against
    the equator texel's angle pi / H; only then are the world's texels the
    better measure of the lights (module doc)."""
    height = int(world_shape[0])
    return probe_lights.tile_radius_for(alpha) >= math.pi / height


def from_world(lights, world, cube_face, to_texture=None, strength=1.0):
    """(residual (H, 2H, 3) float32 lat-long, lights) of the lat-long ``world``
    (H, 2H, 3) radiance, for the ``lights`` bake.probe_lights took from the cube
    of ``cube_face`` px faces that the world was resampled to (through the
    Mapping ``to_texture`` and the Background's ``strength``, both applied to
    the result as to the probe: the residual is in the world image's own
    texels, times ``strength``). Lights are returned brightest region first as
    given, each with its irradiance (W/m^2, RGB), direction and spread
    re-measured on the world's texels (module doc). The residual is the world
    times ``strength`` with :func:`lowered`'s texels replaced."""
    indices, values, out = lowered(lights, world, cube_face, to_texture, strength)
    residual = np.array(np.asarray(world)[..., :3], dtype=np.float32) * np.float32(strength)
    residual.reshape(-1, 3)[indices] = values
    return residual, out


def _texel_directions(shape, rows, cols):
    """(n, 3) float64: the directions of the centres of texels (rows, cols) (n,) of an
    (H, W) lat-long image, as bake.envmap's LatLong.directions gives them (the same
    operations on the same values, from one table of rows and one of columns)."""
    height, width = shape
    theta = np.pi * (np.arange(height) + 0.5) / height
    phi = np.pi - 2.0 * np.pi * (np.arange(width) + 0.5) / width
    sin_theta = np.sin(theta)[rows]
    return np.stack([sin_theta * np.cos(phi)[cols], sin_theta * np.sin(phi)[cols],
                     np.cos(theta)[rows]], -1)


def lowered(lights, world, cube_face, to_texture=None, strength=1.0):
    """(indices (n,) into the world's H x 2H texels (row-major), their values in the
    residual (n, 3) float32, lights) of :func:`from_world`, without a copy of the
    world: the texels each light takes its excess from, lowered to the threshold
    (every other texel of the residual is the world's times ``strength``, in
    float32). BakeError for a world that is not (H, 2H, 3) or has non-finite
    texels."""
    image = np.asarray(world)
    if image.ndim != 3 or image.shape[2] < 3 or image.shape[1] != 2 * image.shape[0]:
        raise BakeError(f"a lat-long world is (H, 2H, 3), not {np.shape(world)}")
    # float32 throughout the image (an 8k x 4k world is 32M texels) and no copy of
    # it; float64 only for the bright texels the lights are measured on.
    rgb = image[..., :3] if image.dtype == np.float32 else image[..., :3].astype(np.float32)
    scale32 = np.float32(strength)
    luminance = (rgb @ LUMINANCE.astype(np.float32)).reshape(-1)
    if scale32 != 1.0:
        luminance *= scale32
    # NaN or an infinity in any channel makes its texel's luminance non-finite.
    if not (np.isfinite(luminance.max()) and np.isfinite(luminance.min())):
        raise BakeError("the world image has non-finite texels (NaN or infinity)")
    none = (np.zeros(0, dtype=np.intp), np.zeros((0, 3), dtype=np.float32), [])
    if not lights:
        return none
    thresholds = {float(light.threshold) for light in lights}
    if len(thresholds) != 1:
        raise BakeError("lights of one extraction share one threshold")
    layout = get_layout("latlong")
    shape = rgb.shape[:2]
    row_omega = layout.solid_angles((shape[0], 1))[:, 0] / shape[1]  # (H,) sr per texel
    # Negative texels count as 0 in the mean and are never bright: clamped in place.
    np.maximum(luminance, 0.0, out=luminance)
    row_sums = luminance.reshape(shape).sum(axis=1, dtype=np.float64)
    mean = float(row_sums @ row_omega / (4.0 * np.pi))
    level = thresholds.pop() * mean
    centres = np.array([light.direction for light in lights], dtype=np.float64)
    cube_texel = 2.0 / float(cube_face)  # the cube's largest texel's angle (rad)
    reach = np.array([REACH_SPREADS * light.spread + REACH_TEXELS * cube_texel
                      for light in lights])
    # Only bright texels within some light's reach can be taken (by their nearest
    # light, within its own reach): those outside every light's box on a grid of
    # at most 512 rows (its texel's half diagonal added to each reach) are left
    # out before any direction is computed.
    factor = max(1, shape[0] // 512)
    coarse = (-(-shape[0] // factor), -(-shape[1] // factor))
    in_texture = centres if to_texture is None else \
        centres @ np.asarray(to_texture, dtype=np.float64).T
    margin = 0.5 * math.hypot(math.pi / coarse[0], 2.0 * math.pi / coarse[1])
    boxes = layout.near(in_texture, reach + margin, coarse)
    if factor > 1:
        boxes = np.repeat(np.repeat(boxes, factor, 0), factor, 1)[:shape[0], :shape[1]]
    bright = np.flatnonzero((luminance > level) & boxes.reshape(-1))
    rows, cols = np.divmod(bright, shape[1])
    directions = _texel_directions(shape, rows, cols)
    if to_texture is not None:  # texture directions -> world: the rotation's transpose
        directions = directions @ np.asarray(to_texture, dtype=np.float64)
    omega = row_omega[rows]
    radiance = (rgb[rows, cols] * scale32).astype(np.float64)
    luminance = radiance @ LUMINANCE
    nearest = np.empty(len(bright), dtype=np.intp)
    angle = np.empty(len(bright))

    def assign(start):  # (chunk, lights) at a time; BLAS and ufuncs release the GIL
        cosines = directions[start:start + CHUNK] @ centres.T
        nearest[start:start + CHUNK] = np.argmax(cosines, axis=1)
        angle[start:start + CHUNK] = np.arccos(np.clip(np.take_along_axis(
            cosines, nearest[start:start + CHUNK, None], axis=1)[:, 0], -1.0, 1.0))

    starts = range(0, len(bright), CHUNK)
    if len(starts) > 1:
        with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
            list(pool.map(assign, starts))
    else:
        for start in starts:
            assign(start)
    inside = angle <= reach[nearest]
    local = np.flatnonzero(inside)
    nearest = nearest[inside]
    # Each light's texels in bright order: one stable sort, not a scan per light.
    order = np.argsort(nearest, kind="stable")
    bounds = np.searchsorted(nearest[order], np.arange(len(lights) + 1))
    out, indices, values = [], [], []
    for k, light in enumerate(lights):
        texels = local[order[bounds[k]:bounds[k + 1]]]  # indices into the bright arrays
        if len(texels) == 0:
            continue
        scale = level / luminance[texels]
        excess = radiance[texels] * (1.0 - scale)[:, None] * omega[texels, None]
        weights = excess @ LUMINANCE
        direction = directions[texels].T @ weights
        direction /= np.linalg.norm(direction)
        centre = np.arccos(np.clip(directions[texels] @ direction, -1.0, 1.0))
        own = float(np.sum(weights * omega[texels] / 6.0) / np.sum(weights))
        extent = np.sum(weights * centre ** 2) / np.sum(weights) + TENT_MOMENTS * own
        spread = float(np.sqrt(extent + own))
        out.append(probe_lights.Light(direction, excess.sum(axis=0), float(omega[texels].sum()),
                                      spread, light.tile, light.threshold, math.sqrt(own)))
        indices.append(bright[texels])
        values.append((radiance[texels] * scale[:, None]).astype(np.float32))
    if not indices:
        return none[0], none[1], out
    return np.concatenate(indices), np.concatenate(values), out


def split_latlong(image, ax, ay=None):
    """(residual (H, 2H, 3) float32, lights) of a lat-long ``image`` that is itself the
    world (the command line's HDRI, ``python -m bake sample``): the lights
    bake.probe_lights.extract_for takes from it, re-measured on the same texels by
    :func:`from_world`, so that each light's extent includes its texels' bilinear
    tent as Cycles' Linear lookup of the image spreads them. The lights are found
    on the image itself, or on its box MIP level of EXTRACT_ROWS to twice that
    many rows when it is larger (an 8k HDRI's 33M texels would need gigabytes of
    directions), and measured on its own texels; the reach's texel is the
    largest of the image they were found on, pi / rows at the equator (a cube of
    2 rows / pi px faces). A 4096 x 2048 sky with a 0.3-degree sun at 30000
    (GGX 0.2): 0.0079 found at full size (two tiles, 7% of the sun's energy
    lost), 0.0006 found at 1024 rows (one light, all of it).

    Measured (runtime sampling with 19 samples, a 32^2 px sphere, against the
    integral over the image's bilinear reconstruction; extract_for's lights
    against these): a 64-row sky with a 3-degree sun at about 1000x the sky
    0.073 -> 0.023 (GGX 0.2), 0.070 -> 0.025 (GGX 0.3, anisotropy 0.8); the
    bundled 1024-row HDRIs at GGX 0.2-0.45 level (night 0.2 0.017 -> 0.019,
    studio 0.3 0.012 -> 0.010, city 0.45 0.011 -> 0.011); at GGX 0.1 sunset
    0.031 -> 0.008 and city 0.030 -> 0.014 (their suns), night 0.022 -> 0.029
    and interior 0.026 -> 0.031 (one-texel lamps)."""
    from .envmap.mip import pyramid

    image = np.asarray(image)
    found = image[..., :3]
    rows, halvings = found.shape[0], 0
    while rows >> (halvings + 1) >= EXTRACT_ROWS and rows % (2 << halvings) == 0:
        halvings += 1
    if halvings:  # the solid-angle-weighted 2 x 2 box means, halvings times
        found = pyramid(found, "latlong", "box", levels=halvings + 1)[-1]
    _, lights = probe_lights.extract_for(found, "latlong", ax, ay)
    return from_world(lights, image, 2.0 * found.shape[0] / math.pi)


def digest(world) -> str:
    """A hex digest of a world image's texels (float32) and shape: a World Only
    probe records it at capture, and the bake measures lights on the world's
    texels only when the scene's world still holds that image."""
    image = np.ascontiguousarray(world, dtype=np.float32)
    hasher = hashlib.blake2b(repr(image.shape).encode(), digest_size=16)
    hasher.update(memoryview(image).cast("B"))  # the texels' bytes, not a copy of them
    return hasher.hexdigest()


def rotation_of(mapping):
    """(3, 3) R with texture direction = R @ world direction when ``mapping``
    (bake.world_mapping.WorldMapping, or None: the identity) only turns
    directions (a rotation, a uniform positive scale, no location that moves
    points), else None: a Mapping that shears, flips or shifts the lookup moves
    texels' solid angles, which :func:`from_world` does not follow."""
    if mapping is None or not mapping.moves_directions:
        return np.eye(3)
    basis = mapping.texture_directions(np.eye(3))  # row j: the texture direction of e_j
    rotation = basis.T
    if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9) or \
            np.linalg.det(rotation) < 0:
        return None
    probe = np.random.default_rng(0).normal(size=(16, 3))
    probe /= np.linalg.norm(probe, axis=1, keepdims=True)
    if not np.allclose(mapping.texture_directions(probe), probe @ rotation.T, atol=1e-9):
        return None
    return rotation


def split_for(probe, layout, ax, ay=None, world=None, mapping=None, world_digest=None):
    """(residual probe, lights, why) of a probe for a lobe of alphas ``ax``, ``ay``:
    bake.probe_lights.extract_kept's split of the probe, and, for a World Only
    cube probe whose ``world`` (H, 2H, 3) image and ``mapping``
    (bake.world_mapping.WorldMapping: its rotation and Strength) are given,
    the same lights re-measured on the world's texels (:func:`from_world`),
    with the world's residual resampled to the probe's cube as the capture
    resampled the world. Only where the lobe's tiles are at least the world's
    texel (:func:`resolves`) and the Mapping only turns directions
    (:func:`rotation_of`); otherwise the cube's split. ``why``: one line that
    says which was used and, when the cube's, why (None without a world).
    Kept per probe, world and lobe (bake.probe_maps): the materials of one
    bake share it; do not modify the residual. ``world_digest``: :func:`digest`
    of ``world`` when the caller has it (hashing a 4k world takes 0.1 s).

    The residual's bake.probe_maps entry is made with the probe's as its parent
    (bake.probe_maps.residual_maps), so its lat-long conversions are the probe's
    recomputed near the lights only, shared by every lobe's residual."""
    residual, lights, why = _split_for(probe, layout, ax, ay, world, mapping, world_digest)
    if layout in ("cube", "latlong") and residual is not probe:
        from .probe_maps import residual_maps

        residual_maps(residual, layout, probe)
    return residual, lights, why


def _split_for(probe, layout, ax, ay, world, mapping, world_digest):
    """:func:`split_for` without making the residual's bake.probe_maps entry."""
    residual, lights = probe_lights.extract_kept(probe, layout, ax, ay)
    if world is None or not lights:
        return residual, lights, None
    mean_alpha = math.sqrt(ax * (ax if ay is None else ay))  # the tiles' (probe_lights)
    if layout != "cube":
        return residual, lights, "lights measured on the probe (it is not a cube)"
    if not resolves(np.shape(world), mean_alpha):
        return residual, lights, (f"lights measured on the probe: the lobe's tiles "
                                  f"({probe_lights.tile_radius_for(mean_alpha):.2g} rad) are "
                                  f"finer than the world's texels")
    rotation = rotation_of(mapping)
    if rotation is None:
        return residual, lights, ("lights measured on the probe: the world's Mapping does "
                                  "more than turn it")
    from .probe_maps import probe_maps

    world = np.ascontiguousarray(world, dtype=np.float32)
    strength = 1.0 if mapping is None else float(mapping.strength)
    world_digest = world_digest or digest(world)
    key = ("world lights", world_digest, tuple(np.round(rotation, 12).ravel()), strength,
           REACH_SPREADS, REACH_TEXELS, round(float(ax), 9),
           round(float(ax if ay is None else ay), 9))
    maps = probe_maps(probe, layout)

    face = int(np.shape(probe)[0])
    count = reduction_count(get_layout("latlong"), world.shape[:2], get_layout("cube"),
                            (face, 6 * face))
    # The level the lights are measured on: the world itself, or the coarsest of the
    # box-reduced levels the conversion reads whose texel the lobe's tiles still
    # span TILE_TEXELS times (measured_level).
    depth = measured_level(world.shape, count, mean_alpha)

    def compute():
        transform = mapping.texture_directions \
            if mapping is not None and mapping.moves_directions else None
        if count == 0:
            indices, values, measured = lowered(lights, world, face, rotation, strength)
            world_residual = np.array(world[..., :3], dtype=np.float32) * np.float32(strength)
            world_residual.reshape(-1, 3)[indices] = values
            return residual_cube(probe, lights, world_residual, transform), measured
        # The conversion reads the world box-reduced ``count`` times: reduced once
        # per probe and world, each lobe's residual is that with the parents of
        # its lowered texels recomputed (no copy of the world).
        levels = maps.kept(("reduced world", world_digest, strength, count),
                           lambda: reduced_world(world, strength, count))
        if depth == 0:
            indices, values, measured = lowered(lights, world, face, rotation, strength)
            world_residual = reduced_residual(levels, world, strength, indices, values)
        else:  # the levels hold the Strength already
            source = levels[depth - 1][0]
            indices, values, measured = lowered(lights, source, face, rotation, 1.0)
            if depth < count:
                world_residual = reduced_residual(levels[depth:], source, 1.0, indices, values)
            else:
                world_residual = source.copy()
                world_residual.reshape(-1, 3)[indices] = values
        return residual_cube(probe, lights, world_residual, transform), measured

    cube, measured = maps.kept(key + (depth,), compute)
    rows = int(np.shape(world)[0])
    where = f"the world's {rows}-row image" if depth == 0 else \
        (f"the world's {rows}-row image box-reduced to {rows >> depth} rows (the lobe's "
         f"tiles span {TILE_TEXELS:g}+ of its texels)")
    return cube, measured, (f"{len(measured)} of the probe's {len(lights)} lights "
                            f"re-measured on {where}")


def measured_level(world_shape, count, alpha) -> int:
    """How many times the (H, 2H) world is box-reduced before a lobe's lights are
    measured on it: the most, up to the ``count`` reductions bake.envmap.convert
    applies for the probe (those levels are made anyway), at which the lobe's
    tiles (probe_lights.tile_radius_for ``alpha``, the geometric mean alpha) still
    span TILE_TEXELS texels (pi / rows at the equator); 0 (the world's own texels)
    when none does. The reduction is exact in energy, so the split stays exact;
    what moves is the share of a bright region's edge texels that a light takes
    (sunset.exr repeated 8 x 8 to 8192 x 4096, 128 px faces: at GGX 0.3 and 0.6,
    measured on 2048 and 1024 rows, the lights' energy moved 0.006% and 0.045%
    of the probe's, their directions 0.01 degrees, against 0.50 -> 0.09 s and
    1.46 -> 0.06 s for measuring them)."""
    rows = int(world_shape[0])
    tile = probe_lights.tile_radius_for(alpha)
    depth = 0
    while depth < count and tile >= TILE_TEXELS * math.pi / (rows >> (depth + 1)):
        depth += 1
    return depth


#: residual_cube converts the whole world again when more than this share of the
#: cube's texels lie near the lights (the local update would save little); it
#: checks CHECK_TEXELS other texels of the cube against the world's own
#: conversion, to CHECK_TOLERANCE relative (bake.envmap.convert.convert_changed's,
#: imported at the top).


def residual_cube(probe, lights, world_residual, transform=None):
    """The World Only cube ``probe`` (N, 6N, 3) float32 with the lights taken out as
    :func:`from_world` took them from its world: convert(world_residual, lat-long ->
    cube, N, transform), computed only where it can differ from the probe.

    ``world_residual`` (H, 2H, 3) is the world times its Strength with the
    ``lights``' texels (those within reach of each light's centre,
    :func:`from_world`) lowered; the probe is the conversion of the world times
    its Strength (glossy.capture_probes' World Only capture). Conversion is
    linear and local, so only cube texels whose lookups reach a lowered texel
    change: those within reach + margin of a light's centre, the margin being
    the cube texel's half diagonal, two texel diagonals of the prereduced world
    the lookups read (bilinear taps and the pole's ring mean), a world texel's
    diagonal and the sub-sample spacing, times 1.5 (bake.envmap.convert). Those
    are recomputed (bake.envmap.convert.convert_texels); CHECK_TEXELS other
    texels are recomputed as well and must equal the probe, else (a probe that
    is not this world's conversion) the whole cube is converted, as it is when
    more than LOCAL_SHARE of the texels are near lights. Equal to the whole
    conversion to float32 rounding (tests/bake/test_world_lights.py); one
    conversion of a 512-row world to 128 px faces took 0.34 s of each
    material's bake."""
    from .envmap.convert import convert_texels

    probe = np.asarray(probe, dtype=np.float32)
    face = int(probe.shape[0])
    cube = get_layout("cube")
    rows_world = int(world_residual.shape[0])
    reduced = rows_world  # the rows of the level bake.envmap.convert reads (_prereduce)
    while 2.0 * reduced * reduced / (6.0 * face * face) > 16.0 and reduced % 2 == 0:
        reduced //= 2
    spacing = math.sqrt(4.0 * math.pi / (6.0 * face * face))  # a texel; sub-samples are closer
    margin = 1.5 * (math.sqrt(2.0) / face + 2.0 * math.sqrt(2.0) * math.pi / reduced
                    + math.sqrt(2.0) * math.pi / rows_world + spacing)
    cube_texel = 2.0 / float(face)
    centres = np.array([light.direction for light in lights], dtype=np.float64)
    limits = np.cos(np.minimum(np.array([REACH_SPREADS * light.spread
                                         + REACH_TEXELS * cube_texel for light in lights])
                               + margin, np.pi))
    ys, xs = np.divmod(np.arange(face * 6 * face), 6 * face)
    near = np.zeros(len(ys), dtype=bool)
    for start in range(0, len(ys), CHUNK):
        directions = cube.directions(xs[start:start + CHUNK] + 0.5, ys[start:start + CHUNK] + 0.5,
                                     probe.shape[:2])
        near[start:start + CHUNK] = np.any(directions @ centres.T >= limits, axis=1)
    if near.mean() > LOCAL_SHARE:
        return convert(world_residual, "latlong", "cube", face, transform=transform)
    far = np.flatnonzero(~near)
    checked = far[np.linspace(0, len(far) - 1, min(CHECK_TEXELS, len(far))).astype(np.intp)]
    chosen = np.concatenate([np.flatnonzero(near), checked])
    values = convert_texels(world_residual, "latlong", "cube", face, ys[chosen], xs[chosen],
                            transform=transform)
    expected = probe[ys[checked], xs[checked]]
    scale = max(float(np.abs(probe).mean()), 1e-30)
    if np.any(np.abs(values[len(chosen) - len(checked):] - expected)
              > CHECK_TOLERANCE * np.maximum(np.abs(expected), scale)):
        return convert(world_residual, "latlong", "cube", face, transform=transform)
    out = probe.copy()
    count = len(chosen) - len(checked)
    out[ys[chosen[:count]], xs[chosen[:count]]] = values[:count]
    return out


def reduced_world(world, strength, count):
    """[(level (h, 2h, 3) float32, its rows' texel solid angle (h,) float64), ...]: the
    lat-long ``world`` (H, 2H, 3) times ``strength`` box-reduced 1 ... ``count`` times
    by bake.envmap.mip.reduce_latlong, as bake.envmap.convert reduces a source
    (the Strength applied after the first reduction, equal to 1e-7)."""
    from .envmap.mip import reduce_latlong

    image = np.asarray(world)
    rgb = image[..., :3] if image.dtype == np.float32 else image[..., :3].astype(np.float32)
    levels = []
    level, omega = reduce_latlong(rgb)
    if np.float32(strength) != 1.0:
        level *= np.float32(strength)
    levels.append((level, omega))
    for _ in range(count - 1):
        levels.append(reduce_latlong(*levels[-1]))
    return levels


def reduced_residual(levels, world, strength, indices, values):
    """The residual world (world times ``strength``, with texels ``indices`` (n,) of its
    H x 2H set to ``values`` (n, 3): :func:`lowered`) reduced as
    :func:`reduced_world` reduces the world, whose ``levels`` it is given: only
    the parents of the changed texels are recomputed, level by level, with
    reduce_latlong's arithmetic (wa (x00 + x01) + wb (x10 + x11)), their
    unchanged siblings read from the world (times ``strength``) or its levels.
    Returns the last level, a new (h, 2h, 3) float32 array (the levels are kept
    unchanged); equal to reducing the whole residual to 1e-7."""
    from .envmap.mip import latlong_row_omega, latlong_row_weights

    image = np.asarray(world)
    rgb = image[..., :3] if image.dtype == np.float32 else image[..., :3].astype(np.float32)
    scale32 = np.float32(strength)
    order = np.argsort(indices, kind="stable")
    flat, changed = np.asarray(indices, dtype=np.intp)[order], np.asarray(values)[order]
    below_width = rgb.shape[1]
    below_omega = latlong_row_omega(*rgb.shape[:2])
    for depth, (level, omega) in enumerate(levels):
        width = level.shape[1]
        parents = np.unique((flat // below_width // 2) * width + (flat % below_width) // 2)
        rows, cols = np.divmod(parents, width)
        wa, wb, _ = latlong_row_weights(below_omega)

        def child(r, c, depth=depth, flat=flat, changed=changed, below_width=below_width):
            value = (rgb[r, c] * scale32) if depth == 0 else levels[depth - 1][0][r, c]
            wanted = r * below_width + c
            at = np.minimum(np.searchsorted(flat, wanted), max(len(flat) - 1, 0))
            hit = (flat[at] == wanted) if len(flat) else np.zeros(len(wanted), bool)
            value[hit] = changed[at[hit]]
            return value

        upper = child(2 * rows, 2 * cols) + child(2 * rows, 2 * cols + 1)
        upper *= wa[rows, None]
        lower = child(2 * rows + 1, 2 * cols) + child(2 * rows + 1, 2 * cols + 1)
        lower *= wb[rows, None]
        flat, changed = parents, upper + lower
        below_width, below_omega = width, omega
    out = levels[-1][0].copy()
    out.reshape(-1, 3)[flat] = changed
    return out
