"""A probe's lat-long working maps and their row spectra, made once and shared.

Every slice and lobe of every material baked from one probe filters the same
lat-long images (at the few row counts the lobes need), and zonal filtering
needs only their per-row longitude spectra (bake.zonal.row_spectrum). A
:class:`ProbeMaps` converts the probe to each row count once, from an exact
2x2 box MIP pyramid of the probe (so a small map is cheap to make and does
not alias), and keeps the conversions and their spectra, and the maps it
was filtered into per lobe shape and size. :func:`probe_maps`
returns the same object for the same probe content in one process, so the
transforms are shared between the materials of a bake and between bakes of
an unchanged probe in a Blender session.

Images are (H, W, 3) float32 lat-long maps, W = 2H, row 0 at the zenith.
"""

import hashlib
import math
import threading
from collections import OrderedDict

import numpy as np

from .envmap import convert, get_layout
from .envmap.convert import convert_changed
from .zonal import row_spectrum

__all__ = ["ProbeMaps", "probe_maps", "residual_maps", "resample_rows", "clear_cache"]

#: Probes kept in the process-wide cache (least recently used dropped first).
CACHE_PROBES = 3
#: Bytes of filtered lobe maps kept per probe (ProbeMaps.filtered).
FILTERED_BYTES = 256 << 20
_cache: "OrderedDict[tuple, ProbeMaps]" = OrderedDict()
_cache_lock = threading.Lock()


