"""How much detail a probe's content holds, whatever its resolution.

bake.resolution sizes a baked map from the lobe and from the probe's texels
(a lobe narrower than half a texel needs no more rows than the texels). A
probe's *content* may be far smoother than its texels: a constant world
colour, a sky gradient, a blurred or low-resolution world resampled to a
fine probe. Its filtered maps then hold no detail finer than that content,
and the rows a fine probe's texels would ask for are wasted (GGX 0.1 from a
6 x 128^2 probe of a constant world: 384 rows and about 1.5 s, where 16 rows
give the same map).

:func:`content_detail` finds the coarsest level of the probe's exact box MIP
pyramid (bake.probe_maps.ProbeMaps.levels, solid-angle weighted) whose
bilinear reconstruction at the probe's own texels stands for the probe:

    RMS over the sphere of |probe - reconstruction of level L|  <=  TOLERANCE * |mean of the probe|

(RGB vectors, each texel weighted by its solid angle). Bake rules then treat
the probe as a probe of that level's size (bake.resolution.choose_map_rows).

Why this bounds the map's extra error: write the probe P = B_L + D, B_L the
level's reconstruction. The baked map is K * P for a zonal kernel K of unit
integral and non-negative values; its Legendre coefficients satisfy
|lambda_l| <= lambda_0 = 1, so K * D has an RMS over the sphere of at most
RMS(D), and K * P keeps P's mean, so the map's own RMS is at least |mean P|.
Sampled at the rows chosen for B_L, the map differs from one sampled at the
probe's rows by the interpolation of K * D at most: a relative RMS of the
order of TOLERANCE (0.1%), under the map's other errors everywhere they were
measured (0.2-7% against the brute-force integral at Auto,
bake.resolution's module doc). Every bundled HDRI keeps its full
resolution (their detail fails the test at the first level already; a sun
or a lamp fails it by orders of magnitude), as does any probe rendered with
Monte Carlo noise: only content that is smooth at the texel scale moves the
rule (`benchmarks/resolution_curve.py --smooth` measures the maps).
"""

from dataclasses import dataclass

import numpy as np

from .envmap import convert, get_layout
from .envmap.convert import convert_texels

__all__ = ["TOLERANCE", "CONSTANT_SHAPES", "ContentDetail", "content_detail", "of_probe"]

#: Largest RMS difference, relative to the magnitude of the probe's mean colour,
#: between the probe and a coarser level's reconstruction that stands for it.
TOLERANCE = 1e-3


#: The shape a probe that is one colour stands for, beyond a pyramid that stopped
#: at an odd size: one texel per cube face, or a one-row lat-long.
CONSTANT_SHAPES = {"cube": (1, 6), "latlong": (1, 2)}


@dataclass(frozen=True)
class ContentDetail:
    """The coarsest pyramid level that stands for a probe (module doc).

    level: its index (0: the probe itself; len(levels) when the pyramid stopped
    at an odd size above one texel and the probe is its mean colour, of shape
    CONSTANT_SHAPES[layout]); shape: its (H, W) in the probe's layout; error:
    its RMS difference from the probe relative to the probe's mean (0.0 for
    level 0).
    """

    level: int
    shape: tuple
    error: float


def _rms_error(probe, reconstruction, weights, mean_norm):
    difference = np.asarray(reconstruction, np.float64) - probe
    squared = np.einsum("hwc,hwc->hw", difference, difference)
    return float(np.sqrt(np.sum(weights * squared))) / mean_norm


#: The pre-check reads every STRIDE-th row and column of the probe ...
STRIDE = 4
#: ... and gives up when level 1's error there is over PRECHECK times the tolerance
#: (keeping the probe's own detail, the conservative choice; an estimate under it
#: leads to the full test).
PRECHECK = 4.0


