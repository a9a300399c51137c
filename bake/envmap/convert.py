"""Resampling an environment map from one parameterization to another.

Each target texel receives the solid-angle-weighted mean of the source over
its footprint: k x k sub-samples spread evenly over the texel in image space,
each weighted by the target layout's Jacobian (solid angle per texel area) at
that point, each a bilinear lookup of the source. k grows with the ratio of
source to target resolution, so a smaller target averages all the source
detail under each texel instead of aliasing it (area-correct downsampling);
the lat-long source additionally box-filters its polar rows along longitude
to the sub-sample spacing. Where even 8 x 8 sub-samples would skip source
texels, a cube or lat-long source is first reduced by exact 2 x 2
solid-angle box steps (its MIP pyramid).
"""

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..errors import BakeError
from ..progress import Progress, report
from .layout import Layout

__all__ = ["convert", "convert_texels", "convert_changed", "reduction_count", "resample",
           "supersampling"]

#: convert_changed: other texels recomputed as a check, the relative tolerance of
#: that check (float32 sums in another order differ by about 1e-7), and the share
#: of the target above which the whole conversion is cheaper.
CHECK_TEXELS = 256
CHECK_TOLERANCE = 1e-4
LOCAL_SHARE = 0.5
#: convert's lat-long to lat-long resampling computed separably
#: (LatLong.resampled); False takes the per-sub-sample path every other pair of
#: layouts takes (benchmarks/probe_face.py times both).
SEPARABLE_LATLONG = True
#: Sub-samples evaluated per work item (bounds memory to a few hundred MB).
_CHUNK_SAMPLES = 1 << 18
MAX_SUPERSAMPLING = 8


def supersampling(source: Layout, source_shape, target: Layout, target_shape) -> int:
    """Sub-samples per target texel side: ceil(1.5 sqrt(source / target texels)), in [1, 8].

    The factor 1.5 keeps about two source texels per sub-sample spacing in
    the densest regions of the common layouts (cube corners are 5x denser than
    face centres), which makes the texel average close to the exact area mean.
    """
    ratio = source.covered_texels(source_shape) / target.covered_texels(target_shape)
    return int(np.clip(math.ceil(2.0 * math.sqrt(ratio)), 1, MAX_SUPERSAMPLING))


def _prereduce(source: Layout, image, target: Layout, shape):
    """Halve a cube or lat-long source by exact 2x2 solid-angle box steps while it
    has more than (MAX_SUPERSAMPLING / 1.5)^2 texels per target texel, so that
    k x k sub-samples of the reduced source still see every source texel."""
    from .mip import reduce_latlong, reduce_level

    count = reduction_count(source, image.shape[:2], target, shape)
    if count == 0:
        return image
    if source.name == "latlong":  # a row's texels share one solid angle
        row_omega = None
        for _ in range(count):
            image, row_omega = reduce_latlong(image, row_omega)
        return image
    stack = source.to_faces(image)
    omega = source.to_faces(source.solid_angles(image.shape[:2])[..., None])[..., 0]
    for _ in range(count):
        stack, omega = reduce_level(stack, omega)
    return source.from_faces(stack)


