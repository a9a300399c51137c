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
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import envmap, exr, lobes, prefilter, resolution  # noqa: E402
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


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=64)
    parser.add_argument("--pixels", type=int, default=24)
    parser.add_argument("--supersample", type=int, default=4,
                        help="sub-pixels per pixel side of the anti-aliased figure")
    parser.add_argument("--hdri", default="sunset.exr")
    parser.add_argument("--roughness", default="0.05,0.1,0.2,0.3,0.6")
    parser.add_argument("--sizes", default="32,48,64,96,128,192,256,384,512")
    args = parser.parse_args()
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