def _sampled_error(levels, layout, weights, mean_norm):
    """Level 1's relative RMS error (as :func:`content_detail` measures it) on every
    STRIDE-th row and column of the probe: 1/16 of its cost, for an early exit."""
    probe = levels[0]
    if mean_norm <= 0:
        return 0.0
    ys, xs = np.meshgrid(np.arange(STRIDE // 2, probe.shape[0], STRIDE),
                         np.arange(STRIDE // 2, probe.shape[1], STRIDE), indexing="ij")
    ys, xs = ys.ravel(), xs.ravel()
    values = convert_texels(levels[1], layout, layout, probe.shape[0], ys, xs, samples=1)
    difference = values.astype(np.float64) - probe[ys, xs]
    local = weights[ys, xs] / weights[ys, xs].sum()
    return float(np.sqrt(np.sum(local * np.einsum("nc,nc->n", difference, difference)))) \
        / mean_norm


def content_detail(levels, layout, tolerance=TOLERANCE) -> ContentDetail:
    """The :class:`ContentDetail` of a probe given as its box MIP pyramid.

    levels: [(H, W, 3) float32 images], level 0 the probe, each level half the
    last (bake.envmap.mip.pyramid with the box filter: cube strips or lat-long
    maps); layout: ``cube`` or ``latlong`` (any other: level 0). The error
    grows with the level (each is a box average of the one before), so level
    1 is tried first (a real HDRI fails there: one reconstruction), then the
    coarsest, then a bisection between the two.
    """
    shape = tuple(np.shape(levels[0])[:2])
    full = ContentDetail(0, shape, 0.0)
    if layout not in ("cube", "latlong") or len(levels) < 2:
        return full
    omega = get_layout(layout).solid_angles(shape)
    weights = omega / omega.sum()
    mean_norm = float(np.linalg.norm(np.einsum("hw,hwc->c", weights, levels[0])))
    errors = {}

    def passes(index):
        reconstruction = convert(levels[index], layout, layout, shape[0], samples=1)
        if mean_norm > 0:
            errors[index] = _rms_error(probe, reconstruction, weights, mean_norm)
        else:
            errors[index] = 0.0 if np.array_equal(reconstruction, probe) else np.inf
        return errors[index] <= tolerance

    coarsest = len(levels) - 1
    if _sampled_error(levels, layout, weights, mean_norm) > PRECHECK * tolerance:
        return full  # level 1 fails clearly on every STRIDE-th texel already
    probe = np.asarray(levels[0], dtype=np.float64)
    if not passes(1):
        return full
    if coarsest == 1 or passes(coarsest):
        best = coarsest
    else:
        best, failed = 1, coarsest  # best passes, failed does not
        while failed - best > 1:
            middle = (best + failed) // 2
            best, failed = (middle, failed) if passes(middle) else (best, middle)
    if best == coarsest and levels[best].shape[0] > 1:
        # The pyramid stopped at an odd size (a 200 px face: 25 px) and still stands
        # for the probe: is the probe its mean colour, one value per face?
        constant = _constant_error(probe, weights, mean_norm)
        if constant <= tolerance:
            return ContentDetail(len(levels), CONSTANT_SHAPES[layout], constant)
    return ContentDetail(best, tuple(levels[best].shape[:2]), errors[best])


def _constant_error(probe, weights, mean_norm):
    """:func:`content_detail`'s error of the probe's mean colour standing for it."""
    if mean_norm <= 0:
        return 0.0 if not np.any(probe) else np.inf
    mean = np.einsum("hw,hwc->c", weights, probe)
    return _rms_error(probe, np.broadcast_to(mean, probe.shape), weights, mean_norm)


def of_probe(image, layout) -> ContentDetail:
    """:func:`content_detail` of a probe image (H, W, 3) in ``layout``, measured once
    per probe content in a process (bake.probe_maps's shared pyramid and cache)."""
    from .probe_maps import probe_maps

    maps = probe_maps(image, layout)
    return maps.kept(("content", TOLERANCE), lambda: content_detail(maps.levels, maps.layout))