class ProbeMaps:
    """Lat-long conversions of one probe at any row count, with their row spectra.

    image: (H, W, 3) float32 probe in ``layout`` (``cube`` strip or ``latlong``).
    Thread-safe: two filtering threads asking for the same rows share one
    conversion.
    """

    def __init__(self, image, layout, parent=None):
        from .envmap.mip import pyramid

        self.layout = layout
        self.shape = image.shape
        self.levels = pyramid(image, layout, "box") if layout in ("cube", "latlong") else [image]
        #: A ProbeMaps of an image of the same shape and layout that differs from this
        #: one on a few texels (the probe this residual's lights were taken from:
        #: :func:`residual_maps`); conversions are then its own, recomputed only
        #: near those texels (bake.envmap.convert.convert_changed).
        self.parent = parent if parent is not None and parent.layout == layout and \
            parent.shape == image.shape and layout in ("cube", "latlong") else None
        self._plain: dict = {}
        self._maps: dict = {}
        self._spectra: dict = {}
        self._lock = threading.Lock()
        self._row_locks: dict = {}
        self._filtered: OrderedDict[tuple, np.ndarray] = OrderedDict()
        self._filtered_bytes = 0
        self._kept: dict = {}
        #: How many conversions, transforms and lobe filterings were computed, and
        #: how many filterings were reused (for tests and benchmarks).
        self.computed = {"maps": 0, "spectra": 0, "filtered": 0, "reused": 0}

    def convert(self, layout, size):
        """The probe in ``layout`` at ``size``, from the finest pyramid level needed."""
        source = get_layout(self.layout)
        target = get_layout(layout)
        needed = target.covered_texels(target.shape(size))
        chosen = self.levels[0]
        for level in self.levels:
            if source.covered_texels(level.shape[:2]) >= needed:
                chosen = level
        ratio = source.covered_texels(chosen.shape[:2]) / needed
        samples = self.samples_for(ratio)
        if self.parent is not None and layout == "latlong":
            index = next(i for i, level in enumerate(self.levels) if level is chosen)
            before = self.parent.levels[index]
            return convert_changed(lambda: self.parent.latlong(size), chosen,
                                   np.any(chosen != before, axis=-1), self.layout, size,
                                   samples=samples)
        return convert(chosen, self.layout, layout, size, samples=samples)

    def plain(self, rows: int):
        """(rows, 2 rows, 3) float32: bake.envmap.convert of the probe itself (not of a
        pyramid level, with convert's own sub-samples) to a lat-long map, as
        bake.sampling_atlas.pack_levels converts it (cached; do not modify)."""
        rows = int(rows)
        with self._row_lock(("plain", rows)):
            if rows not in self._plain:
                image = self.levels[0]
                if self.parent is not None:
                    self._plain[rows] = convert_changed(
                        lambda: self.parent.plain(rows), image,
                        np.any(image != self.parent.levels[0], axis=-1), self.layout, rows)
                else:
                    self._plain[rows] = convert(image, self.layout, "latlong", rows)
                self.computed["maps"] += 1
            return self._plain[rows]

    @staticmethod
    def samples_for(ratio):
        """Sub-samples per target texel side for a source level with ``ratio`` times the
        target's texels (None: envmap.convert's own rule). A level already
        box-filtered close to the target's resolution needs few: 2 x 2 when it
        has at most 4x the target's texels, one (the bilinear reconstruction
        itself) when the target is finer."""
        return 1 if ratio <= 1.0 else (2 if ratio <= 4.0 else None)

    def _row_lock(self, rows):
        with self._lock:
            return self._row_locks.setdefault(rows, threading.Lock())

    def latlong(self, rows: int):
        """(rows, 2 rows, 3) float32 lat-long map of the probe (cached; do not modify)."""
        rows = int(rows)
        with self._row_lock(rows):
            if rows not in self._maps:
                self._maps[rows] = self.convert("latlong", rows)
                self.computed["maps"] += 1
            return self._maps[rows]

    def spectrum(self, rows: int):
        """Row spectra (rows, rows + 1, 3) complex of :meth:`latlong` (cached)."""
        rows = int(rows)
        image = self.latlong(rows)
        with self._row_lock(rows):
            if rows not in self._spectra:
                self._spectra[rows] = row_spectrum(image)
                self.computed["spectra"] += 1
            return self._spectra[rows]


    def kept(self, key, compute):
        """``compute()`` the first time this hashable ``key`` is asked for, the kept
        result after: other products of the probe alone that every material
        shares (bake.sampling_runtime's pre-blurred level stack). Do not modify
        the result."""
        with self._lock:
            if key in self._kept:
                self.computed["reused"] += 1
                return self._kept[key]
        result = compute()
        with self._lock:
            return self._kept.setdefault(key, result)

    def filtered(self, profile, rows: int, compute):
        """The probe filtered by a lobe of this profile at ``rows`` rows: ``compute()`` the
        first time, the kept result after (for another material or bake with the same
        lobe shape, e.g. the same roughness in another colour).

        profile: the lobe's unit-integral profile (bake.lobes.GAMMA nodes); it is
        keyed after rounding to 9 significant digits of its peak, so profiles equal
        up to floating-point noise share one map. Results are kept up to
        FILTERED_BYTES (least recently used dropped first); do not modify them.
        """
        profile = np.asarray(profile, dtype=np.float64)
        scale = float(np.abs(profile).max()) or 1.0
        key = (hashlib.blake2b(np.round(profile / scale, 9).tobytes(), digest_size=16)
               .hexdigest(), f"{scale:.9g}", int(rows))
        with self._lock:
            if key in self._filtered:
                self._filtered.move_to_end(key)
                self.computed["reused"] += 1
                return self._filtered[key]
        result = compute()
        with self._lock:
            if key not in self._filtered:
                self._filtered[key] = result
                self._filtered_bytes += result.nbytes
                self.computed["filtered"] += 1
            while self._filtered_bytes > FILTERED_BYTES and len(self._filtered) > 1:
                _, dropped = self._filtered.popitem(last=False)
                self._filtered_bytes -= dropped.nbytes
            return self._filtered[key]


def _digest(image, layout):
    data = np.ascontiguousarray(image, dtype=np.float32)
    return (layout, data.shape, hashlib.blake2b(data.tobytes(), digest_size=16).hexdigest())


def _cached(image, layout, make) -> ProbeMaps:
    """The cached :class:`ProbeMaps` of this image content, or ``make()``'s, cached."""
    key = _digest(image, layout)
    with _cache_lock:
        maps = _cache.get(key)
        if maps is not None:
            _cache.move_to_end(key)
            return maps
    maps = make()
    with _cache_lock:
        maps = _cache.setdefault(key, maps)
        _cache.move_to_end(key)
        while len(_cache) > CACHE_PROBES:
            _cache.popitem(last=False)
    return maps


def probe_maps(image, layout) -> ProbeMaps:
    """The shared :class:`ProbeMaps` of this probe content (made on first use)."""
    return _cached(image, layout, lambda: ProbeMaps(np.asarray(image, dtype=np.float32), layout))


