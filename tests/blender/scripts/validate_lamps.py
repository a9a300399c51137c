"""glossy.validate under Blender's lamps, as a user's script drives it.

    python validate_lamps.py HDRI WORKDIR RESULT.json

A sphere ("Shiny": a Principled metal, Roughness 0.3, read From Material)
under a dim World Only probe (the HDRI at Strength 0.2) and five lamps, each
kind with what changes its light: a point lamp of radius 0.3 (Soft Falloff),
a spot of radius 0.1 with a blended cone, a sun 5 degrees wide, a 1 x 0.5
rectangular area lamp turned and scaled, and a point lamp with Exposure 1 and
a Temperature colour. A small black cube ("Blocker", hidden from the camera)
between the area lamp and the sphere casts a soft shadow on it. It is seen by
every other ray: Cycles' light samples trace shadow rays but its BSDF samples
trace glossy rays, so an object hidden from glossy rays alone blocks a
glossy lobe's lamp light only in part (a 0.3 metal's penumbra 8-12% brighter
than the shadow's integral, measured). A World Only probe does not hold the
cube, which the reflections in Cycles show as a dark patch of 0.04 sr.
Cycles 2 x 256 spp, 96 px, EEVEE 4 samples. Writes the report's figures for
Shiny and its notes.
"""

import json
import math
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import shader_material, validation_scene  # noqa: E402

scene = validation_scene(hdri, workdir, 96)
scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.2

bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
bpy.ops.object.shade_smooth()
shiny = bpy.context.object
shiny.name = "Shiny"
shiny.glossy.probe_source = "WORLD"
shiny.glossy.probe_size_mode = "FIXED"
shiny.glossy.probe_resolution = 64
material, _, principled = shader_material("Metal")
for name, value in (("Base Color", (0.9, 0.7, 0.5, 1.0)), ("Metallic", 1.0),
                    ("Roughness", 0.3)):
    principled.inputs[name].default_value = value
shiny.data.materials.append(material)

bpy.ops.mesh.primitive_cube_add(size=0.35, location=(1.2, -1.5, -0.2))
blocker = bpy.context.object
blocker.name = "Blocker"
blocker.visible_camera = False  # out of the image; every other ray sees it
black, _, black_bsdf = shader_material("Black", "ShaderNodeBsdfDiffuse")
black_bsdf.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
blocker.data.materials.append(black)


def lamp(name, kind, location, **values):
    light = bpy.data.lights.new(name, kind)
    for key, value in values.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new(name, light)
    obj.location = location
    scene.collection.objects.link(obj)
    aim = -obj.location.normalized()  # at the sphere's centre
    obj.rotation_euler = aim.to_track_quat("-Z", "Y").to_euler()
    return obj


lamp("Point", "POINT", (2.0, -3.0, 2.5), energy=300.0, shadow_soft_size=0.3)
lamp("Spot", "SPOT", (-2.5, -2.5, 1.0), energy=500.0, shadow_soft_size=0.1,
     spot_size=math.radians(40), spot_blend=0.5)
sun = lamp("Sun", "SUN", (0.0, 0.0, 5.0), energy=1.5, angle=math.radians(5))
sun.rotation_euler = (math.radians(50), 0.0, math.radians(-130))
area = lamp("Area", "AREA", (2.4, -3.0, -0.4), energy=250.0, shape="RECTANGLE", size=1.0,
            size_y=0.5)
area.scale = (1.5, 1.0, 1.0)
warm = lamp("Warm", "POINT", (-1.5, -2.0, -2.0), energy=60.0, shadow_soft_size=0.05,
            exposure=1.0, use_temperature=True, temperature=3200.0)

scene.camera = None
for obj in (blocker,):
    obj.select_set(False)
bpy.ops.object.select_all(action="DESELECT")
shiny.select_set(True)
bpy.context.view_layer.objects.active = shiny
steps = {}
for name, operator in (("capture", bpy.ops.glossy.capture_probes),
                       ("bake", bpy.ops.glossy.bake_materials),
                       ("attach", bpy.ops.glossy.attach_materials),
                       ("validate", bpy.ops.glossy.validate)):
    steps[name] = sorted(operator())
folder = workdir / "glossy" / "validation"
report = json.loads((folder / "report.json").read_text())
entry = next(e for e in report["objects"] if e["object"] == "Shiny")
result_path.write_text(json.dumps({"steps": steps, "figures": entry["figures"],
                                   "notes": report["notes"], "folder": str(folder)}))
