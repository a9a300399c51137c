"""Brute-force reflected radiance: the distant-lighting truth Glossy is measured against.

L_o(n, v) = sum over the probe's texels t of L_t f(l_t, v) max(n.l_t, 0) omega_t,

with the true BRDF evaluated in a local frame at each normal (the Kautz-McCool
paper's Figure 15 comparison). Isotropic BRDFs do not depend on the tangent
chosen; anisotropic ones use the given tangents (or ``tangent_hint``
projected onto the surface).

Two implementations of the same sum:

- :func:`reflected_radiance`: the straightforward loop, one pixel at a time
  over every texel. The definition; tests and the benchmark compare with it.
- :func:`render`: vectorized over pixels in chunks with bounded memory, and
  adaptive over a texel pyramid. Each level groups 2x2 blocks of the level
  below; a block's flux sum(L omega) is exact and its direction is the
  flux-weighted mean, so a block's midpoint value is exact for an integrand
  linear across it, whatever the light inside. For a (pixel, block) pair the
  integrand g = f cos is evaluated at the block's four children; the midpoint
  rule being second order, the children's sum is off by about a third of its
  difference from the block's own value (Richardson). Where that is within
  ``tolerance`` of the pixel's coarse total, the extrapolated sum is taken;
  else the children are refined, down to single texels (exact). Refined
  whatever the estimate: blocks straddling the horizon where light above it
  could matter, and, for lobes narrower than a block, blocks near the mirror
  direction or the BRDF's own importance samples of the lobe's core.
  Measured against the loop (tests/bake/test_reference.py,
  benchmarks/validate.py): relative RMS differences of 1e-5 to 4e-4 at the
  default tolerance; tolerance 0 reproduces it to rounding.

Both sum over texel centres: the probe as point lights. A renderer sees the
probe as a function, its bilinear reconstruction (GPU texture sampling,
Cycles' Linear interpolation of the world), and for a lobe narrower than a
few texels the texel sum is a coarse, aliased quadrature of that function's
integral: on a sphere, against the sum over the reconstruction 16x finer, it
is 9% off in night.exr at GGX 0.3 through 64 px faces and 5% in
interior.exr at GGX 0.2 through 128 px faces (0.03-0.2% at GGX 0.6;
benchmarks/reference_reconstruction.py). ``reconstruction="bilinear"``
integrates the reconstruction instead: the same sum over the probe resampled
bilinearly to :func:`reconstruction_factor` times its resolution (a power of
two), chosen so that sub-texels are at most a sixteenth of the median lobe
width apart (1 where the lobe spans enough texels, so wide lobes cost nothing
more), within a memory bound. glossy.validate's reference uses it.

Where memory bounds the factor, or a pixel's lobe is far narrower than the
median (grazing views), the grid is still coarser than the lobe: a near-mirror
lobe (Principled Roughness 0-0.02) is tens to hundreds of times narrower than
a texel and falls between the grid's centres. For such a pixel (its lobe reaches less
than CORE_STEPS grid steps) ``bilinear`` splits the sphere along the grid's own
cells. The pixel's core is the cells about its mirror direction: a cell's share
in it is 1 where its centre lies within R = max(CORE_STEPS steps, twice the
lobe's reach) and falls linearly to 0 at 2R, so neither part has a jump at the
core's edge. The core is integrated by the BRDF's own importance samples and
uniform samples of the core's cap (the balance heuristic), f cos x share /
density, of the reconstruction itself (a bilinear lookup of the probe at each
sample); the grid's sum takes each cell times one minus its share (blocks
that reach into the core are always refined, so its cells are weighed
exactly). Beyond R the lobe changes by at most a quarter of itself per grid
step, where the grid's midpoint rule is accurate; inside, the samples follow
the lobe. The split holds for any BRDF with a pdf (a diffuse part's samples
that fall in the core count with the mixture's density). Since the cores take
the lobes the grid cannot resolve, the factor is at most MAX_FACTOR.
"""

import os
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from .brdf.base import hammersley
from .envmap import get_layout
from .progress import report

