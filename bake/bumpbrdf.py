"""BRDFs of bumpy surfaces from their height fields (Cabral, Max & Springmeyer 1987, sections 4-6).

A height field h (m x m, periodic, heights in units of the grid spacing, so
a height difference of 1 between neighbours is a 45 degree slope) is cut
into 2 m^2 triangular facets (each grid cell split along its (0,0)-(1,1)
diagonal), each a small mirror with its own normal, area and Fresnel
factor. A beam of unit irradiance (perpendicular to it) from direction l
lights facet f with power A_f (n_f . l); the facet reflects it into the
mirror direction r_f = 2 (n_f . l) n_f - l, losing the parts of the facet
that are shadowed (the surface hides l) or masked (it hides r_f).

Shadowing and masking come from horizon tables (section 5): for each vertex
and each of 24 compass directions, the elevation angle of the highest point
of the surface seen along that direction (a ray marched one period across
the tile; at each step the ray crosses a grid line between two vertices and
the height there is interpolated linearly along that edge, with the step's
integer shift and interpolation factor the same for every vertex, so they
are computed once per direction). A vertex sees a direction when the
direction's elevation exceeds the vertex's horizon angle at that azimuth
(interpolated linearly between the two nearest compass directions). A facet
whose three vertices all see both l and r_f counts whole, one whose vertices
all miss either counts nothing, and a partial facet counts the fraction of
its area where both linearly interpolated clearances (elevation minus
horizon) are positive, measured at the 64 centroids of its 8 x 8
sub-triangles (section 5's partial facets, with the shadow line taken as
the zero of the interpolated clearance).

The reflected power is accumulated into outgoing cells (section 6): the
cells of the table's own (theta_o, phi) grid, each node's cell reaching
halfway to its neighbours in theta and phi (clipped to [0, pi/2]; the node
theta_o = 0 owns the polar cap), so their solid angles are known exactly
(the stated alternative to an icosahedral bin set, chosen so that each
table node is the average over its own cell). Eq. 4 then gives

    f_r(l, cell) = P_cell / (A cos theta_l  Omega'_cell),

with A = m^2 the tile's area and Omega'_cell = integral of cos theta_o
d omega over the cell (the projected solid angle: the cell-average of
f cos theta_o over its average cosine). Beams reflected below the
macroscopic horizon are lost (inter-reflection is ignored, as in the
paper). The table is then made reciprocal by averaging f(l, v) with
f(v, l) (incident and outgoing nodes coincide), and isotropic when asked by
averaging over incident azimuths (the cells then follow phi_d = |phi_o -
phi_l| folded to [0, pi]).

The result is a :class:`bake.brdf.IsotropicTable` (theta_i, theta_o, phi_d)
or :class:`bake.brdf.AnisotropicTable` (theta_i, phi_i, theta_o, phi_o) whose
spec is the ``bump:`` spec that made it (``bump:file=H.exr,scale=2,ior=1.5``
or ``bump:preset=gaussian,slope=0.2,seed=1``), so every map, texture and
panel takes it like any other BRDF. See :func:`parse_spec` for the keys.
"""

import hashlib
import math
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from .brdf import fresnel
from .brdf.params import SpecError
from .brdf.tabulated import AnisotropicTable, IsotropicTable
from .errors import BakeError
from .progress import run_steps, scaled_steps

__all__ = ["read_heights", "check_heights", "gaussian_surface", "white_noise", "grooves",
           "facets", "horizon_angles", "horizon_steps", "BumpSurface", "bump_table",
           "bump_table_steps", "bump_model", "bump_model_steps", "parse_spec",
           "reciprocity_error", "COMPASS", "MIN_SIZE", "MAX_SIZE"]

