"""Command line of the baker: ``python -m bake <command> ...`` (DESIGN.md).

Every error a user can cause ends as one line on stderr and exit status 2,
with no output file left behind (outputs are written atomically, after all
checks). Progress goes to stderr; the list of files written to stdout.
"""

import argparse
import json
import os
import signal
import sys
import threading
import warnings
from pathlib import Path

import numpy as np

from . import __version__, exr, outputs
from .blas_threads import limited as limited_blas
from .envmap import LAYOUTS, convert, get_layout, mip
from .envmap.convert import supersampling
from .errors import BakeError
from .progress import LinePrinter, report, scaled

__all__ = ["main", "run"]

#: Work (sub-samples) above which the command line shows a progress line.
PROGRESS_THRESHOLD = 1 << 20

LAYOUT_NOTES = {
    "latlong": "Blender Environment Texture: u = 0.5 - atan2(y, x) / 2pi, row 0 = zenith (+Z)",
    "cube": "OpenGL cube faces in glTF's Y-up frame (x, z, -y); strip N x 6N, faces "
    "+X', -X', +Y', -Y', +Z', -Z' = Blender +X, -X, +Z, -Z, -Y, +Y",
    "paraboloid": "dual paraboloid, front (left half) faces +Z, back (right half) -Z; "
    "extended [-1, 1]^2 domain; s along +X, t along +Y (up)",
    "sphere": "sphere map of a mirror ball seen from -Y, +Z up, +X right; centre = -Y, rim = +Y",
}


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


#: Modes of the textures Glossy bakes that are not environment maps.
BAKED_TEXTURES = ("atlas_runtime", "atlas_levels")


def _guess_layout(shape, meta, path):
    if meta.get("mode") in BAKED_TEXTURES:
        raise BakeError(f"{path}: a texture Glossy baked ({meta['mode']}), not an "
                        f"environment map; give the probe or HDRI it was baked from")
    declared = meta.get("layout")
    if declared in LAYOUTS:
        return declared
    height, width = shape
    if width == 6 * height:
        return "cube"
    if width == height:
        return "sphere"
    if width == 2 * height:
        return "latlong"
    raise BakeError(
        f"{path}: cannot tell the layout of a {height}x{width} image; pass --from"
    )


#: Smallest environment map the commands accept (rows).
MIN_ROWS = 2