__all__ = ["reflected_radiance", "render", "render_steps", "sphere_buffers", "vector_layer",
           "has_layer", "pixel_arrays", "reconstruction_factor", "DEFAULT_TOLERANCE",
           "RECONSTRUCTIONS"]

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: Largest block edge (texels) of the pyramid's top level.
TOP_BLOCK = 64
#: Relative error budget of one (pixel, block) pair, against the pixel's total.
DEFAULT_TOLERANCE = 5e-4
#: Importance samples per pixel that force refinement (plus the mirror direction).
SEED_SAMPLES = 24
#: (pixel, child) evaluations per batch: bounds memory (~100 MB of temporaries).
BATCH = 1 << 17
#: Most (pixel, top block) pairs a chunk of pixels starts with: each pair holds
#: about 200 bytes through a level, so this bounds a chunk's memory to ~0.2 GB.
TOP_PAIRS = 1 << 20
#: What the sum integrates: the texels as point lights, or the probe's bilinear
#: reconstruction (render_steps' ``reconstruction``).
RECONSTRUCTIONS = ("texels", "bilinear")
#: Largest sub-texel spacing of the bilinear reconstruction, as a fraction of the
#: pixels' median lobe width (reconstruction_factor). Measured on the bundled
#: HDRIs (benchmarks/reference_reconstruction.py): the texel sum is up to 9% off
#: (night.exr, GGX 0.3 through 64 px faces, 5 texels a median width); a grid
#: of 8 samples a width left up to 0.74% there, 16 samples a width 0.2%.
SUBTEXEL_SPACING = 1.0 / 16.0
#: Percentile of the pixels' lobe widths that sets the factor (the median: the
#: narrow-axis width of grazing pixels falls steeply and a low percentile would
#: follow how many of them the image happens to hold).
WIDTH_PERCENTILE = 50.0
#: Most texels the finer grid may hold: the pyramid keeps about 100 bytes a texel,
#: so about 1 GiB (a 328 px cube probe 4x finer).
MAX_RECONSTRUCTION_TEXELS = (1 << 30) // 100
#: Pixels whose lobes are sampled to find the narrowest width.
WIDTH_PIXELS = 4096
#: Largest factor chosen: a lobe narrower than the grid then has its core
#: integrated by its own samples (CORE_STEPS), which costs less than a finer grid
#: (a near-mirror lobe wanted 2048x, which no memory bound allows).
MAX_FACTOR = 4
#: A pixel whose lobe reaches (median angle from the mirror direction) less than
#: this many steps of the grid summed (the probe, or its reconstruction at the
#: factor chosen) has its core integrated by the BRDF's own samples instead
#: (:func:`_core_quadrature`): the grid is coarser than such a lobe, whatever
#: factor memory allows (a near-mirror lobe falls between sub-texel centres).
CORE_STEPS = 8
#: Importance samples (Hammersley, the BRDF's own sampler) of a narrow lobe's core,
#: plus half as many uniform over the core's cap (:func:`_core_quadrature`).
#: Against the grid summed 64x finer (16 px faces of night.exr and sunset.exr,
#: GGX 0.2, 38 grid steps a lobe width; grids 1-8x finer than the probe): 1024
#: samples left 0.06-0.6%, 2048 0.03-0.25%.
CORE_SAMPLES = 2048


def _frames(normals, tangents, tangent_hint):
    """(N, 3, 3) rows x = tangent, y = n x t, z = n (the hint's frame where a given
    tangent is zero or along n)."""
    n = normals
    hint = (0.3, 0.5, 0.8) if tangent_hint is None else tangent_hint
    t = np.cross(n, np.asarray(hint, dtype=np.float64))
    small = np.linalg.norm(t, axis=1) < 1e-6
    t[small] = np.cross(n[small], (1.0, 0.0, 0.0))
    t = np.cross(t, n)  # the hint's part along the surface, as the loop below
    if tangents is not None:  # given tangents; the hint where one vanishes (a pole)
        given = tangents - np.sum(tangents * n, axis=1, keepdims=True) * n
        usable = np.linalg.norm(given, axis=1) > 1e-9
        t[usable] = given[usable]
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return np.stack([t, np.cross(n, t), n], axis=1)


def pixel_arrays(normals, views, tangents=None):
    """Normals, views and tangents (or None) as (N, 3) float64; ValueError when the
    normals and views differ in shape."""
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    views = np.asarray(views, dtype=np.float64).reshape(-1, 3)
    if normals.shape != views.shape:
        raise ValueError(f"normals {normals.shape} and views {views.shape} differ in shape")
    if tangents is not None:
        tangents = np.asarray(tangents, dtype=np.float64).reshape(-1, 3)
    return normals, views, tangents


def reflected_radiance(model, probe, layout, normals, views, tangent_hint=(0.3, 0.5, 0.8)):
    """(N, 3) radiance for world-space unit normals and views (surface to viewer), (N, 3) each.

    probe: (H, W, 3) environment in ``layout`` (any of bake.envmap's layouts).
    One pixel at a time over every texel: the definition :func:`render` is
    checked against.
    """
    layout = get_layout(layout)
    shape = probe.shape[:2]
    directions = layout.texel_directions(shape).reshape(-1, 3)
    values = np.asarray(probe, dtype=np.float64).reshape(-1, probe.shape[2])[:, :3]
    omega = layout.solid_angles(shape).reshape(-1)
    normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
    views = np.asarray(views, dtype=np.float64).reshape(-1, 3)
    frames = _frames(normals, None, tangent_hint)
    out = np.empty((len(normals), 3))
    for index, (frame, v) in enumerate(zip(frames, views, strict=True)):
        wi = directions @ frame.T
        wo = np.broadcast_to(frame @ v, wi.shape)
        weight = model.f(wi, wo) * np.clip(wi[:, 2:3], 0, None) * omega[:, None]
        out[index] = np.sum(weight * values, axis=0)
    return out


