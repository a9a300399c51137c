"""The curve behind bake.resolution's Auto rule: map error against map rows.

For GGX roughness 0.05 ... 0.6 and a probe of sunset.exr (the sun is the
hardest case) with cube faces of --faces texels, bakes 3D maps (16 slices)
at fixed rows from 16 up, and prints the relative RMS luminance error of
``BakedMap.shade`` against the brute-force integral of the true BRDF over
the probe's bilinear reconstruction, on the pixels of an isolated sphere
seen by an orthographic camera. The rows Auto would choose (without a Max
Map Size) are marked; the error should be flat from there on.

The truth is ``bake.reference.render(..., reconstruction="bilinear")``: the
integral over the probe's bilinear reconstruction at the factor the lobe
needs, narrow lobes' cores by their own samples (within 0.3% of an
importance-sampled integral of the same reconstruction at GGX 0.1:
tests/bake/test_reference.py). Until stop 55 it was the texel sum over a 3x
reconstruction (:func:`reconstruction`), 3.6% off at GGX 0.1 on a 32-px
probe: as large as the map's own error there, which it hid.

Each error is printed twice: over the pixels' centre rays, and over
anti-aliased pixels (--supersample^2 sub-pixels averaged, as a render's pixel
filter averages), where a sun one or two pixels wide no longer decides the
figure by which map texels a centre ray lands between
(:func:`sphere_subpixels`).

    .venv/bin/python benchmarks/resolution_curve.py [--faces 64] [--pixels 24] [--supersample 4]

``--smooth`` measures the content term instead (bake.probe_content): for
worlds smoother than their texels (Blender's default world colour, a smooth
sky) and sunset.exr beside them, the pyramid level that stands for the probe,
and per roughness the texel rule's rows against the content rule's (Auto),
each with its cold bake time and its error against the same brute-force
integral:

    .venv/bin/python benchmarks/resolution_curve.py --smooth [--faces 128]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import (  # noqa: E402
    envmap,
    exr,
    lobes,
    prefilter,
    probe_content,
    probe_maps,
    resolution,
)
from bake.reference import render  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

LUM = np.array([0.2126, 0.7152, 0.0722])


def sphere_pixels(pixels):
    """Normals and views (surface to viewer) of a unit sphere seen from +Y' looking
    down -Y (orthographic), one per pixel of a pixels x pixels image inside the disc."""
    x = (np.arange(pixels) + 0.5) / pixels * 2 - 1
    gx, gz = np.meshgrid(x, -x)
    inside = gx**2 + gz**2 < 0.98
    gx, gz = gx[inside], gz[inside]
    normals = np.stack([gx, -np.sqrt(1 - gx**2 - gz**2), gz], -1)
    views = np.broadcast_to([0.0, -1.0, 0.0], normals.shape)
    return normals, np.ascontiguousarray(views)


def sphere_subpixels(pixels, supersample):
    """(normals (P, 3), views (P, 3), average) of :func:`sphere_pixels`' sphere with every
    pixel split into supersample^2 sub-pixels (those inside the disc kept); ``average``
    maps values (P,) of the sub-pixels to (N,), each pixel's mean over its covered
    sub-pixels: an anti-aliased image, as a renderer's pixel filter makes one.

    Pixel centres alone alias a highlight narrower than a pixel (a GGX 0.1 sun in
    sunset.exr covers one or two pixels of a 16-28 px sphere): which texels of the
    map a centre ray lands between then decides a sub-percent error, and the error
    at Auto against twice the rows measured 1.73 / 1.20 / 2.53 / 0.66 / 0.83 / 1.19
    on 16 / 20 / 28 / 36 / 48 / 64 px spheres, against 0.87 / 1.02 / 1.08 / 1.14 /
    0.91 / 1.13 over 4 x 4 sub-pixels (1.02 / 1.08 on 16 / 28 px over 8 x 8)."""
    s = int(supersample)
    x = (np.arange(pixels * s) + 0.5) / (pixels * s) * 2 - 1
    gx, gz = np.meshgrid(x, -x)
    inside = gx**2 + gz**2 < 0.98
    rows, cols = np.nonzero(inside)
    pixel = (rows // s) * pixels + cols // s
    covered, group = np.unique(pixel, return_inverse=True)
    counts = np.bincount(group, minlength=len(covered)).astype(np.float64)
    gx, gz = gx[inside], gz[inside]
    normals = np.stack([gx, -np.sqrt(1 - gx**2 - gz**2), gz], -1)
    views = np.broadcast_to([0.0, -1.0, 0.0], normals.shape)

    def average(values):
        return np.bincount(group, np.asarray(values, dtype=np.float64), len(covered)) / counts

    return normals, np.ascontiguousarray(views), average


def pixel_relative_rms(approx, truth, average):
    """Relative RMS of luminance over anti-aliased pixels: ``approx`` and ``truth``
    (P, 3) at the sub-pixels of :func:`sphere_subpixels`, averaged per pixel first."""
    a, t = average(approx @ LUM), average(truth @ LUM)
    return float(np.sqrt(np.mean((a - t) ** 2) / np.mean(t**2)))


def reconstruction(probe, factor=3):
    """The probe's bilinear reconstruction as a finer cube (the continuous truth)."""
    cube = envmap.get_layout("cube")
    shape = cube.shape(probe.shape[0] * factor)
    return cube.sampler(probe)(cube.texel_directions(shape)).astype(np.float32)


