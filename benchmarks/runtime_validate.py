"""Runtime Sampling and the Hybrid in EEVEE against Cycles, on every bundled HDRI
(issue 11's acceptance), through the add-on's operators and glossy.validate.

For each bundled HDRI and each case (method, GGX roughness, anisotropy,
samples), one isolated sphere (tests/blender/scripts/runtime_validate.py:
World Only probe, captured, baked, attached) is validated through a camera
that makes it fill the frame as bake.reference.sphere_buffers' sphere does.
Printed per case: relative RMS of luminance over the sphere's pixels for
EEVEE with Glossy's material, native EEVEE at the scene's defaults and with
the careful user's settings (world sun_threshold 0, clamp_surface_indirect
0), the NumPy reference (distant lighting through the same probe: what
Glossy's method could reach), all against Cycles (two seeds), and Cycles'
own noise (from the two seeds), then Glossy's figure against each seed alone
and against the NumPy reference (no noise). One sphere per run, so every
figure sees the same pixels. With two or more cases, each HDRI ends with
whether the first case's Glossy error is below each other case's against the
mean of the seeds, each seed alone and the NumPy reference
(bake.validation.ordering): an order the two seeds disagree on is decided by
Cycles' noise at that sample count. Each such line ends with how few of the
sphere's pixels decide the order, against the seeds' mean and against the
reference (bake.validation.deciding_pixels: leaving those pixels out reverses
it): a handful says a highlight's edge decides, not the surface.

    .venv/bin/python benchmarks/runtime_validate.py [--size 128] [--cycles 256]
        [--eevee 4] [--probe 64|auto] [--hdri sunset|PATH.exr ...]
        [--case hybrid:0.3:0:19 ...]   (method:roughness:anisotropy:samples;
                                        hybrid-nolights: Probe Lights off)
        [--case auto:0.3:0:19:Metallic=0 ...]   (a From Material Principled BSDF)
        [--rotate 20,0,135] [--strength 2]   (the world turned by a Mapping node)
        [--max-map-size 768]   (every material's Max Map Size, Auto's bound)
        [--keep]   (keep each case's work folder: bakes, renders, report EXRs)
"""

import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake import exr, validation  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

CASES = ("3d:0.3:0:19", "runtime:0.3:0:19", "hybrid:0.3:0:19", "runtime:0.3:0.8:14")


def hdri_path(hdri):
    """A bundled HDRI's stem ("night") or a path to any lat-long .exr."""
    return Path(hdri).resolve() if hdri.endswith(".exr") else studio_lights() / f"{hdri}.exr"


def report_images(work):
    """(Glossy's EEVEE render, the mean of Cycles' seeds, the NumPy reference, the
    sphere's mask) from the glossy.validate report under ``work``, or None."""
    try:
        folder = next(Path(work).rglob("report.json")).parent
        glossy = exr.read(folder / "eevee_glossy.exr")[0][..., :3]
        truth = 0.5 * (exr.read(folder / "cycles_seed1.exr")[0][..., :3]
                       + exr.read(folder / "cycles_seed2.exr")[0][..., :3])
        reference = exr.read(folder / "reference.exr")[0][..., :3]
        layers = exr.read(folder / "masks.exr", layers=True)[0]
        mask = next(v for k, v in layers.items() if k.startswith("mask."))[..., 0] > 0.5
    except (StopIteration, OSError, ValueError, KeyError):
        return None
    return glossy, truth, reference, mask


