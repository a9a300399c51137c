"""A textured metal's base colour applied per pixel: the ratio against the split.

A metallic Principled BSDF with a base-colour texture is baked once; per pixel
the lookup either scales the map baked at the texture's mean m by c / m (the
ratio, what Glossy did before bake.colour_response) or evaluates the split
(R_0 + c (R_1 - R_0)) m(c, mu) from maps baked at colours 0 and 1. Both are
measured here without any map: every R is the brute-force reflected-radiance
integral of the true BRDF (bake.reference) over an isolated sphere's pixels,
so the figures are the colour handling's own error, on every bundled HDRI.

Prints, per roughness and texel colour c (grey, the texture's mean 0.5), the
worst relative RMS error over the HDRIs of each method against the integral
at colour c, and the HDRI where it is worst; then the same for two more
shortcuts the splits replace (bake.colour_response): a Multiscatter GGX
Glossy BSDF's colour as the factor c / m, and a coat tint texture taken at
its mean.

    .venv/bin/python benchmarks/colour_response.py [--quick]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import brdf, colour_response, envmap, exr  # noqa: E402
from bake.reference import reflected_radiance  # noqa: E402
from benchmarks.resolution_curve import relative_rms, sphere_pixels  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

MEAN = 0.5
COLOURS = (0.05, 0.2, 0.8, 0.95)


def table(worst, roughnesses, *columns):
    """Print the worst error and its HDRI per roughness and texel colour for the
    ``columns`` ((key in ``worst``, heading), ...)."""
    print(f"  {'roughness':>9s} {'texel c':>7s}" +
          "".join(f"   {heading:>18s}" for _, heading in columns))
    for roughness in roughnesses:
        for c in COLOURS:
            cells = (worst[(roughness, c, key)] for key, _ in columns)
            print(f"  {roughness:9.2f} {c:7.2f}" +
                  "".join(f"   {value:8.4f} ({where:>8s})" for value, where in cells))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="two HDRIs, smaller sphere")
    args = parser.parse_args()
    hdris = sorted(studio_lights().glob("*.exr"))
    if args.quick:
        hdris = [h for h in hdris if h.stem in ("sunset", "night")]
    normals, views = sphere_pixels(10 if args.quick else 14)
    roughnesses = (0.1, 0.3, 0.6)
    start = time.perf_counter()
    worst = {}
    for hdri in hdris:
        image, _ = exr.read(hdri)
        probe = envmap.convert(image, "latlong", "cube", 32)
        mu = np.einsum("ij,ij->i", normals, views)
        for roughness in roughnesses:
            def radiance(colour, roughness=roughness, probe=probe):
                spec = f"principled:base_color={colour:g},metallic=1,roughness={roughness}"
                return reflected_radiance(brdf.parse(spec), probe, "cube", normals, views)

            model = brdf.parse(f"principled:base_color={MEAN},metallic=1,roughness={roughness}")
            found = colour_response.response(model)
            low = reflected_radiance(brdf.parse(found.low), probe, "cube", normals, views)
            high = reflected_radiance(brdf.parse(found.high), probe, "cube", normals, views)
            at_mean = radiance(MEAN)
            # Two more shortcuts the splits replace: a Multiscatter Glossy BSDF's colour
            # as a factor (its energy term is not linear in it), a coat tint at its mean.
            glossy = f"ggx_multiscatter:roughness={roughness},color="
            coated = (f"principled:base_color=0.8,metallic=1,roughness={roughness},"
                      f"coat_weight=1,coat_roughness=0.1,coat_tint=")
            glossy_mean, coated_mean = (
                reflected_radiance(brdf.parse(f"{spec}{MEAN}"), probe, "cube", normals, views)
                for spec in (glossy, coated))
            for c in COLOURS:
                truth = radiance(c)
                ratio = relative_rms(at_mean * c / MEAN, truth)
                split = relative_rms(found.combine(low, high, np.full(3, c), mu), truth)
                glossy_truth, coated_truth = (
                    reflected_radiance(brdf.parse(f"{spec}{c:g}"), probe, "cube", normals,
                                       views) for spec in (glossy, coated))
                multiscatter = relative_rms(glossy_mean * c / MEAN, glossy_truth)
                coat_tint = relative_rms(coated_mean, coated_truth)
                for key, value in (("ratio", ratio), ("split", split),
                                   ("multiscatter", multiscatter), ("coat tint", coat_tint)):
                    best = worst.get((roughness, c, key), (-1.0, ""))
                    if value > best[0]:
                        worst[(roughness, c, key)] = (value, hdri.stem)
        print(f"  {hdri.stem}: done ({time.perf_counter() - start:.0f} s)", flush=True)
    print(f"\nMetal (Principled, Metallic 1, Multiscatter GGX), grey base-colour texture of "
          f"mean {MEAN}; worst relative RMS over {len(hdris)} HDRIs on {len(normals)} sphere "
          f"pixels, against the brute-force integral at the texel's colour:")
    table(worst, roughnesses, ("ratio", "ratio c/m"), ("split", "split (2 maps)"))
    print(f"\nShortcuts the splits replace (same pixels and HDRIs): a Multiscatter GGX Glossy "
          f"BSDF's colour texture as the factor c / m (the energy term's nonlinearity), and a "
          f"coated metal's (base 0.8, coat 1, coat roughness 0.1) Coat Tint texture taken at "
          f"its mean m = {MEAN}:")
    table(worst, roughnesses, ("multiscatter", "Multiscatter c/m"),
          ("coat tint", "coat tint at m"))
    ratio_all = max(v for (_, _, k), (v, _) in worst.items() if k == "ratio")
    split_all = max(v for (_, _, k), (v, _) in worst.items() if k == "split")
    print(f"worst: ratio {ratio_all:.4f}, split {split_all:.4f} "
          f"({ratio_all / max(split_all, 1e-12):.0f}x lower)")


if __name__ == "__main__":
    main()