def _read_rgb(path, sanitize):
    """(H, W, 3) float32 radiance and the file's metadata. RGBA drops A; a
    one-channel (Y) map becomes grey RGB; anything else is refused."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image, meta = exr.read(path, nonfinite="sanitize" if sanitize else "error")
    for warning in caught:
        print(f"warning: {warning.message}", file=sys.stderr)
    if isinstance(image, dict):
        if "" not in image:
            raise BakeError(f"{path}: several layers and no unnamed one ({', '.join(image)})")
        image = image[""]
    channels = image.shape[2]
    if channels == 1:
        image = np.repeat(image, 3, axis=2)
    elif channels == 4:
        image = image[:, :, :3]
    elif channels != 3:
        raise BakeError(f"{path}: has {channels} colour channels; an environment map needs "
                        f"R, G, B (or one Y channel)")
    if min(image.shape[:2]) < MIN_ROWS:
        raise BakeError(f"{path}: a {image.shape[0]}x{image.shape[1]} image is too small for "
                        f"an environment map (at least {MIN_ROWS} pixels each way)")
    return image, meta


def _progress_for(work, quiet):
    return None if quiet or work < PROGRESS_THRESHOLD else LinePrinter()


def _meta(args, layout, shape, extra=None):
    meta = {
        "generator": f"glossy-bake {__version__}",
        "layout": layout,
        "size": int(get_layout(layout).size_of(shape)),
        "convention": LAYOUT_NOTES[layout],
        "source": Path(args.input).name,
    }
    meta.update(extra or {})
    return meta


def _check_output(path, *inputs):
    return outputs.check_target(path, ".exr", inputs)


def cmd_convert(args):
    output = _check_output(args.output, args.input)
    target = get_layout(args.to)
    shape = target.shape(args.size)
    image, meta = _read_rgb(args.input, args.sanitize)
    source = args.source or _guess_layout(image.shape[:2], meta, args.input)
    source_layout = get_layout(source)
    source_layout.check_image(image)
    k = args.samples or supersampling(source_layout, image.shape[:2], target, shape)
    progress = _progress_for(shape[0] * shape[1] * k * k, args.quiet)
    result = convert(image, source, args.to, args.size, samples=k, progress=progress)
    extra = {"source_layout": source, "samples_per_side": k}
    exr.write(output, result, _meta(args, args.to, shape, extra))
    print(f"wrote {output} ({args.to}, {shape[0]}x{shape[1]}, {result.shape[2]} channels)")


def cmd_mip(args):
    output = _check_output(args.output, args.input)
    image, meta = _read_rgb(args.input, args.sanitize)
    layout = args.layout or _guess_layout(image.shape[:2], meta, args.input)
    progress = _progress_for(image.shape[0] * image.shape[1] * 4, args.quiet)
    levels = mip.pyramid(image, layout, args.filter, args.levels, progress=progress)
    stem = output.with_suffix("")
    paths = [stem.with_name(f"{stem.name}.mip{index}.exr") for index in range(len(levels))]
    for path in paths:  # all checked before the first is written
        outputs.check_implicit(_check_output(path, args.input), "MIP level")
    with outputs.Staged() as staged:
        for index, (path, level) in enumerate(zip(paths, levels, strict=True)):
            extra = {"mip_level": index, "mip_filter": args.filter, "mip_levels": len(levels)}
            level_meta = _meta(args, layout, level.shape[:2], extra)
            staged.add(path, lambda target, level=level, level_meta=level_meta:
                       exr.write(target, level, level_meta))
    for index, (path, level) in enumerate(zip(paths, levels, strict=True)):
        print(f"wrote {path} ({layout} level {index}, {level.shape[0]}x{level.shape[1]})")


def spec_from_blend(blend, material) -> dict:
    """{spec, ignored, approximated} of ``material`` in ``blend``, read by
    glossy_addon.node_reader in a subprocess running glossy_addon/read_blend.py
    with the bpy module (bake never imports bpy). Raises BakeError with the reason."""
    import json
    import subprocess

    blend = Path(blend)
    if not blend.is_file():
        raise BakeError(f"--from-blend: {blend} does not exist")
    root = Path(__file__).resolve().parents[1]
    script = root / "glossy_addon" / "read_blend.py"
    process = subprocess.run([sys.executable, str(script), str(root), str(blend.resolve()),
                              material], capture_output=True, text=True, timeout=600)
    lines = [line for line in process.stdout.splitlines() if line.startswith("{")]
    if process.returncode != 0 or not lines:
        tail = (process.stderr.strip().splitlines() or ["no output"])[-1]
        raise BakeError(f"--from-blend: could not read {blend.name}: {tail}")
    found = json.loads(lines[-1])
    if "error" in found:
        raise BakeError(found["error"])
    return found


def cmd_brdf(args):
    from . import brdf
    from .brdf.plot import albedo_curve, plot_brdf

    if (args.spec is None) == (args.from_blend is None):
        raise BakeError("brdf: give a spec, or --from-blend FILE.blend --material NAME")
    if args.from_blend is not None:
        if not args.material:
            raise BakeError("brdf: --from-blend needs --material NAME")
        found = spec_from_blend(args.from_blend, args.material)
        args.spec = found["spec"]
        for line in found["ignored"]:
            print(f"ignored: {line}")
        for line in found["approximated"]:
            print(f"approximated: {line}")
    model = brdf.parse(args.spec)
    if args.plot:
        outputs.check_target(args.plot, ".png", what="--plot")
    print(f"spec: {model.spec}")
    print(f"hash: {model.spec_hash()}  reciprocal: {model.reciprocal}  "
          f"isotropic: {model.isotropic}")
    theta, rho = albedo_curve(model, n=7)
    for angle, value in zip(theta, rho, strict=True):
        print(f"albedo at theta_o = {angle:4.1f} deg: {value.round(4).tolist()}")
    if args.plot:
        print(f"wrote {plot_brdf(model, args.plot)}")


def cmd_fit(args):
    from . import lobes

    output = outputs.check_target(args.output, ".json")
    progress = None if args.quiet else LinePrinter()
    result = lobes.fit(args.brdf, slices=args.slices, lobes=args.lobes, mode=args.mode,
                       progress=progress, centre=args.centre)
    result.save(output)
    for s in result.slices:
        print(f"cos(theta_o) = {s.mu:.3f}: {len(s.lobes)} lobe(s), offsets "
              f"{[round(lobe.offset, 4) for lobe in s.lobes]} rad, relative RMS error "
              f"{s.relative_rms_error:.4f}")
    print(f"wrote {output}")


def cmd_prefilter(args, mode=None):
    from . import prefilter

    output = _check_output(args.output, args.input)
    outputs.check_implicit(output.with_suffix(".json"), "map's .json sidecar")
    mode = mode or args.mode
    brdf_spec = args.brdf if mode != "irradiance" else "lambert:color=1"
    if mode != "irradiance":
        from .brdf import parse

        model = parse(brdf_spec)  # a bad spec is refused before the probe is read
        if not model.isotropic and mode in ("3d", "2d"):
            raise BakeError(f"{model.spec} is anisotropic: the {mode} map's lobe fitting needs "
                            f"an isotropic BRDF{_sampling_hint(model.spec)}")
    image, meta = _read_rgb(args.input, args.sanitize)
    layout = args.source or _guess_layout(image.shape[:2], meta, args.input)
    progress = None if args.quiet else LinePrinter()
    baked = prefilter.prefilter(image, brdf_spec, mode, args.size, slices=args.slices,
                                lobes_count=args.lobes, layout=layout, levels=args.levels,
                                preset=args.preset, method=args.method,
                                max_size=args.max_size, order=args.order, progress=progress)
    baked.meta["source"] = Path(args.input).name
    baked.write(output)
    reason = baked.meta.get("size_reason")
    print(f"wrote {output} ({mode}, {len(baked.layers)} layer(s)"
          f"{'; ' + reason if reason else ''}) and {output.with_suffix('.json')}")


def _sampling_hint(spec) -> str:
    """"; python -m bake sample ..." when runtime sampling takes BRDF ``spec``."""
    from .sampling_runtime import check

    try:
        check(spec)
    except BakeError:
        return ""
    return "; `python -m bake sample` bakes it for runtime sampling"


def cmd_sample(args):
    """Runtime regular sampling's texture (bake.sampling_runtime.pack) of a probe, and
    with ``--map`` the Hybrid: the 3D map of the same probe without its lights, the
    blend weights w(mu) in the texture's metadata (bake.hybrid)."""
    from . import (
        brdf,
        hybrid,
        prefilter,
        probe_content,
        probe_lights,
        sampling_runtime,
        world_lights,
    )
    from .atlas import storage_precision

    output = _check_output(args.output, args.input)
    sidecar = outputs.check_implicit(output.with_suffix(".json"),
                                     "runtime texture's .json sidecar")
    map_path = None
    if args.map:
        map_path = _check_output(args.map, args.input)
        if outputs.same_file(map_path, output):
            raise BakeError(f"{map_path}: --map and -o name the same file")
        outputs.check_implicit(map_path.with_suffix(".json"), "map's .json sidecar")
    model = brdf.parse(args.brdf)
    lobe, _ = sampling_runtime.check(model.spec, args.samples)  # before the probe is read
    if map_path is not None and lobe.anisotropic:
        raise BakeError(f"{model.spec} is anisotropic: the Hybrid's 3D map needs an isotropic "
                        f"lobe; leave out --map (runtime sampling alone follows anisotropy)")
    image, meta = _read_rgb(args.input, args.sanitize)
    layout = args.source or _guess_layout(image.shape[:2], meta, args.input)
    image = get_layout(layout).check_image(image)
    for name, value in (("--height", args.height), ("--max-size", args.max_size)):
        if value is not None and not 4 <= value <= prefilter.MAX_SIZE:
            raise BakeError(f"{name} must be a whole number in [4, {prefilter.MAX_SIZE}], "
                            f"not {value}")
    cap = args.max_size or prefilter.DEFAULT_MAX_SIZE
    rows, why = sampling_runtime.stack_height(image.shape, layout, fixed=args.height, cap=cap,
                                              names=("--height", f"--max-size {cap}"),
                                              alone=map_path is None and
                                              sampling_runtime.near_mirror(lobe),
                                              content_shape=probe_content.of_probe(
                                                  image, layout).shape)
    prefilter.check_memory(rows, 2, "level stack")
    progress = None if args.quiet else LinePrinter()
    residual, lights = image, ()
    if not args.no_lights:
        report(progress, 0.0, "taking the probe's small bright lights out")
        if layout == "latlong":  # the world itself: its texels as Cycles spreads them
            residual, lights = world_lights.split_latlong(image, lobe.mx, lobe.my)
        else:
            residual, lights = probe_lights.extract_kept(image, layout, lobe.mx, lobe.my)
    report(progress, 0.1, f"pre-blurring {rows}-row probe levels and the albedo table")
    atlas, atlas_meta = sampling_runtime.pack(residual, model.spec, layout=layout,
                                              budget=args.samples, height=rows, lights=lights)
    reason = f"runtime sampling: {sampling_runtime.stack_reason(atlas_meta, why)}"
    if not args.no_lights:
        reason += f"; {probe_lights.describe(lights)}"
    baked = None
    if map_path is not None:
        baked = prefilter.prefilter(residual, model.spec, "3d", args.size, slices=args.slices,
                                    lobes_count=args.lobes, layout=layout,
                                    max_size=args.max_size,
                                    progress=scaled(progress, 0.4, 0.95))
        baked.meta["source"] = Path(args.input).name
        baked.meta["hybrid_runtime"] = output.name
        centres, weights = hybrid.weight_curve(float(np.sqrt(atlas_meta["ax"])),
                                               samples=len(atlas_meta["prob"]),
                                               kind=atlas_meta.get("kind", "ggx"))
        atlas_meta.update({"blend_mu": centres.tolist(), "blend_weight": weights.tolist(),
                           "hybrid_map": map_path.name})
        reason += f"; the Hybrid's 3D map: {baked.meta['size_reason']}"
    half = storage_precision(atlas) == "half"
    atlas_meta.update({
        "generator": f"glossy-bake {__version__}", "source": Path(args.input).name,
        "probe": {"layout": layout, "shape": list(image.shape[:2])}, "size": rows,
        "size_reason": reason, "precision": "half" if half else "float32"})
    text = json.dumps(atlas_meta, indent=1, sort_keys=True)
    with outputs.Staged() as staged:
        staged.add(output, lambda target: exr.write(target, atlas, atlas_meta, half=half))
        staged.add(sidecar, lambda target: Path(target).write_text(text))
        if baked is not None:
            baked.write_staged(staged, map_path)
    report(progress, 1.0, "written")
    print(f"wrote {output} and {sidecar.name} ({reason})"
          + (f", {map_path} and {map_path.with_suffix('.json').name}" if baked else ""))


