"""Speed of environment-map conversion and MIP pyramids (issue: foundation).

Prints, in one run:
- the time to convert Blender's bundled forest.exr (1024 x 512 lat-long) to a
  6 x 256^2 cube map and to build its MIP pyramid (box, gauss4, gauss6);
  target: conversion + pyramid under 1 s on the 2-core reference machine;
- the same conversion done by a straightforward per-texel Python loop on a
  small cube (same sub-sampling), its time per texel and the ratio.

    .venv/bin/python benchmarks/envmap.py [--repeat 3]
"""

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import exr  # noqa: E402
from bake.envmap import convert, get_layout  # noqa: E402
from bake.envmap.convert import resample, supersampling  # noqa: E402
from bake.envmap.mip import FILTERS, pyramid  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402


def best_of(repeat, function):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return min(times), result


def loop_convert_to_cube(image, size, k):
    """Per-texel reference loop: k x k Jacobian-weighted bilinear lat-long taps."""
    height, width = image.shape[:2]
    out = np.zeros((size, 6 * size, 3))
    face_table = [
        lambda a, b: (1.0, -b, -a), lambda a, b: (-1.0, -b, a), lambda a, b: (a, 1.0, b),
        lambda a, b: (a, -1.0, -b), lambda a, b: (a, -b, 1.0), lambda a, b: (-a, -b, -1.0),
    ]

    # Rows 0 and H + 1 are the poles (mean of the nearest row), as in bake.
    rows = np.concatenate([image[:1].mean(1, keepdims=True).repeat(width, 1), image,
                           image[-1:].mean(1, keepdims=True).repeat(width, 1)])

    def lookup(dx, dy, dz):
        x = (0.5 - math.atan2(dy, dx) / (2 * math.pi)) % 1.0 * width - 0.5
        y = math.acos(max(-1.0, min(1.0, dz))) / math.pi * height
        if y < 0.5:
            y = 2.0 * y
        elif y > height - 0.5:
            y = height + 1.0 - 2.0 * (height - y)
        else:
            y = y + 0.5
        x0, y0 = math.floor(x), min(int(y), height)
        fx, fy = x - x0, y - y0
        c0, c1 = x0 % width, (x0 + 1) % width
        top = rows[y0, c0] * (1 - fx) + rows[y0, c1] * fx
        bottom = rows[y0 + 1, c0] * (1 - fx) + rows[y0 + 1, c1] * fx
        return top * (1 - fy) + bottom * fy

    for face in range(6):
        for row in range(size):
            for col in range(size):
                total, weight = np.zeros(3), 0.0
                for i in range(k):
                    for j in range(k):
                        a = 2.0 * (col + (j + 0.5) / k) / size - 1.0
                        b = 2.0 * (row + (i + 0.5) / k) / size - 1.0
                        gx, gy, gz = face_table[face](a, b)
                        norm = math.sqrt(gx * gx + gy * gy + gz * gz)
                        w = (1.0 + a * a + b * b) ** -1.5
                        total += w * lookup(gx / norm, -gz / norm, gy / norm)
                        weight += w
                out[row, face * size + col] = total / weight
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--loop-size", type=int, default=12)
    args = parser.parse_args()

    source_path = studio_lights() / "forest.exr"
    image, _ = exr.read(source_path)
    print(f"source: {source_path.name} {image.shape[1]}x{image.shape[0]} lat-long")
    k = supersampling(get_layout("latlong"), image.shape[:2], get_layout("cube"),
                      get_layout("cube").shape(args.size))
    t_convert, cube = best_of(args.repeat, lambda: convert(image, "latlong", "cube", args.size))
    print(f"convert -> cube 6x{args.size}^2 ({k}x{k} sub-samples/texel): {t_convert:.3f} s")
    for name in FILTERS:
        t_mip, levels = best_of(args.repeat, lambda name=name: pyramid(cube, "cube", name))
        total = t_convert + t_mip
        verdict = "meets" if total < 1.0 else "MISSES"
        print(f"pyramid {name:6s} ({len(levels)} levels): {t_mip:.3f} s; convert + pyramid "
              f"{total:.3f} s ({verdict} the 1 s target)")

    small = args.loop_size
    t_loop, looped = best_of(1, lambda: loop_convert_to_cube(image, small, k))
    # The same work vectorized: no polar prefilter, no MIP pre-reduction.
    cube_layout = get_layout("cube")
    vectorized = resample(get_layout("latlong").sampler(image), cube_layout,
                          cube_layout.shape(small), k, 3)
    difference = float(np.abs(looped - vectorized).max() / np.abs(looped).max())
    per_loop = t_loop / (6 * small * small)
    per_vec = t_convert / (6 * args.size * args.size)
    print(f"per-texel loop, cube 6x{small}^2: {t_loop:.2f} s = {per_loop * 1e6:.0f} us/texel "
          f"(same result to {difference:.1e} of the peak)")
    print(f"vectorized: {per_vec * 1e6:.2f} us/texel; ratio loop/vectorized = "
          f"{per_loop / per_vec:.0f}x; the loop would take {per_loop * 6 * args.size**2:.0f} s "
          f"for 6x{args.size}^2")


if __name__ == "__main__":
    main()