#: Compass directions of the horizon tables (the paper's 24).
COMPASS = 24
#: Smallest and largest height-field side accepted (texels).
MIN_SIZE, MAX_SIZE = 16, 2048
#: Sub-triangles per side of a partial facet's area lattice (64 centroids).
LATTICE = 8
#: RMS facet slope (per axis) outside which the scale is refused: below, the
#: BRDF is a near-delta the table cannot resolve; above, facets are steeper
#: than 84 degrees and the height scale is almost certainly wrong.
SLOPE_RANGE = (2e-3, 10.0)


# --- height fields ----------------------------------------------------------------


def check_heights(heights, name="the height field") -> np.ndarray:
    """Heights (m, m) float64 after the checks every source goes through (square,
    MIN_SIZE..MAX_SIZE, finite, not constant); BakeError with one clear line."""
    h = np.asarray(heights, dtype=np.float64)
    if h.ndim != 2:
        raise BakeError(f"{name}: a height field is one 2D image, not an array of shape {h.shape}")
    rows, cols = h.shape
    if rows != cols:
        raise BakeError(f"{name} is {cols} x {rows}: a height field must be square "
                        f"(one periodic tile)")
    if rows < MIN_SIZE:
        raise BakeError(f"{name} is {rows} x {rows}: too small for a BRDF (at least "
                        f"{MIN_SIZE} x {MIN_SIZE})")
    if rows > MAX_SIZE:
        raise BakeError(f"{name} is {rows} x {rows}: at most {MAX_SIZE} x {MAX_SIZE}")
    if not np.all(np.isfinite(h)):
        raise BakeError(f"{name} holds NaN or infinite heights")
    if np.ptp(h) == 0.0:
        raise BakeError(f"{name} is flat: its BRDF is a mirror's, a delta that no table can "
                        f"hold; use a smooth analytic model instead (e.g. ggx:roughness=0.05)")
    return h


def read_heights(path) -> np.ndarray:
    """Heights (m, m) float64 from an EXR (first channel, or the mean of R, G, B) or a
    PNG (16-bit or 8-bit grey, scaled to [0, 1]); row 0 is the image's top row."""
    path = Path(path)
    if not path.is_file():
        raise BakeError(f"{path}: no such file")
    suffix = path.suffix.lower()
    try:
        if suffix == ".exr":
            from . import exr

            image, _ = exr.read(path)
            image = np.asarray(image, dtype=np.float64)
            heights = image[..., :3].mean(-1) if image.ndim == 3 and image.shape[2] >= 3 \
                else (image[..., 0] if image.ndim == 3 else image)
        elif suffix == ".png":
            from PIL import Image

            with Image.open(path) as picture:
                bits = 16 if picture.mode.startswith("I") else 8
                heights = np.asarray(picture.convert("I") if bits == 16 else
                                     picture.convert("L"), dtype=np.float64)
                heights = heights / (65535.0 if bits == 16 else 255.0)
        else:
            raise BakeError(f"{path.name}: a height field must be an EXR or PNG image")
    except BakeError as error:
        if "NaN or infinite" in str(error):
            raise BakeError(f"{path.name} holds NaN or infinite heights") from None
        raise
    except ImportError:
        raise BakeError(f"{path.name}: reading PNG needs Pillow here; save the height "
                        f"field as EXR") from None
    except Exception as error:  # a corrupt or foreign file: say so in one line
        raise BakeError(f"{path.name}: cannot read it as an image ({error})") from None
    return check_heights(heights, path.name)


def _slope_rms(h) -> float:
    """RMS of the facets' slopes per axis: the forward differences along x and y."""
    dx = np.roll(h, -1, axis=1) - h
    dy = np.roll(h, -1, axis=0) - h
    return float(np.sqrt(0.5 * (np.mean(dx * dx) + np.mean(dy * dy))))