def residual_maps(residual, layout, probe) -> ProbeMaps:
    """The shared :class:`ProbeMaps` of ``residual`` (H, W, 3), a copy of ``probe`` changed
    on a few texels (its small bright lights taken out, bake.world_lights.split_for),
    made with ``probe``'s as its parent: its lat-long conversions are the probe's,
    recomputed only near the changed texels, so the materials of one probe, each
    with its own lights, share the probe's conversions. :func:`probe_maps` of the
    same residual returns it after."""
    return _cached(residual, layout, lambda: ProbeMaps(
        np.asarray(residual, dtype=np.float32), layout, parent=probe_maps(probe, layout)))


def clear_cache():
    """Forget every cached probe (frees their memory)."""
    with _cache_lock:
        _cache.clear()


def _axis_weights(source_count, target_count, periodic):
    """Indices (i0, i1) and weight t of linear interpolation from cell centres of one
    uniform grid to another over the same interval (periodic, or with end nodes)."""
    x = (np.arange(target_count) + 0.5) * source_count / target_count - 0.5
    if periodic:
        i0 = np.floor(x).astype(int)
        t = x - i0
        return np.mod(i0, source_count), np.mod(i0 + 1, source_count), t
    # Non-periodic axis (latitude): nodes are the source centres plus the two
    # poles at -0.5 and source_count - 0.5, held at indices 0 and count + 1.
    x = np.clip(x, -0.5, source_count - 0.5)
    nodes = np.concatenate([[-0.5], np.arange(source_count), [source_count - 0.5]])
    i0 = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, source_count)
    t = (x - nodes[i0]) / (nodes[i0 + 1] - nodes[i0])
    return i0, i0 + 1, t


def resample_rows(image, rows: int):
    """A lat-long map (H, 2H, C) resampled to (rows, 2 rows, C) by bilinear interpolation
    in (theta, phi), the poles taking the mean of their nearest ring (float32).

    Used to bring a map filtered at the resolution its lobe needs to the
    material's map size: for a map filtered by a lobe that spans several of
    its texels, the interpolation error is a small fraction of the lobe's own
    blur (measured in bake.resolution's curve).
    """
    image = np.asarray(image, dtype=np.float32)
    height, width = image.shape[:2]
    rows = int(rows)
    if rows == height and 2 * rows == width:
        return image
    north = image[:1].mean(axis=1, keepdims=True).repeat(width, 1)
    south = image[-1:].mean(axis=1, keepdims=True).repeat(width, 1)
    padded = np.concatenate([north, image, south])
    r0, r1, tr = _axis_weights(height, rows, periodic=False)
    tr = tr.astype(np.float32)[:, None, None]
    by_rows = padded[r0] * (1 - tr) + padded[r1] * tr
    factor, remainder = divmod(2 * rows, width)
    if factor > 1 and remainder == 0:
        # An integer upsampling in longitude: output column p + factor k lies between
        # input columns k - 1 and k (p < factor / 2) or k and k + 1, at the same
        # fraction for every k, so each phase p is a weighted sum of two
        # shifted slices of the input (wrapped at the seam) rather than gathers.
        wrapped = np.concatenate([by_rows[:, -1:], by_rows, by_rows[:, :1]], axis=1)
        out = np.empty((rows, 2 * rows, image.shape[2]), np.float32)
        for phase in range(factor):
            x = (phase + 0.5) / factor - 0.5
            first = math.floor(x)
            t = np.float32(x - first)
            start = 1 + first
            out[:, phase::factor] = (wrapped[:, start:start + width] * (1 - t)
                                     + wrapped[:, start + 1:start + 1 + width] * t)
        return out
    c0, c1, tc = _axis_weights(width, 2 * rows, periodic=True)
    tc = tc.astype(np.float32)[None, :, None]
    return (by_rows[:, c0] * (1 - tc) + by_rows[:, c1] * tc).astype(np.float32)


def latlong_detail_rows(shape, layout) -> int:
    """Lat-long rows whose equatorial texel matches the probe's finest angular spacing.

    cube (N, 6N): a face texel at the face centre spans 2 / N rad, so
    rows = ceil(pi N / 2); lat-long (H, 2H): H.
    """
    if layout == "cube":
        return int(math.ceil(math.pi * shape[0] / 2.0))
    return int(shape[0])