def _pixels(args):
    """(normals (H, W, 3), views (H, W, 3), mask (H, W), where, tangents) of ``--sphere
    SIZE`` or ``--buffers EXR`` (its 'normal' layer and a 'view' layer, or 'position'
    and ``--camera``; a 'tangent' layer orients anisotropic lobes, else
    bake.reference's hint frame), unit vectors (tangents as given, or None);
    ``where``: what the output's header records."""
    from . import reference

    tangents = None
    if args.buffers:
        layers, _ = exr.read(args.buffers, layers=True)
        normals = reference.vector_layer(layers, "normal", args.buffers)
        if reference.has_layer(layers, "tangent"):
            tangents = reference.vector_layer(layers, "tangent", args.buffers)
        if reference.has_layer(layers, "view"):
            views = reference.vector_layer(layers, "view", args.buffers)
        else:
            if args.camera is None:
                raise BakeError(f"{args.buffers}: no 'view' layer; give --camera X,Y,Z to "
                                f"compute views from its 'position' layer")
            positions = reference.vector_layer(layers, "position", args.buffers)
            views = np.asarray(args.camera) - positions
        length = np.linalg.norm(normals, axis=-1)
        mask = (length > 0.5) & (np.linalg.norm(views, axis=-1) > 0)
        normals = normals / np.where(length > 0, length, 1.0)[..., None]
        views = views / np.maximum(np.linalg.norm(views, axis=-1, keepdims=True), 1e-30)
        where = {"buffers": Path(args.buffers).name, "camera": args.camera,
                 "tangents": "the buffers' tangent layer" if tangents is not None else
                 "bake.reference's hint frame"}
    else:
        normals, views, mask = reference.sphere_buffers(args.sphere, args.distance, args.lens)
        where = {"sphere": args.sphere, "distance": args.distance, "lens_mm": args.lens}
    if not mask.any():
        raise BakeError("no pixel to render: the buffers hold no surface")
    return normals, views, mask, where, tangents