def relative_rms(approx, truth):
    a, t = approx @ LUM, truth @ LUM
    return float(np.sqrt(np.mean((a - t) ** 2) / np.mean(t**2)))


def truth_of(model, probe, normals, views):
    """The brute-force integral over the probe's bilinear reconstruction (module doc)."""
    return render(model, probe, "cube", normals, views, reconstruction="bilinear")


def curve(probe, spec, pixels, supersample, sizes):
    """(Auto's meta, [(rows, error at pixel centres, error over anti-aliased pixels,
    bake seconds)]) of a 3D map of ``spec`` from ``probe`` at each of ``sizes`` rows
    and at Auto's."""
    model = prefilter.parse(spec)
    normals, views = sphere_pixels(pixels)
    truth = truth_of(model, probe, normals, views)
    sub_normals, sub_views, average = sphere_subpixels(pixels, supersample)
    sub_truth = truth_of(model, probe, sub_normals, sub_views)
    fit = lobes.fit(spec, slices=16)
    auto = prefilter.prefilter(probe, fit, "3d", "auto", layout="cube", max_size=2048)
    rows = []
    for size in sorted(set(sizes) | {auto.meta["size"]}):
        start = time.perf_counter()
        baked = prefilter.prefilter(probe, fit, "3d", size, layout="cube")
        elapsed = time.perf_counter() - start
        rows.append((size, relative_rms(baked.shade(normals, views), truth),
                     pixel_relative_rms(baked.shade(sub_normals, sub_views), sub_truth, average),
                     elapsed))
    return auto.meta, rows


def smooth_sky(face, glow=0.6, sharpness=3.0):
    """(face, 6 face, 3) float32 cube: a constant plus a broad glow exp(k (d.s - 1))
    about an oblique direction, smooth everywhere (no horizon kink), coloured."""
    cube = envmap.get_layout("cube")
    directions = cube.texel_directions(cube.shape(face))
    towards = np.array([0.48, 0.6, 0.64])
    glow_term = glow * np.exp(sharpness * (directions @ towards - 1.0))
    return (np.array([0.2, 0.25, 0.35]) + glow_term[..., None] * np.array([1.0, 0.8, 0.5])
            ).astype(np.float32)


