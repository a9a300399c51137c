"""A sphere lit only by lamps (world black), as a user's script would set it up:
Glossy bake + attach, then EEVEE with Glossy, Cycles with the true BSDF (two
seeds) and EEVEE with the true BSDF (native), saved as EXR for the pytest side.

    python lamps_scene.py WORKDIR SPEC LAMPS SIZE TERMS PARAM RESULT.json

LAMPS: comma-separated kinds among point, sun, spot, area and textured (a
point lamp with a texture in its node tree: Glossy must skip it and say so).
Afterwards: a lamp added after attach (the panel's "changed" flag, picked up
by re-attach) and an absurd term count (refused before any work).
"""

import json
import math
import sys
from pathlib import Path

workdir, spec, kinds = Path(sys.argv[1]), sys.argv[2], sys.argv[3].split(",")
size, terms, param, result_path = int(sys.argv[4]), int(sys.argv[5]), sys.argv[6], \
    Path(sys.argv[7])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon import lamps, scenes, validation  # noqa: E402

RESOLUTION = 64
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world
scene.render.film_transparent = True
bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
sphere = bpy.context.object
bpy.ops.object.shade_smooth()
camera_data = bpy.data.cameras.new("camera")
camera_data.type = "ORTHO"
camera_data.ortho_scale = 2.2
camera = bpy.data.objects.new("camera", camera_data)
camera.location = (0.0, -6.0, 1.5)
camera.rotation_euler = (math.radians(90 - 14.04), 0.0, 0.0)
scene.collection.objects.link(camera)
scene.camera = camera
LAMPS = {"point": ("POINT", (2.0, -3.0, 2.5), None, {"energy": 400.0, "shadow_soft_size": 0.0}),
         "sun": ("SUN", (0.0, 0.0, 5.0), (math.radians(50), 0.0, math.radians(-130)),
                 {"energy": 2.0, "angle": 0.0}),
         "spot": ("SPOT", (-2.0, -3.0, 1.0), None, {"energy": 600.0, "shadow_soft_size": 0.0,
                                                    "spot_size": math.radians(30),
                                                    "spot_blend": 0.5}),
         "area": ("AREA", (1.0, -4.0, -1.0), None, {"energy": 300.0, "size": 0.2}),
         "textured": ("POINT", (0.0, -3.0, -2.0), None, {"energy": 100.0})}
for name in kinds:
    kind, location, rotation, values = LAMPS[name]
    light = bpy.data.lights.new(name, kind)
    for key, value in values.items():
        setattr(light, key, value)
    if name == "textured":
        light.use_nodes = True
        light.node_tree.nodes.new("ShaderNodeTexNoise")
    obj = bpy.data.objects.new(name, light)
    obj.location = location
    scene.collection.objects.link(obj)
    if rotation is None:  # aim at the sphere's centre
        direction = -obj.location.normalized()
        obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    else:
        obj.rotation_euler = rotation
material = bpy.data.materials.new("Lit")
sphere.data.materials.append(material)
settings = material.glossy
settings.model = "CUSTOM"
settings.spec = spec
settings.lamp_size, settings.lamp_terms, settings.lamp_parameterization = size, terms, param
settings.slices = 4
settings.map_size = 16
settings.size_mode = "FIXED"
sphere.glossy.probe_source = "RENDER"
sphere.glossy.probe_resolution = 8
bpy.context.view_layer.objects.active = sphere
sphere.select_set(True)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "lamps.blend"))
bpy.ops.glossy.capture_probes()
truth, why = validation.truth_material(material)
report = {"truth": why}
bpy.ops.glossy.bake_materials()
bpy.ops.glossy.attach_materials()
report.update({"lamp_error": settings.lamp_error, "lamp_set": json.loads(settings.lamp_set),
               "skipped": json.loads(settings.lamp_skipped),
               "lamp_path": settings.lamp_path, "bake_path": settings.bake_path,
               "groups": sorted(g.name for g in bpy.data.node_groups)})


if "textured" in kinds:  # skipped by Glossy (said above); out of the comparison renders
    bpy.data.objects["textured"].hide_render = True


def render(engine, name, samples=1, seed=0):
    scenes.float_exr_output(scene, RESOLUTION)
    if engine == "CYCLES":
        scenes.exact_cycles(scene, samples)
        scene.cycles.seed = seed
        scene.cycles.max_bounces = 0
    else:
        scene.render.engine = scenes.eevee_engine()
        scene.eevee.taa_render_samples = samples
        scene.render.filter_size = 0.01
        scene.eevee.clamp_surface_indirect = 0.0
    path = workdir / f"{name}.exr"
    validation.render_to(scene, path)
    return str(path)


report["glossy"] = render("EEVEE", "glossy")
# Move the point lamp: the drivers follow it without a re-attach.
if "point" in kinds:
    lamp = bpy.data.objects["point"]
    lamp.location = (-2.0, -3.0, 1.0)
    report["glossy_moved"] = render("EEVEE", "glossy_moved")
    report["truth_moved"] = None
    if truth is not None:
        sphere.material_slots[0].material = truth
        report["truth_moved"] = render("CYCLES", "truth_moved", 64)
        sphere.material_slots[0].material = material
    lamp.location = (2.0, -3.0, 2.5)
if truth is not None:
    sphere.material_slots[0].material = truth
    report["cycles"] = [render("CYCLES", f"cycles{seed}", 64, seed) for seed in (1, 2)]
    report["native"] = render("EEVEE", "native", 16)
sphere.material_slots[0].material = material
report["changed_before"] = lamps.lamp_set_changed(material, scene)
late = bpy.data.objects.new("late", bpy.data.lights.new("late", "POINT"))
scene.collection.objects.link(late)
report["changed_after_adding"] = lamps.lamp_set_changed(material, scene)
bpy.ops.glossy.attach_materials()
report["changed_after_reattach"] = lamps.lamp_set_changed(material, scene)
report["lamp_nodes"] = sorted(n.get("glossy_lamp", "") for n in material.node_tree.nodes
                              if "glossy_lamp" in n)
settings.lamp_terms = 0
before = sorted(p.name for p in (workdir / "glossy").iterdir())
try:
    bpy.ops.glossy.bake_materials()
    report["zero_terms"] = ""
except RuntimeError as error:
    report["zero_terms"] = str(error)
report["files_unchanged"] = before == sorted(p.name for p in (workdir / "glossy").iterdir())
result_path.write_text(json.dumps(report))