def _rgba(mask, radiance):
    """(H, W, 4) float32: ``radiance`` (N, 3) at the ``mask``'s pixels, A = surface."""
    image = np.zeros((*mask.shape, 4), dtype=np.float32)
    image[mask, :3] = radiance
    image[mask, 3] = 1.0
    return image


def cmd_reference(args):
    from . import brdf, reference

    output = _check_output(args.output, args.input, *([args.buffers] if args.buffers else []))
    model = brdf.parse(args.brdf)
    probe, meta = _read_rgb(args.input, args.sanitize)
    layout = args.source or _guess_layout(probe.shape[:2], meta, args.input)
    normals, views, mask, where, tangents = _pixels(args)
    pixels = int(mask.sum())
    progress = None if args.quiet else LinePrinter()
    radiance = reference.render(model, probe, layout, normals[mask], views[mask],
                                tangents=None if tangents is None else tangents[mask],
                                tolerance=args.tolerance, progress=progress,
                                reconstruction=args.reconstruction)
    exr.write(output, _rgba(mask, radiance), _meta(args, layout, probe.shape[:2], {
        "kind": "reference", "brdf": model.spec, "probe": Path(args.input).name,
        "pixels": pixels, "tolerance": args.tolerance,
        "reconstruction": args.reconstruction, **where}))
    print(f"wrote {output} ({pixels} pixels, {model.spec} against {Path(args.input).name})")


def cmd_lookup(args):
    """What a baked file gives at each pixel: the NumPy twin of the lookup Blender's
    node groups do (BakedMap.shade; bake.sampling_runtime.shade; bake.hybrid.shade
    for a runtime texture with the Hybrid's weights and its 3D map)."""
    from . import hybrid, prefilter, sampling_runtime

    inputs = [args.input] + ([args.buffers] if args.buffers else []) + \
        ([args.map] if args.map else [])
    output = _check_output(args.output, *inputs)
    header = exr.read_header(args.input)
    raw = header.get(exr.META_ATTRIBUTE)
    meta = json.loads(raw) if raw else {}
    mode = meta.get("mode")
    runtime = mode == sampling_runtime.MODE
    if not runtime and mode not in prefilter.MODES:
        raise BakeError(f"{args.input}: not a map or runtime texture Glossy baked (mode "
                        f"{mode!r}); `python -m bake prefilter` or `sample` writes one")
    map_path = args.map
    if runtime and map_path is None and meta.get("hybrid_map"):
        map_path = str(Path(args.input).with_name(meta["hybrid_map"]))
        if not Path(map_path).exists():
            raise BakeError(f"{args.input}: its Hybrid map {meta['hybrid_map']} is not beside "
                            f"it; pass --map, or --no-map for runtime sampling alone")
    if args.no_map:
        map_path = None
    if map_path is not None and not runtime:
        raise BakeError(f"{args.input}: --map goes with a runtime texture (the Hybrid)")
    if map_path is not None and "blend_mu" not in meta:
        raise BakeError(f"{args.input}: the runtime texture has no Hybrid weights; bake it "
                        f"with `python -m bake sample --map`")
    normals, views, mask, where, tangents = _pixels(args)
    n, v = normals[mask], views[mask]
    t = None if tangents is None else tangents[mask]
    if runtime:
        atlas, _ = exr.read(args.input)
        if map_path is not None:
            radiance = hybrid.shade(prefilter.load(map_path), atlas, meta, n, v, t)
            what = f"the Hybrid of {Path(args.input).name} and {Path(map_path).name}"
        else:
            radiance = sampling_runtime.shade(atlas, meta, n, v, t)
            what = f"runtime sampling of {Path(args.input).name}"
    else:
        radiance = prefilter.load(args.input).shade(n, v)
        what = f"the {mode} map {Path(args.input).name}"
    exr.write(output, _rgba(mask, radiance), {
        "generator": f"glossy-bake {__version__}", "kind": "lookup", "source":
        Path(args.input).name, "map": Path(map_path).name if map_path else None,
        "mode": "hybrid" if map_path else mode, "pixels": int(mask.sum()), **where})
    print(f"wrote {output} ({int(mask.sum())} pixels, {what})")


