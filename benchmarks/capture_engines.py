"""What the capture engine does to a whole result: one Principled metal sphere whose
Render Scene probe is captured by Cycles and by EEVEE, baked, attached and validated
against Cycles (tests/blender/scripts/capture_world_validate.py, a fresh process each).

    .venv/bin/python benchmarks/capture_engines.py [--world sky|sunset|PATH.exr ...]
        [--roughness 0.25] [--cycles 1024] [--engine CYCLES --engine BLENDER_EEVEE]
        [--checkout DIR]

Printed per world and engine: the capture's time, the probe's face, Glossy's
relative RMS of luminance from Cycles (the mean over two seeds, and each seed),
the NumPy reference over the same probe from Cycles (what the probe allows),
native EEVEE with the careful user's settings, Cycles' own noise, and how the
probe's sky was made (its header's ``world``). ``--checkout`` runs the script of
another checkout of Glossy (``git worktree add DIR REV``) to compare with an
earlier capture in the same session. "sky" is a Sky Texture world, which World
Only cannot read; the default worlds are it and sunset.exr (a sun of a few texels).
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tools.bpy_wheel import studio_lights  # noqa: E402


def world_argument(world):
    if world == "sky" or world.endswith(".exr"):
        return world if world == "sky" else str(Path(world).resolve())
    return str(studio_lights() / f"{world}.exr")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--world", action="append", help="sky, a bundled HDRI stem or a path")
    parser.add_argument("--roughness", type=float, default=0.25)
    parser.add_argument("--cycles", type=int, default=1024, help="Cycles samples per seed")
    parser.add_argument("--engine", action="append", choices=("CYCLES", "BLENDER_EEVEE"))
    parser.add_argument("--checkout", default=str(ROOT),
                        help="the Glossy checkout whose script and add-on run (default: this)")
    args = parser.parse_args()
    script = Path(args.checkout).resolve() / "tests" / "blender" / "scripts" / \
        "capture_world_validate.py"
    if not script.exists():
        parser.error(f"{script} is missing (a checkout from before this benchmark? copy the "
                     "script into it)")
    print(f"Principled metal {args.roughness}, Auto probe, 96^2 px, Cycles 2 x {args.cycles} "
          f"spp; relative RMS of luminance against Cycles ({args.checkout})", flush=True)
    print(f"{'world':8s} {'engine':14s} {'capture s':>9s} {'face':>5s} {'Glossy':>7s} "
          f"{'seed 1':>7s} {'seed 2':>7s} {'NumPy ref':>9s} {'careful':>7s} {'noise':>6s}  sky",
          flush=True)
    for world in args.world or ["sky", "sunset"]:
        for engine in args.engine or ["CYCLES", "BLENDER_EEVEE"]:
            work = Path(tempfile.mkdtemp(prefix="glossy-ce-"))
            start = time.perf_counter()
            process = subprocess.run(
                [sys.executable, str(script), str(work), engine, world_argument(world),
                 str(args.roughness), str(args.cycles), str(work / "result.json")],
                cwd=script.parent, capture_output=True, text=True)
            try:
                result = json.loads((work / "result.json").read_text())
            except (OSError, ValueError):
                tail = (process.stderr or process.stdout).strip().splitlines()[-1:]
                print(f"{world:8s} {engine:14s} failed: {tail}", flush=True)
                continue
            figures = result["figures"]
            methods = figures["methods"]
            seeds = methods["eevee_glossy"].get("relative_rms_per_seed") or [float("nan")] * 2
            print(f"{Path(world).stem:8s} {engine:14s} {result['capture_s']:9.1f} "
                  f"{result['probe']['size']:5d} {methods['eevee_glossy']['relative_rms']:7.4f} "
                  f"{seeds[0]:7.4f} {seeds[1]:7.4f} {methods['reference']['relative_rms']:9.4f} "
                  f"{methods['eevee_native_careful']['relative_rms']:7.4f} "
                  f"{figures['cycles_noise']:6.4f}  {result['probe'].get('world')} "
                  f"({time.perf_counter() - start:.0f} s)", flush=True)


if __name__ == "__main__":
    main()
