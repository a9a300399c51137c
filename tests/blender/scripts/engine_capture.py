"""Capture the world with each render engine and resample it, in one Blender.

    python engine_capture.py ZIP WORKDIR RESULT.json                      (bpy module)
    blender --background --python engine_capture.py -- WORKDIR RESULT.json (installed)

Three empty cubes at the origin, hidden from renders: one captured with
Cycles, one with EEVEE (the 4.x/5.x engine identifier is Glossy's business),
one resampled from the world image (no render). Writes their probe paths.
"""

import json
import sys
from pathlib import Path

if "--" in sys.argv:  # a blender executable, extension already installed
    workdir, result_path = sys.argv[sys.argv.index("--") + 1:][:2]
else:  # the bpy module: install the zip first
    from _installed import install  # hides the venv's OpenEXR

    install(sys.argv[1])
    workdir, result_path = sys.argv[2:4]

# isort: split
import bpy  # noqa: E402
from bl_ext.user_default.glossy.glossy_addon import scenes  # noqa: E402

workdir = Path(workdir)
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
scene = bpy.context.scene
scenes.environment_world(
    scene, Path(bpy.utils.system_resource("DATAFILES"), "studiolights", "world", "forest.exr"))
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
probes = {}
for name, source, engine in (("cycles", "RENDER", "CYCLES"),
                             ("eevee", "RENDER", "BLENDER_EEVEE"),
                             ("world", "WORLD", "CYCLES")):
    bpy.ops.mesh.primitive_cube_add(size=0.1)
    obj = bpy.context.object
    obj.name = name
    obj.hide_render = True  # none of the cubes shows in another's capture
    settings = obj.glossy
    settings.probe_source, settings.capture_engine = source, engine
    settings.probe_size_mode = "FIXED"  # compared with the world at a known size
    settings.probe_resolution = 32
    settings.capture_samples = 16
    settings.centre_mode = "ORIGIN"
    probes[name] = obj
bpy.ops.object.select_all(action="SELECT")
report = {"capture": sorted(bpy.ops.glossy.capture_probes()),
          "engine_after": scene.render.engine, "version": bpy.app.version_string}
report["probes"] = {name: bpy.path.abspath(obj.glossy.probe_path) for name, obj in probes.items()}
Path(result_path).write_text(json.dumps(report, indent=1))
