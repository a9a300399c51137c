"""Lamps of any size in the lamp term (bake.lamp_spread), in NumPy.

A unit sphere seen from 6 m (96^2 px), lit by one lamp 3.9-4.7 m away, no
world. For each BRDF and lamp: the relative RMS of luminance over the
sphere of Glossy's lamp term (bake.lamp_term, the nodes' twin) against the
integral over the emitter (bake.lamp_reference, checked against Cycles in
tests/blender/test_validate_lamps.py), with every lamp taken as a point (the
baseline: the lamp term before stop 54) and with its size (cap levels, area
cells), and the ratio of the two errors; then the cost of the cap levels
beside the factorization they add to, both measured in the same run.

    .venv/bin/python benchmarks/lamp_spread.py [--brdf SPEC ...] [--size 256]
"""

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, lamp_reference, lamp_spread, lamp_term, metrics, separable  # noqa: E402

BRDFS = ("principled:base_color=0.9/0.7/0.5,metallic=1,roughness=0.3", "ggx:roughness=0.15",
         "ggx:roughness=0.5", "principled:base_color=0.2/0.4/0.8,roughness=0.2")


def lamps():
    """(name, bake.lamp_reference.Lamp) of the cases."""
    point, low, high = (2.0, -3.0, 2.5), (2.4, -3.0, -0.4), (3.0, -3.0, 4.0)
    Lamp, aim = lamp_reference.Lamp, lamp_reference.aimed_axes
    return [
        ("point r 0.1", Lamp("POINT", (300.0,) * 3, point, aim(point), radius=0.1)),
        ("point r 0.3", Lamp("POINT", (300.0,) * 3, point, aim(point), radius=0.3)),
        ("point r 0.8", Lamp("POINT", (300.0,) * 3, point, aim(point), radius=0.8)),
        ("sphere r 0.8", Lamp("POINT", (300.0,) * 3, point, aim(point), radius=0.8,
                              sphere=True)),
        ("spot r 0.5", Lamp("SPOT", (500.0,) * 3, point, aim(point), radius=0.5,
                            spot_size=math.radians(60), spot_blend=0.3)),
        ("sun 5 deg", Lamp("SUN", (1.5,) * 3, high, aim(high), angle=math.radians(5))),
        ("sun 15 deg", Lamp("SUN", (1.5,) * 3, high, aim(high), angle=math.radians(15))),
        ("area 1 x 1", Lamp("AREA", (250.0,) * 3, low, aim(low), shape="SQUARE",
                            size=(1.0, 1.0))),
        ("area 1.5 x 0.5", Lamp("AREA", (250.0,) * 3, low, aim(low), shape="RECTANGLE",
                                size=(1.5, 0.5))),
        ("area 0.3 x 2", Lamp("AREA", (250.0,) * 3, low, aim(low), shape="RECTANGLE",
                              size=(0.3, 2.0))),
        ("disk 1.2", Lamp("AREA", (250.0,) * 3, low, aim(low), shape="DISK",
                          size=(1.2, 1.2))),
        ("ellipse 2 x 0.6", Lamp("AREA", (250.0,) * 3, low, aim(low), shape="ELLIPSE",
                                 size=(2.0, 0.6))),
    ]


def sphere_pixels(width=96):
    """(positions, normals, views, tangents) of a unit sphere's pixels seen
    orthographically-ish from (0, -6, 0); tangents radial about Z."""
    xs = (np.arange(width) + 0.5) / width * 2.4 - 1.2
    x, z = np.meshgrid(xs, -xs)
    inside = x * x + z * z < 0.98
    y = -np.sqrt(1.0 - x[inside] ** 2 - z[inside] ** 2)
    normals = np.stack([x[inside], y, z[inside]], -1)
    views = np.array([0.0, -6.0, 0.0]) - normals
    views /= np.linalg.norm(views, axis=1, keepdims=True)
    tangents = np.stack([-normals[:, 1], normals[:, 0], np.zeros(len(normals))], -1)
    tangents[np.linalg.norm(tangents, axis=1) < 1e-9] = (1.0, 0.0, 0.0)
    return normals.copy(), normals, views, tangents


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--brdf", action="append")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--size-h", type=int, default=32)
    args = parser.parse_args()
    positions, normals, views, tangents = sphere_pixels()
    print(f"{'BRDF':58s} {'lamp':16s} {'as points':>9s} {'sized':>7s} {'ratio':>6s}")
    timings = []
    for spec in args.brdf or BRDFS:
        start = time.perf_counter()
        factors = separable.factorize(spec, "half-difference", "sampled", 2, args.size, "xy",
                                      size_h=args.size_h)
        factor_seconds = time.perf_counter() - start
        start = time.perf_counter()
        levels = lamp_spread.blur_levels(factors)
        timings.append((spec, factor_seconds, time.perf_counter() - start))
        image, meta = separable.pack(factors, levels)
        model = brdf.parse(spec)
        for name, lamp in lamps():
            truth = lamp_reference.radiance(model, [lamp], positions, normals, views,
                                            tangents=tangents)
            mask = np.ones((len(truth), 1), bool)
            errors = []
            for sized in (False, True):
                glossy = lamp_term.radiance(image, meta, [lamp], positions, normals, views,
                                            tangents, sized=sized)
                errors.append(metrics.relative_rms(glossy[:, None], truth[:, None], mask))
            print(f"{spec:58s} {name:16s} {errors[0]:9.1%} {errors[1]:7.1%} "
                  f"{errors[0] / max(errors[1], 1e-12):6.1f}", flush=True)
    print(f"\n{'BRDF':58s} {'factor s':>8s} {'levels s':>8s} {'ratio':>6s}")
    for spec, factor_seconds, level_seconds in timings:
        print(f"{spec:58s} {factor_seconds:8.2f} {level_seconds:8.2f} "
              f"{level_seconds / factor_seconds:6.2f}")


if __name__ == "__main__":
    main()
