"""The curve behind the roughness-texture blend's knot spacing: how far apart
in roughness can two baked maps be before blending them per pixel costs
accuracy?

For every bundled HDRI (cube faces of --faces texels, over their bilinear
reconstruction 3x finer) and a GGX lobe, renders an isolated sphere
(orthographic, --pixels across) with the brute-force integral
(bake.reference) at roughness r, and compares it with the blend of the
renders at knots low < r < high = ratio * low (what the attached material
does between two baked roughnesses, per pixel): weights linear in r, in
r^2, or geometric (R0^(1-w) R1^w, w linear in log r), at r a quarter, half
and three quarters of the way. Prints the relative RMS luminance error of
each blend, worst over low in 0.1 ... 0.45.
glossy_addon.spatial.ROUGHNESS_RATIO is chosen from this curve (its comment
has the figures; about 8 minutes on 2 cores).

    .venv/bin/python benchmarks/roughness_blend.py [--faces 24] [--pixels 16]
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import envmap, exr, prefilter  # noqa: E402
from bake.reference import reflected_radiance  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from resolution_curve import reconstruction, relative_rms, sphere_pixels  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", type=int, default=24)
    parser.add_argument("--pixels", type=int, default=16)
    parser.add_argument("--ratios", default="1.15,1.25,1.4,1.6,2.0")
    args = parser.parse_args()
    ratios = [float(q) for q in args.ratios.split(",")]
    normals, views = sphere_pixels(args.pixels)
    lows = (0.1, 0.15, 0.2, 0.3, 0.45)
    kinds = ("r", "r2", "geo")
    worst = {(q, kind): 0.0 for q in ratios for kind in kinds}
    for hdri in sorted(studio_lights().glob("*.exr")):
        source, _ = exr.read(hdri)
        probe = reconstruction(envmap.convert(source, "latlong", "cube", args.faces))
        renders = {}

        def render(r, probe=probe, renders=renders):
            key = round(float(r), 5)
            if key not in renders:
                model = prefilter.parse(f"ggx:roughness={key:g}")
                renders[key] = reflected_radiance(model, probe, "cube", normals, views)
            return renders[key]

        line = [f"{hdri.name:14s}"]
        for q in ratios:
            errors = {kind: [] for kind in kinds}
            for low in lows:
                high = min(low * q, 1.0)
                for t in (0.25, 0.5, 0.75):
                    r = low + t * (high - low)
                    truth = render(r)
                    t2 = (r * r - low * low) / (high * high - low * low)
                    for kind, w in (("r", t), ("r2", t2)):
                        blend = (1 - w) * render(low) + w * render(high)
                        errors[kind].append(relative_rms(blend, truth))
                    w = np.log(r / low) / np.log(high / low)
                    blend = np.maximum(render(low), 1e-6) ** (1 - w) * \
                        np.maximum(render(high), 1e-6) ** w
                    errors["geo"].append(relative_rms(blend, truth))
            for kind in kinds:
                worst[(q, kind)] = max(worst[(q, kind)], max(errors[kind]))
            line.append(f"x{q:g}: " + "/".join(f"{max(errors[k]):.4f}" for k in kinds))
        print("  ".join(line), flush=True)
    print("worst over HDRIs (weights linear in r / in r^2 / geometric blend in log r):")
    for q in ratios:
        print(f"  ratio {q:g}: " + " / ".join(f"{worst[(q, k)]:.4f}" for k in kinds))


if __name__ == "__main__":
    main()
