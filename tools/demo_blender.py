"""The demo's Blender part: a default scene baked with Glossy, EEVEE beside Cycles.

A sphere, Suzanne and a torus over Blender's bundled forest.exr, each with a
Glossy material (GGX 0.2, Beckmann 0.35, Ashikhmin-Shirley 0.5). Glossy
captures a probe at each object's volume centroid (Cycles, the others
visible), bakes a 3D map per material and attaches the lookup nodes; EEVEE
renders that, Cycles renders the true BSDFs, and out/demo/eevee_vs_cycles.png
shows them side by side (tonemapped for viewing). Run by ``make demo``.
"""

import os
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
from glossy.glossy_addon.scenes import environment_world, exact_cycles, float_exr_output  # noqa: E402

from tools.bpy_wheel import studio_lights  # noqa: E402

OBJECTS = [  # (primitive, location, distribution, Glossy model, roughness)
    ("sphere", (-2.4, 0.0, 0.0), "GGX", "ggx", 0.2),
    ("monkey", (0.0, 0.0, 0.0), "BECKMANN", "beckmann", 0.35),
    ("torus", (2.4, 0.0, 0.0), "ASHIKHMIN_SHIRLEY", "ashikhmin_shirley", 0.5),
]


def truth_material(name, distribution, roughness):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfAnisotropic")
    bsdf.distribution = distribution
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Anisotropy"].default_value = 0.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(bsdf.outputs[0], output.inputs["Surface"])
    return material


def main():
    out = ROOT / "out" / "demo"
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    bpy.ops.wm.read_factory_settings(use_empty=True)
    glossy.register()
    scene = bpy.context.scene
    float_exr_output(scene, 240, 120)
    environment_world(scene, studio_lights() / "forest.exr", "forest")
    world = scene.world
    if hasattr(world, "sun_threshold"):
        world.sun_threshold = 0.0
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
        pairs.append((obj, material, truth_material(f"true_{kind}", distribution, roughness)))
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.location = (0.0, -9.0, 1.5)
    camera.rotation_euler = (1.41, 0.0, 0.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "demo_scene.blend"))
    for obj, _, _ in pairs:
        bpy.ops.object.select_all(action="DESELECT")
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        bpy.ops.glossy.capture_probes()
        bpy.ops.glossy.bake_materials()
        bpy.ops.glossy.attach_materials()
    images = {}
    for engine, samples in (("BLENDER_EEVEE", 16), ("CYCLES", 128)):
        scene.render.engine = engine
        if engine == "CYCLES":
            exact_cycles(scene, samples)
            for obj, _, truth in pairs:
                obj.data.materials[0] = truth
        else:
            scene.eevee.taa_render_samples = samples
        path = out / f"render_{engine.lower()}.exr"
        scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        images[engine] = exr.read(path)[0][..., :3]
    exposure = 0.18 / max(float(np.median(images["CYCLES"] @ [0.2126, 0.7152, 0.0722])), 1e-6)
    sheet = preview.contact_sheet([[preview.tonemap(images["BLENDER_EEVEE"], exposure),
                                    preview.tonemap(images["CYCLES"], exposure)]])
    path = preview.write_png(out / "eevee_vs_cycles.png", sheet)
    print(f"wrote {path.relative_to(ROOT)} (left: EEVEE with Glossy's baked materials, "
          f"right: Cycles with the true BSDFs) in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