def _report_table(args, model, progress):
    """Errors per parameterization, method, term count and texture size (section 5.2)."""
    from . import separable

    sizes = sorted(set(args.sizes))
    largest = sizes[-1]
    pairs = separable.stratified_pairs(args.strata)
    rows, by_terms, by_size = [], {}, {}
    jobs = [(param, size) for param in separable.PARAMETERIZATIONS for size in sizes]
    for index, (param, size) in enumerate(jobs):
        matrix = separable.matrix_for(model, param, size, args.map)
        for method in separable.METHODS:
            errors = []
            if matrix.complete:  # truncations of one factorization are the k-term ones
                fac = separable.factorize(model, param, method, args.terms, size, args.map,
                                          args.p, matrix=matrix)
                errors = [separable.error(fac, model, pairs, k)
                          for k in range(1, args.terms + 1)]
            else:  # weighted fits are not nested: one per term count
                for k in range(1, args.terms + 1):
                    fac = separable.factorize(model, param, method, k, size, args.map,
                                              args.p, matrix=matrix)
                    errors.append(separable.error(fac, model, pairs))
            rows.append((param, method, size, errors))
            if size == largest:
                by_terms[(param, method)] = errors
            by_size.setdefault((param, method), []).append((size, errors[0]))
        if progress:
            progress((index + 1) / len(jobs), f"{param} at {size}^2")
    head = "  ".join(f"{k} term{'s' if k > 1 else ' '}" for k in range(1, args.terms + 1))
    print(f"cosine-weighted relative RMS error of outgoing radiance, {model.spec}, "
          f"{len(pairs[0])} stratified pairs, {args.map} hemisphere maps:")
    print(f"{'parameterization':18s} {'method':6s} {'size':>4s}  {head}")
    for param, method, size, errors in rows:
        print(f"{param:18s} {method:6s} {size:4d}  " + "  ".join(f"{e:7.4f}" for e in errors))
    best = {method: min(separable.PARAMETERIZATIONS, key=lambda q: by_terms[(q, method)][-1])
            for method in separable.METHODS}
    single_nd = min(by_terms[(q, "nd")][0] for q in separable.PARAMETERIZATIONS)
    print(f"best at {largest}^2: SVD {best['svd']}, ND {best['nd']} (single-term ND "
          f"{single_nd:.4f}, {args.terms}-term SVD {by_terms[(best['svd'], 'svd')][-1]:.4f})")
    return by_terms, by_size, largest


def _report_plots(prefix, model, by_terms, by_size, largest, terms):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for name, title in (("terms", f"Figure 5: error against terms ({largest}^2)"),
                        ("sizes", "Figure 6: error against texture size (1 term)")):
        figure, axis = plt.subplots(figsize=(6.4, 4.2))
        for (param, method), values in sorted(by_terms.items() if name == "terms"
                                              else by_size.items()):
            xs = list(range(1, terms + 1)) if name == "terms" else [s for s, _ in values]
            ys = values if name == "terms" else [e for _, e in values]
            axis.plot(xs, ys, marker="o", linestyle="-" if method == "svd" else "--",
                      label=f"{param} ({method.upper()})")
        axis.set_xlabel("terms" if name == "terms" else "texture size (texels per side)")
        axis.set_ylabel("relative RMS error of f cos(theta_i)")
        axis.set_yscale("log")
        if name == "sizes":
            axis.set_xscale("log", base=2)
        axis.grid(alpha=0.3)
        axis.set_title(f"{title}\n{model.spec[:60]}", fontsize=9)
        axis.legend(fontsize=7)
        path = Path(f"{prefix}_{name}.png")
        outputs.atomic_write(path, lambda target, figure=figure: figure.savefig(
            target, dpi=100, format="png"))
        plt.close(figure)
        written.append(path)
    return written


