"""glossy.validate on two isolated spheres, as a user's script drives it.

    python validate_scene.py HDRI CHECKS(0/1) WORKDIR [CAMERA] RESULT.json

Sphere "Shiny" (GGX roughness 0.3, which Cycles has) and sphere "Ward" (Ward
alpha 0.15, which it has not), World Only probes of 128 px faces, no scene
camera (validation frames one), 96 px, Cycles 2 x 1024 spp, EEVEE 8 samples.
CAMERA "ortho": the scene gets an orthographic camera 3 units in front of the
spheres instead, close enough that the direction to its position is up to 45
degrees from its rays (which a NumPy reference must follow).
Neither sphere is seen in the other's reflections nor casts a shadow on it
(ray visibility: Cycles' world light samples trace shadow rays, which a sphere
invisible only to glossy rays would still block, darkening the side facing it
by 8-17%), so each is an isolated sphere under distant light. With CHECKS=1 it also tries bad
input, an Esc in the middle, and a re-bake that must make the figures stale.
"""

import json
import sys
from pathlib import Path

hdri, checks = sys.argv[1], sys.argv[2] == "1"
workdir, result_path = Path(sys.argv[3]), Path(sys.argv[-1])
camera_kind = sys.argv[4] if len(sys.argv) > 5 else ""
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402
from glossy.operators.validate import GLOSSY_OT_validate  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
scene.render.resolution_x = scene.render.resolution_y = 100
settings = scene.glossy
settings.validate_resolution = 96
settings.validate_samples = 1024
settings.validate_eevee_samples = 8
result = {}


def run(operator, **kwargs):
    try:
        return sorted(operator(**kwargs)), ""
    except RuntimeError as error:  # an operator's ERROR report, in background mode
        return ["CANCELLED"], str(error).strip()


def sphere(name, x):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0,
                                         location=(x, 0.0, 0.0))
    bpy.ops.object.shade_smooth()
    obj = bpy.context.object
    obj.name = name
    obj.visible_glossy = obj.visible_diffuse = obj.visible_transmission = False
    obj.visible_shadow = False
    obj.glossy.probe_source = "WORLD"
    obj.glossy.probe_size_mode = "FIXED"
    obj.glossy.probe_resolution = 128
    return obj


shiny, ward = sphere("Shiny", -1.25), sphere("Ward", 1.25)
if camera_kind == "ortho":  # looking along +Y from 3 units, both spheres in frame
    data = bpy.data.cameras.new("Ortho")
    data.type, data.ortho_scale = "ORTHO", 5.0
    view = bpy.data.objects.new("Ortho", data)
    view.location, view.rotation_euler = (0.0, -3.0, 0.0), (0.5 * 3.141592653589793, 0.0, 0.0)
    scene.collection.objects.link(view)
    scene.camera = view
bpy.ops.object.select_all(action="SELECT")
if checks:
    result["no_material"] = run(bpy.ops.glossy.validate)
for obj, model, roughness in ((shiny, "ggx", 0.3), (ward, "ward", 0.15)):
    material = bpy.data.materials.new(obj.name)
    material.glossy.model = model
    material.glossy.roughness = roughness
    material.glossy.slices = 16
    obj.data.materials.append(material)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
if checks:
    result["not_baked"] = run(bpy.ops.glossy.validate)
for obj in (shiny, ward):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.glossy.capture_probes()
    bpy.ops.glossy.bake_materials()
    if checks and obj is shiny:
        result["not_attached"] = run(bpy.ops.glossy.validate)
    bpy.ops.glossy.attach_materials()
bpy.ops.object.select_all(action="SELECT")


def state():
    return {"engine": scene.render.engine, "resolution": [scene.render.resolution_x,
            scene.render.resolution_y], "camera": str(scene.camera), "format":
            scene.render.image_settings.file_format, "objects": len(bpy.data.objects),
            "materials": len(bpy.data.materials), "cameras": len(bpy.data.cameras),
            "slots": [o.material_slots[0].material.name for o in (shiny, ward)],
            "sun_threshold": scene.world.sun_threshold,
            "clamp": scene.eevee.clamp_surface_indirect}


before = state()
folder = workdir / "glossy" / "validation"
if checks:  # Esc in the middle: the steps the modal loop runs, then what Esc does
    class Driver:
        def report(self, kind, message):
            pass
    for name in ("_begin", "_setup", "_use", "_run_step", "_reference_steps", "_lamps",
                 "_integrate", "_material_reference", "_shade", "_note_per_pixel_inputs",
                 "_mask",
                 "_write_report", "_store", "_cleanup"):
        setattr(Driver, name, GLOSSY_OT_validate.__dict__[name])
    driver = Driver()
    settings.validate_samples = 16  # these renders are thrown away: Esc is what is checked
    steps = driver._begin(bpy.context)
    work = driver._work
    for step in steps[:5]:
        driver._run_step(bpy.context, step)
    part = driver._run_step(bpy.context, next(s for s in steps if s[0] == "reference"))
    next(part)  # one chunk of the reference, then Esc
    part.close()
    driver._cleanup()
    settings.validate_samples = 1024
    result["esc"] = {"restored": state() == before, "report": folder.exists(),
                     "work_left": work.exists()}
result["validate"] = run(bpy.ops.glossy.validate)
result["restored"] = state() == before
result["before"], result["after"] = before, state()
result["folder"] = str(folder)
material = shiny.material_slots[0].material
result["stored"] = {"error": material.glossy.validation_error,
                    "native": material.glossy.validation_native_error,
                    "truth": material.glossy.validation_truth,
                    "cause": material.glossy.validation_cause,
                    "fresh": material.glossy.validation_bake_hash == material.glossy.bake_hash}
if checks:
    material.glossy.roughness = 0.35
    bpy.ops.object.select_all(action="DESELECT")
    shiny.select_set(True)
    bpy.context.view_layer.objects.active = shiny
    bpy.ops.glossy.bake_materials()
    result["stale_after_rebake"] = \
        material.glossy.validation_bake_hash != material.glossy.bake_hash
result_path.write_text(json.dumps(result, indent=1, default=str))
