"""#5's acceptance scene with a sun lamp added (issue 12): Glossy captures,
bakes (environment maps and lamp factors) and attaches as a user would; EEVEE
renders the Glossy materials, Cycles the true BSDFs (two seeds), and each
pixel's object comes from ray casts, for the pytest side to compare where the
highlights are.

    python sun_scene.py WORKDIR HDRI RESULT.json
"""

import json
import sys
from pathlib import Path

import _acceptance_scene
import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon import scenes, validation  # noqa: E402
from mathutils import Vector  # noqa: E402

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
SIZE = 96
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
sphere, torus = _acceptance_scene.build(scenes, hdri)
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
sun.data.energy = 12.0
sun.data.angle = 0.0
sun.rotation_euler = Vector((0.25, 0.9, -0.6)).to_track_quat("-Z", "Y").to_euler()
bpy.context.scene.collection.objects.link(sun)
scene = bpy.context.scene
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
report = _acceptance_scene.capture_bake_attach((sphere, torus))
for obj in (sphere, torus):
    report[obj.name + "_lamps"] = json.loads(obj.data.materials[0].glossy.lamp_set)
scenes.float_exr_output(scene, SIZE)
index, _, _ = validation.pixel_geometry(scene, scene.camera, SIZE, SIZE, [sphere, torus])
exr.write(workdir / "ids.exr", np.repeat(index[..., None], 3, -1).astype(np.float32))
report["ids"] = str(workdir / "ids.exr")
scene.render.engine = scenes.eevee_engine()
scene.eevee.taa_render_samples = 4
scene.eevee.clamp_surface_indirect = 0.0
scene.world.sun_threshold = 0.0
report["glossy"] = str(workdir / "glossy.exr")
validation.render_to(scene, Path(report["glossy"]))
truth, why = validation.truth_material(sphere.data.materials[0])
report["truth_problem"] = why
sphere.data.materials[0] = truth
report["cycles"] = []
for seed in (1, 2):
    scenes.exact_cycles(scene, 64)
    scene.cycles.seed = seed
    path = workdir / f"cycles{seed}.exr"
    validation.render_to(scene, path)
    report["cycles"].append(str(path))
Path(result_path).write_text(json.dumps(report))
