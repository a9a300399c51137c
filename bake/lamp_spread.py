"""Lamps of any size in the separable lamp term: g factors averaged over caps.

The lamp term (glossy_addon.lamps, Kautz & McCool 1999) evaluates f at one
light direction l_c, the lamp's centre, times the irradiance E. A lamp of
angular radius alpha seen from the shading point (a point or spot lamp's
sphere or disc, a sun's half angle, a cell of an area lamp) lights the
surface over a cone of light directions instead, and the reflection is

    L_o = integral over the cone of f(wi, wo) L cos(theta_i) dwi
        ~ E cos(theta_c) sum_k s_k h_k(v_c) mean over the cone of g_k(u(wi)).

In the half-vector parameterizations (``half-difference``, ``gram-schmidt``:
u = h = normalize(wi + wo)) a cone of light directions of radius alpha
maps, for a fixed view, onto a region of half vectors of radii alpha / 2
(in the plane of wi and wo) and alpha / (2 cos theta_d) (across it; the
Jacobian dwh / dwi is 1 / (4 cos theta_d)), and the mean of g over the cone
is the mean of g over that region. It is taken as a cap of radius
rho = alpha / 2 around h_c (``spread_scale`` 1/2); in ``incident-view``
(u = wi) rho = alpha (``spread_scale`` 1). ``elevation-azimuth`` has no
direction map to average on: its factors get no levels and its lamps stay
points. The v factors h_k are smooth and stay at the centre's v_c.

Measured (``benchmarks/lamps.py --numpy``, a Principled metal at Roughness
0.3 on a sphere 3.9-4.7 m from the lamp, against bake.lamp_reference's
integral over the emitter, relative RMS of luminance): a point lamp of
radius 0.3 (alpha 4.3 degrees) 11.4% -> 5.4%, radius 0.8 62.6% -> 7.0%, a
15-degree sun 26.2% -> 4.1%; the ellipse's elongation taken as the
equal-area cap radius alpha / (2 sqrt(cos theta_d)) was worse (6.7%, 8.3%,
9.5%), so the cap stays round.

Levels: j = 1..L at cap radii rho_j = rho_1 2^((j - 1) / P), P =
PER_OCTAVE levels per octave, rho_1 two texels at the centre of the N x N
map (4 / N rad for ``xy``, 8 / N for ``parabolic``); level j is stored at
S_j = N / 2^floor((j - 1) / P) texels per side (rho_j spans 2 to 2.8 of
them) while S_j is a whole number >= MIN_LEVEL_SIZE and rho_j <= pi / 2;
level 0 is the factor itself (rho_0 = 0). Each level is the mean of the
factor over the part of each cap above the horizon (:func:`cap_means`).
Between levels a and b = a + 1 the cap *integral* is interpolated
linearly in the cap's solid angle A = 2 pi (1 - cos rho):

    mean(rho) = ((1 - t) A_a m_a + t A_b m_b) / A(rho),  t = (A - A_a) / (A_b - A_a),

exact both for features much smaller than both caps (the integral is then
constant) and much larger (the mean is then constant); below rho_1 the mean
is mixed linearly in A between level 0 and level 1. Radii beyond the last
level are taken at it.
"""

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .errors import BakeError

__all__ = ["SOURCE_TEXELS", "MIN_LEVEL_SIZE", "PER_OCTAVE", "MAX_AREA_CELLS", "Levels",
           "blur_levels", "first_radius", "level_side", "level_radius", "level_count",
           "level_weights", "level_layout", "spread_scale", "area_cells", "cap_means",
           "texel_solid_angles"]

