"""Runtime regular sampling (bake.sampling) against filtered importance sampling.

The regular-sampling paper's comparison (Figures 8-10) on this machine: a
sphere (48^2 pixels) lit by an environment of tiny bright discs (2-10 degrees,
30 to 3000 times a dim sky; three random layouts), for the Kurt model
(isotropic m = 0.1 with 14 samples, anisotropic m_x = 0.2, m_y = 0.075 with
the anisotropic pattern closest to 17) and for Cycles' GGX (roughness 0.3,
isotropic and anisotropy 0.8, 19 and 14 samples). For each: the relative RMS
of luminance against the brute-force integral over every texel
(bake.reference), for regular sampling at its defaults and for Colbert &
Krivanek's filtered importance sampling with the same number of samples at
MIP bias 0, 0.5 and 1 (their +1 is the last), and the time per pixel of each
estimator in NumPy (the baseline being FIS, measured in the same run; the
first layout's regular times include the directional-albedo integrals of
eq. 18's constant, cached afterwards, as a lookup table holds them at run time).

The paper's Figure 7 (EEVEE frame time against samples per pixel) and the
node graph's compile time are in benchmarks/sampling_eevee.py.

    .venv/bin/python benchmarks/sampling.py [--size 48] [--probe 64]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import brdf, reference, sampling  # noqa: E402

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
CASES = (("Kurt iso m 0.1", "kurt:ks=1,mx=0.1,my=0.1,f0=1,alpha=0.5", 14),
         ("Kurt aniso 0.2/0.075", "kurt:ks=1,mx=0.2,my=0.075,f0=1,alpha=0.5", 17),
         ("GGX 0.3", "ggx:roughness=0.3", 19),
         ("GGX 0.3 aniso 0.8", "ggx:roughness=0.3,anisotropy=0.8", 17))


def relative_rms(image, truth):
    return float(np.sqrt(np.mean((image @ LUMINANCE - truth @ LUMINANCE) ** 2)
                         / np.mean((truth @ LUMINANCE) ** 2)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=48, help="sphere image size (pixels)")
    parser.add_argument("--probe", type=int, default=64, help="cube face size")
    args = parser.parse_args()
    normals, views, mask = reference.sphere_buffers(args.size)
    normals, views = normals[mask], views[mask]
    print(f"sphere {args.size}^2 ({len(normals)} pixels), cube probe {args.probe}^2 per face, "
          "tiny bright spots; relative RMS of luminance against brute force")
    print(f"{'material':22s} {'seed':>4s} {'N':>3s} {'regular':>8s} {'FIS b0':>7s} "
          f"{'FIS b.5':>7s} {'FIS b1':>7s}  {'reg us/px':>9s} {'FIS us/px':>9s}")
    for seed in (3, 7, 11):
        env = sampling.spots_environment(args.probe, seed)
        mip = sampling.MipProbe(env)
        for name, spec, budget in CASES:
            model = brdf.parse(spec)
            truth = reference.render(model, env, "cube", normals, views)
            count = len(sampling.pattern_for_budget(budget, sampling.lobe_of(model).anisotropic))
            start = time.perf_counter()
            regular = sampling.render_regular(model, None, normals, views, budget=budget,
                                              mip=mip)
            regular_s = time.perf_counter() - start
            fis, fis_s = [], 0.0
            for bias in (0.0, 0.5, 1.0):
                start = time.perf_counter()
                fis.append(relative_rms(sampling.render_fis(model, None, normals, views,
                                                            samples=count, mip=mip, bias=bias),
                                        truth))
                fis_s = time.perf_counter() - start
            print(f"{name:22s} {seed:4d} {count:3d} {relative_rms(regular, truth):8.3f} "
                  + " ".join(f"{e:7.3f}" for e in fis)
                  + f"  {1e6 * regular_s / len(normals):9.1f} {1e6 * fis_s / len(normals):9.1f}",
                  flush=True)


if __name__ == "__main__":
    main()