def cmd_factorize(args):
    from . import brdf, separable

    output = _check_output(args.output) if args.output else None
    if output is None and not args.report:
        raise BakeError("give -o OUT.exr (the factor textures) or --report (the error table)")
    if args.plots and not args.report:
        raise BakeError("--plots goes with --report")
    if args.plots:
        for name in ("terms", "sizes"):
            outputs.check_target(f"{args.plots}_{name}.png", ".png", what="--plots")
    for size in [args.size] + (args.sizes if args.report else []):
        separable.check_arguments(size, args.terms, args.param, args.map, args.method, args.p,
                                  args.size_h)
    if not 2 <= args.strata <= 400:
        raise BakeError(f"--strata must be in [2, 400], not {args.strata}")
    model = brdf.parse(args.brdf)
    progress = None if args.quiet else LinePrinter()
    if args.report:
        by_terms, by_size, largest = _report_table(args, model, progress)
        if args.plots:
            for path in _report_plots(args.plots, model, by_terms, by_size, largest,
                                      args.terms):
                print(f"wrote {path}")
    if output:
        fac = separable.factorize(model, args.param, args.method, args.terms, args.size,
                                  args.map, args.p, progress=progress, size_h=args.size_h)
        if fac.size_h == fac.size:
            exr.write(output, fac.layers(), fac.meta())
        else:  # layers of two sizes: one EXR part each (exr.read_parts reads them)
            exr.write_parts(output, fac.layers(), fac.meta())
        sizes = f"{args.size}^2" if fac.size_h == fac.size else \
            f"{args.size}^2 and {fac.size_h}^2"
        print(f"wrote {output} ({fac.terms} term(s) of {sizes} {args.map} maps, "
              f"{args.param}, {args.method.upper()}; error "
              f"{separable.error(fac, model):.4f})")


def _sizes(text):
    try:
        return [int(x) for x in text.split(",") if x]
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be sizes like 16,32,64, not {text!r}") from None


def _vector(text):
    try:
        values = [float(x) for x in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"must be three numbers X,Y,Z, not {text!r}")
    return values


def _positive_int(text):
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number, not {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, not {value}")
    return value


def _size_or_auto(text):
    if text == "auto":
        return "auto"
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number or 'auto', not {text!r}")\
            from None


def _add_prefilter_options(p, with_brdf=True):
    p.add_argument("input", help="probe EXR (cube strip or lat-long)")
    if with_brdf:
        p.add_argument("--brdf", required=True, help="BRDF spec, e.g. ggx:roughness=0.3")
    p.add_argument("--from", dest="source", choices=["latlong", "cube"],
                   help="probe layout (default: from metadata or shape)")
    p.add_argument("--size", default="auto", type=_size_or_auto,
                   help="lat-long rows N (N x 2N maps), or 'auto' (default: from the lobe "
                        "width and the probe's detail, at most --max-size); split-sum: the "
                        "base cube face (required)")
    p.add_argument("--max-size", type=int, default=None,
                   help="upper bound of an auto size (default 384)")
    p.add_argument("--slices", type=int, default=16, help="view elevations K (default 16)")
    p.add_argument("--lobes", type=int, default=1, help="lobes per slice (3d, default 1)")
    p.add_argument("--levels", type=int, help="split-sum MIP levels (default 6, fewer if small)")
    p.add_argument("--preset", default="khronos", choices=["khronos", "filament"],
                   help="split-sum level-to-roughness mapping")
    p.add_argument("--method", default="direct", choices=["direct", "sh"],
                   help="irradiance: direct convolution or 9 SH coefficients")
    p.add_argument("--order", type=int, default=8,
                   help="sh mode: spherical-harmonic order M (default 8)")
    p.add_argument("-o", "--output", required=True, help="output EXR (+ .json sidecar)")
    p.add_argument("--sanitize", action="store_true", help="replace NaN/inf input texels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")


def _add_pixel_options(p):
    """The pixels a render command shades: an analytic sphere or render passes."""
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--sphere", type=_positive_int, metavar="SIZE",
                       help="an analytic unit sphere, SIZE x SIZE pixels, seen from "
                            "(0, -distance, 0) along +Y")
    where.add_argument("--buffers", metavar="EXR",
                       help="render passes: a 'normal' layer (world space), a 'view' layer "
                            "(surface to viewer) or a 'position' layer with --camera, and "
                            "optionally a 'tangent' layer (anisotropic lobes)")
    p.add_argument("--camera", type=_vector, help="camera position X,Y,Z (with 'position')")
    p.add_argument("--distance", type=float, default=6.0, help="sphere: camera distance")
    p.add_argument("--lens", type=float, default=90.0, help="sphere: focal length (mm, 36 mm "
                                                            "sensor)")


