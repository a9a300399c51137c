"""Runtime sampling's own accuracy in NumPy (bake.sampling_runtime.shade, the
nodes' twin) against the brute-force integral, as the sample count and the
probe grow, on every bundled HDRI.

A sphere (bake.reference.sphere_buffers, --size pixels) with Blender's radial
tangent about Z, a cube probe of --face pixels converted from the HDRI, the
level stack at the probe's own detail (2 x face rows up to a power of two);
relative RMS of luminance against bake.reference.render through the same
probe (so the probe's resolution is not part of this error: it is the
estimator's). Separates what more samples buy from what a finer probe buys.
With ``--taps 4`` (or a list, 1,4,8) each budget is also shaded with up to
that many lookups along each sample's footprint (sampling_runtime.shade's
``taps``, not yet in the nodes). With ``--lights`` each budget is also shaded
with the probe's small bright lights taken out and shaded exactly
(bake.probe_lights, as the bake does with Probe Lights on): column "+L".

    .venv/bin/python benchmarks/runtime_accuracy.py [--spec ggx:roughness=0.3]
        [--budgets 19,61,127,252] [--face 64] [--size 48] [--hdri night ...]
        [--taps 1,4] [--lights]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, envmap, exr, probe_lights, reference, sampling_runtime  # noqa: E402
from bake.sampling import lobe_of  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--spec", default="ggx:roughness=0.3,anisotropy=0.8")
    parser.add_argument("--budgets", default="14,52,114,200")
    parser.add_argument("--face", type=int, default=64, help="cube probe face (px)")
    parser.add_argument("--size", type=int, default=48, help="sphere image size (px)")
    parser.add_argument("--hdri", action="append", help="HDRI stem (repeatable; default all)")
    parser.add_argument("--taps", default="1", help="lookups per sample footprint, e.g. 1,4")
    parser.add_argument("--lights", action="store_true",
                        help="also with the probe's lights shaded exactly (bake.probe_lights)")
    args = parser.parse_args()
    taps = [int(t) for t in args.taps.split(",")]
    model = brdf.parse(args.spec)
    budgets = [int(b) for b in args.budgets.split(",")]
    normals, views, mask = reference.sphere_buffers(args.size)
    normals, views = normals[mask], views[mask]
    tangents = np.stack([-normals[:, 1], normals[:, 0], np.zeros(len(normals))], -1)
    names = args.hdri or sorted(p.stem for p in studio_lights().glob("*.exr"))
    print(f"{args.spec}, {len(normals)} sphere pixels, {args.face}^2-face probe, level stack "
          f"{1 << (2 * args.face - 1).bit_length()} rows; relative RMS of luminance against "
          f"brute force", flush=True)
    header = None
    for name in names:
        environment, _ = exr.read(studio_lights() / f"{name}.exr")
        probe = envmap.convert(environment[..., :3], "latlong", "cube", args.face)
        start = time.perf_counter()
        truth = reference.render(model, probe, "cube", normals, views,
                                 tangents=tangents) @ LUMINANCE
        errors, counts, taken = [], [], None
        height = 1 << (2 * args.face - 1).bit_length()  # a power of two >= 2 faces
        for budget in budgets:
            atlas, meta = sampling_runtime.pack(probe, args.spec, budget=budget,
                                                height=height)
            for tap in taps:
                estimate = sampling_runtime.shade(atlas, meta, normals, views, tangents,
                                                  taps=tap) @ LUMINANCE
                errors.append(float(np.sqrt(np.mean((estimate - truth) ** 2)
                                            / np.mean(truth ** 2))))
                counts.append(f"{len(meta['prob'])}x{tap}" if len(taps) > 1 else
                              f"{len(meta['prob'])} smp")
            if args.lights:
                lobe = lobe_of(model)
                residual, lights = probe_lights.extract_for(probe, "cube", lobe.mx,
                                                            lobe.my)
                split, split_meta = sampling_runtime.pack(residual, args.spec, budget=budget,
                                                          height=height, lights=lights)
                estimate = sampling_runtime.shade(split, split_meta, normals, views,
                                                  tangents) @ LUMINANCE
                errors.append(float(np.sqrt(np.mean((estimate - truth) ** 2)
                                            / np.mean(truth ** 2))))
                counts.append(f"{len(meta['prob'])}+L")
                taken = len(lights)
        if header is None:
            header = f"{'HDRI':10s} " + " ".join(f"{c:>8s}" for c in counts)
            print(header, flush=True)
        print(f"{name:10s} " + " ".join(f"{e:8.3f}" for e in errors)
              + f"   ({time.perf_counter() - start:.0f} s"
              + (f", {taken} light(s) taken" if taken is not None else "") + ")", flush=True)


if __name__ == "__main__":
    main()
