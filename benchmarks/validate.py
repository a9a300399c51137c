"""Cost of one validation, and the NumPy reference's pixel throughput.

1. glossy.validate on one sphere (GGX 0.3, World Only probe of 128 px faces,
   sunset.exr) at 128 x 128 px: the seconds of each render (Cycles x 2, EEVEE
   native, EEVEE Glossy, EEVEE native without sun/clamp) and of the reference,
   from the report's own timings.
2. bake.reference.render against the straightforward per-pixel loop
   bake.reference.reflected_radiance on the same input (a 128 x 128 sphere,
   GGX 0.3, sunset probes of 64 and 128 px faces): pixels per second of each
   (the loop timed on a subset of the pixels: its cost per pixel is constant),
   their ratio (target at least 20x), and the reference's difference from it.
3. bake.lamp_reference.radiance (the lamps' part of the reference, stop 53) on
   the same sphere pixels, a Principled metal at Roughness 0.3, one lamp of
   each kind with extent: pixels per second on one thread and on the default
   two (the baseline and the ratio, in the same run), and each estimate's
   relative RMS difference from one at 8x the samples.

    .venv/bin/python benchmarks/validate.py [--skip-blender] [--samples 128]
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

from bake import brdf, envmap, exr, reference  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

LUM = np.array([0.2126, 0.7152, 0.0722])

SCENE = r'''
import json, sys
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import _checkout  # noqa
import bpy, glossy
from glossy.glossy_addon.scenes import environment_world
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, sys.argv[2])
bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48)
bpy.ops.object.shade_smooth()
obj = bpy.context.object
material = bpy.data.materials.new("Shiny")
obj.data.materials.append(material)
material.glossy.roughness = 0.3
obj.glossy.probe_source = "WORLD"
obj.glossy.probe_size_mode = "FIXED"
obj.glossy.probe_resolution = 128
bpy.ops.wm.save_as_mainfile(filepath=sys.argv[3] + "/scene.blend")
bpy.ops.glossy.capture_probes()
bpy.ops.glossy.bake_materials()
bpy.ops.glossy.attach_materials()
scene.glossy.validate_resolution = 128
scene.glossy.validate_samples = int(sys.argv[4])
scene.glossy.validate_eevee_samples = 16
bpy.ops.glossy.validate()
'''


def validation_cost(samples):
    work = Path(tempfile.mkdtemp())
    script = work / "scene.py"
    script.write_text(SCENE)
    start = time.perf_counter()
    subprocess.run([sys.executable, str(script), str(ROOT / "tests" / "blender" / "scripts"),
                    str(studio_lights() / "sunset.exr"), str(work), str(samples)],
                   check=True, capture_output=True)
    total = time.perf_counter() - start
    report = json.loads((work / "glossy" / "validation" / "report.json").read_text())
    print(f"1. one validation, one sphere at 128 x 128 px (Cycles 2 x {samples} spp, "
          f"EEVEE 16 samples): {total:.1f} s for the whole script (set-up, capture, bake)")
    for name, seconds in report["timings_s"].items():
        print(f"   {name:28s} {seconds:7.2f} s")
    figures = report["objects"][0]["figures"]
    print(f"   Cycles noise {100 * figures['cycles_noise']:.1f}%; relative RMS: " + ", ".join(
        f"{m} {100 * v['relative_rms']:.1f}%" for m, v in figures["methods"].items()))


def throughput():
    image, _ = exr.read(studio_lights() / "sunset.exr")
    normals, views, mask = reference.sphere_buffers(128)
    n, v = normals[mask], views[mask]
    model = brdf.parse("ggx:roughness=0.3")
    print(f"2. NumPy reference, GGX 0.3, sunset, {len(n)} sphere pixels of 128 x 128")
    for face in (64, 128):
        probe = envmap.convert(image[..., :3], "latlong", "cube", face)
        subset = np.linspace(0, len(n) - 1, 150).astype(int)
        start = time.perf_counter()
        exact = reference.reflected_radiance(model, probe, "cube", n[subset], v[subset])
        loop_rate = len(subset) / (time.perf_counter() - start)
        start = time.perf_counter()
        fast = reference.render(model, probe, "cube", n, v)
        rate = len(n) / (time.perf_counter() - start)
        error = np.sqrt(np.sum(((fast[subset] - exact) @ LUM) ** 2) / np.sum((exact @ LUM) ** 2))
        print(f"   probe 6 x {face}^2: loop {loop_rate:8.0f} px/s, render {rate:8.0f} px/s, "
              f"ratio {rate / loop_rate:5.1f}x (target >= 20x: "
              f"{'met' if rate >= 20 * loop_rate else 'MISSED'}); difference {error:.1e}")


def lamps_throughput():
    from bake.lamp_reference import SAMPLES, Lamp, radiance

    normals, views, mask = reference.sphere_buffers(128)
    n, v = normals[mask], views[mask]
    model = brdf.parse("principled:base_color=0.9/0.7/0.5,metallic=1,roughness=0.3")
    down = ((1.0, 0.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0))  # shining along +Z
    lamps = {
        "point, radius 0.3": Lamp("POINT", (300.0,) * 3, position=(2.0, -3.0, 2.5),
                                  radius=0.3),
        "sun, 5 degrees": Lamp("SUN", (1.5,) * 3, axes=((1.0, 0.0, 0.0), (0.0, 0.6, -0.8),
                                                        (0.0, 0.8, 0.6)),
                               angle=np.radians(5.0)),
        "area 1.5 x 0.5": Lamp("AREA", (250.0,) * 3, position=(0.0, 0.0, -3.0), axes=down,
                               shape="RECTANGLE", size=(1.5, 0.5)),
    }
    print(f"3. The lamps' part, Principled metal 0.3, {len(n)} sphere pixels, {SAMPLES} "
          f"samples per technique")
    for name, lamp in lamps.items():
        start = time.perf_counter()
        one = radiance(model, [lamp], n, n, v, threads=1)
        single = len(n) / (time.perf_counter() - start)
        start = time.perf_counter()
        radiance(model, [lamp], n, n, v)
        rate = len(n) / (time.perf_counter() - start)
        converged = radiance(model, [lamp], n, n, v, samples=8 * SAMPLES) @ LUM
        error = np.sqrt(np.sum((one @ LUM - converged) ** 2) / np.sum(converged ** 2))
        print(f"   {name:18s}: 1 thread {single:7.0f} px/s, default {rate:7.0f} px/s, "
              f"ratio {rate / single:4.2f}x; against {8 * SAMPLES} samples {error:.1e}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skip-blender", action="store_true")
    parser.add_argument("--samples", type=int, default=128)
    args = parser.parse_args()
    if not args.skip_blender:
        validation_cost(args.samples)
    throughput()
    lamps_throughput()


if __name__ == "__main__":
    main()