def smooth_worlds(faces, pixels, supersample, roughness_values):
    """The ``--smooth`` table (module doc)."""
    source, _ = exr.read(studio_lights() / "sunset.exr")
    worlds = {"constant 0.0508 (Blender's default)": np.full((faces, 6 * faces, 3), 0.0508,
                                                             np.float32),
              "smooth sky (glow 0.3, k 1)": smooth_sky(faces, 0.3, 1.0),
              "smooth sky (glow 0.6, k 3)": smooth_sky(faces, 0.6, 3.0),
              "sunset.exr": envmap.convert(source, "latlong", "cube", faces)}
    normals, views, average = sphere_subpixels(pixels, supersample)
    print(f"content term (bake.probe_content, tolerance {probe_content.TOLERANCE:g}): "
          f"6 x {faces}^2 probes, {pixels} px sphere over {supersample}^2 sub-pixels, error "
          f"against the brute-force integral over the probe's bilinear reconstruction; "
          f"bakes cold (fit included)")
    print(f"   {'world':36s} {'level':>5s} {'GGX':>5s}   {'texel rows':>10s} {'s':>5s} "
          f"{'error':>7s}   {'Auto rows':>9s} {'s':>5s} {'error':>7s}")
    for name, probe in worlds.items():
        probe_maps.clear_cache()
        detail = probe_content.of_probe(probe, "cube")
        for roughness in roughness_values:
            spec = f"ggx:roughness={roughness}"
            truth = truth_of(prefilter.parse(spec), probe, normals, views)
            results = []
            for content in (False, True):
                lobes._CACHE.clear()
                probe_maps.clear_cache()
                start = time.perf_counter()
                fit = lobes.fit(spec, slices=16)
                if content:
                    baked = prefilter.prefilter(probe, fit, "3d", "auto", layout="cube")
                else:
                    widths = [resolution.lobe_half_width(lobes.GAMMA, s.lobes[0].profile)
                              for s in fit.slices]
                    rows = resolution.choose_map_rows(widths, probe.shape, "cube",
                                                      prefilter.DEFAULT_MAX_SIZE, 16).value
                    baked = prefilter.prefilter(probe, fit, "3d", rows, layout="cube")
                elapsed = time.perf_counter() - start
                error = pixel_relative_rms(baked.shade(normals, views), truth, average)
                results.append((baked.meta["size"], elapsed, error))
            (rows0, time0, error0), (rows1, time1, error1) = results
            print(f"   {name:36s} {detail.level:5d} {roughness:5g}   {rows0:10d} {time0:5.2f} "
                  f"{error0:7.4f}   {rows1:9d} {time1:5.2f} {error1:7.4f}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=None,
                        help="probe cube faces (default 64; 128 with --smooth)")
    parser.add_argument("--pixels", type=int, default=24)
    parser.add_argument("--supersample", type=int, default=4,
                        help="sub-pixels per pixel side of the anti-aliased figure")
    parser.add_argument("--hdri", default="sunset.exr")
    parser.add_argument("--roughness", default="0.05,0.1,0.2,0.3,0.6")
    parser.add_argument("--sizes", default="32,48,64,96,128,192,256,384,512")
    parser.add_argument("--smooth", action="store_true",
                        help="the content term's table instead (module doc)")
    args = parser.parse_args()
    if args.smooth:
        smooth_worlds(args.faces or 128, args.pixels, args.supersample,
                      [float(r) for r in args.roughness.split(",")])
        return
    args.faces = args.faces or 64
    source, _ = exr.read(studio_lights() / args.hdri)
    probe = envmap.convert(source, "latlong", "cube", args.faces)
    sizes = [int(x) for x in args.sizes.split(",")]
    print(f"{args.hdri}, cube faces {args.faces}, {len(sphere_pixels(args.pixels)[0])} sphere "
          f"pixels (at their centres, and over {args.supersample} x {args.supersample} "
          f"sub-pixels); "
          f"rule: hypot(lobe width, half a probe texel) spans "
          f"{resolution.TEXELS_PER_HALF_WIDTH:g} texels")
    for roughness in (float(r) for r in args.roughness.split(",")):
        meta, rows = curve(probe, f"ggx:roughness={roughness}", args.pixels, args.supersample,
                           sizes)
        print(f"GGX {roughness}: Auto = {meta['size_reason']}")
        for size, error, smooth, elapsed in rows:
            mark = "  <- Auto" if size == meta["size"] else ""
            print(f"   rows {size:4d}: relative RMS {error:.4f} (centres), {smooth:.4f} "
                  f"(anti-aliased)   bake {elapsed:5.2f} s{mark}")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
