"""NumPy's OpenBLAS held to one thread (bake.blas_threads) against its default, in one run.

The bake's steps and the validation's NumPy reference run their own threads
on every core; OpenBLAS's threads, woken by each matrix product, spin
against them. This times the same work both ways, alternating, best of
``--repeat``, with the process's system time for each (the spinning shows
there): the NumPy reference of a 64^2 px sphere (bake.reference.render) and
a 3D map at Auto size (bake.prefilter, the probe's cached transforms
cleared each time), both from a 128 px cube probe of sunset.exr.

    .venv/bin/python benchmarks/blas_threads.py [--repeat 3] [--hdri sunset]

Run it without OPENBLAS_NUM_THREADS set (make test sets it to 1, which would
make both columns the same).
"""

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import blas_threads, brdf, exr, prefilter, probe_maps, reference  # noqa: E402
from bake.envmap import convert  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402


def timed(work, limited):
    """(wall seconds, system seconds) of work() with BLAS limited or not."""
    system = os.times().system
    start = time.perf_counter()
    if limited:
        with blas_threads.limited():
            work()
    else:
        work()
    return time.perf_counter() - start, os.times().system - system


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--hdri", default="sunset")
    args = parser.parse_args()
    if not blas_threads.available():
        sys.exit("NumPy's OpenBLAS was not found: nothing to compare")
    image, _ = exr.read(studio_lights() / f"{args.hdri}.exr")
    cube = convert(image[..., :3], "latlong", "cube", 128)
    normals, views, mask = reference.sphere_buffers(64)
    normals, views = normals[mask], views[mask]

    def sphere(spec):
        return lambda: reference.render(brdf.parse(spec), cube, "cube", normals, views)

    def bake(spec):
        def work():
            probe_maps.clear_cache()
            prefilter.prefilter(cube, spec, "3d", "auto")
        return work

    print(f"OpenBLAS threads by default: {blas_threads.current()} "
          f"(OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}); "
          f"{args.hdri}.exr, 128 px cube probe, best of {args.repeat}")
    print(f"{'work':44s} {'default':>16s} {'one thread':>16s} {'ratio':>6s}")
    for label, work in (("NumPy reference, 64^2 sphere, GGX 0.3", sphere("ggx:roughness=0.3")),
                        ("NumPy reference, 64^2 sphere, GGX 0.1", sphere("ggx:roughness=0.1")),
                        ("3D map at Auto size, GGX 0.1", bake("ggx:roughness=0.1")),
                        ("3D map at Auto size, GGX 0.3", bake("ggx:roughness=0.3"))):
        work()  # warm: fits, tables, caches other than the probe's
        runs = {False: [], True: []}
        for _ in range(args.repeat):
            for limited in (False, True):
                runs[limited].append(timed(work, limited))
        best = {k: min(v) for k, v in runs.items()}
        print(f"{label:44s} {best[False][0]:6.2f} s (sys {best[False][1]:4.2f}) "
              f"{best[True][0]:6.2f} s (sys {best[True][1]:4.2f}) "
              f"{best[False][0] / best[True][0]:6.2f}", flush=True)


if __name__ == "__main__":
    main()
