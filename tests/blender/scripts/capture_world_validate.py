"""One sphere of Principled metal in a world, its Render Scene probe captured by ENGINE,
baked, attached and validated against Cycles through the add-on's operators.

    python capture_world_validate.py WORKDIR ENGINE WORLD ROUGHNESS CYCLES_SAMPLES RESULT.json

WORLD is a lat-long .exr (an Environment Texture world) or "sky": a Sky Texture
(Multiple Scattering where the build has it; sun at 25 degrees elevation, 40
degrees rotation, Background Strength 0.3), a world World Only cannot read. The
probe is Auto (the lobe's width, the world image's detail); the camera frames the
sphere as bake.reference.sphere_buffers does; validation renders 96^2 px with
Cycles at CYCLES_SAMPLES per seed and EEVEE at 4 samples. Writes the capture's
time, the probe header's size, engine and ``world`` note, and the validation
figures (benchmarks/capture_engines.py prints them).
"""

import json
import math
import sys
import time
from pathlib import Path

workdir, engine, world_name, roughness, cycles_samples, result_path = sys.argv[1:7]
workdir = Path(workdir)
workdir.mkdir(parents=True, exist_ok=True)
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
if world_name == "sky":
    scene.world = bpy.data.worlds.new("sky")
    scene.world.use_nodes = True
    tree = scene.world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    kinds = [item.identifier for item in sky.bl_rna.properties["sky_type"].enum_items]
    if "MULTIPLE_SCATTERING" in kinds:
        sky.sky_type = "MULTIPLE_SCATTERING"
    sky.sun_elevation, sky.sun_rotation = math.radians(25.0), math.radians(40.0)
    background = tree.nodes["Background"]
    background.inputs["Strength"].default_value = 0.3
    tree.links.new(sky.outputs["Color"], background.inputs["Color"])
else:
    environment_world(scene, world_name)
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.render.resolution_x = scene.render.resolution_y = 96
scene.glossy.validate_resolution = 96
scene.glossy.validate_samples = int(cycles_samples)
scene.glossy.validate_eevee_samples = 4
bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0)
bpy.ops.object.shade_smooth()
ball = bpy.context.object
ball.glossy.probe_source = "RENDER"
ball.glossy.capture_engine = engine
material = bpy.data.materials.new("metal")
material.glossy.model = "MATERIAL"
if material.node_tree is None:  # Blender before 5.0
    material.use_nodes = True
bsdf = material.node_tree.nodes["Principled BSDF"]
bsdf.inputs["Metallic"].default_value = 1.0
bsdf.inputs["Roughness"].default_value = float(roughness)
ball.data.materials.append(material)
view = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
view.data.lens, view.data.sensor_width, view.data.sensor_fit = 90.0, 36.0, "HORIZONTAL"
view.location, view.rotation_euler = (0.0, -6.0, 0.0), (0.5 * math.pi, 0.0, 0.0)
scene.collection.objects.link(view)
scene.camera = view
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))  # outputs go beside it
bpy.ops.object.select_all(action="DESELECT")
ball.select_set(True)
bpy.context.view_layer.objects.active = ball
start = time.perf_counter()
result = {"capture": sorted(bpy.ops.glossy.capture_probes())}
result["capture_s"] = time.perf_counter() - start
header = exr.read_meta(ball.glossy.probe_path)
result["probe"] = {key: header.get(key) for key in ("size", "engine", "world")}
result["bake"] = sorted(bpy.ops.glossy.bake_materials())
result["attach"] = sorted(bpy.ops.glossy.attach_materials())
result["validate"] = sorted(bpy.ops.glossy.validate())
report = json.loads(Path(scene.glossy.last_report).with_suffix(".json").read_text())
result["figures"] = report["objects"][0]["figures"]
Path(result_path).write_text(json.dumps(result, indent=1, default=str))
