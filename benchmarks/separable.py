"""Separable BRDF factorization (bake.separable): time and memory peak.

For 64^2 factor textures of a sampled 4D table (anisotropic GGX, roughness
0.5, anisotropy 0.8, tabulated as a 16 x 32 x 16 x 32 anisotropic table and
interpolated multilinearly; its horizon nodes hold the values at 88 degrees,
as a measured table would, rather than the 1 / (cos theta_i cos theta_o) peak
of a mirror at exact grazing), per parameterization: the time to sample
the 4096 x 4096 matrix, then the time and the memory peak (tracemalloc, NumPy's
allocations included) of the one-term ND (target under 2 s) and of the
truncated SVD (1 and 5 terms), against a baseline measured in the same run:
NumPy's full SVD of the same matrix (green channel), what a truncated solver
avoids. The half-vector parameterizations fit only the pairs above the
horizon (weighted least squares), which costs a few more passes.

    .venv/bin/python benchmarks/separable.py [--size 64]
"""

import argparse
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, separable  # noqa: E402
from bake.brdf.tabulated import AnisotropicTable  # noqa: E402


def measured(function):
    tracemalloc.start()
    start = time.perf_counter()
    result = function()
    seconds = time.perf_counter() - start
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return result, seconds, peak / 2**20


def grazing_safe_table(spec, shape=(16, 32, 16, 32), last_degrees=88.0):
    """An anisotropic table of ``spec`` whose horizon nodes are sampled at ``last_degrees``."""
    model = brdf.parse(spec)
    ni, pi_, no, po = shape
    cap = np.radians(last_degrees)
    ti = np.minimum(np.linspace(0, np.pi / 2, ni), cap)[:, None, None, None]
    fi = (np.arange(pi_) * 2 * np.pi / pi_)[None, :, None, None]
    to = np.minimum(np.linspace(0, np.pi / 2, no), cap)[None, None, :, None]
    fo = (np.arange(po) * 2 * np.pi / po)[None, None, None, :]
    ti, fi, to, fo = np.broadcast_arrays(ti, fi, to, fo)
    wi = np.stack([np.sin(ti) * np.cos(fi), np.sin(ti) * np.sin(fi), np.cos(ti)], -1)
    wo = np.stack([np.sin(to) * np.cos(fo), np.sin(to) * np.sin(fo), np.cos(to)], -1)
    return AnisotropicTable(model.f(wi, wo), source=f"<{spec} {ni}x{pi_}x{no}x{po}>")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=64)
    args = parser.parse_args()
    size = args.size
    table = grazing_safe_table("ggx:roughness=0.5,anisotropy=0.8")
    pairs = separable.stratified_pairs()
    print(f"{size}^2 factors of {table.spec[:60]} ({size * size} x {size * size} matrix, RGB); "
          f"error: cosine-weighted relative RMS over {len(pairs[0])} stratified pairs")
    print(f"{'parameterization':18s} {'sample s':>8s} {'ND1 s':>6s} {'MB':>6s} {'err':>6s}  "
          f"{'SVD1 s':>6s} {'MB':>6s} {'err':>6s}  {'SVD5 s':>6s} {'MB':>6s} {'err':>6s}")
    baseline = None
    for param in separable.PARAMETERIZATIONS:
        matrix, sample_s, _ = measured(lambda param=param: separable.matrix_for(table, param,
                                                                              size))
        cells = []
        for method, terms in (("nd", 1), ("svd", 1), ("svd", 5)):
            fac, seconds, peak = measured(
                lambda method=method, terms=terms, param=param, matrix=matrix:
                separable.factorize(table, param, method, terms, size, matrix=matrix))
            cells.append(f"{seconds:6.2f} {peak:6.0f} {separable.error(fac, table, pairs):6.3f}")
        print(f"{param:18s} {sample_s:8.2f} " + "  ".join(cells), flush=True)
        if baseline is None and matrix._kept is not None:
            green = matrix._kept[1].astype(np.float64)
            _, baseline, peak = measured(lambda green=green: np.linalg.svd(green,
                                                                          compute_uv=True))
            print(f"   baseline: NumPy's full SVD of the green channel alone: {baseline:.2f} s, "
                  f"{peak:.0f} MB (the truncated solver needs neither)")


if __name__ == "__main__":
    main()
