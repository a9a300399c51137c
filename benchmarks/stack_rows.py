"""The runtime level stack's rows against accuracy: a power of two (before stop 73)
or three times one (bake.sampling_atlas.stack_rows_below), on the bundled HDRIs.

At the default Max Map Size (384 rows) a 328 px probe's own detail is 656 rows;
rounded down to a power of two the stack had 256, a third fewer rows than the
3D map beside it. This script measures what those rows cost a near-mirror
lobe. For each HDRI and isotropic GGX roughness, from a cube probe of ``--face``
px (328: what the capture's Auto gives GGX 0.05 and 0.1 in most bundled HDRIs)
without its small bright lights (bake.world_lights.split_for, as the bake splits
them), a sphere (64^2 pixels, 2 x 2 sub-pixels each) is shaded by runtime
sampling (19 samples, bake.sampling_runtime.shade: the nodes' NumPy twin), by
the 3D map at Auto size under the default Max Map Size (the lights' exact term
added) and by the Hybrid (bake.hybrid.shade, the committed weights), each with
the level stack at the old rule's rows (256), the rule's (384) and the probe's
own detail uncapped (512), against the brute-force integral over the HDRI's
bilinear reconstruction (what Cycles renders, bake.reference). It prints each
method's relative RMS of luminance and the time the level stack took to pack.

    .venv/bin/python benchmarks/stack_rows.py [--hdri courtyard,night,sunset]
        [--roughness 0.05,0.1] [--face 328]

No figure is asserted; tests/bake/test_sampling_runtime.py asserts the smaller
case of a 48 px probe of tiny spots.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from hybrid import LUMINANCE, hdri_directory, sphere_pixels  # noqa: E402

from bake import (  # noqa: E402
    brdf,
    exr,
    hybrid,
    prefilter,
    reference,
    sampling_runtime,
    world_lights,
)
from bake.envmap import convert  # noqa: E402

HDRIS = ("city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset")


def relative_rms(estimate, truth):
    return float(np.sqrt(np.mean((estimate - truth) ** 2) / np.mean(truth ** 2)))


def measure(image, roughness, face, normals, views, average):
    """{rows: (runtime, map, hybrid, pack seconds)} for one HDRI and roughness."""
    spec = f"ggx:roughness={roughness}"
    model = brdf.parse(spec)
    cube = convert(image, "latlong", "cube", face)
    truth = average(reference.render(model, image, "latlong", normals, views,
                                     reconstruction="bilinear") @ LUMINANCE)
    lobe = sampling_runtime.check(spec)[0]
    probe, lights, _ = world_lights.split_for(cube, "cube", lobe.mx, lobe.my, image)
    baked = prefilter.prefilter(probe, spec, "3d", "auto")
    rule = sampling_runtime.stack_height(cube.shape, "cube",
                                         cap=prefilter.DEFAULT_MAX_SIZE)[0]
    out = {}
    for rows in sorted({256, rule, sampling_runtime.stack_height(cube.shape, "cube")[0]}):
        start = time.perf_counter()
        atlas, meta = sampling_runtime.pack(probe, spec, budget=19, height=rows, lights=lights)
        seconds = time.perf_counter() - start
        centres, weights = hybrid.weight_curve(float(np.sqrt(meta["ax"])),
                                               samples=len(meta["prob"]))
        meta.update({"blend_mu": centres.tolist(), "blend_weight": weights.tolist()})
        runtime = sampling_runtime.shade(atlas, meta, normals, views)
        light_term = runtime - sampling_runtime.shade(atlas, {**meta, "lights": []},
                                                      normals, views) if lights else 0.0
        mapped = baked.shade(normals, views) + light_term
        blended = hybrid.shade(baked, atlas, meta, normals, views)
        out[rows] = tuple(relative_rms(average(value @ LUMINANCE), truth)
                          for value in (runtime, mapped, blended)) + (seconds,)
    return rule, baked.meta["size"], out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hdri", default=",".join(HDRIS), help="bundled HDRI names")
    parser.add_argument("--roughness", default="0.05,0.1", help="GGX roughness values")
    parser.add_argument("--face", type=int, default=328, help="probe face px")
    args = parser.parse_args()
    normals, views, average = sphere_pixels(64, 2)
    print(f"level stack rows against the world's brute force, {args.face} px probe, "
          f"19 samples, 3D map at Auto (Max Map Size {prefilter.DEFAULT_MAX_SIZE}); "
          f"relative RMS of luminance, runtime / 3D map / Hybrid:", flush=True)
    for name in args.hdri.split(","):
        image = exr.read(hdri_directory() / f"{name}.exr")[0][..., :3]
        for roughness in (float(r) for r in args.roughness.split(",")):
            rule, map_rows, rows = measure(image, roughness, args.face, normals, views, average)
            cells = "  ".join(
                f"{count} rows{' (rule)' if count == rule else ''}: {run:.4f} / {mapped:.4f} / "
                f"{blended:.4f} ({seconds:.2f} s)"
                for count, (run, mapped, blended, seconds) in rows.items())
            print(f"{name:9s} GGX {roughness:<5g} map {map_rows} rows  {cells}", flush=True)


if __name__ == "__main__":
    main()