def gaussian_surface(size=256, slope=0.2, correlation=4.0, seed=0) -> np.ndarray:
    """A periodic Gaussian random surface (size, size): white noise filtered by a
    Gaussian of ``correlation`` texels (standard deviation), scaled so the facets'
    RMS slope per axis is ``slope``. Its slopes are Gaussian, so its facet normals
    follow Beckmann's distribution with alpha = sqrt(2) slope."""
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal((size, size))
    k = np.fft.fftfreq(size) * 2.0 * np.pi
    gain = np.exp(-0.5 * correlation**2 * (k[:, None] ** 2 + k[None, :] ** 2))
    h = np.real(np.fft.ifft2(np.fft.fft2(noise) * gain))
    return h * (slope / _slope_rms(h))


def white_noise(size=256, slope=0.2, seed=0) -> np.ndarray:
    """Independent uniform heights (size, size) scaled to RMS slope ``slope`` per axis."""
    h = np.random.default_rng(seed).uniform(-1.0, 1.0, (size, size))
    return h * (slope / _slope_rms(h))


def grooves(size=256, period=16.0, depth=4.0) -> np.ndarray:
    """Parallel cylindrical grooves running along y (constant along y), ``period``
    texels apart across x, each a circular arc with chord ``period`` and depth
    ``depth`` (texels, at most period / 2)."""
    if not 0 < depth <= period / 2:
        raise BakeError(f"grooves: depth {depth:g} must be in (0, period/2 = {period / 2:g}]")
    radius = (period * period / 4 + depth * depth) / (2 * depth)
    u = np.mod(np.arange(size) + 0.5, period) - period / 2
    profile = np.sqrt(np.maximum(radius * radius - u * u, 0.0)) - (radius - depth)
    return np.tile(-profile, (size, 1))


# --- geometry -----------------------------------------------------------------------


def facets(h):
    """Facets of the periodic height field h (m, m): unit normals (F, 3), areas (F,)
    and vertex indices (F, 3) into h.ravel() (index y m + x), F = 2 m^2; x is the
    column axis, y the row axis, z up. Sum of area x normal is (0, 0, m^2)."""
    m = h.shape[0]
    h10 = np.roll(h, -1, axis=1)
    h01 = np.roll(h, -1, axis=0)
    h11 = np.roll(h10, -1, axis=0)
    one = np.ones_like(h)
    lower = np.stack([-(h10 - h), -(h11 - h10), one], -1)   # (00, 10, 11)
    upper = np.stack([h01 - h11, -(h01 - h), one], -1)      # (00, 11, 01)
    cross = np.concatenate([lower.reshape(-1, 3), upper.reshape(-1, 3)])
    length = np.linalg.norm(cross, axis=1)
    y, x = np.divmod(np.arange(m * m), m)
    v00, v10 = y * m + x, y * m + (x + 1) % m
    v01, v11 = ((y + 1) % m) * m + x, ((y + 1) % m) * m + (x + 1) % m
    verts = np.concatenate([np.stack([v00, v10, v11], 1), np.stack([v00, v11, v01], 1)])
    return cross / length[:, None], 0.5 * length, verts


def _crossings(angle, reach):
    """The ray/edge interpolation factors of one compass direction: every crossing of
    the ray from a vertex with a facet edge (the grid lines x = i and y = j and the
    diagonals x - y = k) within ``reach`` texels, as (kind, dy, dx, t, distance):
    the height there is h[dy, dx] + t (h[next] - h[dy, dx]) relative to the
    vertex, next being one step along x (kind 0), along y (kind 1) or along the
    diagonal (kind 2). The same for every vertex, so computed once per direction.
    Within a facet the surface is a plane, so the elevation of the terrain seen
    from the vertex, atan((h - h0) / t), is monotonic between two crossings: its
    maximum over these crossings is the exact horizon of the triangulated surface."""
    c, s = math.cos(angle), math.sin(angle)
    c = 0.0 if abs(c) < 1e-12 else c
    s = 0.0 if abs(s) < 1e-12 else s
    out = []

    def fraction(value):
        base = math.floor(value + 1e-12)
        return base, max(value - base, 0.0)

    if c:
        for k in range(1, reach + 1):  # x = +-k: x integer, y fractional: edge along y
            t = k / abs(c)
            base, frac = fraction(t * s)
            out.append((1, base, int(math.copysign(k, c)), frac, t))
    if s:
        for k in range(1, reach + 1):  # y = +-k: edge along x
            t = k / abs(s)
            base, frac = fraction(t * c)
            out.append((0, int(math.copysign(k, s)), base, frac, t))
    if abs(c - s) > 1e-12:
        for k in range(1, int(reach * abs(c - s)) + 1):  # x - y = +-k: along the diagonal
            t = k / abs(c - s)
            base, frac = fraction(t * c)
            out.append((2, base - int(math.copysign(k, c - s)), base, frac, t))
    return [crossing for crossing in out if crossing[4] <= reach + 1e-9]