def reduction_count(source: Layout, source_shape, target: Layout, shape) -> int:
    """How many 2x2 box halvings :func:`convert` applies to a ``source_shape`` image in
    layout ``source`` (cube or lat-long; others none) before resampling it to
    ``shape`` in ``target``: while it has more than (MAX_SUPERSAMPLING / 2)^2
    texels per target texel and its faces' sides are even."""
    if source.name not in ("cube", "latlong"):
        return 0
    limit = (MAX_SUPERSAMPLING / 2.0) ** 2
    target_texels = target.covered_texels(shape)
    height = int(source_shape[0])  # a face's sides: N x N (cube), H x W (lat-long)
    width = height if source.name == "cube" else int(source_shape[1])
    src_shape = tuple(source_shape[:2])
    count = 0
    while source.covered_texels(src_shape) / target_texels > limit:
        if height % 2 or width % 2 or height < 2:
            break
        height, width = height // 2, width // 2
        src_shape = (src_shape[0] // 2, src_shape[1] // 2)
        count += 1
    return count


def resample(sample, target: Layout, shape, k: int, channels: int, progress=None, dtype=np.float32):
    """Evaluate ``sample(directions) -> (..., channels)`` averaged over every texel.

    shape: target image shape (H, W). Returns (H, W, channels) of ``dtype``.
    """
    height, width = shape
    offsets = (np.arange(k) + 0.5) / k
    rows_per_chunk = max(1, _CHUNK_SAMPLES // (width * k * k))
    chunks = [(r, min(r + rows_per_chunk, height)) for r in range(0, height, rows_per_chunk)]
    out = np.empty((height, width, channels), dtype=dtype)
    x = (np.arange(width)[:, None] + offsets[None, :])[None, None, :, :]

    def work(bounds):
        r0, r1 = bounds
        y = (np.arange(r0, r1)[:, None] + offsets[None, :])[:, :, None, None]
        # A cube's face and column coordinate follow x alone: kept apart from y
        # (Cube.directions gathers its face table per column then).
        xs = x if target.name == "cube" else None
        if xs is None:
            xs, y = np.broadcast_arrays(x, y)
        directions = target.directions(xs, y, shape)
        weights = target.jacobian(xs, y, shape)
        weights = np.broadcast_to(weights, directions.shape[:-1]).astype(np.float32)
        values = sample(directions)
        total = np.einsum("abcd,abcde->ace", weights, values.astype(np.float32, copy=False))
        out[r0:r1] = total / weights.sum(axis=(1, 3))[..., None]
        return r1 - r0

    done = 0
    workers = min(2, os.cpu_count() or 1, len(chunks))
    with ThreadPoolExecutor(max_workers=max(workers, 1)) as pool:
        for rows in pool.map(work, chunks):
            done += rows
            report(progress, done / height, f"resampling {done}/{height} rows")
    return out


def convert(image, src, dst, size, *, samples: int | None = None, progress: Progress | None = None,
            transform=None):
    """Convert an environment map between parameterizations.

    image: (H, W, C) float array in layout ``src``; ``src``/``dst`` one of
    ``latlong``, ``cube``, ``paraboloid``, ``sphere`` (or a Layout); ``size``
    the target size (lat-long: N x 2N, cube: N x 6N, paraboloid: N x 2N,
    sphere: N x N). ``samples`` overrides the sub-samples per texel side.
    ``transform``: a function of target directions (..., 3) returning the unit
    directions (..., 3) in which to look up the source (e.g. a world's Mapping
    node, bake.world_mapping); None looks up the same direction.
    Returns a float32 (H', W', C) image; radiance is never clamped.
    """
    source, target, image, shape, k, spacing = _prepare(image, src, dst, size, samples)
    if source.name == target.name == "latlong" and transform is None and SEPARABLE_LATLONG:
        # Lat-long to lat-long at the same directions: the same resampling with
        # rows and columns apart (LatLong.resampled), 3-9x faster here.
        result = source.resampled(image, shape[0], k, spacing)
        report(progress, 1.0, f"resampled {shape[0]} rows")
        return result
    sample, channels = _sampler(source, image, spacing, transform), image.shape[2]
    return resample(sample, target, shape, k, channels, progress)


def convert_texels(image, src, dst, size, ys, xs, *, samples: int | None = None,
                   transform=None):
    """(N, C) float32: what :func:`convert` (same arguments) gives at target texels
    (ys[i], xs[i]) (integer row and column arrays (N,)), computed for those
    texels alone: the same prereduction, sub-samples, Jacobian weights and
    lookups, so the values equal convert's to float32 rounding (the sums run
    in another order). For updating a few texels of a converted image after a
    local change of the source."""
    sample, target, shape, k, channels = _plan(image, src, dst, size, samples, transform)
    ys = np.asarray(ys, dtype=np.intp).reshape(-1)
    xs = np.asarray(xs, dtype=np.intp).reshape(-1)
    out = np.empty((len(ys), channels), np.float32)
    offsets = (np.arange(k) + 0.5) / k
    # Chunks of texels (a few hundred thousand sub-samples each, at least two
    # chunks for two cores once there are enough texels).
    per_chunk = max(1, min(_CHUNK_SAMPLES // (k * k), -(-len(ys) // 2)))

    def work(start):
        y = ys[start:start + per_chunk, None, None] + offsets[None, :, None]  # (n, k, 1)
        x = xs[start:start + per_chunk, None, None] + offsets[None, None, :]  # (n, 1, k)
        x, y = np.broadcast_arrays(x, y)
        weights = np.broadcast_to(target.jacobian(x, y, shape), x.shape).astype(np.float32)
        values = sample(target.directions(x, y, shape)).astype(np.float32, copy=False)
        total = np.einsum("abc,abcd->ad", weights, values)
        out[start:start + per_chunk] = total / weights.sum(axis=(1, 2))[:, None]

    starts = range(0, len(ys), per_chunk)
    with ThreadPoolExecutor(max_workers=max(1, min(2, os.cpu_count() or 1, len(starts)))) as pool:
        list(pool.map(work, starts))
    return out


def _prepare(image, src, dst, size, samples):
    """(source layout, target layout, checked and prereduced float32 image, target
    shape, sub-samples per texel side k, the sampler's row-prefilter spacing)."""
    from . import get_layout

    source, target = get_layout(src), get_layout(dst)
    image = source.check_image(image)
    if not np.all(np.isfinite(image)):
        raise BakeError("the environment map holds NaN or infinite values")
    shape = target.shape(size)
    image = _prereduce(source, image.astype(np.float32, copy=False), target, shape)
    k = samples if samples is not None else supersampling(source, image.shape[:2], target, shape)
    if not 1 <= int(k) <= 64:
        raise BakeError(f"samples must be between 1 and 64, not {k}")
    spacing = math.sqrt(4.0 * math.pi / target.covered_texels(shape)) / k
    return source, target, image, shape, int(k), spacing


def _sampler(source, image, spacing, transform):
    """``sample(directions) -> (..., C)``: the source's bilinear lookups (through
    ``transform`` when given)."""
    sample = source.sampler(image, spacing)
    if transform is None:
        return sample

    def transformed(directions):
        return sample(transform(directions))

    return transformed


def _plan(image, src, dst, size, samples, transform):
    """(sample, target layout, target shape, k, channels) of a conversion."""
    source, target, image, shape, k, spacing = _prepare(image, src, dst, size, samples)
    return _sampler(source, image, spacing, transform), target, shape, k, image.shape[2]


def _reduced_mask(mask, layout: Layout, count: int):
    """``mask`` (H, W) bool after ``count`` 2x2 halvings (per face): a texel is set when
    any of its children is, as a box reduction mixes them."""
    stack = layout.to_faces(mask[..., None])[..., 0]
    for _ in range(count):
        faces, height, width = stack.shape
        stack = stack.reshape(faces, height // 2, 2, width // 2, 2).any(axis=(2, 4))
    return layout.from_faces(stack[..., None])[..., 0]


def _source_texel_angle(layout: Layout, shape) -> float:
    """The largest angular side (rad) of a texel of ``shape`` in ``layout``."""
    if layout.name == "latlong":
        return max(math.pi / shape[0], 2.0 * math.pi / shape[1])
    if layout.name == "cube":
        return 2.0 / shape[0]  # a face-centre texel: 2 / N of the unit face
    return float(np.sqrt(layout.solid_angles(shape).max())) * 2.0


def convert_changed(converted, image, changed, src, size, *, samples: int | None = None):
    """convert(image, src, "latlong", size, samples=samples) (float32 (size, 2 size, C)),
    given ``converted``, the same conversion of an image that differs from ``image``
    only at the texels where ``changed`` (H, W) bool is set (a probe with its small
    bright lights taken out, against the probe): only the target texels that can
    read a changed texel are recomputed (:func:`convert_texels`). ``converted``
    may be a function that returns it, called only when the local update is used
    (not when ``image`` is converted whole).

    Conversion is linear and local: a target texel reads its sub-samples (within
    its half diagonal) by bilinear lookups (the four texels around a point, within
    a texel diagonal) of the source, after convert's 2 x 2 box reductions (which
    widen a changed texel to its parent) and, for a lat-long source, the polar
    rows' box filter to the sub-sample spacing. Target texels within 1.5 times
    the sum of those reaches of a changed texel's centre are recomputed; so are
    CHECK_TEXELS others, which must equal ``converted`` (else it was not this
    conversion, and the whole image is converted), as is the whole image when
    over LOCAL_SHARE of it is near a change. Equal to the whole conversion to
    float32 rounding."""
    from . import get_layout

    source, target = get_layout(src), get_layout("latlong")
    image = source.check_image(image)
    shape = target.shape(size)
    changed = np.asarray(changed, dtype=bool)
    if changed.shape != image.shape[:2]:
        raise BakeError(f"convert_changed: a {changed.shape} mask for a {image.shape} image")

    def original():
        result = np.asarray(converted() if callable(converted) else converted)
        if result.shape[:2] != shape:
            raise BakeError(f"convert_changed: a {result.shape} conversion at size {size}")
        return result

    if not changed.any():
        return original().astype(np.float32, copy=True)
    count = reduction_count(source, image.shape[:2], target, shape)
    reduced_shape = (image.shape[0] >> count, image.shape[1] >> count)
    mask = _reduced_mask(changed, source, count)
    k = samples if samples is not None else supersampling(source, reduced_shape, target, shape)
    spacing = math.sqrt(4.0 * math.pi / target.covered_texels(shape)) / k
    reach = (math.sqrt(2.0) * _source_texel_angle(source, reduced_shape)
             + 0.5 * math.hypot(math.pi / shape[0], 2.0 * math.pi / shape[1])
             + (spacing if source.name == "latlong" else 0.0))
    ys, xs = np.nonzero(mask)
    directions = source.directions(xs + 0.5, ys + 0.5, reduced_shape).reshape(-1, 3)
    near = target.near(directions, 1.5 * reach, shape)
    if near.mean() > LOCAL_SHARE:
        return convert(image, src, "latlong", size, samples=samples)
    converted = original()
    far = np.flatnonzero(~near)
    checked = far[np.linspace(0, len(far) - 1, min(CHECK_TEXELS, len(far))).astype(np.intp)]
    chosen = np.concatenate([np.flatnonzero(near), checked])
    rows, cols = np.divmod(chosen, shape[1])
    values = convert_texels(image, src, "latlong", size, rows, cols, samples=samples)
    count_near = len(chosen) - len(checked)
    flat = converted.reshape(-1, converted.shape[-1])
    expected = flat[checked]
    scale = max(float(np.abs(converted).mean()), 1e-30)
    if np.any(np.abs(values[count_near:] - expected)
              > CHECK_TOLERANCE * np.maximum(np.abs(expected), scale)):
        return convert(image, src, "latlong", size, samples=samples)
    out = converted.astype(np.float32, copy=True)
    out.reshape(-1, out.shape[-1])[chosen[:count_near]] = values[:count_near]
    return out