def deciding(first, second):
    """'   (k of N pixels decide it; k' against the reference)'
    (bake.validation.deciding_pixels), or '' without both cases' images."""
    if first is None or second is None or first[3].shape != second[3].shape:
        return ""
    k, pixels = validation.deciding_pixels(first[0], second[0], first[1], first[3])
    k_reference, _ = validation.deciding_pixels(first[0], second[0], first[2], first[3])
    return f"   ({k} of {pixels} pixels decide it; {k_reference} against the reference)"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--cycles", type=int, default=256, help="Cycles samples per seed")
    parser.add_argument("--eevee", type=int, default=4, help="EEVEE samples")
    parser.add_argument("--probe", default="64", help="probe face size, or auto")
    parser.add_argument("--hdri", action="append",
                        help="bundled HDRI stem or a path to a lat-long .exr (repeatable; "
                             "default all bundled)")
    parser.add_argument("--rotate", default=None,
                        help="turn the world's image by a Mapping node: Euler X,Y,Z degrees")
    parser.add_argument("--strength", type=float, default=1.0,
                        help="the world's Background Strength (default 1)")
    parser.add_argument("--max-map-size", type=int, default=None,
                        help="every material's Max Map Size (default: the add-on's, 384)")
    parser.add_argument("--case", action="append",
                        help="method:roughness:anisotropy:samples (repeatable)")
    parser.add_argument("--keep", action="store_true",
                        help="keep each case's work folder (bakes, renders, the validation "
                             "report's EXRs) and print its path")
    args = parser.parse_args()
    hdris = args.hdri or sorted(p.stem for p in studio_lights().glob("*.exr"))
    script = ROOT / "tests" / "blender" / "scripts" / "runtime_validate.py"
    environment = dict(os.environ)
    if args.rotate or args.strength != 1.0:
        degrees = [float(a) for a in (args.rotate or "0,0,0").split(",")]
        environment["GLOSSY_WORLD_MAPPING"] = json.dumps(
            {"rotation": [math.radians(a) for a in degrees], "strength": args.strength})
    if args.max_map_size:
        environment["GLOSSY_MAX_MAP_SIZE"] = str(args.max_map_size)
    print(f"{args.size}^2 px, Cycles 2 x {args.cycles} spp, EEVEE {args.eevee} samples, "
          f"probe {args.probe}; relative RMS of luminance against Cycles", flush=True)
    print(f"{'HDRI':10s} {'case':22s} {'Glossy':>7s} {'native':>7s} {'careful':>7s} "
          f"{'NumPy ref':>9s} {'noise':>6s} {'run s':>6s} {'face':>5s} "
          f"{'seed 1':>7s} {'seed 2':>7s} {'vs ref':>7s}", flush=True)
    cases = args.case or CASES
    figures_of = {}  # (hdri, case) -> figures
    images_of = {}  # (hdri, case) -> report_images
    for case in cases:
        method, roughness, anisotropy, samples, *principled = case.split(":")
        for hdri in hdris:
            work = Path(tempfile.mkdtemp(prefix="glossy-rv-"))
            spheres = [["S", method, float(roughness), float(anisotropy), 0.0, int(samples)]]
            if principled:  # a Principled BSDF's float inputs, "Metallic=1,IOR=1.45"
                spheres[0].append({key: float(value) for key, value in
                                   (item.split("=") for item in principled[0].split(","))})
            start = time.perf_counter()
            process = subprocess.run(
                [sys.executable, str(script), str(hdri_path(hdri)), str(work),
                 str(args.size), str(args.cycles), str(args.eevee), json.dumps(spheres), "0",
                 "1", args.probe, str(work / "result.json")],
                cwd=script.parent, capture_output=True, text=True, env=environment)
            seconds = time.perf_counter() - start
            try:
                result = json.loads((work / "result.json").read_text())
                figures = result["S"]["figures"]
            except (OSError, KeyError, ValueError):
                tail = (process.stderr or process.stdout).strip().splitlines()[-1:]
                print(f"{Path(hdri).stem:10s} {case:22s} failed: {tail} (its files: {work})",
                      flush=True)
                continue
            images_of[(hdri, case)] = report_images(work)
            if args.keep:
                print(f"  (kept: {work})", flush=True)
            else:
                shutil.rmtree(work, ignore_errors=True)  # renders and bakes, up to 30 MB a case
            figures_of[(hdri, case)] = figures
            rms = {k: v["relative_rms"] for k, v in figures["methods"].items()}
            face = re.search(r"(\d+) px", result["S"].get("probe_reason", ""))
            seeds = figures["methods"]["eevee_glossy"].get("relative_rms_per_seed",
                                                          [float("nan")] * 2)
            own = figures.get("glossy_vs_reference", {}).get("relative_rms", float("nan"))
            print(f"{Path(hdri).stem:10s} {case:22s} {rms['eevee_glossy']:7.3f} "
                  f"{rms['eevee_native']:7.3f} "
                  f"{rms.get('eevee_native_careful', float('nan')):7.3f} "
                  f"{rms['reference']:9.3f} {figures['cycles_noise']:6.3f} {seconds:6.0f} "
                  f"{face.group(1) if face else '?':>5s} {seeds[0]:7.4f} {seeds[1]:7.4f} "
                  f"{own:7.4f}", flush=True)
    if len(cases) > 1:
        print(f"\nIs {cases[0]}'s Glossy error below the other case's? (against the mean of "
              f"the seeds / seed 1 / seed 2 / the NumPy reference)")
        for hdri in hdris:
            for other in cases[1:]:
                pair = figures_of.get((hdri, cases[0])), figures_of.get((hdri, other))
                if None in pair:
                    continue
                verdict = validation.ordering(*pair)
                seeds = verdict["per_seed"] or [None, None]
                words = ["yes" if x else "no" if x is not None else "-"
                         for x in (verdict["mean"], *seeds, verdict["reference"])]
                print(f"{Path(hdri).stem:10s} vs {other:22s} {' / '.join(words)}"
                      + ("   (decided by Cycles' noise)" if verdict["decided_by_noise"] else "")
                      + deciding(images_of.get((hdri, cases[0])), images_of.get((hdri, other))),
                      flush=True)


if __name__ == "__main__":
    main()