#: Source texels per level texel along each side: a level is gathered from
#: the factor box-reduced to SOURCE_TEXELS S_j (or the factor itself, when
#: smaller). Measured at GGX 0.15 (256^2 factors) against the cap mean of the
#: factor's own reconstruction by 8192 points, around the peak: 8 keeps every
#: level whose cap stays within 80 degrees of the pole within 0.8% of the
#: peak (4: up to 5.7%). Near the rim an xy map's texels stretch (dw = dX dY
#: / z) and caps reaching there are 4% off: lamps wider than 80 degrees.
SOURCE_TEXELS = 8
#: Cap levels per octave of radius (measured: GGX 0.15 under a 5-degree sun,
#: 1 per octave 12.2% from the emitter's integral, the exact cap 3.7%).
PER_OCTAVE = 2
#: The smallest level, in texels per side.
MIN_LEVEL_SIZE = 4
#: Output texels per level (gathered) from which cap_means sums offset by offset
#: over strided views; fewer: many offsets at once by fancy indexing.
SLICED_OUTPUTS = 64 * 64
#: The largest number of cells an area lamp is split into.
MAX_AREA_CELLS = 8


def spread_scale(parameterization):
    """The cap radius of g per radian of the lamp's angular radius, or 0 where the
    parameterization has no direction map for g (``elevation-azimuth``)."""
    if parameterization in ("half-difference", "gram-schmidt"):
        return 0.5
    if parameterization == "incident-view":
        return 1.0
    return 0.0


def first_radius(size, kind="xy"):
    """rho_1 (rad): two texels at the centre of a size x size hemisphere map."""
    return (4.0 if kind == "xy" else 8.0) / size


def level_side(size, level, per_octave=PER_OCTAVE):
    """S_j: texels per side of level j >= 1 (size / 2^floor((j - 1) / per_octave))."""
    return size // 2 ** ((level - 1) // per_octave)


def level_radius(first, level, per_octave=PER_OCTAVE):
    """rho_j (rad) of level j >= 1."""
    return first * 2.0 ** ((level - 1) / per_octave)


def level_count(size, kind="xy", per_octave=PER_OCTAVE):
    """L: the number of cap levels for an N x N map: while S_j is a whole number
    >= MIN_LEVEL_SIZE and rho_j <= pi / 2."""
    first, count = first_radius(size, kind), 0
    while True:
        j = count + 1
        q = (j - 1) // per_octave
        if size % 2 ** q or size // 2 ** q < MIN_LEVEL_SIZE or \
                level_radius(first, j, per_octave) > math.pi / 2:
            return count
        count = j


def level_layout(size, terms, level, term, per_octave=PER_OCTAVE):
    """(side, column, row) of a term's tile of one level in the lamp atlas's g
    bands: level 0 is the factor's own band (row 0), levels >= 1 lie side by
    side in the second band (row size + 2), each level's terms together. With
    j - 1 = q P + r (P levels per octave) the closed forms the material's nodes
    compute (glossy_addon.lamps) are side = N / 2^q and column = terms (P (N
    (2 - 2^(1 - q)) + 2 q) + r (side + 2)) + term (side + 2)."""
    if level == 0:
        return size, term * (size + 2), 0
    q, r = divmod(level - 1, per_octave)
    side = size // 2 ** q
    column = terms * (per_octave * (size * (2.0 - 2.0 ** (1 - q)) + 2 * q) + r * (side + 2)) \
        + term * (side + 2)
    return side, int(round(column)), size + 2


class Levels:
    """The cap levels of a factorization's g factors.

    ``radii``: (L,) rho_1..rho_L (rad); ``maps``: list of L arrays (K, S_j,
    S_j, 3) float32 (same normalisation as Factorization.g); ``scale``: the
    spread scale (:func:`spread_scale`)."""

    def __init__(self, radii, maps, scale, per_octave=PER_OCTAVE):
        self.radii, self.maps, self.scale = np.asarray(radii, np.float64), list(maps), scale
        self.per_octave = per_octave

    @property
    def count(self):
        return len(self.maps)


