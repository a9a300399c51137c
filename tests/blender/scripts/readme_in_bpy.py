"""The README's headless pipeline through the bpy module, with the extension
installed from its zip: each ``--python-expr`` runs after opening scene.blend,
as ``blender --background scene.blend --python-expr`` would.

    python readme_in_bpy.py ZIP WORKDIR EXPRESSIONS.json RESULT.json
"""

import json
import sys
from pathlib import Path

from _installed import MODULE, install  # first: hides the venv's OpenEXR

# isort: split
import importlib

import _acceptance_scene
import bpy

zip_path, workdir, expressions_path, result_path = sys.argv[1:5]
workdir = Path(workdir)
report = {"install": install(zip_path)}
scenes = importlib.import_module(MODULE + ".glossy_addon.scenes")
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
hdri = Path(bpy.utils.system_resource("DATAFILES"), "studiolights", "world", "forest.exr")
_acceptance_scene.build(scenes, hdri)
blend = workdir / "scene.blend"
bpy.ops.wm.save_as_mainfile(filepath=str(blend))
for expression in json.loads(Path(expressions_path).read_text()):
    bpy.ops.wm.open_mainfile(filepath=str(blend))
    exec(compile(expression, "<README --python-expr>", "exec"), {"__name__": "__main__"})
bpy.ops.wm.open_mainfile(filepath=str(blend))
report["views"] = _acceptance_scene.render_views(workdir)
Path(result_path).write_text(json.dumps(report, indent=1))
