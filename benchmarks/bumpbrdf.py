"""BRDF tables from bump height fields (bake.bumpbrdf): speed and accuracy.

Prints, in one run:
1. the full isotropic table of a 256^2 Gaussian random surface (RMS slope 0.2,
   24 incident elevations x 24 azimuths x the 24 x 25 outgoing cells, the
   Cabral et al. set-up): seconds for the horizon tables and for the beams,
   against the straightforward per-facet Python loop (every facet's shadowing,
   masking, reflection and binning one at a time; timed on 2,000 facets of
   one incident direction, its cost per facet is constant, and extrapolated
   to the whole table), their ratio, and the target (< 60 s);
2. the same table against Beckmann + Smith at alpha = sqrt(2) sigma averaged
   over each cell (the closed form the surface should follow): median and
   90th-percentile relative error over the lobe's cells per incident elevation
   up to 60 degrees, and the reciprocity error before averaging;
3. the spherical-harmonic lobe coefficients from the facets (section 8)
   against the quadrature of the same Beckmann lobe, per tilt.

    .venv/bin/python benchmarks/bumpbrdf.py [--size 256]
"""

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, bumpbrdf  # noqa: E402
from bake import sh_reflection as shr  # noqa: E402


def per_facet_loop(surface, wi, facets, thetas, phis):
    """The straightforward loop: one facet at a time, the same model as
    BumpSurface.scatter (horizon interpolation, partial-facet lattice, binning)."""
    flux = np.zeros((thetas, phis))
    lattice = bumpbrdf._lattice()
    elevation = math.asin(wi[2])
    azimuth = math.atan2(wi[1], wi[0])
    for f in facets:
        n = surface.normals[f]
        c = float(n @ wi)
        if c <= 0:
            continue
        r = 2 * c * n - wi
        if r[2] <= 1e-9:
            continue
        lit, seen = [], []
        r_elevation, r_azimuth = math.asin(min(r[2], 1.0)), math.atan2(r[1], r[0])
        for vertex in surface.verts[f]:
            for angle, height, out in ((azimuth, elevation, lit),
                                       (r_azimuth, r_elevation, seen)):
                position = (angle % (2 * math.pi)) / (2 * math.pi) * bumpbrdf.COMPASS
                k0 = int(position) % bumpbrdf.COMPASS
                t = position - math.floor(position)
                horizon = (1 - t) * surface.horizons[k0, vertex] + \
                    t * surface.horizons[(k0 + 1) % bumpbrdf.COMPASS, vertex]
                out.append(height - horizon)
        fraction = 0.0
        for b in lattice:
            if sum(w * x for w, x in zip(b, lit, strict=True)) > 0 and \
                    sum(w * x for w, x in zip(b, seen, strict=True)) > 0:
                fraction += 1.0 / len(lattice)
        power = surface.areas[f] * c * fraction
        theta_o = math.acos(r[2])
        row = min(int(round(theta_o / (math.pi / 2) * (thetas - 1))), thetas - 1)
        relative = abs((r_azimuth - azimuth + math.pi) % (2 * math.pi) - math.pi)
        col = min(int(round(relative / (math.pi / (phis - 1)))), phis - 1)
        flux[row, col] += power
    return flux


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=256)
    args = parser.parse_args()
    sigma, thetas, phis, azimuths = 0.2, 24, 25, 24
    heights = bumpbrdf.gaussian_surface(args.size, sigma, 4.0, 0)

    start = time.perf_counter()
    surface = bumpbrdf.BumpSurface(heights, mirror=True)
    horizons = time.perf_counter() - start
    start = time.perf_counter()
    values, raw = bumpbrdf.bump_table(surface, thetas=thetas, phis=phis, azimuths=azimuths)
    beams = time.perf_counter() - start
    total = horizons + beams

    facets = np.linspace(0, len(surface.areas) - 1, 2000).astype(int)
    wi = np.array([math.sin(0.6), 0.0, math.cos(0.6)])
    start = time.perf_counter()
    per_facet_loop(surface, wi, facets, thetas, phis)
    per_facet = (time.perf_counter() - start) / len(facets)
    loop = per_facet * len(surface.areas) * thetas * azimuths
    print(f"1. full table, {args.size}^2 Gaussian surface ({len(surface.areas)} facets), "
          f"{thetas} incident elevations x {azimuths} azimuths x {thetas} x {phis} cells:")
    print(f"   horizon tables {horizons:6.1f} s, beams {beams:6.1f} s, total {total:6.1f} s "
          f"({'meets' if total < 60 else 'MISSES'} the 60 s target)")
    print(f"   per-facet Python loop: {1e6 * per_facet:.0f} us per facet and direction, "
          f"{loop / 3600:.1f} h for the table (extrapolated): ratio {loop / beams:.0f}x")

    reference = brdf.parse(f"beckmann:alpha={math.sqrt(2) * sigma}")
    print(f"2. against Beckmann + Smith, alpha = sqrt(2) x {sigma} (cell averages, F = 1):")
    from tests.bake.test_bumpbrdf import _cell_average

    exact = _cell_average(reference, thetas, phis, sub=4)
    table = values[..., 0]
    for index, theta in enumerate(np.degrees(bumpbrdf._incident_theta(thetas))):
        if theta > 60 or index % 3:
            continue
        lobe = exact[index] > 0.05 * exact[index].max()
        error = np.abs(table[index][lobe] - exact[index][lobe]) / exact[index][lobe]
        print(f"   theta_i {theta:5.1f}: {lobe.sum():4d} cells, median {np.median(error):.3f}, "
              f"p90 {np.percentile(error, 90):.3f}")
    print(f"   reciprocity before averaging (median |f(l,v) - f(v,l)| / mean over the lobe): "
          f"{bumpbrdf.reciprocity_error(raw):.4f}")

    order = 8
    start = time.perf_counter()
    facets_a = shr.facet_coefficients(surface, order, alphas=9, azimuths=4)[..., 0]
    spent = time.perf_counter() - start
    quadrature = shr.lobe_coefficients(reference, order, alphas=9)[..., 0]
    print(f"3. SH lobe coefficients (M = {order}) from the facets ({spent:.1f} s for 9 tilts x "
          f"4 azimuths) against quadrature of the Beckmann lobe, |difference| / |a|:")
    print("   " + ", ".join(
        f"{math.degrees(a):.0f} deg {np.linalg.norm(facets_a[j] - quadrature[j]) / np.linalg.norm(quadrature[j]):.3f}"  # noqa: E501
        for j, a in enumerate(shr.alpha_nodes(9))))


if __name__ == "__main__":
    main()
