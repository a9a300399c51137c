"""Prefiltered environment maps: Kautz-McCool 3D/2D maps and the standard IBL prefilters.

Modes (``prefilter(image, model_or_fit, mode=...)``):

- ``3d``: Kautz & McCool 2000 eq. 2. For each of K view-elevation slices and
  each lobe sequence j, the probe convolved with that slice's radially
  symmetric lobe (lobes.py) scaled by its RGB weight: K lat-long layers
  ``slice.<k>`` (``lobe<j>.slice.<k>`` for several lobes). The lobe is
  fitted to f cos(theta_i), so the cosine is carried inside it, as if
  n.l were n.r_v over the lobe (the paper's approximation).
- ``2d``: one lat-long layer filtered with the shared unit lobe, plus the
  table k(theta_o) (RGB) and the per-slice offsets in the metadata.
- ``split-sum``: a GGX roughness-indexed MIP chain of cube maps (n = v = r,
  kernel D(h) (n.l)) and a float DFG table (A, B over n.v and roughness),
  with the level-to-roughness mapping of Filament's cmgen or of the Khronos
  glTF IBL sampler (``preset``).
- ``phong``: Heidrich 3.2.2, the probe filtered by the unit Phong lobe
  cos^n about r, times the directional albedo table.
- ``irradiance``: diffuse irradiance E(n) = integral L cos / pi, by direct
  convolution or from 9 spherical-harmonic coefficients (``method="sh"``).

All filtering of radially symmetric kernels goes through zonal.py (FFT along
longitude, O(H^2 W log W) whatever the lobe width; narrow lobes integrate the
kernel over input texels). ``BakedMap.shade(normal, view)`` is the NumPy twin
of the node-group lookup; ``BakedMap.write`` stores an EXR (parameters in the
``glossy`` header attribute) and a JSON sidecar; :func:`load` reads one back.
"""

import functools
import json
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import __version__, exr, lobes, outputs, probe_content, resolution, sh, slice_basis
from .brdf import BRDF, parse
from .brdf.microfacet import ggx_d
from .envmap import get_layout
from .errors import BakeError
from .probe_maps import latlong_detail_rows, probe_maps, resample_rows
from .progress import run_steps
from .zonal import suggested_supersample, zonal_convolve

__all__ = ["MODES", "PRESETS", "prefilter", "load", "BakedMap", "Companion", "split_sum_kernel",
           "dfg_table"]

MODES = ("3d", "2d", "split-sum", "phong", "irradiance", "sh")
#: Default spherical-harmonic order of the ``sh`` mode.
SH_ORDER = 8
#: Level fraction x = l / (levels - 1) -> perceptual roughness of that level.
PRESETS = {
    "khronos": lambda x: x,  # glTF IBL sampler: lod = roughness * (levels - 1)
    "filament": lambda x: 1.0 - math.sqrt(max(1.0 - x, 0.0)),  # cmgen: lod = r (2 - r)
}
MAX_SIZE = 2048
#: Upper bound of an Auto size when none is given (the Blender default too): the
#: largest at which the default method's bake of the narrowest lobes (GGX
#: 0.05-0.2, whose Auto size is 1000-1600 rows) stays under issue 10's 3 s from a
#: 128 px probe on the 2-core machine (benchmarks/prefilter.py 5: 2.0-2.4 s at
#: 384 rows, 1.4-1.5 s at 256; 512 rows would take about 3 s).
DEFAULT_MAX_SIZE = 384
FORMAT = 1


def split_sum_level_weights(meta: dict) -> list[tuple[str, float]]:
    """The split-sum MIP levels to blend at ``meta["material_roughness"]``:
    [("level<k>", weight)], the two levels around it in
    ``meta["roughness_levels"]``, linear in level index (one level when exact)."""
    levels = meta["roughness_levels"]
    x = float(np.interp(meta["material_roughness"], levels, np.arange(len(levels))))
    l0 = int(math.floor(x))
    t = x - l0
    weights = [(f"level{l0}", 1.0 - t)]
    if t > 0:
        weights.append((f"level{min(l0 + 1, len(levels) - 1)}", t))
    return weights


def _check_probe(image, layout):
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] < 3:
        raise BakeError(f"the probe must be an (H, W, 3) image, got shape {image.shape}")
    image = image[:, :, :3]
    if not np.all(np.isfinite(image)):
        raise BakeError("the probe holds NaN or infinite values")
    if layout is None:
        layout = "cube" if image.shape[1] == 6 * image.shape[0] else "latlong"
    get_layout(layout).check_image(image)
    return image.astype(np.float32), layout


def _check_size(size, name="size"):
    if int(size) != size or not 4 <= size <= MAX_SIZE:
        raise BakeError(f"{name} must be a whole number in [4, {MAX_SIZE}], not {size!r}")
    return int(size)


def _profile_kernel(profile):
    profile = np.asarray(profile, dtype=np.float64)

    def kernel(cos_gamma):
        return np.interp(np.arccos(np.clip(cos_gamma, -1.0, 1.0)), lobes.GAMMA, profile)

    return kernel


def _half_width(kernel):
    """Angle (rad) at which a kernel falls to half its value at gamma = 0 (rough width)."""
    gamma = np.linspace(0.0, np.pi, 4097)
    values = kernel(np.cos(gamma))
    peak = values.max()
    if peak <= 0:
        return np.pi
    below = np.nonzero(values < 0.5 * peak)[0]
    return float(gamma[below[0]]) if below.size else np.pi


