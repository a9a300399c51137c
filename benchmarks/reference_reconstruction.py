"""How far the texel sum is from the integral of the probe's bilinear reconstruction,
and how close bake.reference's ``reconstruction="bilinear"`` comes, on every
bundled HDRI.

The NumPy reference (glossy.validate's "NumPy reference" column, ``python -m
bake reference``) sums the BRDF over the probe's texel centres. A renderer
samples the probe's bilinear reconstruction; for a lobe a few texels wide the
texel sum is an aliased quadrature of that integral. For each HDRI and case
(BRDF, probe face), on a sphere seen as bake.reference.sphere_buffers sees
it, this prints the relative RMS (luminance) against the same sum over the
reconstruction sampled ``--truth`` times finer per side (converged: the
script also prints the difference between the truth and the sum at half its
factor), for the texel sum and for the bilinear option at its own factor
(bake.reference.reconstruction_factor), with the seconds each took.

With ``--world`` the truth is instead the integral over the HDRI's own bilinear
reconstruction (``--truth`` times finer), what Cycles renders, and the table
adds a box reconstruction of the probe (each texel constant): how close each
reading of the probe comes to Cycles' integral, the probe's own loss of
detail included.

    .venv/bin/python benchmarks/reference_reconstruction.py [--sphere 48] [--truth 8]
        [--hdri interior ...] [--case ggx:roughness=0.1@328 ...] [--world]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, envmap, exr, reference  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

LUM = np.array([0.2126, 0.7152, 0.0722])
CASES = ("ggx:roughness=0.1@328", "ggx:roughness=0.2@128", "ggx:roughness=0.3@64",
         "ggx:roughness=0.6@64")


def relative_rms(values, truth):
    return float(np.sqrt(np.sum(((values - truth) @ LUM) ** 2) / np.sum((truth @ LUM) ** 2)))


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    value = function(*args, **kwargs)
    return value, time.perf_counter() - start


def box_grid(cube, factor):
    """A cube strip (N, 6N, 3) with each texel repeated factor x factor times: its box
    reconstruction on a finer grid (a cube face's grid subdivides exactly)."""
    n = cube.shape[0]
    faces = cube.reshape(n, 6, n, cube.shape[2])
    fine = np.repeat(np.repeat(faces, factor, axis=0), factor, axis=2)
    return np.ascontiguousarray(fine.reshape(n * factor, 6 * n * factor, cube.shape[2]))


def against_world(image, cases, normals, views, factor):
    """Rows of the --world table for one HDRI (lat-long ``image``)."""
    latlong = envmap.get_layout("latlong")
    for spec, face in cases:
        model = brdf.parse(spec)
        world = reference.render(model, reference._bilinear_grid(image, latlong, factor),
                                 "latlong", normals, views)
        half = reference.render(model, reference._bilinear_grid(image, latlong, factor // 2),
                                "latlong", normals, views) if factor > 1 else world
        probe = envmap.convert(image, "latlong", "cube", face)
        texels = reference.render(model, probe, "cube", normals, views)
        bilinear = reference.render(model, probe, "cube", normals, views,
                                    reconstruction="bilinear")
        box = reference.render(model, box_grid(probe, 4), "cube", normals, views)
        yield spec, face, [relative_rms(x, world) for x in (texels, bilinear, box)], \
            relative_rms(half, world)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sphere", type=int, default=48, help="sphere image size (px)")
    parser.add_argument("--truth", type=int, default=8,
                        help="the truth's sub-texels per texel side (a power of two)")
    parser.add_argument("--hdri", action="append", help="bundled HDRI stems (default: all)")
    parser.add_argument("--case", action="append", help="SPEC@FACE (default: a set of four)")
    parser.add_argument("--world", action="store_true",
                        help="the truth is the integral over the HDRI's own reconstruction")
    args = parser.parse_args()
    hdris = args.hdri or sorted(p.stem for p in studio_lights().glob("*.exr"))
    cases = [(spec, int(face)) for spec, face in
             (case.rsplit("@", 1) for case in (args.case or CASES))]
    normals, views, mask = reference.sphere_buffers(args.sphere)
    normals, views = normals[mask], views[mask]
    if args.world:
        print(f"{len(normals)} sphere pixels; truth: the integral over the HDRI's bilinear "
              f"reconstruction ({args.truth}x finer); the probe read three ways; relative RMS "
              f"of luminance")
        print(f"{'HDRI':10s} {'BRDF':22s} {'face':>5s} {'texels':>7s} {'bilinear':>8s} "
              f"{'box':>7s}   {'truth/2 vs truth':>16s}")
        for hdri in hdris:
            image = exr.read(studio_lights() / f"{hdri}.exr")[0][..., :3]
            for spec, face, errors, half in against_world(image, cases, normals, views,
                                                          args.truth):
                print(f"{hdri:10s} {spec:22s} {face:5d} {errors[0]:7.4f} {errors[1]:8.4f} "
                      f"{errors[2]:7.4f}   {half:16.5f}", flush=True)
        return
    cube = envmap.get_layout("cube")
    print(f"{len(normals)} sphere pixels; truth: the sum over the bilinear reconstruction "
          f"{args.truth}x finer per side; relative RMS of luminance")
    print(f"{'HDRI':10s} {'BRDF':22s} {'face':>5s} {'texels':>7s} {'s':>5s}   {'bilinear':>8s} "
          f"{'factor':>6s} {'s':>5s}   {'truth/2 vs truth':>16s}")
    for hdri in hdris:
        image, _ = exr.read(studio_lights() / f"{hdri}.exr")
        for spec, face in cases:
            model = brdf.parse(spec)
            probe = envmap.convert(image[..., :3], "latlong", "cube", face)
            factor, _ = reference.reconstruction_factor(model, probe.shape, "cube", normals,
                                                        views)
            truth = reference.render(model, reference._bilinear_grid(probe, cube, args.truth),
                                     "cube", normals, views)
            half = reference.render(model, reference._bilinear_grid(probe, cube,
                                                                    args.truth // 2),
                                    "cube", normals, views) if args.truth > 2 else probe
            texels, texel_s = timed(reference.render, model, probe, "cube", normals, views)
            bilinear, bilinear_s = timed(reference.render, model, probe, "cube", normals, views,
                                         reconstruction="bilinear")
            print(f"{hdri:10s} {spec:22s} {face:5d} {relative_rms(texels, truth):7.4f} "
                  f"{texel_s:5.1f}   {relative_rms(bilinear, truth):8.4f} {factor:6d} "
                  f"{bilinear_s:5.1f}   {relative_rms(half, truth):16.5f}", flush=True)


if __name__ == "__main__":
    main()