def horizon_steps(h, directions=COMPASS, reach=None):
    """:func:`horizon_angles` as a generator: yields (fraction, message) after each
    compass direction and returns the (directions, m^2) table."""
    m = h.shape[0]
    reach = m if reach is None else int(reach)
    neighbour = {0: np.roll(h, -1, axis=1), 1: np.roll(h, -1, axis=0),
                 2: np.roll(np.roll(h, -1, axis=0), -1, axis=1)}
    out = np.empty((directions, m * m))
    for k in range(directions):
        best = np.zeros_like(h)
        for kind, dy, dx, t, distance in _crossings(2 * math.pi * k / directions, reach):
            value = np.roll(h, (-dy, -dx), axis=(0, 1))
            if t > 0.0:
                value = value + t * (np.roll(neighbour[kind], (-dy, -dx), axis=(0, 1)) - value)
            np.maximum(best, (value - h) / distance, out=best)
        out[k] = np.arctan(best).ravel()
        yield (k + 1) / directions, f"horizon table {k + 1}/{directions}"
    return out


def horizon_angles(h, directions=COMPASS, reach=None) -> np.ndarray:
    """(directions, m^2) horizon elevation angles (radians, clamped at 0) of every
    vertex of h (m, m) towards azimuth 2 pi k / directions (azimuth 0 along +x, pi/2
    along +y): the largest atan((h(p + t d) - h(p)) / t) over the ray's crossings
    with facet edges (:func:`_crossings`) within ``reach`` texels (default m, one
    period of the tile)."""
    return run_steps(horizon_steps(h, directions, reach))


def _lattice(n=LATTICE) -> np.ndarray:
    """(n^2, 3) barycentric centroids of the n^2 equal sub-triangles of a triangle."""
    points = []
    for i in range(n):
        for j in range(n - i):
            points.append(((i + 1 / 3) / n, (j + 1 / 3) / n))
            if i + j < n - 1:
                points.append(((i + 2 / 3) / n, (j + 2 / 3) / n))
    uv = np.array(points)
    return np.column_stack([1.0 - uv.sum(1), uv])


