"""Speed of Glossy's NumPy EXR codec (used inside Blender on Linux) against the
OpenEXR package, on a real baked-map-sized image.

Prints write and read times (best of N) and file sizes for both backends, and
the codec/package ratios, for forest.exr resampled to a 16-slice 256 x 128
atlas-sized image (2048 x 512 x 3 float32) with ZIP compression.

    .venv/bin/python benchmarks/exr_codec.py [--repeat 3]
"""

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bake import exr  # noqa: E402
from bake.envmap import convert  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402


def best_of(repeat, function):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    os.environ.pop("GLOSSY_EXR_BACKEND", None)
    forest, _ = exr.read(studio_lights() / "forest.exr")
    image = convert(forest, "latlong", "latlong", 512)  # 512 x 1024
    image = image.repeat(2, axis=1)[:, :2048]  # 512 x 2048: the size of a 16-slice atlas
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        for backend in ("openexr", "numpy"):
            os.environ["GLOSSY_EXR_BACKEND"] = backend
            path = Path(folder) / f"{backend}.exr"
            write = best_of(args.repeat, lambda p=path: exr.write(p, image, {"bench": 1}))
            read = best_of(args.repeat, lambda p=path: exr.read(p))
            results[backend] = (write, read, path.stat().st_size / 1e6)
            print(f"{backend:8s} write {write * 1e3:7.1f} ms  read {read * 1e3:7.1f} ms  "
                  f"{results[backend][2]:.1f} MB")
    os.environ.pop("GLOSSY_EXR_BACKEND", None)
    (pw, pr, _), (cw, cr, _) = results["openexr"], results["numpy"]
    print(f"codec / package: write x{cw / pw:.2f}, read x{cr / pr:.2f} "
          f"({image.shape[1]} x {image.shape[0]} x {image.shape[2]} float32, ZIP)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