def _kernel_half_width(kernel):
    """HWHM (rad) of a kernel, resolved finely near gamma = 0 (the lobes' node grid)."""
    return resolution.lobe_half_width(lobes.GAMMA, kernel(np.cos(lobes.GAMMA)))


#: The finest tier's radius in texels of its grid and in lobe widths (at least
#: both); sub-sampling reaches SUPERSAMPLE_HALF_WIDTHS widths (plus a texel).
CORE_TEXELS = 8.0
CORE_HALF_WIDTHS = 2.0
SUPERSAMPLE_HALF_WIDTHS = 4.0
#: Lobes narrower than this fraction of a working texel have their core filtered
#: as an equal-energy Gaussian of that width; sub-samples per texel side (near
#: each direction only) are at most MAX_SUPERSAMPLE.
SUBTEXEL_FRACTION = 1.0 / 16.0
MAX_SUPERSAMPLE = 8


#: Texels per lobe width of the grid a lobe is filtered on, when that is coarser than
#: the map (then interpolated up): on GGX 0.5 from a 32-px probe, filtering at
#: 3 texels per width and interpolating added 0.4-3.6% against filtering at the
#: map's rows; at 6 it adds about 0.1%.
FILTER_TEXELS_PER_HALF_WIDTH = 6.0


def filter_rows(half_width, rows):
    """Rows at which a lobe of this width (rad, bake.resolution.lobe_half_width) is
    filtered for a map of ``rows`` rows: FILTER_TEXELS_PER_HALF_WIDTH texels per width,
    rounded up to a multiple of 8, never more than ``rows``."""
    needed = math.ceil(FILTER_TEXELS_PER_HALF_WIDTH * math.pi / max(half_width, 1e-9))
    return int(min(rows, max(resolution.MIN_ROWS, math.ceil(needed / 8.0) * 8)))