def _build_parser():
    parser = _Parser(prog="python -m bake", description="Glossy's pure-NumPy baker.")
    parser.add_argument("--version", action="version", version=__version__)
    commands = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    layouts = list(LAYOUTS)
    p = commands.add_parser("convert", help="convert an environment map between layouts")
    p.add_argument("input", help="input EXR (lat-long, cube strip, paraboloid or sphere map)")
    p.add_argument("--to", required=True, choices=layouts, help="target layout")
    p.add_argument("--from", dest="source", choices=layouts,
                   help="input layout (default: from the file's metadata or its shape)")
    p.add_argument("--size", required=True, type=int, help="target size N (see DESIGN.md)")
    p.add_argument("--samples", type=_positive_int,
                   help="sub-samples per texel side (default: automatic)")
    p.add_argument("-o", "--output", required=True, help="output EXR")
    p.add_argument("--sanitize", action="store_true", help="replace NaN/inf input texels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_convert)

    p = commands.add_parser("mip", help="solid-angle-weighted MIP pyramid of a cube/lat-long map")
    p.add_argument("input", help="input EXR (cube strip or lat-long)")
    p.add_argument("--layout", choices=["cube", "latlong"], help="input layout (default: guess)")
    p.add_argument("--filter", default="gauss4", choices=list(mip.FILTERS), help="MIP filter")
    p.add_argument("--levels", type=int, help="number of levels (default: all)")
    p.add_argument("-o", "--output", required=True,
                   help="output name; level k goes to NAME.mip<k>.exr")
    p.add_argument("--sanitize", action="store_true", help="replace NaN/inf input texels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_mip)

    p = commands.add_parser("fit", help="fit Kautz-McCool lobes to a BRDF (JSON)")
    p.add_argument("--brdf", required=True, help="isotropic BRDF spec")
    p.add_argument("--slices", type=int, default=16, help="view elevations K (default 16)")
    p.add_argument("--lobes", type=int, default=1, help="lobes per slice (default 1)")
    p.add_argument("--mode", default="3d", choices=["3d", "2d"], help="3d or 2d lobe")
    p.add_argument("--centre", default="best", choices=["best", "peak"],
                   help="the first lobe's centre: best (between the slice's peak and "
                        "centroid, the default) or peak (Kautz & McCool's)")
    p.add_argument("-o", "--output", required=True, help="output .json")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_fit)

    from .prefilter import MODES

    p = commands.add_parser("prefilter", help="prefilter a probe for a BRDF")
    _add_prefilter_options(p)
    p.add_argument("--mode", default="3d", choices=list(MODES), help="prefilter mode")
    p.set_defaults(run=cmd_prefilter)

    p = commands.add_parser("sample", help="runtime regular sampling's texture of a probe "
                                           "(anisotropic lobes too); --map: the Hybrid")
    p.add_argument("input", help="probe EXR (cube strip or lat-long)")
    p.add_argument("--brdf", required=True,
                   help="BRDF spec with one GGX or Cycles Beckmann lobe, e.g. "
                        "ggx:roughness=0.3,anisotropy=0.8")
    p.add_argument("--from", dest="source", choices=["latlong", "cube"],
                   help="probe layout (default: from metadata or shape)")
    p.add_argument("--samples", type=_positive_int, default=19,
                   help="samples per pixel: the regular pattern with the closest count "
                        "(default 19)")
    p.add_argument("--height", type=_positive_int, default=None,
                   help="rows of the level stack (a power of two or three times one; "
                        "default: the probe's own detail, at most --max-size; for a "
                        "near-mirror lobe without --map at most twice it, up to 1024)")
    p.add_argument("--no-lights", action="store_true",
                   help="keep the probe's small bright lights in the level stack rather "
                        "than shading them exactly")
    p.add_argument("--map", metavar="MAP.exr",
                   help="also bake the Hybrid's 3D map here (isotropic lobes) and put the "
                        "blend weights w(n.v) in the texture's metadata")
    p.add_argument("--size", default="auto", type=_size_or_auto,
                   help="--map: lat-long rows of the 3D map, or 'auto' (default)")
    p.add_argument("--max-size", type=_positive_int, default=None,
                   help="upper bound of the automatic sizes (default 384)")
    p.add_argument("--slices", type=int, default=16, help="--map: view elevations (default 16)")
    p.add_argument("--lobes", type=int, default=1, help="--map: lobes per slice (default 1)")
    p.add_argument("-o", "--output", required=True,
                   help="output EXR: the runtime texture (+ .json sidecar)")
    p.add_argument("--sanitize", action="store_true", help="replace NaN/inf input texels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_sample)

    p = commands.add_parser("irradiance", help="diffuse irradiance map of a probe")
    _add_prefilter_options(p, with_brdf=False)
    p.set_defaults(run=lambda args: cmd_prefilter(args, "irradiance"))

    p = commands.add_parser("reference", help="brute-force render of the true BRDF lit by "
                                              "a probe (the distant-lighting truth)")
    p.add_argument("input", help="probe EXR (any layout)")
    p.add_argument("--brdf", required=True, help="BRDF spec (any of bake.brdf)")
    p.add_argument("--from", dest="source", choices=layouts,
                   help="probe layout (default: from metadata or shape)")
    _add_pixel_options(p)
    p.add_argument("--tolerance", type=float, default=None,
                   help="relative error budget per block (default: bake.reference's; 0 = "
                        "every texel)")
    p.add_argument("--reconstruction", choices=("bilinear", "texels"), default="bilinear",
                   help="integrate the probe's bilinear reconstruction, sampled finer where "
                        "the lobe is narrow against a texel (default; what a renderer "
                        "sees), or sum its texel centres as point lights")
    p.add_argument("-o", "--output", required=True, help="output EXR (RGBA, A = surface)")
    p.add_argument("--sanitize", action="store_true", help="replace NaN/inf probe texels")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_reference)

    from .separable import MAPS, METHODS, PARAMETERIZATIONS

    p = commands.add_parser("lookup", help="render what a baked map or runtime texture gives "
                                           "(the node groups' lookup, in NumPy)")
    p.add_argument("input", help="a map (prefilter) or runtime texture (sample) EXR")
    p.add_argument("--map", metavar="MAP.exr",
                   help="the Hybrid's 3D map (default: the texture's own, beside it)")
    p.add_argument("--no-map", action="store_true",
                   help="runtime sampling alone, even for a Hybrid's texture")
    _add_pixel_options(p)
    p.add_argument("-o", "--output", required=True, help="output EXR (RGBA, A = surface)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_lookup)

    p = commands.add_parser("factorize", help="separable approximation of a BRDF (Kautz & "
                                              "McCool 1999): factor textures, error report")
    p.add_argument("--brdf", required=True, help="BRDF spec (any of bake.brdf)")
    p.add_argument("--param", default="half-difference", choices=PARAMETERIZATIONS,
                   help="parameterization (default half-difference)")
    p.add_argument("--method", default="svd", choices=METHODS,
                   help="truncated SVD, ND, or the sampled fit (never the whole matrix)")
    p.add_argument("--terms", type=int, default=1, help="pairs of textures (1-16)")
    p.add_argument("--size", type=int, default=64, help="texels per side (4-256)")
    p.add_argument("--size-h", type=int, default=None,
                   help="texels per side of the h factors (default: --size)")
    p.add_argument("--map", default="xy", choices=MAPS, help="hemisphere map: xy or parabolic")
    p.add_argument("--p", type=float, default=2.0, help="ND: the p of the column p-norms")
    p.add_argument("--report", action="store_true",
                   help="print the error table over parameterizations, methods, terms "
                        "(1..--terms) and --sizes")
    p.add_argument("--sizes", type=_sizes, default=[16, 32, 64],
                   help="report: texture sizes (default 16,32,64)")
    p.add_argument("--strata", type=int, default=90,
                   help="report: strata per hemisphere; every incident stratum is paired with "
                        "every outgoing one (default 90: 8100 pairs)")
    p.add_argument("--plots", metavar="PREFIX",
                   help="report: write PREFIX_terms.png (Figure 5) and PREFIX_sizes.png "
                        "(Figure 6)")
    p.add_argument("-o", "--output", help="output EXR: layers g<k>, h<k> (RGB) + metadata")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress line")
    p.set_defaults(run=cmd_factorize)

    p = commands.add_parser("brdf", help="describe a BRDF spec; --plot draws it")
    p.add_argument("spec", nargs="?",
                   help="BRDF spec, e.g. ggx:roughness=0.3 (see bake.brdf.models())")
    p.add_argument("--from-blend", metavar="FILE.blend",
                   help="read the spec from a material's node tree (needs the bpy module)")
    p.add_argument("--material", metavar="NAME", help="the material of --from-blend")
    p.add_argument("--plot", help="write polar slices and the albedo curve to this PNG")
    p.set_defaults(run=cmd_brdf)
    return parser


INTERRUPTED = "error: interrupted; no output written"


def _stop_at_once_on_interrupt() -> None:
    """Make Ctrl-C end the process within milliseconds, even inside a long NumPy call.

    The C-level signal handler writes to a wake-up pipe; a watcher thread
    blocked on it (NumPy's heavy loops release the GIL) removes the
    temporaries of writes in flight, prints one line and exits 130. Outputs
    are only ever renamed into place whole, so nothing half-written remains.
    Only from the main thread of the ``python -m bake`` process.
    """
    if threading.current_thread() is not threading.main_thread():
        return
    read_end, write_end = os.pipe()
    os.set_blocking(write_end, False)
    stderr = os.dup(2)  # the EXR writer silences fd 2 while it runs

    def watch():
        os.read(read_end, 1)
        outputs.remove_temporaries()
        os.write(stderr, (INTERRUPTED + "\n").encode())
        os._exit(130)

    signal.signal(signal.SIGINT, lambda number, frame: None)
    signal.set_wakeup_fd(write_end, warn_on_full_buffer=False)
    threading.Thread(target=watch, name="glossy-interrupt", daemon=True).start()


def main(argv=None) -> int:
    """Run one command; returns the exit status (0, 2 for a user error, 130 when
    interrupted, 3 for an internal error, with one line on stderr)."""
    parser = _build_parser()
    args = parser.parse_args(argv)
    try:
        with limited_blas():  # the commands run their own threads (bake.blas_threads)
            args.run(args)
    except BakeError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    except MemoryError:
        print("error: out of memory (try a smaller --size)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        outputs.remove_temporaries()
        print(INTERRUPTED, file=sys.stderr)
        return 130
    except OSError as error:
        where = f"{error.filename}: " if error.filename else ""
        print(f"error: {where}{error.strerror or error}", file=sys.stderr)
        return 2
    except Exception as error:  # noqa: BLE001 - one line, never a traceback
        if os.environ.get("GLOSSY_DEBUG"):
            raise
        print(f"error: internal error ({type(error).__name__}: {error}); please report it "
              f"(GLOSSY_DEBUG=1 shows the traceback)", file=sys.stderr)
        return 3
    return 0


def run() -> int:
    """``python -m bake``: main() with Ctrl-C stopping at once."""
    np.seterr(all="ignore")
    _stop_at_once_on_interrupt()
    return main()