class BumpSurface:
    """A height field's facets and horizon tables, and the beams they reflect.

    heights: (m, m) in texel units (already scaled). Fresnel per facet: a
    dielectric of index ``ior`` (k = 0), a conductor ior + i k (k > 0), or 1
    (``mirror=True``; for the white furnace test). ``horizons``: the table
    :func:`horizon_angles` gives, when already computed.
    """

    def __init__(self, heights, *, ior=1.5, k=0.0, mirror=False, reach=None, horizons=None):
        self.heights = check_heights(heights)
        self.size = self.heights.shape[0]
        self.slope = self.check_slope(self.heights)
        self.normals, self.areas, self.verts = facets(self.heights)
        self.horizons = horizon_angles(self.heights, reach=reach) if horizons is None \
            else np.asarray(horizons)
        self.area = float(self.size * self.size)
        self.ior, self.k, self.mirror = float(ior), float(k), bool(mirror)
        self._lattice = _lattice()

    @staticmethod
    def check_slope(heights) -> float:
        """The RMS facet slope per axis of scaled heights; BakeError outside SLOPE_RANGE."""
        slope = _slope_rms(check_heights(heights))
        if not SLOPE_RANGE[0] <= slope <= SLOPE_RANGE[1]:
            what = ("nearly flat: a near-delta the table cannot resolve (use ggx with a "
                    "small roughness)" if slope < SLOPE_RANGE[0] else
                    "steeper than 84 degrees on average: heights are in texel units, so "
                    "the scale is probably wrong")
            raise BakeError(f"the scaled height field has an RMS slope of {slope:.3g}: {what}")
        return slope

    def fresnel(self, cos_theta):
        """(F,) reflectance of facets at cos(incidence)."""
        if self.mirror:
            return np.ones_like(cos_theta)
        if self.k > 0.0:
            return fresnel.conductor(cos_theta, self.ior, self.k)
        return fresnel.dielectric(cos_theta, self.ior)

    def _horizon(self, azimuth):
        """Horizon angles at real azimuths: (k0, k1, t) to interpolate the table."""
        position = np.mod(azimuth, 2 * np.pi) / (2 * np.pi) * COMPASS
        k0 = np.floor(position).astype(np.intp) % COMPASS
        return k0, (k0 + 1) % COMPASS, position - np.floor(position)

    def scatter(self, wi):
        """The beams reflected for light from unit direction wi (3,), z > 0: mirror
        directions (B, 3) above the macroscopic horizon and their power (B,) for a
        beam of unit irradiance (area x cosine x Fresnel x unshadowed-and-unmasked
        fraction)."""
        wi = np.asarray(wi, dtype=np.float64)
        cosine = self.normals @ wi
        front = np.nonzero(cosine > 0.0)[0]
        n, c = self.normals[front], cosine[front]
        r = 2.0 * c[:, None] * n - wi
        up = r[:, 2] > 1e-9
        front, n, c, r = front[up], n[up], c[up], r[up]
        verts = self.verts[front]
        k0, k1, t = self._horizon(math.atan2(wi[1], wi[0]))
        lit_vertex = math.asin(min(wi[2], 1.0)) - ((1 - t) * self.horizons[k0]
                                                   + t * self.horizons[k1])
        lit = lit_vertex[verts]
        k0, k1, t = self._horizon(np.arctan2(r[:, 1], r[:, 0]))
        horizon = (1 - t)[:, None] * self.horizons[k0[:, None], verts] \
            + t[:, None] * self.horizons[k1[:, None], verts]
        seen = np.arcsin(np.clip(r[:, 2], -1, 1))[:, None] - horizon
        fraction = (np.all(lit > 0, 1) & np.all(seen > 0, 1)).astype(np.float64)
        partial = ~(np.all(lit <= 0, 1) | np.all(seen <= 0, 1)) & (fraction == 0.0)
        if partial.any():
            a = lit[partial] @ self._lattice.T
            b = seen[partial] @ self._lattice.T
            fraction[partial] = np.mean((a > 0) & (b > 0), axis=1)
        power = self.areas[front] * c * self.fresnel(c) * fraction
        keep = power > 0
        return r[keep], power[keep]


# --- tables -------------------------------------------------------------------------


def _theta_cells(nodes):
    """(lower, upper) polar bounds of the cells of theta nodes on [0, pi/2] inclusive."""
    step = (np.pi / 2) / (nodes - 1)
    centre = np.arange(nodes) * step
    return np.clip(centre - step / 2, 0, np.pi / 2), np.clip(centre + step / 2, 0, np.pi / 2)


def _incident_theta(nodes):
    """The incident polar angles used for theta nodes: the node itself, except the
    horizon node (no light arrives at exactly 90 degrees), taken a quarter step in."""
    step = (np.pi / 2) / (nodes - 1)
    theta = np.arange(nodes) * step
    theta[-1] -= step / 4
    return theta


def bump_table(surface, *, thetas=24, phis=None, isotropic=True, azimuths=24,
               reciprocal=True, progress=None):
    """:func:`bump_table_steps` run to its end; ``progress(fraction, message)``."""
    return run_steps(bump_table_steps(surface, thetas=thetas, phis=phis, isotropic=isotropic,
                                      azimuths=azimuths, reciprocal=reciprocal), progress)