def _box_reduce(texture, factor):
    """Mean over factor x factor blocks of (n, n, C)."""
    if factor == 1:
        return texture
    n = texture.shape[0]
    return texture.reshape(n // factor, factor, n // factor, factor, -1).mean(axis=(1, 3))


def texel_solid_angles(size, kind="xy"):
    """(size, size) solid angle (sr) of each texel of a hemisphere map; 0 for
    texels whose centre lies outside the unit disc (they repeat the rim)."""
    from .separable import _texel_centres

    x = _texel_centres(size)[None, :].repeat(size, 0)
    y = -_texel_centres(size)[:, None].repeat(size, 1)
    r2 = x * x + y * y
    if kind == "xy":  # dw = dX dY / z, z held at half the rim texel's
        z = np.sqrt(np.maximum(1.0 - r2, 0.0))
        jacobian = 1.0 / np.maximum(z, 0.5 * math.sqrt(2.0 / size))
    else:  # parabolic: dw = 4 dX dY / (1 + X^2 + Y^2)^2
        jacobian = 4.0 / (1.0 + r2) ** 2
    return np.where(r2 < 1.0, (2.0 / size) ** 2 * jacobian, 0.0)


def cap_means(source, kind, side, rho, symmetry=None):
    """(side, side, C): the mean of ``source`` (n, n, C), a hemisphere map, over
    the part above the horizon of a cap of radius ``rho`` (rad) around each
    texel centre of a side x side map of the same kind (n a multiple of side).
    ``symmetry`` (:func:`map_symmetry`), which the means share with the source:
    "mirror" (the source equals its mirror images across both axes: an
    isotropic BRDF's g, bake.separable) gathers the top-left quadrant, a
    quarter of the work, and mirrors it; "half-turn" (it equals itself turned
    by 180 degrees about the centre: an anisotropic elliptical lobe's g) gathers
    the top half and turns it; None gathers every texel.

    A sum over the source's texels weighed by their solid angle and by how much
    of each the cap covers (a ramp one texel wide across the cap's edge, in
    cos gamma / sin rho), gathered offset by offset over the source texels
    around each output texel: no sampling pattern to alias with a narrow peak."""
    from .separable import hemisphere_directions

    n = source.shape[0]
    step = n // side
    directions = hemisphere_directions(n, kind).astype(np.float32)
    weights = texel_solid_angles(n, kind).astype(np.float32)
    centres = hemisphere_directions(side, kind).astype(np.float32)
    if symmetry not in (None, "mirror", "half-turn"):
        raise ValueError(f"unknown symmetry {symmetry!r}")
    half = (side + 1) // 2
    gathered = half if symmetry else side  # output rows gathered
    across = half if symmetry == "mirror" else side  # and columns
    centres = centres[:gathered, :across]
    reach = int(math.ceil(rho * n / 2.0)) + 1  # the map never stretches an angle
    pad = reach + step

    def padded(array):
        return np.pad(array, ((pad, pad), (pad, pad)) + ((0, 0),) * (array.ndim - 2))

    directions, weights, values = padded(directions), padded(weights), padded(
        source.astype(np.float32))
    slope = 1.0 / (math.sin(rho) * np.sqrt(np.maximum(weights, 1e-30)))
    total = np.zeros((gathered, across, source.shape[-1]), np.float32)
    covered = np.zeros((gathered, across), np.float32)
    cos_rho, middle, limit = math.cos(rho), (step - 1) / 2.0, (reach + step) ** 2
    a, b = np.meshgrid(np.arange(-reach, reach + step), np.arange(-reach, reach + step),
                       indexing="ij")
    near = (a - middle) ** 2 + (b - middle) ** 2 <= limit
    a, b = a[near], b[near]  # source offsets from each output texel's first source texel
    if gathered * across >= SLICED_OUTPUTS:
        for a_, b_ in zip(a.tolist(), b.tolist(), strict=True):  # strided views, one offset
            rows = slice(pad + a_, pad + a_ + step * gathered, step)
            cols = slice(pad + b_, pad + b_ + step * across, step)
            cos_gamma = np.einsum("ijk,ijk->ij", directions[rows, cols], centres)
            weight = np.clip((cos_gamma - cos_rho) * slope[rows, cols] + 0.5, 0.0, 1.0) * \
                weights[rows, cols]
            total += weight[..., None] * values[rows, cols]
            covered += weight
    else:  # small levels: their caps span thousands of offsets; NumPy's loops, not Python's
        batch = max(1, (1 << 20) // (gathered * across * (source.shape[-1] + 4)))
        for start in range(0, len(a), batch):
            rows = pad + a[start:start + batch, None] + step * np.arange(gathered)
            cols = pad + b[start:start + batch, None] + step * np.arange(across)
            rows, cols = rows[:, :, None], cols[:, None, :]  # (B, gathered, 1), (B, 1, across)
            cos_gamma = np.einsum("oijk,ijk->oij", directions[rows, cols], centres)
            weight = np.clip((cos_gamma - cos_rho) * slope[rows, cols] + 0.5, 0.0, 1.0) * \
                weights[rows, cols]
            total += np.einsum("oij,oijc->ijc", weight, values[rows, cols])
            covered += weight.sum(axis=0)
    means = total / np.maximum(covered, 1e-30)[..., None]
    if symmetry is None:
        return means
    out = np.empty((side, side) + means.shape[2:], means.dtype)
    if symmetry == "mirror":
        out[:half, :half] = means
        out[:half, side - half:] = means[:, ::-1]
        out[side - half:] = out[:half][::-1]
    else:
        out[:half] = means
        out[side - half:] = means[::-1, ::-1]
    return out


def map_symmetry(source):
    """The symmetry of a hemisphere map (n, n, C) that :func:`cap_means` can use:
    "mirror" if it equals its mirror images across both axes exactly,
    "half-turn" if it equals itself turned by 180 degrees, else None."""
    source = np.asarray(source)
    if np.array_equal(source, source[::-1]) and np.array_equal(source, source[:, ::-1]):
        return "mirror"
    if np.array_equal(source, source[::-1, ::-1]):
        return "half-turn"
    return None


def blur_levels(factorization, per_octave=PER_OCTAVE, progress=None) -> Levels:
    """The cap levels of ``factorization``'s g factors (see the module's docstring);
    none for ``elevation-azimuth``. progress(fraction, message) per level."""
    f = factorization
    scale = spread_scale(f.parameterization)
    if scale == 0.0:
        return Levels([], [], 0.0, per_octave)
    n, terms = f.size, f.terms
    stacked = np.concatenate(list(f.g), axis=-1).astype(np.float64)  # (n, n, 3K)
    symmetry = map_symmetry(stacked)  # so is every level's (box reduction keeps it)
    count = level_count(n, f.kind, per_octave)
    first = first_radius(n, f.kind)
    radii = [level_radius(first, j, per_octave) for j in range(1, count + 1)]

    def level(j):
        side = level_side(n, j, per_octave)
        source = _box_reduce(stacked, max(1, n // (SOURCE_TEXELS * side)))
        means = cap_means(source, f.kind, side, radii[j - 1], symmetry)
        means = means.reshape(side, side, terms, 3)
        return np.ascontiguousarray(np.moveaxis(means, 2, 0)).astype(np.float32)

    # The levels are independent: one per core (NumPy releases the GIL in its loops).
    maps = []
    with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        for j, result in enumerate(pool.map(level, range(1, count + 1)), 1):
            maps.append(result)
            if progress is not None:
                progress(j / count, f"lamp factors: cap level {j} of {count}")
    return Levels(radii, maps, scale, per_octave)


def _cap_area(rho):
    """1 - cos(rho) as 2 sin^2(rho / 2) (the nodes' form: no cancellation in float32)."""
    return 2.0 * np.sin(0.5 * np.asarray(rho, np.float64)) ** 2


def level_weights(spread, first, count, per_octave=PER_OCTAVE):
    """(level_a, level_b, weight_a, weight_b) arrays for cap radii ``spread`` (rad,
    any shape): the g value is weight_a m_a + weight_b m_b (the module's
    interpolation). ``first``: rho_1; ``count``: L >= 1. Exactly the arithmetic
    of the material's ``Glossy Spread Level`` node group."""
    spread = np.asarray(spread, np.float64)
    last = level_radius(first, count, per_octave)
    rho = np.clip(spread, 0.0, last)
    area = _cap_area(rho)
    area_1 = _cap_area(first)
    small = rho < first
    # rho_1 <= rho: a = clamp(floor(P log2(rho / rho_1)) + 1, 1, L - 1), b = a + 1
    step = np.floor(per_octave * np.log2(np.maximum(rho, first) / first)) + 1.0
    a = np.clip(step, 1.0, max(count - 1, 1))
    b = np.minimum(a + 1.0, count)
    area_a = _cap_area(first * 2.0 ** ((a - 1) / per_octave))
    area_b = _cap_area(first * 2.0 ** ((b - 1) / per_octave))
    t = np.where(b > a, (area - area_a) / np.maximum(area_b - area_a, 1e-30), 0.0)
    t = np.clip(t, 0.0, 1.0)
    floor_area = _cap_area(np.maximum(rho, first))  # bounded in both branches
    large_a, large_b = (1.0 - t) * area_a / floor_area, t * area_b / floor_area
    s = np.clip(area / area_1, 0.0, 1.0)
    return (np.where(small, 0.0, a), np.where(small, 1.0, b),
            np.where(small, 1.0 - s, large_a), np.where(small, s, large_b))


def area_cells(shape, width, height):
    """[(u, v, fraction)]: the cells an area lamp of ``shape`` and full extents
    (width, height) along its X and Y is split into for the lamp term, each a
    cap of its own area: centroid (u, v) in units of the extents (in
    [-1/2, 1/2]) and its share of the lamp's area (and power). Cells are as
    near square as their number allows, about four for a square and one per
    unit of aspect for a long rectangle (at most MAX_AREA_CELLS; measured:
    a square 1 x 1 at 3.9 m 9.2% -> 3.5% from the integral with 2 x 2 cells,
    a 1.5 x 0.5 rectangle 21.0% -> 3.5% with 3 x 1); a disk is one cell (a
    cap is its shape); an ellipse is cut across its long axis into slices of
    equal width, each with its own area and centroid."""
    if width <= 0.0 or height <= 0.0:
        raise BakeError(f"an area lamp's size must be positive, not {width} x {height}")
    long_x = width >= height
    aspect = max(width, height) / min(width, height)
    if shape in ("SQUARE", "RECTANGLE"):
        across = max(1, round(math.sqrt(4.0 / aspect)))
        along = max(1, min(MAX_AREA_CELLS // across, round(aspect * across)))
        cells = [((i + 0.5) / along - 0.5, (k + 0.5) / across - 0.5, 1.0 / (along * across))
                 for i in range(along) for k in range(across)]
    elif shape in ("DISK", "ELLIPSE"):
        along = 1 if aspect < 1.5 else min(MAX_AREA_CELLS, round(aspect))
        edges = np.linspace(-1.0, 1.0, along + 1)  # the unit circle cut at x = edges

        def primitive(x):  # integral of 2 sqrt(1 - x^2) dx and of 2 x sqrt(1 - x^2) dx
            root = np.sqrt(np.maximum(1.0 - x * x, 0.0))
            return x * root + np.arcsin(x), -2.0 / 3.0 * root ** 3

        area, moment = primitive(edges)
        parts = np.diff(area)
        centroids = np.diff(moment) / parts
        cells = [(float(c) / 2.0, 0.0, float(p / math.pi)) for c, p in zip(centroids, parts,
                                                                             strict=True)]
    else:
        raise BakeError(f"unknown area lamp shape {shape!r}")
    return cells if long_x else [(v, u, share) for u, v, share in cells]
