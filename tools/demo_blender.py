"""The demo's Blender part, end to end: capture, bake, attach, validate.

A sphere, Suzanne and a torus over Blender's bundled forest.exr, each with a
Glossy material (GGX 0.2, Beckmann 0.35, and Ward 0.2, which EEVEE and
Cycles cannot render natively). Glossy captures a probe at each object's
volume centroid (Cycles, the others visible), bakes a 3D map per material
and attaches the lookup nodes; glossy.validate then renders Cycles (2 seeds),
native EEVEE, EEVEE with Glossy and the NumPy reference and writes the sheets
and the table to out/demo/glossy/validation/ (copied to out/demo/validation/).
out/demo/eevee_vs_cycles.png shows EEVEE with Glossy beside Cycles. Run by
``make demo``.
"""

import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
packages = Path(tempfile.mkdtemp())
os.symlink(ROOT, packages / "glossy")
sys.path.insert(0, str(packages))
sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import exr, preview  # noqa: E402
from glossy.glossy_addon.scenes import environment_world, float_exr_output  # noqa: E402

from tools.bpy_wheel import studio_lights  # noqa: E402

OBJECTS = [  # (primitive, location, distribution, Glossy model, roughness)
    ("sphere", (-2.4, 0.0, 0.0), "GGX", "ggx", 0.2),
    ("monkey", (0.0, 0.0, 0.0), "BECKMANN", "beckmann", 0.35),
    ("torus", (2.4, 0.0, 0.0), None, "ward", 0.2),  # no native BSDF: reference only
]


def main():
    out = ROOT / "out" / "demo"
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    glossy.register()
    scene = bpy.context.scene
    float_exr_output(scene, 240, 120)
    environment_world(scene, studio_lights() / "forest.exr", "forest")
    # The world keeps EEVEE's defaults (sun extraction on): the validation measures
    # the scene's own EEVEE and, once more, without sun extraction and clamp.
    adders = {"sphere": bpy.ops.mesh.primitive_uv_sphere_add,
              "monkey": bpy.ops.mesh.primitive_monkey_add,
              "torus": bpy.ops.mesh.primitive_torus_add}
    pairs = []
    for kind, location, distribution, model, roughness in OBJECTS:
        adders[kind](location=location)
        obj = bpy.context.object
        bpy.ops.object.shade_smooth()
        if kind == "torus":
            obj.rotation_euler = (1.2, 0.0, 0.0)
        material = bpy.data.materials.new(f"glossy_{kind}")
        material.glossy.model = model
        material.glossy.roughness = roughness
        material.glossy.map_size = 64
        material.glossy.slices = 8
        obj.data.materials.append(material)
        obj.glossy.probe_resolution = 64
        obj.glossy.capture_samples = 16
        pairs.append((obj, material, distribution))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.0, -9.0, 1.5)
    camera.rotation_euler = (1.41, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "demo_scene.blend"))

    # As a user does: select the three, then Capture Probes, Bake Materials and
    # Attach Lookups once each (every object gets its own probe and bakes).
    bpy.ops.object.select_all(action="DESELECT")
    for obj, _, _ in pairs:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = pairs[0][0]
    bpy.ops.glossy.capture_probes()
    bpy.ops.glossy.bake_materials()
    bpy.ops.glossy.attach_materials()
    settings = scene.glossy
    settings.validate_resolution = 240
    settings.validate_samples = 64
    settings.validate_eevee_samples = 16
    bpy.ops.glossy.validate()
    folder = out / "glossy" / "validation"
    copy = out / "validation"
    copy.mkdir(exist_ok=True)
    for path in folder.iterdir():
        if path.suffix in (".png", ".md", ".json"):
            shutil.copyfile(path, copy / path.name)
    report = json.loads((folder / "report.json").read_text())
    cycles = (exr.read(folder / "cycles_seed1.exr")[0][..., :3]
              + exr.read(folder / "cycles_seed2.exr")[0][..., :3]) / 2
    glossy_image = exr.read(folder / "eevee_glossy.exr")[0][..., :3]
    exposure = 0.18 / max(float(np.median(cycles @ [0.2126, 0.7152, 0.0722])), 1e-6)
    sheet = preview.contact_sheet([[preview.tonemap(glossy_image, exposure),
                                    preview.tonemap(cycles, exposure)]])
    preview.write_png(out / "eevee_vs_cycles.png", sheet)
    print((folder / "report.md").read_text())
    for entry in report["objects"]:
        glossy_error = entry["figures"]["methods"]["eevee_glossy"]["relative_rms"]
        cause = entry["figures"].get("diagnosis", {}).get("cause")
        print(f"{entry['object']}: Glossy {100 * glossy_error:.1f}% from "
              f"{entry['figures']['truth']}" + (f" (cause: {cause})" if cause else "")
              + f"; sheet out/demo/validation/{entry['sheet']}")
    print(f"demo finished in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
