"""Glossy's lamp terms (issue 12) against native EEVEE, both measured against
Cycles rendering the true BSDF, on a sphere lit only by lamps (world black).

For each BRDF: the relative RMS of luminance over the sphere's pixels of
EEVEE with Glossy's factored lamps and of EEVEE with the true BSDF (which
EEVEE renders as isotropic GGX when it is anisotropic; for Ward, which Cycles
lacks, Blender's nearest anisotropic GGX plus diffuse), against the mean of
two Cycles seeds (64 samples, 64^2 px; for Ward the NumPy truth the script
computes, checked against Cycles in tests/blender/test_lamps.py), the Cycles
noise, the factor's own BRDF error and the whole script's time (bake +
renders). The baseline is native EEVEE, measured in the same run.

    .venv/bin/python benchmarks/lamps.py [--lamps point,sun] [--size 256] [--terms 2]
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import exr, metrics  # noqa: E402

SCRIPT = ROOT / "tests" / "blender" / "scripts" / "lamps_scene.py"
CASES = ("ggx:roughness=0.3", "ggx:roughness=0.3,anisotropy=0.8", "ggx:roughness=0.5",
         "beckmann:roughness=0.3", "ward:ax=0.21,ay=0.048,ks=0.3,kd=1/0/0")


def _image(path):
    image, _ = exr.read(path)
    return np.asarray(image, dtype=np.float64)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lamps", default="point,sun")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--terms", type=int, default=2)
    parser.add_argument("--param", default="half-difference")
    args = parser.parse_args()
    print(f"{'BRDF':36s} {'Glossy':>7s} {'native':>7s} {'ratio':>6s} {'noise':>6s} "
          f"{'factor':>7s} {'time':>6s}")
    for spec in CASES:
        with tempfile.TemporaryDirectory() as folder:
            folder = Path(folder)
            start = time.perf_counter()
            subprocess.run([sys.executable, str(SCRIPT), str(folder), spec, args.lamps,
                            str(args.size), str(args.terms), args.param,
                            str(folder / "r.json")], cwd=SCRIPT.parent, check=True,
                           capture_output=True)
            seconds = time.perf_counter() - start
            r = json.loads((folder / "r.json").read_text())
            mask = _image(r["glossy"])[..., 3] > 0.999
            if r.get("cycles"):
                first, second = (_image(p)[..., :3] for p in r["cycles"])
                reference = (first + second) / 2
                noise = metrics.relative_rms(first, second, mask) / 2
            else:  # no Cycles BSDF (Ward): the script's NumPy truth, noise-free
                reference, noise = _image(r["numpy_truth"])[..., :3], 0.0
            glossy = metrics.relative_rms(_image(r["glossy"])[..., :3], reference, mask)
            native = metrics.relative_rms(_image(r["native"])[..., :3], reference, mask)
            print(f"{spec:36s} {100 * glossy:6.1f}% {100 * native:6.1f}% "
                  f"{glossy / native:6.2f} {100 * noise:5.1f}% {100 * r['lamp_error']:6.1f}% "
                  f"{seconds:5.0f}s", flush=True)


if __name__ == "__main__":
    main()