def bump_table_steps(surface, *, thetas=24, phis=None, isotropic=True, azimuths=24,
                     reciprocal=True):
    """The BRDF table of ``surface`` (a :class:`BumpSurface`), as a generator that
    yields (fraction, message) after each incident elevation.

    isotropic: values (thetas, thetas, phis, 3) over (theta_i, theta_o, phi_d)
    (phis default 25: 7.5 degree steps on [0, pi]), each incident elevation
    averaged over ``azimuths`` incident azimuths; otherwise (thetas, phis,
    thetas, phis, 3) over (theta_i, phi_i, theta_o, phi_o) (phis default 32).
    ``reciprocal``: average f(l, v) with f(v, l). Returns (values, raw) where raw
    is the table before the reciprocity average (for :func:`reciprocity_error`).
    """
    phis = (25 if isotropic else 32) if phis is None else int(phis)
    low, high = _theta_cells(thetas)
    band = 0.5 * (np.sin(high) ** 2 - np.sin(low) ** 2)  # integral of cos sin dtheta
    incident = _incident_theta(thetas)
    if isotropic:
        step = np.pi / (phis - 1)
        centre = np.arange(phis) * step
        width = 2.0 * (np.clip(centre + step / 2, 0, np.pi) - np.clip(centre - step / 2, 0, np.pi))
        directions = [[i * 2 * np.pi / azimuths for i in range(azimuths)]] * thetas
    else:
        step = 2 * np.pi / phis
        width = np.full(phis, step)
        directions = [[0.0] if index == 0 else [i * step for i in range(phis)]
                      for index in range(thetas)]
    projected = band[:, None] * width[None, :]
    cap = np.pi * np.sin(high[0]) ** 2  # the polar cap's projected solid angle (2 pi band)
    values = np.zeros((thetas, 1 if isotropic else phis, thetas, phis))

    def cells(task):
        """f over the outgoing cells (thetas, phis) for one incident direction."""
        theta, phi = task
        wi = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi),
                       math.cos(theta)])
        r, power = surface.scatter(wi)
        theta_o = np.arccos(np.clip(r[:, 2], -1, 1))
        row = np.clip(np.rint(theta_o / (np.pi / 2) * (thetas - 1)).astype(np.intp),
                      0, thetas - 1)
        azimuth = np.arctan2(r[:, 1], r[:, 0])
        if isotropic:
            relative = np.abs(np.mod(azimuth - phi + np.pi, 2 * np.pi) - np.pi)
            col = np.clip(np.rint(relative / step).astype(np.intp), 0, phis - 1)
        else:
            col = np.rint(np.mod(azimuth, 2 * np.pi) / step).astype(np.intp) % phis
        flux = np.bincount(row * phis + col, power, thetas * phis).reshape(thetas, phis)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = flux / (surface.area * math.cos(theta) * projected)
        f[0, :] = flux[0].sum() / (surface.area * math.cos(theta) * cap)
        return f

    # NumPy releases the GIL in the large array operations: two threads use both cores.
    with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        for index, theta in enumerate(incident):
            tasks = [(theta, phi) for phi in directions[index]]
            for column, f in enumerate(pool.map(cells, tasks)):
                if isotropic:
                    values[index, 0] += f / len(tasks)
                elif index == 0:
                    values[index, :] = f
                else:
                    values[index, column] = f
            yield (index + 1) / thetas, f"incident elevation {index + 1}/{thetas}"
    if isotropic:
        raw = values[:, 0]
        table = 0.5 * (raw + raw.transpose(1, 0, 2)) if reciprocal else raw
    else:
        raw = values
        table = 0.5 * (raw + raw.transpose(2, 3, 0, 1)) if reciprocal else raw
    return np.repeat(table[..., None], 3, -1), raw


