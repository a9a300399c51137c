"""BRDF evaluation speed (issue: BRDF library): evaluations per second on 10^6 pairs.

Prints, for GGX (isotropic and anisotropic), Ward, Kurt, an isotropic
tabulated BRDF and Principled BSDFs as Blender's node makes them (metal,
the default dielectric with its diffuse part, anisotropic metal, a coated
mix: what From Material bakes, for lobe fits, lamp factors and tables), the
rate of ``model.f(wi, wo)`` on 10^6 random direction pairs (float64, RGB
out), and the rate of a plain per-pair Python loop of the
GGX formula as the baseline. Target: >= 5e6 GGX evaluations per second on the
2-core reference machine.

    .venv/bin/python benchmarks/brdf.py [--pairs 1000000] [--repeat 3]
"""

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import brdf  # noqa: E402
from bake.brdf.tabulated import IsotropicTable  # noqa: E402


def pairs(n, seed=0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, n, 3))
    v[..., 2] = np.abs(v[..., 2])
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def rate(function, n, repeat):
    best = math.inf
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return n / best


def loop_ggx(wi, wo, alpha):
    out = []
    a2 = alpha * alpha
    for a, b in zip(wi.tolist(), wo.tolist(), strict=True):
        hx, hy, hz = a[0] + b[0], a[1] + b[1], a[2] + b[2]
        norm = math.sqrt(hx * hx + hy * hy + hz * hz)
        ch = hz / norm
        d = a2 / (math.pi * ((1 - ch * ch) + a2 * ch * ch) ** 2)
        la = (math.sqrt(1 + a2 * (1 - a[2] ** 2) / a[2] ** 2) - 1) / 2
        lb = (math.sqrt(1 + a2 * (1 - b[2] ** 2) / b[2] ** 2) - 1) / 2
        out.append(d / (1 + la + lb) / (4 * a[2] * b[2]))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=1_000_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    wi, wo = pairs(args.pairs)
    models = {
        "ggx:roughness=0.3": brdf.parse("ggx:roughness=0.3"),
        "ggx:roughness=0.3,anisotropy=0.8,rotation=0.25":
            brdf.parse("ggx:roughness=0.3,anisotropy=0.8,rotation=0.25"),
        "ward:alpha=0.1": brdf.parse("ward:alpha=0.1"),
        "kurt (2 lobes)": brdf.parse("kurt:kd=0.1,ks=0.5,mx=0.2,my=0.3,ks2=0.2,mx2=0.05,my2=0.05"),
        "table 64x64x65 (from ggx)": IsotropicTable.from_model(brdf.parse("ggx:roughness=0.3"),
                                                               (64, 64, 65)),
    }
    for spec in ("principled:metallic=1,roughness=0.1", "principled:roughness=0.5",
                 "principled:metallic=1,roughness=0.3,anisotropy=0.8",
                 "principled:roughness=0.2,metallic=0.3,coat_weight=0.6"):
        models[spec] = brdf.parse(spec)
    print(f"{args.pairs} direction pairs, float64, RGB out, best of {args.repeat}")
    rates = {}
    for name, model in models.items():
        rates[name] = rate(lambda model=model: model.f(wi, wo), args.pairs, args.repeat)
        print(f"  {name:50s} {rates[name] / 1e6:7.2f} M evaluations/s")
    small = 20_000
    loop = rate(lambda: loop_ggx(wi[:small], wo[:small], 0.09), small, 1)
    ggx = rates["ggx:roughness=0.3"]
    verdict = "meets" if ggx >= 5e6 else "MISSES"
    label = "plain Python loop, isotropic GGX"
    print(f"  {label:50s} {loop / 1e6:7.2f} M evaluations/s")
    print(f"GGX vectorized / loop = {ggx / loop:.0f}x; GGX {ggx / 1e6:.2f} M/s {verdict} the "
          f"5 M/s target")


if __name__ == "__main__":
    main()
