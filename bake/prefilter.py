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
from pathlib import Path

import numpy as np

from . import __version__, exr, lobes, sh
from .brdf import BRDF, parse
from .brdf.microfacet import ggx_d
from .envmap import convert, get_layout
from .errors import BakeError
from .progress import report, scaled
from .zonal import suggested_supersample, zonal_convolve

__all__ = ["MODES", "PRESETS", "prefilter", "load", "BakedMap", "split_sum_kernel", "dfg_table"]

MODES = ("3d", "2d", "split-sum", "phong", "irradiance")
#: Level fraction x = l / (levels - 1) -> perceptual roughness of that level.
PRESETS = {
    "khronos": lambda x: x,  # glTF IBL sampler: lod = roughness * (levels - 1)
    "filament": lambda x: 1.0 - math.sqrt(max(1.0 - x, 0.0)),  # cmgen: lod = r (2 - r)
}
MAX_SIZE = 2048
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


def _filter(work, kernel, progress=None):
    """Zonal convolution of the working lat-long map (H, 2H, 3) -> (H, 2H, 3).

    A kernel much narrower than the sphere is split into a *core*, kept within
    6x its half width (tapered to 0 by 12x), filtered at the working
    resolution over the band of rows it reaches, and a *tail* (heavy GGX
    tails reach across the sphere), which is smooth on the scale of the core
    and so is filtered on a coarse copy of the map and interpolated back.
    Each part is normalized to its own exact integral, so the sum keeps the
    kernel's energy exactly (a constant map stays its constant).
    """
    height = work.shape[0]
    texel = np.pi / height
    half = _half_width(kernel)
    if half < 0.25 * texel / 8:
        # Narrower than the finest sub-texel spacing: below the map's
        # resolution the lobe's shape cannot matter, only its energy. Use a
        # Gaussian of a quarter texel carrying the same integral.
        from .zonal import kernel_integral

        energy = kernel_integral(kernel)
        sigma = 0.25 * texel

        def kernel(cos_gamma, energy=energy, sigma=sigma):
            gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
            return energy * np.exp(-0.5 * (gamma / sigma) ** 2) / (2 * np.pi * sigma**2)

        half = _half_width(kernel)
    supersample = suggested_supersample(half, texel)
    core_radius = 6.0 * half
    coarse_rows = int(np.clip(math.ceil(4.0 * np.pi / core_radius), 32, height))
    if core_radius >= np.pi / 2 or coarse_rows >= height:
        return zonal_convolve(work, kernel, supersample=supersample, progress=progress)

    def window(cos_gamma):
        gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
        x = np.clip((gamma - core_radius) / core_radius, 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    def core(cos_gamma):
        return kernel(cos_gamma) * window(cos_gamma)

    def tail(cos_gamma):
        return kernel(cos_gamma) * (1.0 - window(cos_gamma))

    result = zonal_convolve(work, core, supersample=supersample,
                            progress=scaled(progress, 0.0, 0.7))
    coarse = convert(work, "latlong", "latlong", coarse_rows)
    tail_map = zonal_convolve(coarse, tail, progress=scaled(progress, 0.7, 1.0))
    centres = get_layout("latlong").texel_directions(work.shape[:2])
    result = result + get_layout("latlong").sampler(tail_map)(centres).astype(np.float32)
    return result.astype(np.float32)


def _working_rows(kernel, minimum, probe_rows, cap=1024):
    """Lat-long rows for filtering: >= minimum, and fine enough that the kernel's
    half width spans about 2 texels, but no finer than 3x the probe's resolution."""
    width = _half_width(kernel)
    wanted = math.ceil(3.0 * np.pi / max(width, 1e-6))
    return int(min(max(minimum, wanted), max(minimum, 3 * probe_rows), cap))


def _probe_rows(image, layout):
    """Lat-long rows with about the probe's angular resolution."""
    if layout == "cube":
        return int(math.ceil(image.shape[0] * 1.5))  # cube texels: 2/N rad at face centres
    return image.shape[0]


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
        """Write the EXR (parameters in its header) and ``<path>.json`` beside it."""
        path = Path(path)
        if path.suffix.lower() != ".exr":
            raise BakeError(f"{path}: output file name must end in .exr")
        if self.mode == "split-sum":
            exr.write_parts(path, self.layers, self.meta)
        else:
            exr.write(path, self.layers, self.meta)
        sidecar = path.with_suffix(".json")
        temporary = sidecar.with_name(f".{sidecar.name}.{os.getpid()}.partial")
        temporary.write_text(json.dumps(self.meta, indent=1, sort_keys=True))
        os.replace(temporary, sidecar)
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


def prefilter(image, model_or_fit, mode="3d", size=128, *, slices=16, lobes_count=1,
              layout=None, levels=None, preset="khronos", method="direct", dfg=True,
              progress=None):
    """Prefilter a probe (cube strip or lat-long (H, W, 3)) for a BRDF; returns a BakedMap.

    size: lat-long output height N (maps are N x 2N), or the base cube face for
    ``split-sum``. slices / lobes_count: the lobe fit (3d, 2d, phong tables).
    levels / preset: the split-sum chain (default: 6 levels, fewer for small sizes).
    method: ``direct`` or ``sh`` (irradiance). dfg: include the split-sum DFG table.
    ``model_or_fit``: a spec, a BRDF or a lobes.Fit (3d/2d).
    """
    if mode not in MODES:
        raise BakeError(f"unknown mode {mode!r} (use one of: {', '.join(MODES)})")
    image, probe_layout = _check_probe(image, layout)
    size = _check_size(size)
    fit = model_or_fit if isinstance(model_or_fit, lobes.Fit) else None
    model = parse(fit.spec) if fit else (model_or_fit if isinstance(model_or_fit, BRDF)
                                        else parse(model_or_fit))
    if mode == "split-sum":
        return _split_sum(image, probe_layout, model, size, levels, preset, dfg, progress)
    work = convert(image, probe_layout, "latlong", size)
    meta = _base_meta(mode, model, probe_layout, image.shape, size)
    if mode == "irradiance":
        return _irradiance(work, model, meta, method, progress)
    if mode == "phong":
        return _phong(work, model, meta, slices, progress)
    if fit is None:
        fit = lobes.fit(model, slices=slices, lobes=lobes_count, mode=mode,
                        progress=scaled(progress, 0.0, 0.2))
    elif fit.mode != mode:
        raise BakeError(f"the fit is for mode {fit.mode}, not {mode}")
    meta.update({"slices": len(fit.slices), "lobes": fit.lobes, "mu": fit.mus.tolist(),
                 "offsets": [[lobe.offset for lobe in s.lobes] for s in fit.slices],
                 "albedo": [s.albedo for s in fit.slices],
                 "rms_error": [s.relative_rms_error for s in fit.slices]})
    layers = {}
    if mode == "2d":
        shape = fit.slices[-1].lobes[0].profile
        layers[""] = _filter(work, _profile_kernel(shape), scaled(progress, 0.2, 1.0))
        meta["k"] = [s.lobes[0].weight for s in fit.slices]
        return BakedMap(mode, layers, meta)
    jobs = [(k, j) for k in range(len(fit.slices)) for j in range(fit.lobes)]

    def job(item):
        k, j = item
        slice_fit = fit.slices[k]
        if j >= len(slice_fit.lobes):
            return item, np.zeros_like(work)
        lobe = slice_fit.lobes[j]
        filtered = _filter(work, _profile_kernel(lobe.profile))
        return item, filtered * np.asarray(lobe.weight, dtype=np.float32)

    # Slices are independent; NumPy's FFTs and products release the GIL, so
    # two threads use both cores.
    with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
        for done, ((k, j), layer) in enumerate(pool.map(job, jobs), start=1):
            layers[f"slice.{k}" if fit.lobes == 1 else f"lobe{j}.slice.{k}"] = layer
            report(progress, 0.2 + 0.8 * done / len(jobs),
                   f"filtered slice {k + 1}/{len(fit.slices)}")
    # Missing lobes of a slice have no offset: pad so every slice lists fit.lobes.
    meta["offsets"] = [offs + [0.0] * (fit.lobes - len(offs)) for offs in meta["offsets"]]
    return BakedMap(mode, layers, meta)


def _phong(work, model, meta, slices, progress):
    if model.name != "phong":
        raise BakeError(f"the phong mode filters Phong lobes; {model.spec} is not a phong BRDF")
    if np.any(np.asarray(model.params["kd"]) > 0):
        raise BakeError("the phong mode has no diffuse term: use kd=0 (and an irradiance map)")
    exponent = model.params["n"]

    def kernel(cos_gamma):
        return (exponent + 1.0) / (2.0 * np.pi) * np.clip(cos_gamma, 0.0, None) ** exponent

    mus = lobes.slice_nodes(int(slices))
    wo = np.stack([np.sqrt(1 - mus**2), np.zeros_like(mus), mus], -1)
    meta.update({"slices": len(mus), "lobes": 1, "mu": mus.tolist(),
                 "offsets": [[0.0] for _ in mus], "k": model.albedo(wo).tolist(),
                 "exponent": exponent})
    return BakedMap("phong", {"": _filter(work, kernel, progress)}, meta)


def _irradiance(work, model, meta, method, progress):
    if model.name != "lambert":
        raise BakeError(f"the irradiance mode is for lambert BRDFs, not {model.spec}")
    if method == "direct":
        def kernel(cos_gamma):
            return np.clip(cos_gamma, 0.0, None) / np.pi
        irradiance = _filter(work, kernel, progress)
    elif method == "sh":
        coefficients = sh.project(work, "latlong")
        directions = get_layout("latlong").texel_directions(work.shape[:2])
        irradiance = sh.irradiance(coefficients, directions).astype(np.float32)
        meta["sh9"] = coefficients.tolist()
    else:
        raise BakeError(f"irradiance method must be 'direct' or 'sh', not {method!r}")
    meta.update({"method": method, "color": list(model.params["color"])})
    return BakedMap("irradiance", {"irradiance": irradiance}, meta)


class _Source:
    """A probe with its exact 2x2 box MIP pyramid: conversions to smaller maps
    start from the level just finer than needed, so they stay cheap (few
    sub-samples per texel) without aliasing."""

    def __init__(self, image, layout):
        from .envmap.mip import pyramid

        self.layout = layout
        self.levels = pyramid(image, layout, "box") if layout in ("cube", "latlong") else [image]

    def convert(self, layout, size):
        source = get_layout(self.layout)
        target = get_layout(layout)
        needed = target.covered_texels(target.shape(size))
        chosen = self.levels[0]
        for level in self.levels:
            if source.covered_texels(level.shape[:2]) >= needed:
                chosen = level
        ratio = source.covered_texels(chosen.shape[:2]) / needed
        # A level already box-filtered close to the target's resolution needs
        # few sub-samples: 2 x 2 when it has at most 4x the target's texels.
        samples = 2 if ratio <= 4.0 else None
        return convert(chosen, self.layout, layout, size, samples=samples)


def _split_sum(image, probe_layout, model, size, levels, preset, dfg, progress):
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
    source = _Source(image, probe_layout)
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
            rows = _working_rows(kernel, max(2 * face, 32), _probe_rows(image, probe_layout))
            work = source.convert("latlong", rows)
            filtered = _filter(work, kernel)
            centres = cube.texel_directions(cube.shape(face))
            layers[f"level{index}"] = get_layout("latlong").sampler(filtered)(centres).astype(
                np.float32)
        report(progress, (index + 1) / (levels + 1), f"split-sum level {index}")
    if dfg:
        layers["dfg"] = dfg_table().copy()
    report(progress, 1.0, "DFG table")
    meta = _base_meta("split-sum", model, probe_layout, image.shape, size)
    material = float(np.sqrt(np.sqrt(model.ax * model.ay)))  # perceptual roughness
    f0 = list(model.params.get("base_color", model.params.get("color", (1.0, 1.0, 1.0))))
    meta.update({"layout": "cube", "levels": levels, "preset": preset,
                 "roughness_levels": roughness, "material_roughness": material, "f0": f0})
    return BakedMap("split-sum", layers, meta)