def reciprocity_error(raw, floor=0.05):
    """Median of |f(l, v) - f(v, l)| / mean of the two over the table's entries
    whose mean exceeds ``floor`` x the table's largest value (the lobe, not the
    empty cells). raw: an isotropic (Ni, Ni, Np) or anisotropic (Ni, Pi, Ni, Pi) table."""
    swapped = raw.transpose(1, 0, 2) if raw.ndim == 3 else raw.transpose(2, 3, 0, 1)
    mean = 0.5 * (raw + swapped)
    keep = mean > floor * mean.max()
    return float(np.median(np.abs(raw - swapped)[keep] / mean[keep]))


# --- the bump: spec ---------------------------------------------------------------

#: Keys of a bump: spec, their defaults and ranges (file is a path; preset a word).
_NUMBERS = {
    "scale": (1.0, 1e-6, 1e4), "ior": (1.5, 0.01, 10.0), "k": (0.0, 0.0, 20.0),
    "mirror": (0, 0, 1), "isotropic": (1, 0, 1), "size": (256, MIN_SIZE, MAX_SIZE),
    "slope": (0.2, 1e-3, 5.0), "seed": (0, 0, 2**31 - 1), "correlation": (4.0, 0.5, 64.0),
    "period": (16.0, 2.0, 1024.0), "depth": (4.0, 0.01, 512.0), "thetas": (24, 4, 90),
    "phis": (0, 0, 180),
}
_PRESETS = ("gaussian", "noise", "grooves")
_cache: dict = {}
_cache_lock = threading.Lock()


def parse_spec(body: str) -> dict:
    """The keys of ``bump:KEY=VALUE,...`` (the part after ``bump:``) with defaults:
    ``file=PATH`` (EXR or PNG height field) or ``preset=gaussian|noise|grooves``;
    ``scale`` (height, in texel spacings, of a height value of 1; presets are
    already in texel units); Fresnel ``ior`` (dielectric, or the real part with
    ``k`` > 0 for a conductor) or ``mirror=1`` (F = 1); ``isotropic`` (1: a 3D
    table averaged over azimuths, 0: 4D); presets: ``size``, ``slope`` (RMS per
    axis), ``seed``, ``correlation`` (texels), ``period`` and ``depth`` (grooves,
    texels); table nodes ``thetas`` and ``phis`` (0: the default)."""
    params: dict = {}
    for part in body.split(","):
        if not part.strip():
            continue
        key, sep, value = part.partition("=")
        key, value = key.strip().lower(), value.strip()
        if not sep or not value:
            raise SpecError(f"bump: expected KEY=VALUE, got {part.strip()!r}")
        if key in params:
            raise SpecError(f"bump: {key} given twice")
        if key == "file":
            params[key] = value
        elif key == "preset":
            if value.lower() not in _PRESETS:
                raise SpecError(f"bump: preset={value!r}: one of {', '.join(_PRESETS)}")
            params[key] = value.lower()
        elif key in _NUMBERS:
            _, low, high = _NUMBERS[key]
            try:
                number = float(value)
            except ValueError:
                raise SpecError(f"bump: {key}={value!r} is not a number") from None
            if not math.isfinite(number) or not low <= number <= high:
                raise SpecError(f"bump: {key}={value} is out of range [{low:g}, {high:g}]")
            params[key] = number
        else:
            allowed = ", ".join(["file", "preset", *_NUMBERS])
            raise SpecError(f"bump: unknown key {key!r} (allowed: {allowed})")
    if ("file" in params) == ("preset" in params):
        raise SpecError("bump: give file=PATH (a height field image) or preset=NAME, one of them")
    for key, (default, _, _) in _NUMBERS.items():
        params.setdefault(key, default)
    return params


