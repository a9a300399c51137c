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

    .venv/bin/python benchmarks/resolution_curve.py [--faces 64] [--pixels 24]
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


def curve(probe, spec, normals, views, sizes):
    model = prefilter.parse(spec)
    truth = truth_of(model, probe, normals, views)
    fit = lobes.fit(spec, slices=16)
    auto = prefilter.prefilter(probe, fit, "3d", "auto", layout="cube", max_size=2048)
    rows = []
    for size in sorted(set(sizes) | {auto.meta["size"]}):
        start = time.perf_counter()
        baked = prefilter.prefilter(probe, fit, "3d", size, layout="cube")
        elapsed = time.perf_counter() - start
        rows.append((size, relative_rms(baked.shade(normals, views), truth), elapsed))
    return auto.meta, rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=64)
    parser.add_argument("--pixels", type=int, default=24)
    parser.add_argument("--hdri", default="sunset.exr")
    parser.add_argument("--roughness", default="0.05,0.1,0.2,0.3,0.6")
    parser.add_argument("--sizes", default="32,48,64,96,128,192,256,384,512")
    args = parser.parse_args()
    source, _ = exr.read(studio_lights() / args.hdri)
    probe = envmap.convert(source, "latlong", "cube", args.faces)
    normals, views = sphere_pixels(args.pixels)
    sizes = [int(x) for x in args.sizes.split(",")]
    print(f"{args.hdri}, cube faces {args.faces}, {len(normals)} sphere pixels; "
          f"rule: hypot(lobe width, half a probe texel) spans "
          f"{resolution.TEXELS_PER_HALF_WIDTH:g} texels")
    for roughness in (float(r) for r in args.roughness.split(",")):
        meta, rows = curve(probe, f"ggx:roughness={roughness}", normals, views, sizes)
        print(f"GGX {roughness}: Auto = {meta['size_reason']}")
        for size, error, elapsed in rows:
            mark = "  <- Auto" if size == meta["size"] else ""
            print(f"   rows {size:4d}: relative RMS {error:.4f}   bake {elapsed:5.2f} s{mark}")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
