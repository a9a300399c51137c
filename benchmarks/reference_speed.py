"""The NumPy reference's time per BRDF, this tree against another checkout.

glossy.validate's reference (bake.reference.render_steps over the probe's bilinear
reconstruction, as the operator calls it) of an orthographic 64 x 64 px unit
sphere seen from -Y, lit by sunset.exr resampled to a cube of 64 px faces, for a
near-mirror coat over a rough dielectric, a near-mirror metal, a rough
dielectric and GGX 0.1 (the first two integrate their lobes' cores by their own
samples). Each case runs in a fresh process per checkout, one after the other,
so both see the same machine; prints seconds, the ratio and the largest
difference between the two results relative to the largest value.

    .venv/bin/python benchmarks/reference_speed.py --checkout /tmp/wt62
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
SPECS = (
    "principled:base_color=0.8,metallic=0,roughness=0.3,coat_weight=1,coat_roughness=0.03",
    "principled:metallic=1,roughness=0.02",
    "principled:base_color=0.5,metallic=0,roughness=0.3",
    "ggx:roughness=0.1",
)

CASE = r'''
import sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from bake import brdf, envmap, exr, reference
from tools.bpy_wheel import studio_lights
image, _ = exr.read(studio_lights() / "sunset.exr")
probe = envmap.convert(image[..., :3], "latlong", "cube", 64)
n = 64
y, x = np.mgrid[0:n, 0:n]
u, v = (x + 0.5) / n * 2 - 1, 1 - (y + 0.5) / n * 2
inside = u ** 2 + v ** 2 < 0.98
normals = np.stack([u[inside], -np.sqrt(1 - u[inside] ** 2 - v[inside] ** 2), v[inside]], 1)
views = np.broadcast_to([0.0, -1.0, 0.0], normals.shape)
model = brdf.parse(sys.argv[2])
start = time.perf_counter()
out = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
np.save(sys.argv[3], out)
print(time.perf_counter() - start)
'''


def run(checkout, spec, folder):
    path = Path(folder) / f"{abs(hash((str(checkout), spec)))}.npy"
    process = subprocess.run([sys.executable, "-c", CASE, str(checkout), spec, str(path)],
                             capture_output=True, text=True,
                             env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    if process.returncode != 0:
        raise SystemExit(f"{checkout}: {process.stderr.strip().splitlines()[-1]}")
    return float(process.stdout.strip().splitlines()[-1]), np.load(path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checkout", type=Path, required=True,
                        help="another checkout of the repository (git worktree add DIR REV)")
    args = parser.parse_args()
    rows = []
    print(f"{'BRDF':72s} {'this':>7s} {'other':>7s} {'ratio':>6s}  max diff")
    with tempfile.TemporaryDirectory() as folder:
        for spec in SPECS:
            mine, ours = run(ROOT, spec, folder)
            theirs, other = run(args.checkout.resolve(), spec, folder)
            difference = float(np.abs(ours - other).max() / max(np.abs(other).max(), 1e-300))
            print(f"{spec[:72]:72s} {mine:6.2f}s {theirs:6.2f}s {theirs / mine:5.2f}x  "
                  f"{difference:.1e}", flush=True)
            rows.append({"brdf": spec, "seconds": mine, "other_seconds": theirs,
                         "max_difference": difference})
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