def _canonical(params) -> str:
    keys = ["file" if "file" in params else "preset", "scale", "ior", "k", "mirror",
            "isotropic", "thetas", "phis"]
    if params.get("preset") in ("gaussian", "noise"):
        keys += ["size", "slope", "seed"] + (["correlation"] if params["preset"] == "gaussian"
                                             else [])
    elif params.get("preset") == "grooves":
        keys += ["size", "period", "depth"]
    def text(key):
        return params[key] if key in ("file", "preset") else format(params[key], "g")

    return "bump:" + ",".join(f"{key}={text(key)}" for key in keys)


def heights_of(params) -> np.ndarray:
    """The scaled height field (m, m) a parsed bump spec describes."""
    if "file" in params:
        h = read_heights(params["file"])
    else:
        size = int(params["size"])
        if params["preset"] == "gaussian":
            h = gaussian_surface(size, params["slope"], params["correlation"], int(params["seed"]))
        elif params["preset"] == "noise":
            h = white_noise(size, params["slope"], int(params["seed"]))
        else:
            h = grooves(size, params["period"], params["depth"])
    return h * params["scale"]


class _BumpTable:
    """Mixin: a table made from a bump spec keeps that spec as its identity."""

    @property
    def spec(self):
        return self._bump_spec

    def spec_hash(self):
        return hashlib.sha256((self._bump_spec + self._content).encode()).hexdigest()[:16]


class BumpIsotropicTable(_BumpTable, IsotropicTable):
    """Isotropic BRDF table computed from a bump height field."""


class BumpAnisotropicTable(_BumpTable, AnisotropicTable):
    """Anisotropic BRDF table computed from a bump height field."""


def _cache_folder() -> Path:
    root = os.environ.get("GLOSSY_CACHE_DIR") or Path.home() / ".cache" / "glossy"
    return Path(root) / "bump"


def bump_model(body: str, progress=None):
    """The table model of a ``bump:`` spec body; computed once per content and kept in
    memory and in $GLOSSY_CACHE_DIR (default ~/.cache/glossy)/bump/<hash>.npz.
    ``progress(fraction, message)`` while it is computed."""
    return run_steps(bump_model_steps(body), progress)


def bump_model_steps(body: str):
    """:func:`bump_model` as a generator of (fraction, message): the horizon tables
    (one step per compass direction) then the table (one per incident elevation).
    Writes the cache file only at the end."""
    params = parse_spec(body)
    spec = _canonical(params)
    content = ""
    if "file" in params:
        path = Path(params["file"])
        if not path.is_file():
            raise SpecError(f"bump: {path}: no such file")
        content = hashlib.sha256(path.read_bytes()).hexdigest()[:16]
    key = hashlib.sha256((spec + content).encode()).hexdigest()[:20]
    with _cache_lock:
        values = _cache.get(key)
    cached = _cache_folder() / f"{key}.npz"
    if values is None and cached.is_file():
        try:
            with np.load(cached, allow_pickle=False) as data:
                values = data["values"]
        except (OSError, ValueError, KeyError):
            values = None
    if values is None:
        heights = heights_of(params)
        BumpSurface.check_slope(heights)
        horizons = yield from scaled_steps(horizon_steps(heights), 0.0, 0.15)
        surface = BumpSurface(heights, ior=params["ior"], k=params["k"],
                              mirror=bool(params["mirror"]), horizons=horizons)
        phis = int(params["phis"]) or None
        values, _ = yield from scaled_steps(
            bump_table_steps(surface, thetas=int(params["thetas"]), phis=phis,
                             isotropic=bool(params["isotropic"])), 0.15, 1.0)
        try:
            cached.parent.mkdir(parents=True, exist_ok=True)
            temporary = cached.with_name(f".{key}.{os.getpid()}.npz")
            np.savez_compressed(temporary, values=values)
            os.replace(temporary, cached)
        except OSError:
            pass  # a read-only cache only costs the next process the computation
    with _cache_lock:
        _cache[key] = values
    cls = BumpIsotropicTable if values.ndim == 4 else BumpAnisotropicTable
    model = cls(values, source=spec)
    model._bump_spec, model._content = spec, content
    return model
