"""Probe Lights' threshold ladder (bake.probe_lights.THRESHOLDS): the ladder of
stop 34 and before (20, 10, 5, 3, 2x the probe's mean; 40 ... 640x above),
the current one (about four rungs per octave) without its refinement between
rungs, and as extract_for uses it (REFINE_STEPS halvings between the rung that
fits and the one that does not), on every bundled HDRI.

extract_for keeps the lowest threshold at which every bright region fits in
MAX_LIGHTS; the ladder is that rule's discretisation. With rungs an octave
apart the count of lights taken jumps (courtyard.exr at GGX 0.45: 96 lights
at 3x from 40 px faces, then 56 at 5x from 48 px, because 3x needs 104 there),
so the error of both probe methods was not monotone in the probe's face. The
lights taken are not monotone in the threshold either (courtyard.exr at GGX
0.3, 72 px: 67 lights at 9.85x, more than 96 at 8.25x, 92 at 8.41x), so
extract_for refines between the last rung that fits and the first that fails.

For each HDRI and GGX roughness, from the probe face Auto captures for it
(benchmarks/hybrid.py's world_face: the lobe rule raised for the world's
small lights), a 64^2 px sphere: the lights taken (count, threshold), and
the relative RMS of luminance against the brute-force integral over the same
probe of the 3D map (+ the lights' exact term), Runtime Sampling's twin (19
samples) and the Hybrid (bake.hybrid's committed weights), both ladders.

    .venv/bin/python benchmarks/light_ladder.py [--roughness 0.2,0.3,0.45,0.6] [--hdri night ...]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, exr, hybrid, prefilter, probe_lights, reference  # noqa: E402
from bake.envmap import convert  # noqa: E402
from benchmarks.hybrid import (  # noqa: E402
    LUMINANCE,
    hdri_directory,
    relative_rms,
    runtime_twin,
    world_face,
)

#: The ladders before this benchmark's change (one rung per octave or so).
OCTAVE_LADDER = ((20.0, 10.0, 5.0, 3.0, 2.0), (40.0, 80.0, 160.0, 320.0, 640.0))


def measure(cube, spec, roughness, normals, views, weight, truth):
    """(lights, threshold, map, runtime, hybrid) for the ladder now in probe_lights."""
    probe, lights = probe_lights.extract_for(cube, "cube", roughness ** 2)
    full = runtime_twin(probe, spec, 19, normals, views, lights)
    bare = runtime_twin(probe, spec, 19, normals, views)
    baked = (prefilter.prefilter(probe, spec, "3d", "auto").shade(normals, views)
             + full - bare) @ LUMINANCE
    regular = full @ LUMINANCE
    blend = (1.0 - weight) * baked + weight * regular
    return (len(lights), min((light.threshold for light in lights), default=0.0),
            relative_rms(baked, truth), relative_rms(regular, truth), relative_rms(blend, truth))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--roughness", default="0.2,0.3,0.45,0.6")
    parser.add_argument("--hdri", action="append", help="HDRI stem (repeatable; default all)")
    args = parser.parse_args()
    directory = hdri_directory()
    names = args.hdri or sorted(p.stem for p in directory.glob("*.exr"))
    normals, views, mask = reference.sphere_buffers(64)
    normals, views = normals[mask], views[mask]
    mu = np.clip(np.sum(normals * views, axis=-1), 0.0, 1.0)
    current = (probe_lights.THRESHOLDS, probe_lights.THRESHOLDS_ABOVE)
    refine = probe_lights.REFINE_STEPS
    variants = (("octave", OCTAVE_LADDER, 0), ("rungs only", current, 0),
                ("refined", current, refine))
    print(f"{'GGX':>4s} {'HDRI':10s} {'face':>4s} | "
          f"{'octave ladder: lights, map, runtime, hybrid':45s}| {'current rungs only':45s}| "
          f"{'current, refined (extract_for)':45s}| s")
    totals = {label: [] for label, _, _ in variants}
    try:
        for roughness in (float(r) for r in args.roughness.split(",")):
            spec = f"ggx:roughness={roughness}"
            model = brdf.parse(spec)
            weight = hybrid.blend_curve(mu, *hybrid.weight_curve(roughness, samples=19))
            for name in names:
                start = time.perf_counter()
                image = exr.read(directory / f"{name}.exr")[0][..., :3]
                face = world_face(image, roughness)
                cube = convert(image, "latlong", "cube", face)
                truth = reference.render(model, cube, "cube", normals, views) @ LUMINANCE
                cells = []
                for label, ladder, steps in variants:
                    probe_lights.THRESHOLDS, probe_lights.THRESHOLDS_ABOVE = ladder
                    probe_lights.REFINE_STEPS = steps
                    count, threshold, *errors = measure(cube, spec, roughness, normals, views,
                                                        weight, truth)
                    totals[label].append(errors)
                    cells.append(f"{count:3d} at {threshold:6.4g}x {errors[0]:.4f} "
                                 f"{errors[1]:.4f} {errors[2]:.4f}")
                print(f"{roughness:4g} {name:10s} {face:4d} | " + " | ".join(cells)
                      + f" | {time.perf_counter() - start:.0f}", flush=True)
    finally:
        probe_lights.THRESHOLDS, probe_lights.THRESHOLDS_ABOVE = current
        probe_lights.REFINE_STEPS = refine
    for label, rows in totals.items():
        rows = np.asarray(rows)
        print(f"{label}: root mean square over {len(rows)} cases: map "
              f"{np.sqrt(np.mean(rows[:, 0] ** 2)):.4f}, runtime "
              f"{np.sqrt(np.mean(rows[:, 1] ** 2)):.4f}, hybrid "
              f"{np.sqrt(np.mean(rows[:, 2] ** 2)):.4f}")


if __name__ == "__main__":
    main()
