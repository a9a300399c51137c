"""glossy.validate on an isolated sphere, as a user's script drives it.

    python validate_scene.py HDRI MODEL ROUGHNESS WORKDIR RESULT.json

A unit sphere with a Glossy material (MODEL at ROUGHNESS, World Only probe),
no scene camera (validation frames one), 64 px, Cycles 2 x 64 spp, EEVEE 8
samples. Records what the operator reported and wrote; then re-bakes at
another roughness to see the stored figures turn stale, and tries bad input.
"""

import json
import sys
from pathlib import Path

hdri, model, roughness = sys.argv[1], sys.argv[2], float(sys.argv[3])
workdir, result_path = Path(sys.argv[4]), Path(sys.argv[5])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402,F401
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
scene.render.resolution_x = scene.render.resolution_y = 100
bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
bpy.ops.object.shade_smooth()
sphere = bpy.context.object
result = {}


def run(operator, **kwargs):
    try:
        return sorted(operator(**kwargs)), ""
    except RuntimeError as error:  # an operator's ERROR report, in background mode
        return ["CANCELLED"], str(error)


result["no_material"] = run(bpy.ops.glossy.validate)
material = bpy.data.materials.new("Shiny")
sphere.data.materials.append(material)
material.glossy.model = model
material.glossy.roughness = roughness
material.glossy.slices = 8
material.glossy.map_size = 64
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_resolution = 32
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
result["not_baked"] = run(bpy.ops.glossy.validate)
bpy.ops.glossy.capture_probes()
bpy.ops.glossy.bake_materials()
material.glossy.bake_path = ""  # as if the bake were missing
result["missing_bake"] = run(bpy.ops.glossy.validate)
bpy.ops.glossy.bake_materials()
result["not_attached"] = run(bpy.ops.glossy.validate)
bpy.ops.glossy.attach_materials()
material = sphere.material_slots[0].material
settings = scene.glossy
settings.validate_resolution = 64
settings.validate_samples = 64
settings.validate_eevee_samples = 8
before = {"engine": scene.render.engine, "res": [scene.render.resolution_x,
          scene.render.resolution_y], "camera": scene.camera, "format":
          scene.render.image_settings.file_format, "objects": len(bpy.data.objects),
          "materials": len(bpy.data.materials), "slot": sphere.material_slots[0].material.name}
result["validate"] = run(bpy.ops.glossy.validate)
after = {"engine": scene.render.engine, "res": [scene.render.resolution_x,
         scene.render.resolution_y], "camera": scene.camera, "format":
         scene.render.image_settings.file_format, "objects": len(bpy.data.objects),
         "materials": len(bpy.data.materials), "slot": sphere.material_slots[0].material.name}
result["scene_restored"] = before == after
result["report"] = settings.last_report
result["stored"] = {"error": material.glossy.validation_error,
                    "native": material.glossy.validation_native_error,
                    "truth": material.glossy.validation_truth,
                    "fresh": material.glossy.validation_bake_hash == material.glossy.bake_hash}
material.glossy.roughness = roughness + 0.1
bpy.ops.glossy.bake_materials()
result["stale_after_rebake"] = material.glossy.validation_bake_hash != material.glossy.bake_hash
result_path.write_text(json.dumps(result, indent=1, default=str))