@dataclass
class _Level:
    """Blocks of ``size`` x ``size`` texels: directions (B, 3), flux (B, 3), flux
    luminance (B,), children (B, 4) indices into the level below (None for texels)."""

    size: int
    shape: tuple
    directions: np.ndarray
    flux: np.ndarray
    flux_y: np.ndarray
    children: np.ndarray | None
    radius: np.ndarray  # (B,) angle (rad) from the block's direction that holds its texels


def _pyramid(probe, layout):
    """Texel pyramid of a probe: levels from single texels up to TOP_BLOCK blocks."""
    height, width = probe.shape[:2]
    omega = layout.solid_angles((height, width))
    flux = np.asarray(probe[..., :3], dtype=np.float64) * omega[..., None]
    # Directions weighted by luminance flux (plus a trace of solid angle, for black
    # blocks): the midpoint rule of a block is then exact for a linear integrand
    # whatever the radiance inside it, and its error is second order.
    weight = np.abs(flux @ LUMINANCE)
    weight = weight + 1e-6 * (weight.sum() / max(omega.sum(), 1e-300)) * omega
    direction = layout.texel_directions((height, width)) * weight[..., None]
    levels = []
    size, index = 1, np.arange(height * width).reshape(height, width)
    while True:
        unit = direction / np.maximum(np.linalg.norm(direction, axis=-1, keepdims=True), 1e-300)
        levels.append([size, index.shape, unit.reshape(-1, 3), flux.reshape(-1, 3), index])
        h, w = index.shape
        if size * 2 > TOP_BLOCK or h % 2 or w % 2 or (layout.name == "cube" and h < 2):
            break
        direction = direction.reshape(h // 2, 2, w // 2, 2, 3).sum(axis=(1, 3))
        flux = flux.reshape(h // 2, 2, w // 2, 2, 3).sum(axis=(1, 3))
        index = np.arange((h // 2) * (w // 2)).reshape(h // 2, w // 2)
        size *= 2
    out = []
    for k, (size, shape, unit, level_flux, _) in enumerate(levels):
        children = None
        if k == 0:  # a texel lies within the half-diagonal of a square of its solid angle
            radius = np.sqrt(omega.reshape(-1))
        else:
            h, w = shape
            below = levels[k - 1][4]
            children = below.reshape(h, 2, w, 2).transpose(0, 2, 1, 3).reshape(-1, 4)
            lower = out[k - 1]
            cosine = np.einsum("bj,bkj->bk", unit, lower.directions[children])
            radius = np.max(np.arccos(np.clip(cosine, -1.0, 1.0)) + lower.radius[children],
                            axis=1)
        out.append(_Level(size, shape, unit, level_flux, level_flux @ LUMINANCE, children,
                          np.minimum(radius, np.pi)))
    return out


def _seeds(model, frames, wo_local, count):
    """(P, S, 3) world directions every pixel's lobe certainly covers: the mirror
    direction and ``count`` importance samples of the BRDF."""
    u = hammersley(count, shift=(0.37, 0.61)) if count else np.zeros((0, 2))
    seeds = [np.stack([-wo_local[:, 0], -wo_local[:, 1], wo_local[:, 2]], axis=1)[:, None]]
    if count:
        wo = np.broadcast_to(wo_local[:, None, :], (len(wo_local), count, 3))
        wi, _ = model.sample(wo, np.broadcast_to(u, (len(wo_local), count, 2)))
        seeds.append(np.nan_to_num(np.asarray(wi, dtype=np.float64)))
    local = np.concatenate(seeds, axis=1)
    world = np.einsum("pji,psj->psi", frames, local)
    return world / np.maximum(np.linalg.norm(world, axis=-1, keepdims=True), 1e-300)


#: Median |x| of a unit normal variable over the median radius of a 2D one:
#: turns the median spread along the narrow axis into a median-angle width.
_NARROW_TO_MEDIAN = np.sqrt(2.0 * np.log(2.0)) / 0.6745


def _lobe_widths(seeds, narrow_axis=True):
    """(P,) how wide each pixel's lobe is, as far as its own sampler tells: the
    median angle of its importance samples from the mirror direction, or, for a
    lobe much narrower one way than the other (Cycles' anisotropy 0.8 at
    roughness 0.3 is 25 times narrower across than along), the median spread
    across its narrow axis scaled to the median angle an isotropic lobe of that
    spread would have, whichever is smaller. The narrow axis is the minor
    principal axis of the samples within the median angle (robust to a heavy
    tail); isotropic lobes keep the median angle (axes within a factor 2).
    ``narrow_axis=False``: the median angle alone (how far the lobe reaches)."""
    if seeds.shape[1] < 2:
        return np.full(len(seeds), np.pi)
    mirror = seeds[:, 0]
    cosine = np.einsum("psj,pj->ps", seeds[:, 1:], mirror)
    angle = np.arccos(np.clip(cosine, -1.0, 1.0))
    median = np.median(angle, axis=1)
    if seeds.shape[1] < 5 or not narrow_axis:
        return median
    offsets = seeds[:, 1:] - cosine[..., None] * mirror[:, None]  # tangent-plane offsets
    core = (angle <= median[:, None])[..., None]
    centred = np.where(core, offsets, 0.0)
    covariance = np.einsum("psi,psj->pij", centred, centred) / \
        np.maximum(core.sum(axis=1), 1)[:, :, None]
    values, vectors = np.linalg.eigh(covariance)  # ascending; one ~0 along the mirror
    major, middle = values[:, 2], values[:, 1]
    minor_axis = vectors[:, :, 1]
    across = np.abs(np.einsum("psj,pj->ps", offsets, minor_axis))
    with np.errstate(all="ignore"):
        narrow = np.nanmedian(np.where(core[..., 0], across, np.nan), axis=1) * _NARROW_TO_MEDIAN
    elongated = major > 4.0 * np.maximum(middle, 1e-300)
    return np.where(elongated & np.isfinite(narrow), np.minimum(median, narrow), median)


def _forced(model, level, pixel, block, seeds, widths, frames, wo_local, budget):
    """Pairs refined whatever their error estimate.

    Blocks that straddle the pixel's horizon (the integrand's kink: its
    midpoints may all fall below it while texels above hold light) unless they
    cannot matter: f at half the block's radius above the horizon, times twice
    sin(radius) for the cosine, times the block's flux, within the budget. And,
    where the lobe is narrower than twice the block's radius (its midpoints
    could fall either side of it), blocks within twice their radius of a seed.
    """
    radius = level.radius[block]
    sine = np.sin(np.minimum(radius, np.pi / 2))
    direction = level.directions[block]
    normal = frames[pixel, 2]
    height = np.sum(direction * normal, axis=1)
    forced = np.abs(height) < sine
    if forced.any():
        p, r = pixel[forced], radius[forced]
        along = direction[forced] - height[forced, None] * normal[forced]
        along /= np.maximum(np.linalg.norm(along, axis=1, keepdims=True), 1e-300)
        lift = np.minimum(0.5 * r, np.pi / 4)[:, None]
        above = along * np.cos(lift) + normal[forced] * np.sin(lift)
        local = np.einsum("mij,mj->mi", frames[p], above)
        f_near = model.f(local, wo_local[p]) @ LUMINANCE
        bound = 2.0 * f_near * sine[forced] * np.abs(level.flux_y[block[forced]])
        forced[forced] = bound > budget[p]
    narrow = radius > 0.5 * widths[pixel]
    if narrow.any():
        closest = np.max(np.einsum("msj,mj->ms", seeds[pixel[narrow]], direction[narrow]), axis=1)
        forced[narrow] |= closest > np.cos(np.minimum(2.0 * radius[narrow], np.pi))
    return forced


def _core_seeds(seeds, widths):
    """(P, S', 3): the mirror direction and the samples within ``widths`` (the
    lobe's median angle) of it (the tail's samples fall where the lobe is broad and smooth);
    the others are replaced by the mirror direction."""
    cosine = np.einsum("psj,pj->ps", seeds, seeds[:, 0])
    core = cosine >= np.cos(widths)[:, None]
    return np.where(core[..., None], seeds, seeds[:, :1])


def _evaluate(model, frames, wo_local, directions, flux, pixel):
    """Integrand x flux at child blocks, for pairs with pixels ``pixel`` (M,), child
    directions (M, K, 3) and flux (M, K, 3): returns (sum over K (M, 3), each (M, K, 3))."""
    frame = frames[pixel]
    wi = np.empty(directions.shape)
    for i in range(3):  # (M, K) products: far faster than a batched 3x3 einsum
        wi[..., i] = (frame[:, None, i, 0] * directions[..., 0]
                      + frame[:, None, i, 1] * directions[..., 1]
                      + frame[:, None, i, 2] * directions[..., 2])
    values = model.f(wi, wo_local[pixel][:, None, :])  # view terms once per pair
    values *= np.maximum(wi[..., 2:3], 0.0)
    values *= flux
    return values.sum(axis=1), values


def reconstruction_factor(model, probe_shape, layout, normals, views, *, tangents=None,
                          tangent_hint=(0.3, 0.5, 0.8)):
    """(factor, reason): how many times finer than the probe (per side) the bilinear
    reconstruction must be sampled for the texel sum over it to converge.

    The lobe width is the narrow-axis width :func:`_lobe_widths` gives (from the
    BRDF's own importance samples), its WIDTH_PERCENTILE percentile over up to
    WIDTH_PIXELS of the pixels; the texel angle is the square root of the
    probe's largest texel solid angle (a cube face's centre, a lat-long's
    equator); the factor is the least power of two at least texel /
    (SUBTEXEL_SPACING x width), at least 1, at most the largest power of two
    that keeps the finer grid within MAX_RECONSTRUCTION_TEXELS (the reason then
    says so). Powers of two keep the texel pyramid as deep as the probe's own
    (its blocks halve down to the same top level). probe_shape: (H, W) of the
    probe in ``layout``.
    """
    layout = get_layout(layout)
    normals, views, tangents = pixel_arrays(normals, views, tangents)
    if not len(normals):
        return 1, "no pixels"
    stride = max(1, len(normals) // WIDTH_PIXELS)
    frames = _frames(normals[::stride], None if tangents is None else tangents[::stride],
                     tangent_hint)
    wo_local = np.einsum("pij,pj->pi", frames, views[::stride])
    widths = _lobe_widths(_seeds(model, frames, wo_local, SEED_SAMPLES))
    width = float(np.percentile(widths, WIDTH_PERCENTILE))
    texel = float(np.sqrt(layout.solid_angles(tuple(probe_shape[:2])).max()))
    needed = texel / (SUBTEXEL_SPACING * max(width, 1e-9))
    wanted = 1 << max(0, int(np.ceil(np.log2(max(needed, 1.0)) - 1e-9)))
    texels = float(probe_shape[0] * probe_shape[1])
    allowed = 1 << max(0, int(np.floor(0.5 * np.log2(max(MAX_RECONSTRUCTION_TEXELS / texels,
                                                          1.0)))))
    factor = min(wanted, allowed, MAX_FACTOR)
    reason = (f"lobe {np.degrees(width):.3g} deg (median over the pixels) against "
              f"{np.degrees(texel):.3g} deg texels")
    if factor < min(wanted, MAX_FACTOR):
        reason += f"; {wanted}x wanted, {factor}x within the memory bound"
    elif factor < wanted:
        reason += (f"; {wanted}x wanted, {factor}x and the narrower lobes' cores "
                   f"integrated by their own samples")
    return factor, reason


def _bilinear_grid(probe, layout, factor):
    """The probe's bilinear reconstruction at its texel layout ``factor`` times finer
    per side (the layout's size scaled), as float32 (H', W', 3)."""
    from .envmap import convert

    size = layout.size_of(probe.shape[:2])
    return convert(np.asarray(probe[..., :3], dtype=np.float32), layout, layout,
                   size * factor, samples=1)


def render_steps(model, probe, layout, normals, views, *, tangents=None,
                 tangent_hint=(0.3, 0.5, 0.8), tolerance=None, chunk=512, threads=None,
                 reconstruction="texels"):
    """:func:`render` as a generator: yields (fraction, message) after each chunk of
    pixels and returns the (N, 3) radiance. Chunks run on ``threads`` worker
    threads (default: two, or one on a single core; NumPy releases the GIL in
    the array work), at most one chunk ahead per thread; closing the generator
    (Esc) cancels the chunks not started and waits only for those running.
    ``reconstruction``: ``texels`` (the sum over texel centres, :func:`reflected_radiance`'s)
    or ``bilinear`` (the sum over the probe's bilinear reconstruction at
    :func:`reconstruction_factor` times its resolution; the first message says
    which factor and why)."""
    layout = get_layout(layout)
    probe = np.asarray(probe)
    normals, views, tangents = pixel_arrays(normals, views, tangents)
    tolerance = DEFAULT_TOLERANCE if tolerance is None else float(tolerance)
    if reconstruction not in RECONSTRUCTIONS:
        raise ValueError(f"reconstruction must be one of {', '.join(RECONSTRUCTIONS)}, "
                         f"not {reconstruction!r}")
    core = None
    if reconstruction == "bilinear":
        factor, why = reconstruction_factor(model, probe.shape, layout, normals, views,
                                            tangents=tangents, tangent_hint=tangent_hint)
        sampler = layout.sampler(np.asarray(probe[..., :3], dtype=np.float32))
        if factor > 1:
            probe = _bilinear_grid(probe, layout, factor)
        core = _Core(sampler, probe.shape[:2],
                     float(np.sqrt(layout.solid_angles(tuple(probe.shape[:2])).max())))
        yield 0.0, f"reference: the probe's bilinear reconstruction at {factor}x ({why})"
    levels = _pyramid(probe, layout)
    out = np.zeros((len(normals), 3))
    threads = threads or min(2, os.cpu_count() or 1)
    # A chunk starts with every (pixel, top block) pair: bound their number (a
    # probe face with a large odd factor, e.g. 328 = 8 x 41, stops its pyramid at
    # 8-texel blocks, 10086 of them).
    chunk = max(1, min(int(chunk), TOP_PAIRS // max(len(levels[-1].directions), 1)))

    def job(start):
        stop = min(start + chunk, len(normals))
        frames = _frames(normals[start:stop], None if tangents is None
                         else tangents[start:stop], tangent_hint)
        wo_local = np.einsum("pij,pj->pi", frames, views[start:stop])
        mirror, radius = _core_radii(model, frames, wo_local, core)
        value = _render_chunk(model, layout, probe.shape[:2], levels, frames, wo_local,
                              tolerance, mirror, radius)
        narrow = radius > 0.0
        if narrow.any():
            value[narrow] += _core_quadrature(model, layout, core, frames[narrow],
                                              wo_local[narrow], mirror[narrow], radius[narrow])
        return stop, value

    starts = list(range(0, len(normals), chunk))
    pool = ThreadPoolExecutor(max_workers=threads)
    try:
        pending = deque(pool.submit(job, start) for start in starts[:2 * threads])
        submitted = len(pending)
        for start in starts:
            stop, value = pending.popleft().result()
            out[start:stop] = value
            if submitted < len(starts):
                pending.append(pool.submit(job, starts[submitted]))
                submitted += 1
            yield stop / len(normals), f"reference: {stop} of {len(normals)} pixels"
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
    return out


@dataclass
class _Core:
    """What a narrow lobe's core quadrature needs: the probe's bilinear lookup
    (directions (..., 3) -> (..., 3)), the shape (H, W) of the grid summed
    elsewhere (whose cells split the sphere), and that grid's largest texel angle
    (rad), its step."""

    sampler: object
    grid_shape: tuple
    step: float


def _core_radii(model, frames, wo_local, core):
    """(mirror (P, 3) world directions, inner core radius (P,) rad): 0 (no core) for
    pixels whose lobe the grid resolves, or when ``core`` is None."""
    seeds = _seeds(model, frames, wo_local, SEED_SAMPLES)
    mirror = seeds[:, 0]
    radius = np.zeros(len(frames))
    if core is not None:
        # The median angle of the samples, or twice their 20th percentile where that
        # is less: a narrow lobe mixed with a wide one (a dielectric's specular
        # and diffuse parts) then counts as narrow. For GGX the two agree.
        angle = np.arccos(np.clip(np.einsum("psj,pj->ps", seeds[:, 1:], mirror), -1.0, 1.0))
        reach = np.minimum(np.median(angle, axis=1), 2.0 * np.percentile(angle, 20.0, axis=1))
        narrow = reach < CORE_STEPS * core.step
        radius[narrow] = np.minimum(np.maximum(CORE_STEPS * core.step, 2.0 * reach[narrow]),
                                    0.5 * np.pi)
    return mirror, radius


def _core_share(directions, mirror, radius):
    """(..., K) the core's share of cells centred at directions (..., K, 3), for pixels
    with mirror directions (..., 3) and inner core radii (...,): 1 within the
    radius, falling linearly with the angle to 0 at twice it (0 where the radius
    is 0). The grid sums each cell times one minus its share, the core's samples
    weigh it by its share: the two add up to every cell once, and the taper keeps
    the samples' integrand free of a jump at the core's edge."""
    cosine = np.einsum("...kj,...j->...k", directions, mirror)
    angle = np.arccos(np.clip(cosine, -1.0, 1.0))
    radius = radius[..., None]
    with np.errstate(all="ignore"):
        share = np.clip(2.0 - angle / radius, 0.0, 1.0)
    return np.where(radius > 0.0, share, 0.0)


def _core_quadrature(model, layout, core, frames, wo_local, mirror, radius):
    """(P, 3) integral of the probe's bilinear reconstruction x f cos over each
    pixel's core (each grid cell weighted by its :func:`_core_share`).

    Two sets of Hammersley points: CORE_SAMPLES through the BRDF's sampler (they
    follow the narrow lobe) and CORE_SAMPLES / 2 uniform over the core's cap,
    out to twice its inner radius (they cover what else lies in the core: a
    diffuse part, the lobe's tail over a lamp), combined by the balance
    heuristic: each sample's f cos, share and radiance over the two counts'
    densities summed."""
    step = max(1, BATCH // CORE_SAMPLES)
    if len(frames) > step:  # bounded memory: a batch of pixels at a time
        return np.concatenate([
            _core_quadrature(model, layout, core, frames[i:i + step], wo_local[i:i + step],
                             mirror[i:i + step], radius[i:i + step])
            for i in range(0, len(frames), step)])
    lobe_count, cap_count = CORE_SAMPLES, CORE_SAMPLES // 2
    shape = (len(frames), lobe_count)
    wo = np.broadcast_to(wo_local[:, None, :], (*shape, 3))
    with np.errstate(all="ignore"):
        wi, _ = model.sample(wo, np.broadcast_to(hammersley(lobe_count, shift=(0.21, 0.47)),
                                                 (*shape, 2)))
    lobe = np.einsum("pji,psj->psi", frames, np.nan_to_num(np.asarray(wi, dtype=np.float64)))
    # Uniform over the cap of angle 2 x radius about the mirror direction.
    cap_angle = np.minimum(2.0 * radius, np.pi)
    u = hammersley(cap_count, shift=(0.63, 0.29))
    cos_t = 1.0 - u[None, :, 0] * (1.0 - np.cos(cap_angle))[:, None]
    sin_t = np.sqrt(np.maximum(1.0 - cos_t ** 2, 0.0))
    phi = 2.0 * np.pi * u[None, :, 1]
    hint = np.where(np.abs(mirror[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    x = np.cross(hint, mirror)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(mirror, x)
    cap = (sin_t[..., None] * (np.cos(phi)[..., None] * x[:, None] + np.sin(phi)[..., None]
                               * y[:, None]) + cos_t[..., None] * mirror[:, None])
    world = np.concatenate([lobe, cap], axis=1)
    world /= np.maximum(np.linalg.norm(world, axis=-1, keepdims=True), 1e-300)
    local = np.einsum("pij,psj->psi", frames, world)
    cosine = np.einsum("psj,pj->ps", world, mirror)
    inside_cap = cosine >= np.cos(cap_angle)[:, None] - 1e-12
    row, col = layout.direction_to_texel(world, core.grid_shape)
    share = _core_share(layout.directions(col + 0.5, row + 0.5, core.grid_shape), mirror, radius)
    # Only samples in the core and above the surface add anything: the BRDF, its
    # density and the probe are evaluated at those alone (a mixture's wide part
    # sends most of its samples outside a narrow part's core).
    pixel, sample = np.nonzero((share > 0.0) & (local[..., 2] > 0.0))
    local, world = local[pixel, sample], world[pixel, sample]
    wo = wo_local[pixel]
    with np.errstate(all="ignore"):
        pdf_lobe = np.nan_to_num(np.asarray(model.pdf(local, wo), dtype=np.float64))
    pdf_cap = np.where(inside_cap[pixel, sample],
                       1.0 / (2.0 * np.pi * (1.0 - np.cos(cap_angle)))[pixel], 0.0)
    density = lobe_count * pdf_lobe + cap_count * pdf_cap
    keep = density > 0.0
    weight = share[pixel, sample] * local[:, 2] / np.where(keep, density, 1.0)
    value = model.f(local, wo) * weight[:, None]
    value *= np.asarray(core.sampler(world), dtype=np.float64)
    value = np.where(keep[:, None], value, 0.0)
    return np.stack([np.bincount(pixel, weights=value[:, c], minlength=len(frames))
                     for c in range(3)], axis=1)


def _render_chunk(model, layout, image_shape, levels, frames, wo_local, tolerance,
                  mirror=None, core_radius=None):
    """(P, 3) the adaptive texel sum for a chunk of pixels, each grid cell weighted by
    one minus its :func:`_core_share` (``core_radius`` 0 or None: no core)."""
    count = len(frames)
    if core_radius is None:
        mirror, core_radius = np.zeros((count, 3)), np.zeros(count)
    if len(levels) == 1:  # no pyramid (odd sizes): every texel, vectorized
        texels = levels[0]
        total = np.zeros((count, 3))
        step = max(1, BATCH // len(texels.directions))
        for start in range(0, count, step):
            pixel = np.arange(start, min(start + step, count))
            directions = np.broadcast_to(texels.directions, (len(pixel), *texels.directions.shape))
            flux = np.broadcast_to(texels.flux, directions.shape)
            _, values = _evaluate(model, frames, wo_local, directions, flux, pixel)
            share = _core_share(directions, mirror[pixel], core_radius[pixel])
            total[pixel] = np.sum(values * (1.0 - share)[..., None], axis=1)
        return total
    seeds = _seeds(model, frames, wo_local, SEED_SAMPLES)
    widths = _lobe_widths(seeds)
    seeds = _core_seeds(seeds, _lobe_widths(seeds, narrow_axis=False))
    top = levels[-1]
    blocks = len(top.directions)
    pixel = np.repeat(np.arange(count), blocks)
    block = np.tile(np.arange(blocks), count)
    # The top blocks' own midpoint values: the coarse estimate every pixel's error
    # budget is relative to, and the first level's coarse term.
    coarse = np.empty((len(pixel), 3))
    step = BATCH
    for start in range(0, len(pixel), step):
        part = slice(start, start + step)
        coarse[part] = _evaluate(model, frames, wo_local, top.directions[block[part]][:, None],
                                 top.flux[block[part]][:, None], pixel[part])[0]
    estimate = np.abs(_sum_by_pixel(pixel, coarse @ LUMINANCE, count))
    budget = tolerance * np.maximum(estimate, 1e-300)
    total = np.zeros((count, 3))
    for k in range(len(levels) - 1, 0, -1):
        level, below = levels[k], levels[k - 1]
        children = level.children[block]
        fine = np.empty((len(pixel), 3))
        values = np.empty((len(pixel), 4, 3))
        step = BATCH // 4
        for start in range(0, len(pixel), step):
            part = slice(start, start + step)
            fine[part], values[part] = _evaluate(
                model, frames, wo_local, below.directions[children[part]],
                below.flux[children[part]], pixel[part])
        if k == 1:  # the children are texels: their sum is exact (less any core's)
            cored = core_radius[pixel] > 0.0
            if cored.any():
                share = _core_share(below.directions[children[cored]], mirror[pixel[cored]],
                                    core_radius[pixel[cored]])
                fine[cored] = np.sum(values[cored] * (1.0 - share)[..., None], axis=1)
            total += _sum_rgb(pixel, fine, count)
            break
        # Richardson: the midpoint rule is second order, so the children's sum is off
        # by about a third of its difference from the block's own midpoint value.
        error = np.abs((fine - coarse) @ LUMINANCE) / 3.0
        refine = (error > budget[pixel]) | _forced(model, level, pixel, block, seeds, widths,
                                                   frames, wo_local, budget)
        # Blocks reaching into a pixel's core (out to twice its inner radius) go
        # down to its cells, to be weighted.
        reach = np.minimum(2.0 * core_radius[pixel] + level.radius[block], np.pi)
        refine |= (core_radius[pixel] > 0.0) & (
            np.einsum("mj,mj->m", level.directions[block], mirror[pixel]) > np.cos(reach))
        keep = ~refine  # Richardson-extrapolated: the leading error term cancels
        total += _sum_rgb(pixel[keep], fine[keep] + (fine[keep] - coarse[keep]) / 3.0, count)
        pixel = np.repeat(pixel[refine], 4)
        block = children[refine].reshape(-1)
        coarse = values[refine].reshape(-1, 3)
        if not len(pixel):
            break
    return total


def _sum_by_pixel(pixel, values, count):
    return np.bincount(pixel, weights=values, minlength=count)


def _sum_rgb(pixel, values, count):
    return np.stack([_sum_by_pixel(pixel, values[:, c], count) for c in range(3)], axis=1)


def render(model, probe, layout, normals, views, *, tangents=None, tangent_hint=(0.3, 0.5, 0.8),
           tolerance=None, chunk=512, progress=None, reconstruction="texels"):
    """(N, 3) reflected radiance of ``model`` lit by ``probe`` (H, W, 3 in ``layout``)
    for world-space unit normals and views (surface to viewer), (N, 3) each.

    Vectorized over ``chunk`` pixels at a time (memory stays bounded) and
    adaptive over the probe's texel pyramid (see the module docstring);
    ``tangents`` (N, 3) orient anisotropic BRDFs. ``progress(fraction, message)``
    is called after each chunk. ``reconstruction``: see :func:`render_steps`.
    """
    steps = render_steps(model, probe, layout, normals, views, tangents=tangents,
                         tangent_hint=tangent_hint, tolerance=tolerance, chunk=chunk,
                         reconstruction=reconstruction)
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            return done.value
        report(progress, fraction, message)


def _layer_key(layers, name):
    """The key of the layer whose last name part is ``name`` (case-insensitive):
    ``Normal``, ``ViewLayer.Normal`` or ``ViewLayer.Normal.XYZ``; None if absent."""
    for key in layers:
        parts = [p.lower() for p in key.split(".")]
        if parts and parts[-1] == name or len(parts) > 1 and parts[-2] == name \
                and parts[-1] in ("xyz", "rgb", "rgba"):
            return key
    return None


def has_layer(layers, name) -> bool:
    return _layer_key(layers, name) is not None or all(
        any(k.lower().endswith(f"{name}.{c}") for k in layers) for c in "xyz")


def vector_layer(layers, name, path="buffers"):
    """(H, W, 3) float64 of the layer ``name`` in ``exr.read(..., layers=True)``'s dict:
    one 3-channel layer, or three single channels ``<...>.<name>.X/Y/Z``."""
    from .errors import BakeError

    key = _layer_key(layers, name)
    if key is not None and layers[key].shape[-1] >= 3:
        return np.asarray(layers[key][..., :3], dtype=np.float64)
    channels = []
    for c in "xyz":
        match = [k for k in layers if k.lower().endswith(f"{name}.{c}")]
        if not match:
            raise BakeError(f"{path}: no '{name}' layer (layers: {', '.join(sorted(layers))})")
        channels.append(layers[match[0]][..., 0])
    return np.stack(channels, axis=-1).astype(np.float64)


def sphere_buffers(size, distance=6.0, lens=90.0, sensor=36.0):
    """Normals, views (H, W, 3) and mask (H, W) of a unit sphere at the origin seen by
    Blender's default perspective camera at (0, -distance, 0) looking along +Y (+Z up),
    focal length ``lens`` mm on a ``sensor`` mm wide sensor, ``size`` x ``size``
    pixels, rays through pixel centres (row 0 at the top)."""
    half = 0.5 * sensor / lens
    coords = (np.arange(size) + 0.5) / size * 2.0 - 1.0
    x = coords[None, :] * half
    z = -coords[:, None] * half
    rays = np.stack(np.broadcast_arrays(x, np.ones_like(x), z), axis=-1)
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    origin = np.array([0.0, -distance, 0.0])
    b = rays @ origin
    disc = b**2 - (origin @ origin - 1.0)
    mask = disc > 0
    t = -b - np.sqrt(np.where(mask, disc, 0.0))
    points = origin + t[..., None] * rays
    normals = points / np.maximum(np.linalg.norm(points, axis=-1, keepdims=True), 1e-300)
    normals[~mask] = (0.0, 0.0, 1.0)
    views = -rays
    return normals, views, mask
