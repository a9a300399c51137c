"""EEVEE's shadows where no light casts one: off changes no pixel.

    python eevee_shadows.py HDRI WORKDIR RESULT.json

A sphere over a plane (the sphere casts shadows) in HDRI, 24 px, 1 sample, as
validation's careful native render has it (world sun extraction off): rendered
with the scene's shadows on and off; then with a sun lamp added, on and off
again (there they must differ, or the first comparison proves nothing); then
with the sphere and the plane hidden from shadow rays, and hidden (only the
world renders), on and off each.
Also what ``scenes.casts_shadows`` answers for each set-up.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.scenes import (  # noqa: E402
    casts_shadows,
    eevee_engine,
    environment_world,
    float_exr_output,
)

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
environment_world(scene, hdri)
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.6, location=(0.0, 0.0, 0.2))
bpy.ops.mesh.primitive_plane_add(size=6.0, location=(0.0, 0.0, -0.4))
camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(camera)
camera.location, camera.rotation_euler = (0.0, -4.0, 2.0), (1.1, 0.0, 0.0)
scene.camera = camera
scene.render.engine = eevee_engine()
float_exr_output(scene, 24)
scene.eevee.taa_render_samples = 1
result = {"world_sun": casts_shadows(scene)}  # sunset's sun above the default threshold
scene.world.use_sun_shadow = False
result["world_sun_unshadowed"] = casts_shadows(scene)
scene.world.use_sun_shadow = True
scene.world.sun_threshold = 0.0  # validation's careful render
result["careful"] = casts_shadows(scene)


def render(name):
    scene.render.filepath = str(workdir / f"{name}.exr")
    bpy.ops.render.render(write_still=True)
    return exr.read(workdir / f"{name}.exr")[0][..., :3]


def compare(tag):
    scene.eevee.use_shadows = True
    shadowed = render(f"{tag}_on")
    scene.eevee.use_shadows = False
    unshadowed = render(f"{tag}_off")
    result[f"{tag}_max_difference"] = float(np.abs(shadowed - unshadowed).max())
    result[f"{tag}_mean"] = float(shadowed.mean())


compare("no_light")
lamp = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
lamp.data.energy = 5.0
scene.collection.objects.link(lamp)
result["lamp"] = casts_shadows(scene)
compare("lamp")
# The sphere and the plane hidden from shadow rays (as isolated objects are), under
# the lamp and the world's sun: nothing casts a shadow.
scene.world.sun_threshold = 10.0
for obj in scene.objects:
    obj.visible_shadow = False
result["no_caster"] = casts_shadows(scene)
compare("no_caster")
for obj in scene.objects:
    obj.visible_shadow = True
# Nothing that renders but the world: no shadow to cast or catch.
for obj in scene.objects:
    if obj.type == "MESH":
        obj.hide_render = True
result["nothing_to_shadow"] = casts_shadows(scene)
compare("nothing_to_shadow")
lamp.hide_render = True
for obj in scene.objects:
    obj.hide_render = obj.type != "MESH"
scene.world.sun_threshold = 0.0
result["lamp_hidden"] = casts_shadows(scene)
result_path.write_text(json.dumps(result, indent=1))