def _taper(radius):
    """Window of cos(gamma): 1 within ``radius``, 0 beyond twice it, a raised cosine between."""
    def window(cos_gamma):
        gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
        x = np.clip((gamma - radius) / radius, 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    return window


def _tier_piece(kernel, inner, outer):
    """kernel times (outer window - inner window); a missing window counts as 0
    (inner) or 1 (outer)."""
    def piece(cos_gamma):
        weight = 1.0 if outer is None else outer(cos_gamma)
        if inner is not None:
            weight = weight - inner(cos_gamma)
        return kernel(cos_gamma) * weight

    return piece


def _filter(maps, kernel, rows, half=None):
    """Zonal convolution of the probe with ``kernel``: a (rows, 2 rows, 3) lat-long map.

    maps: the probe's shared ProbeMaps. Multi-scale: the kernel is cut by
    raised-cosine windows at radii R, 2R, 4R, ... into a disc and annuli;
    tier t (the annulus from 2^(t-1) R to 2^(t+1) R) is filtered on a grid
    of rows / 2^t rows, over only the rows and longitudes it reaches, so
    every tier spans the same number of its own texels and the total cost
    is about 4/3 of the finest tier's, whatever the kernel's width or the
    length of its tail (heavy GGX tails reach across the sphere). The finest
    grid has the rows the lobe needs (:func:`filter_rows`), at most ``rows``;
    R = max(2 lobe widths, 8 texels), so each window's taper spans at least
    4 texels of the grid it is filtered on. Each piece is normalized to its
    own exact integral, so the sum keeps the kernel's energy exactly (a
    constant map stays its constant). Near each output direction (within 4
    lobe widths and a texel) the kernel is integrated over input texels
    with up to 8 x 8 sub-samples (a lobe's core narrower than a texel sees
    only the texel it is in, as the texel-integrated truth does); the core
    of a lobe narrower than 1/16 texel (its part within 1-2 texels) is
    replaced by an equal-energy Gaussian of 1/16 texel, its tail kept.
    """
    from .zonal import kernel_integral

    half = _kernel_half_width(kernel) if half is None else half
    work_rows = filter_rows(half, rows)
    texel = np.pi / work_rows
    if half < SUBTEXEL_FRACTION * texel:
        # The lobe's core is under 1/16 texel, finer than the sub-samples can
        # follow; only its energy and centre matter there. The part within 1-2
        # texels becomes an equal-energy Gaussian of 1/16 texel (inside the
        # texel it sits in); the rest (GGX's heavy tail, often a large share
        # of the energy) is kept as it is.
        near = _taper(texel)
        core_energy = kernel_integral(_tier_piece(kernel, None, near))
        sigma = SUBTEXEL_FRACTION * texel
        outside = _tier_piece(kernel, near, None)

        def kernel(cos_gamma, energy=core_energy, sigma=sigma, outside=outside):
            gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
            core = energy * np.exp(-0.5 * (gamma / sigma) ** 2) / (2 * np.pi * sigma**2)
            return core + outside(cos_gamma)

        half = _kernel_half_width(kernel)
    supersample = min(suggested_supersample(half, texel), MAX_SUPERSAMPLE)
    near = SUPERSAMPLE_HALF_WIDTHS * half + 1.0 * texel
    radius = max(CORE_HALF_WIDTHS * half, CORE_TEXELS * texel)
    result = np.zeros((rows, 2 * rows, 3), np.float32)
    inner = None  # the previous tier's window
    tier_rows = work_rows
    while True:
        outer = _taper(radius)
        last = radius >= np.pi / 2 or tier_rows // 2 < resolution.MIN_ROWS
        piece = _tier_piece(kernel, inner, None if last else outer)
        finest = inner is None
        filtered = zonal_convolve(maps.latlong(tier_rows), piece,
                                  supersample=supersample if finest else 1,
                                  supersample_radius=near if finest else None,
                                  spectrum=maps.spectrum(tier_rows))
        result += resample_rows(filtered, rows)
        if last:
            return result
        inner, radius, tier_rows = outer, 2.0 * radius, tier_rows // 2


def view_frame(normal, view):
    """(n, mu, r, toward) of world-space normals and views (..., 3), as the nodes compute.

    n, v normalized; mu = clamp(n.v, 0, 1); r = 2 mu n - v normalized (the
    mirror direction); toward = normalize(mu r - n), the direction in the
    (n, r) plane away from n along which lobe offsets turn r (zero at mu = 1,
    as Blender's Normalize node gives, where offsets vanish anyway).
    """
    n = np.asarray(normal, dtype=np.float64)
    v = np.asarray(view, dtype=np.float64)
    n, v = np.broadcast_arrays(n, v)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    mu = np.clip(np.sum(n * v, -1), 0.0, 1.0)
    r = 2.0 * mu[..., None] * n - v
    r /= np.linalg.norm(r, axis=-1, keepdims=True)
    toward = mu[..., None] * r - n
    length = np.linalg.norm(toward, axis=-1, keepdims=True)
    toward = np.where(length > 0, toward / np.where(length > 0, length, 1.0), 0.0)
    return n, mu, r, toward


def split_sum_kernel(roughness):
    """GGX prefilter kernel with n = v = r: D(h) max(cos gamma, 0) with h halfway
    (at gamma / 2), normalized to unit integral over the sphere (1/sr)."""
    from .zonal import kernel_integral

    alpha = max(float(roughness) ** 2, 1e-6)

    def raw(cos_gamma):
        cos_half = np.sqrt(np.clip(0.5 * (1.0 + np.asarray(cos_gamma)), 0.0, 1.0))
        h = np.stack([np.sqrt(1.0 - cos_half**2), np.zeros_like(cos_half), cos_half], -1)
        return ggx_d(h, alpha, alpha) * np.clip(cos_gamma, 0.0, None)

    total = kernel_integral(raw)

    def kernel(cos_gamma):
        return raw(cos_gamma) / total

    return kernel


@functools.lru_cache(maxsize=4)
def dfg_table(size=32, samples=256):
    """Split-sum DFG table (size, size, 3): rows n.v (mu = (i + 0.5) / size, top row
    first), columns roughness ((j + 0.5) / size); channels A = integral f cos (1 - Fc),
    B = integral f cos Fc with Fc = (1 - v.h)^5, for Cycles' GGX; third channel A + B.
    Visible-normal importance sampling with Hammersley points: about 1e-3 accurate.
    The returned array is shared (cached): copy it before changing it."""
    from .brdf.base import hammersley
    from .brdf.cycles import GGX

    mu = (np.arange(size) + 0.5) / size
    rough = (np.arange(size) + 0.5) / size
    u = hammersley(samples)
    table = np.zeros((size, size, 3))
    for j, r in enumerate(rough):
        model = GGX(roughness=max(float(r), 0.01))
        wo = np.stack([np.sqrt(1 - mu**2), np.zeros_like(mu), mu], -1)[:, None, :]
        wi, pdf = model.sample(np.broadcast_to(wo, (size, samples, 3)), u[None])
        with np.errstate(all="ignore"):
            weight = np.where(pdf > 0, model.f(wi, np.broadcast_to(wo, wi.shape))[..., 0]
                              * np.clip(wi[..., 2], 0, None) / pdf, 0.0)
        h = wi + wo
        h /= np.linalg.norm(h, axis=-1, keepdims=True)
        fc = (1.0 - np.clip(np.sum(h * wo, -1), 0, 1)) ** 5
        table[:, j, 0] = np.mean(weight * (1 - fc), axis=1)
        table[:, j, 1] = np.mean(weight * fc, axis=1)
    table[..., 2] = table[..., 0] + table[..., 1]
    return table[::-1].astype(np.float32)


class BakedMap:
    """A prefiltered map in memory: layers (lat-long or cube levels) and parameters."""

    def __init__(self, mode, layers: dict, meta: dict):
        self.mode = mode
        self.layers = layers
        self.meta = meta
        self._samplers = {}
        #: {(k, j): filtered unit lobe} and the lobes.Fit of a 3d bake with
        #: keep_unit_layers (what a Companion holds), else None.
        self.unit_layers = self.unit_fit = None

    # --- lookups -----------------------------------------------------------
    def _sampler(self, name, layout="latlong"):
        if name not in self._samplers:
            self._samplers[name] = get_layout(layout).sampler(self.layers[name])
        return self._samplers[name]

    @staticmethod
    def _frame(normal, view):
        return view_frame(normal, view)

    @staticmethod
    def _tent(mu, nodes):
        """Tent weights (..., K) of mu over the slice nodes (clamped at both ends)."""
        nodes = np.asarray(nodes)
        x = np.interp(mu, nodes, np.arange(nodes.size))
        k0 = np.clip(np.floor(x).astype(int), 0, nodes.size - 1)
        k1 = np.minimum(k0 + 1, nodes.size - 1)
        t = x - k0
        weights = np.zeros((*np.shape(mu), nodes.size))
        np.put_along_axis(weights, k0[..., None], (1 - t)[..., None], -1)
        extra = np.take_along_axis(weights, k1[..., None], -1) + t[..., None]
        np.put_along_axis(weights, k1[..., None], extra, -1)
        return weights

    def shade(self, normal, view):
        """Reflected radiance (..., 3) for world-space unit normals and views.

        normal, view: (..., 3) world-space directions (view points from the
        surface to the viewer), normalized here. Back-facing views (n.v < 0)
        are treated as grazing.
        """
        n, mu, r, toward = self._frame(normal, view)
        if self.mode in ("3d", "2d", "phong"):
            return self._shade_lobes(mu, r, toward)
        if self.mode == "irradiance":
            return self._sampler("irradiance")(n) * np.asarray(self.meta["color"])
        if self.mode == "sh":
            from .sh_reflection import SHReflection

            table = self.layers["sh"]  # row 0: environment; rows 1..K: the lobe
            return SHReflection(table[0], table[1:]).shade(normal, view)
        return self._shade_split_sum(mu, r)

    def _shade_lobes(self, mu, r, toward):
        nodes = self.meta["mu"]
        weights = self._tent(mu, nodes)
        out = np.zeros((*mu.shape, 3))
        for k in range(len(nodes)):
            w = weights[..., k]
            if not np.any(w > 0):
                continue
            for j, offset in enumerate(self.meta["offsets"][k]):
                centre = np.cos(offset) * r + np.sin(offset) * toward
                # Unit already for front-facing views (toward is normal to r).
                centre /= np.linalg.norm(centre, axis=-1, keepdims=True)
                if self.mode == "3d":
                    name = f"slice.{k}" if self.meta["lobes"] == 1 else f"lobe{j}.slice.{k}"
                    value = self._sampler(name)(centre)
                else:
                    value = self._sampler("")(centre) * np.asarray(self.meta["k"][k])
                out += w[..., None] * value
        return out

    def _shade_split_sum(self, mu, r):
        roughness = self.meta["material_roughness"]
        value = sum(weight * self._sampler(name, "cube")(r)
                    for name, weight in split_sum_level_weights(self.meta))
        dfg = self.layers["dfg"]
        size = dfg.shape[0]
        row = np.clip((1.0 - mu) * size - 0.5, 0, size - 1)  # top row is mu = 1
        col = np.clip(roughness * size - 0.5, 0, size - 1)
        from .envmap.grid import bilinear

        ab = bilinear(dfg[None], np.zeros(np.shape(mu), int), np.full(np.shape(mu), col), row)
        f0 = np.asarray(self.meta.get("f0", [1.0, 1.0, 1.0]))
        return value * (f0 * ab[..., :1] + ab[..., 1:2])

    # --- files ---------------------------------------------------------------
    def write(self, path):
        """Write the EXR (parameters in its header) and ``<path>.json`` beside it.

        Both are checked first (the sidecar may replace only a file Glossy
        wrote), staged, and renamed together: a failure leaves neither."""
        with outputs.Staged() as staged:
            path = self.write_staged(staged, path)
        return path

    def write_staged(self, staged, path):
        """:meth:`write` as part of a larger result: the EXR and its sidecar are
        checked and added to ``staged`` (bake.outputs.Staged), renamed with the
        result's other files. Returns the path."""
        path = outputs.check_target(path, ".exr")
        sidecar = outputs.check_implicit(path.with_suffix(".json"), "map's .json sidecar")
        text = json.dumps(self.meta, indent=1, sort_keys=True)
        if self.mode == "split-sum":
            staged.add(path, lambda target: exr.write_parts(target, self.layers, self.meta))
        else:
            staged.add(path, lambda target: exr.write(target, self.layers, self.meta))
        staged.add(sidecar, lambda target: Path(target).write_text(text))
        return path


def load(path) -> BakedMap:
    """Read a map written by :meth:`BakedMap.write`."""
    path = Path(path)
    header = exr.read_header(path)
    raw = header.get(exr.META_ATTRIBUTE)
    meta = json.loads(raw) if raw else {}
    mode = meta.get("mode")
    if mode not in MODES:
        raise BakeError(f"{path}: not a Glossy prefiltered map (mode {mode!r})")
    if mode == "split-sum":
        layers, meta = exr.read_parts(path)
    else:
        layers, meta = exr.read(path, layers=True)
    return BakedMap(mode, layers, meta)


def _base_meta(mode, model, probe_layout, probe_shape, size):
    return {"format": FORMAT, "generator": f"glossy-bake {__version__}", "mode": mode,
            "spec": model.spec, "spec_hash": model.spec_hash(), "layout": "latlong",
            "size": size, "probe": {"layout": probe_layout, "shape": list(probe_shape[:2])}}


#: Bytes of memory a bake may plan to use, as a fraction of what is available.
MEMORY_FRACTION = 0.8


def available_memory() -> int:
    """Bytes of memory available to this process now (MemAvailable; else total RAM)."""
    try:
        with open("/proc/meminfo") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 34


def bake_memory(rows: int, layers: int) -> int:
    """Bytes a bake of ``layers`` maps of (rows, 2 rows, 3) float32 needs at its peak:
    the layers, the atlas they pack into, and per filtering thread a working
    map, its spectrum and the kernel chunk (bounded by zonal's chunk size)."""
    layer = rows * 2 * rows * 3 * 4
    per_thread = 4 * layer + (1 << 27)
    return 2 * layers * layer + 2 * per_thread


def check_memory(rows: int, layers: int, what: str = "map"):
    """Raise BakeError, before anything is allocated, when a bake cannot fit in memory."""
    need = bake_memory(rows, layers)
    have = available_memory()
    if need > MEMORY_FRACTION * have:
        raise BakeError(f"a {what} of {layers} layer(s) at {rows}x{2 * rows} texels needs about "
                        f"{need / 2**30:.1f} GiB; {have / 2**30:.1f} GiB is available: "
                        f"use a smaller size or fewer slices/lobes")


def _resolve_size(size, max_size, half_widths, image, probe_layout, layers=1):
    """(rows, reason) from size = an int or "auto" (then max_size bounds it)."""
    if size in (None, "auto"):
        max_size = DEFAULT_MAX_SIZE if max_size is None else _check_size(max_size, "max_size")
        choice = resolution.choose_map_rows(half_widths, image.shape, probe_layout, max_size,
                                            layers, content_shape=_content_shape(image,
                                                                                 probe_layout))
        return choice.value, choice.reason
    size = _check_size(size)
    return size, f"{size} rows: set by hand"


def _content_shape(image, probe_layout):
    """The shape of the coarsest pyramid level standing for the probe's content."""
    return probe_content.of_probe(image, probe_layout).shape


@dataclass
class Companion:
    """The high end of a two-map split, whose filtered lobes the low end's 3D map may take.

    A split material (bake.colour_response: a metal's base colour, a specular
    tint) shades (1 - c) M_low + c M_high per pixel, c in [0, 1] from its
    texture. Both maps hold the same slices of lobes with the same normal
    distribution; near normal incidence the low map's weights are small (a
    metal at base colour 0 reflects Schlick's grazing term alone: 0-4% of the
    high map's at GGX 0.1-0.5), so its own lobe shapes matter little there.
    The low map takes the high map's filtered unit lobe for slice (k, j) where

        w_low L1(p_low, p_high) <= TOLERANCE ((1 - share) w_low + share w_high),

    w the slice's weight (mean over RGB), L1 the relative L1 error of the lobe
    shape (bake.slice_basis.energy_error), share the texture's mean value of
    the split input: the error so made at any pixel is at most TOLERANCE of
    what the slice gives at the mean colour times the brightest radiance the
    lobe covers (slice_basis's bound, taken against the material's mean
    brightness instead of the low map's own). With share 0 this is slice_basis's
    own bound, L1 <= TOLERANCE.

    fit: the high map's lobes.Fit; unit_layers: {(k, j): (size, 2 size, 3)
    float32} its filtered unit lobes (BakedMap.unit_layers of a bake with
    ``keep_unit_layers``); size: its rows; share in [0, 1].
    """

    fit: "lobes.Fit"
    unit_layers: dict
    size: int
    share: float

    def reusable(self, fit, jobs) -> list:
        """The jobs (k, j) of ``fit`` (the low map's) that may take the high map's lobe."""
        if len(fit.slices) != len(self.fit.slices) or \
                not np.allclose(fit.mus, self.fit.mus, rtol=0.0, atol=1e-9):
            return []
        share = float(np.clip(self.share, 0.0, 1.0))
        out = []
        for k, j in jobs:
            if (k, j) not in self.unit_layers or j >= len(self.fit.slices[k].lobes):
                continue
            own, other = fit.slices[k].lobes[j], self.fit.slices[k].lobes[j]
            low = float(np.mean(own.weight))
            high = float(np.mean(other.weight))
            error = slice_basis.energy_error(other.profile, own.profile, lobes.GAMMA)
            if low * error <= slice_basis.TOLERANCE * ((1.0 - share) * low + share * high):
                out.append((k, j))
        return out


def prefilter(image, model_or_fit, mode="3d", size=128, *, slices=16, lobes_count=1,
              layout=None, levels=None, preset="khronos", method="direct", dfg=True,
              max_size=None, order=SH_ORDER, progress=None):
    """Prefilter a probe (cube strip or lat-long (H, W, 3)) for a BRDF; returns a BakedMap.

    size: lat-long output height N (maps are N x 2N), or the base cube face for
    ``split-sum``; ``"auto"`` (3d, 2d, phong, irradiance) chooses N from the
    lobes' widths and the probe's detail (bake.resolution), at most
    ``max_size``; the choice and its reason are in ``meta["size_reason"]``.
    slices / lobes_count: the lobe fit (3d, 2d, phong tables).
    levels / preset: the split-sum chain (default: 6 levels, fewer for small sizes).
    method: ``direct`` or ``sh`` (irradiance). dfg: include the split-sum DFG table.
    order: the ``sh`` mode's spherical-harmonic order M (bake.sh_reflection; size
    is not used there).
    ``model_or_fit``: a spec, a BRDF or a lobes.Fit (3d/2d).
    progress(fraction, message) is called after the fit and after every slice.
    """
    return run_steps(prefilter_steps(image, model_or_fit, mode, size, slices=slices,
                                     lobes_count=lobes_count, layout=layout, levels=levels,
                                     preset=preset, method=method, dfg=dfg,
                                     max_size=max_size, order=order), progress)


def prefilter_steps(image, model_or_fit, mode="3d", size=128, *, slices=16, lobes_count=1,
                    layout=None, levels=None, preset="khronos", method="direct", dfg=True,
                    max_size=None, threads=None, order=SH_ORDER, companion=None,
                    keep_unit_layers=False):
    """:func:`prefilter` as a generator: yields (fraction, message) after each step (the
    fit, each pair of slices filtered on two threads) and returns the BakedMap.

    Each step is a fraction of a second for the maps Auto chooses, so a
    caller that runs one step per UI timer tick stays responsive and can stop
    between steps (nothing has been written until the caller writes the map).
    Bad arguments raise BakeError before the first step.

    3d only: ``keep_unit_layers`` keeps each slice's filtered unit lobe in the
    returned map's ``unit_layers`` ({(k, j): layer}); ``companion``
    (:class:`Companion`) lets the slices its bound allows take those of another
    map (the high end of a split): this map then has that map's rows where Auto
    would choose fewer, and a companion with fewer rows is resampled up to this
    map's; ``meta["reused_slices"]`` lists the slices taken.
    """
    if mode not in MODES:
        raise BakeError(f"unknown mode {mode!r} (use one of: {', '.join(MODES)})")
    image, probe_layout = _check_probe(image, layout)
    if size not in (None, "auto"):
        size = _check_size(size)
    fit = model_or_fit if isinstance(model_or_fit, lobes.Fit) else None
    model = parse(fit.spec) if fit else (model_or_fit if isinstance(model_or_fit, BRDF)
                                        else parse(model_or_fit))
    if mode == "split-sum":
        if size in (None, "auto"):
            raise BakeError("the split-sum mode needs a face size (not auto)")
        return (yield from _split_sum(image, probe_layout, model, size, levels, preset, dfg))
    if mode == "sh":
        return (yield from _sh(image, probe_layout, model, order))
    maps = probe_maps(image, probe_layout)
    threads = threads or min(2, os.cpu_count() or 1)
    if mode == "irradiance":
        return (yield from _irradiance(maps, model, image, probe_layout, size, max_size,
                                       method))
    if mode == "phong":
        return (yield from _phong(maps, model, image, probe_layout, size, max_size, slices))
    if fit is None:
        if lobes_count != 1 and mode == "2d":
            raise BakeError("the 2D mode has a single lobe (lobes=1)")
        fit = lobes.fit(model, slices=slices, lobes=lobes_count, mode=mode)
        yield 0.1, "fitted the lobes"
    elif fit.mode != mode:
        raise BakeError(f"the fit is for mode {fit.mode}, not {mode}")
    jobs = [(k, j) for k in range(len(fit.slices)) for j in range(fit.lobes)
            if j < len(fit.slices[k].lobes)]
    halves = {(k, j): resolution.lobe_half_width(lobes.GAMMA, fit.slices[k].lobes[j].profile)
              for k, j in jobs}
    if mode == "2d":
        jobs = [(len(fit.slices) - 1, 0)]  # the shared shape (that of the last slice)
    layer_count = len(fit.slices) * fit.lobes if mode == "3d" else 1
    auto = size in (None, "auto")
    size, reason = _resolve_size(size, max_size, [halves[job] for job in jobs], image,
                                 probe_layout, layer_count)
    reused = companion.reusable(fit, jobs) if companion is not None and mode == "3d" else []
    if reused and auto and companion.size > size:
        size, reason = companion.size, (f"{companion.size} rows: the size of the map whose "
                                        f"lobes {len(reused)} slices take ({reason})")
    check_memory(size, layer_count)
    meta = _base_meta(mode, model, probe_layout, image.shape, size)
    meta.update({"slices": len(fit.slices), "lobes": fit.lobes, "mu": fit.mus.tolist(),
                 "offsets": [[lobe.offset for lobe in s.lobes] for s in fit.slices],
                 "albedo": [s.albedo for s in fit.slices],
                 "rms_error": [s.relative_rms_error for s in fit.slices],
                 "size_reason": reason,
                 "filter_rows": {f"{k}.{j}": filter_rows(halves[(k, j)], size)
                                 for k, j in jobs},
                 "precision": "float32"})

    meta["reused_slices"] = [f"{k}.{j}" for k, j in reused]
    all_jobs, jobs = jobs, [job for job in jobs if job not in reused]
    # Filter only the slices the others are mixes of (bake.slice_basis).
    if mode == "3d" and len(jobs) > 2:
        profiles = [fit.slices[k].lobes[j].profile for k, j in jobs]
        chosen, mixes, basis_errors = slice_basis.choose(profiles, lobes.GAMMA)
    else:
        chosen, mixes, basis_errors = list(range(len(jobs))), np.eye(len(jobs)), np.zeros(
            len(jobs))
    meta["filtered_slices"] = [f"{jobs[i][0]}.{jobs[i][1]}" for i in chosen]
    meta["mix_error"] = float(basis_errors.max()) if len(basis_errors) else 0.0

    def job(index):
        k, j = jobs[index]
        profile = fit.slices[k].lobes[j].profile
        return maps.filtered(profile, size, lambda: _filter(maps, _profile_kernel(profile),
                                                            size, halves[jobs[index]]))

    # The probe's working maps and spectra (shared, cached) as a step of their own,
    # so each later step is one batch of filtering.
    work_rows = sorted({filter_rows(halves[jobs[i]], size) for i in chosen}, reverse=True)
    for rows in work_rows:
        while rows >= resolution.MIN_ROWS:
            maps.spectrum(rows)
            rows //= 2
    yield 0.15, f"probe maps at {', '.join(map(str, work_rows))} rows"

    filtered = {}
    # Chosen slices are independent; NumPy's FFTs and products release the GIL,
    # so two threads use both cores. One step per batch of ``threads`` slices.
    with ThreadPoolExecutor(max_workers=threads) as pool:
        for start in range(0, len(chosen), threads):
            batch = chosen[start:start + threads]
            for index, layer in zip(batch, pool.map(job, batch), strict=True):
                filtered[index] = layer
            done = start + len(batch)
            yield 0.15 + 0.8 * done / len(chosen), f"filtered slice {done}/{len(chosen)} " \
                                                   f"({size} rows)"
    layers, units = {}, {}
    stack = np.stack([filtered[i] for i in chosen]) if chosen else None  # (r, H, W, 3)
    # A companion with fewer rows (Auto chose them for its own lobes, the ones taken
    # here) is resampled up to this map's rows (bilinear in latitude, probe_maps).
    units.update({(k, j): companion.unit_layers[(k, j)] if companion.size == size
                  else resample_rows(companion.unit_layers[(k, j)], size) for k, j in reused})
    for row, (k, j) in enumerate(jobs):
        mix = mixes[row]
        units[(k, j)] = np.tensordot(mix.astype(np.float32), stack, axes=1) \
            if row not in filtered else filtered[row]
    for k, j in all_jobs:
        layer = units[(k, j)]
        lobe = fit.slices[k].lobes[j]
        if mode == "2d":
            layers[""] = layer.copy()  # the filtered map may be shared (ProbeMaps.filtered)
        else:
            weight = np.asarray(lobe.weight, dtype=np.float32)
            layers[f"slice.{k}" if fit.lobes == 1 else f"lobe{j}.slice.{k}"] = layer * weight
    yield 1.0, f"combined {len(all_jobs)} slices from {len(chosen)} filtered" + (
        f" and {len(reused)} taken from the split's other map" if reused else "")
    if mode == "2d":
        meta["k"] = [s.lobes[0].weight for s in fit.slices]
        return BakedMap(mode, layers, meta)
    # Missing lobes of a slice have no offset (and no layer): pad with zeros.
    for k, s in enumerate(fit.slices):
        for j in range(len(s.lobes), fit.lobes):
            layers[f"lobe{j}.slice.{k}"] = np.zeros((size, 2 * size, 3), np.float32)
    meta["offsets"] = [offs + [0.0] * (fit.lobes - len(offs)) for offs in meta["offsets"]]
    baked = BakedMap(mode, layers, meta)
    if keep_unit_layers:
        baked.unit_layers, baked.unit_fit = units, fit
    return baked


def _phong(maps, model, image, probe_layout, size, max_size, slices):
    if model.name != "phong":
        raise BakeError(f"the phong mode filters Phong lobes; {model.spec} is not a phong BRDF")
    if np.any(np.asarray(model.params["kd"]) > 0):
        raise BakeError("the phong mode has no diffuse term: use kd=0 (and an irradiance map)")
    exponent = model.params["n"]

    def kernel(cos_gamma):
        return (exponent + 1.0) / (2.0 * np.pi) * np.clip(cos_gamma, 0.0, None) ** exponent

    half = _kernel_half_width(kernel)
    size, reason = _resolve_size(size, max_size, [half], image, probe_layout)
    check_memory(size, 1)
    mus = lobes.slice_nodes(int(slices))
    wo = np.stack([np.sqrt(1 - mus**2), np.zeros_like(mus), mus], -1)
    meta = _base_meta("phong", model, probe_layout, image.shape, size)
    meta.update({"slices": len(mus), "lobes": 1, "mu": mus.tolist(),
                 "offsets": [[0.0] for _ in mus], "k": model.albedo(wo).tolist(),
                 "exponent": exponent, "size_reason": reason})
    filtered = _filter(maps, kernel, size, half)
    yield 1.0, "filtered the Phong lobe"
    return BakedMap("phong", {"": filtered}, meta)


def irradiance_kernel(cos_gamma):
    """The clamped cosine over pi (1/sr): irradiance / pi, i.e. Lambert's reflected radiance."""
    return np.clip(cos_gamma, 0.0, None) / np.pi


def _irradiance(maps, model, image, probe_layout, size, max_size, method):
    if model.name != "lambert":
        raise BakeError(f"the irradiance mode is for lambert BRDFs, not {model.spec}")
    half = _kernel_half_width(irradiance_kernel)
    size, reason = _resolve_size(size, max_size, [half], image, probe_layout)
    check_memory(size, 1)
    meta = _base_meta("irradiance", model, probe_layout, image.shape, size)
    if method == "direct":
        # White irradiance, shared by every material's diffuse part (colour is applied
        # when the atlas is packed).
        irradiance = maps.filtered(irradiance_kernel(np.cos(lobes.GAMMA)), size,
                                   lambda: _filter(maps, irradiance_kernel, size, half)).copy()
    elif method == "sh":
        work = maps.latlong(size)
        coefficients = sh.project(work, "latlong")
        directions = get_layout("latlong").texel_directions(work.shape[:2])
        irradiance = sh.irradiance(coefficients, directions).astype(np.float32)
        meta["sh9"] = coefficients.tolist()
    else:
        raise BakeError(f"irradiance method must be 'direct' or 'sh', not {method!r}")
    meta.update({"method": method, "color": list(model.params["color"]),
                 "size_reason": reason})
    yield 1.0, "filtered the irradiance"
    return BakedMap("irradiance", {"irradiance": irradiance}, meta)


def _sh(image, probe_layout, model, order):
    """The spherical-harmonic path (bake.sh_reflection): environment and lobe
    coefficients to ``order``; a bump BRDF's lobe from its facets (eq. 7)."""
    from . import sh, sh_reflection

    order = int(order)
    if not 1 <= order <= 32:
        raise BakeError(f"the SH order must be between 1 and 32, not {order}")
    bump = getattr(model, "_bump_spec", None)
    if not model.isotropic and bump is None:
        raise BakeError(f"the sh mode needs an isotropic BRDF (or a bump: table), not "
                        f"{model.spec}")
    environment = sh.project(image, probe_layout, order)
    yield 0.2, f"projected the probe to order {order}"
    if bump is not None:
        from .bumpbrdf import BumpSurface, heights_of, parse_spec

        params = parse_spec(bump[len("bump:"):])
        surface = BumpSurface(heights_of(params), ior=params["ior"], k=params["k"],
                              mirror=bool(params["mirror"]))
        lobe = sh_reflection.facet_coefficients(surface, order)
        source = "facets"
    else:
        lobe = sh_reflection.lobe_coefficients(model, order)
        source = "quadrature"
    yield 1.0, f"lobe coefficients at {lobe.shape[0]} tilts ({source})"
    meta = _base_meta("sh", model, probe_layout, image.shape, order)
    meta.update({"order": order, "alphas": lobe.shape[0], "lobe_source": source,
                 "layout": "sh"})
    # One image (K + 1, N, 3): row 0 the environment's coefficients, rows 1..K the
    # lobe's at the K tilts (EXR layers share one size).
    layers = {"sh": np.concatenate([environment[None], lobe]).astype(np.float32)}
    return BakedMap("sh", layers, meta)


def _split_sum(image, probe_layout, model, size, levels, preset, dfg):
    if model.name not in ("ggx", "ggx_multiscatter", "principled_metallic") or not \
            model.isotropic:
        raise BakeError(f"the split-sum mode is for isotropic GGX BRDFs, not {model.spec}")
    if preset not in PRESETS:
        raise BakeError(f"unknown preset {preset!r} (use one of: {', '.join(PRESETS)})")
    if levels is None:
        levels = min(6, int(math.log2(size)) + 1)
    if int(levels) != levels or not 1 <= levels <= int(math.log2(size)) + 1:
        raise BakeError(f"levels must be in [1, {int(math.log2(size)) + 1}] for size {size}")
    levels = int(levels)
    roughness = [PRESETS[preset](index / max(levels - 1, 1)) for index in range(levels)]
    layers = {}
    cube = get_layout("cube")
    source = probe_maps(image, probe_layout)
    for index, r in enumerate(roughness):
        face = max(size >> index, 2)
        if r <= 1e-4:
            same = probe_layout == "cube" and image.shape[0] == face
            layers[f"level{index}"] = image.copy() if same else source.convert("cube", face)
        else:
            # Filter on a lat-long grid about twice as fine as the level's
            # faces, then read the result at the level's texel centres (as
            # cmgen and the Khronos sampler filter per texel direction).
            kernel = split_sum_kernel(r)
            half = _kernel_half_width(kernel)
            detail = latlong_detail_rows(image.shape, probe_layout)
            rows = int(min(max(2 * face, 32, resolution.rows_for_half_width(half)),
                           max(2 * face, 32, 3 * detail), 1024))
            filtered = _filter(source, kernel, rows, half)
            centres = cube.texel_directions(cube.shape(face))
            layers[f"level{index}"] = get_layout("latlong").sampler(filtered)(centres).astype(
                np.float32)
        yield (index + 1) / (levels + 1), f"split-sum level {index}"
    if dfg:
        layers["dfg"] = dfg_table().copy()
    yield 1.0, "DFG table"
    meta = _base_meta("split-sum", model, probe_layout, image.shape, size)
    material = float(np.sqrt(np.sqrt(model.ax * model.ay)))  # perceptual roughness
    f0 = list(model.params.get("base_color", model.params.get("color", (1.0, 1.0, 1.0))))
    meta.update({"layout": "cube", "levels": levels, "preset": preset,
                 "roughness_levels": roughness, "material_roughness": material, "f0": f0})
    return BakedMap("split-sum", layers, meta)
