"""The whole Blender path on a small scene, as #5's acceptance test describes it.

    python scene_lookup.py WORKDIR HDRI RESULT.json

A sphere (GGX 0.3) and a torus (Ward 0.15) over a plane, the world from a
bundled HDRI (_acceptance_scene.build). Glossy captures a probe at both
centres (Cycles renders, the other objects visible), bakes both materials and
attaches the lookups; EEVEE renders the scene and two more views give each
pixel's shading normal and object (_acceptance_scene.render_views), so the
pytest side can compare with bake.atlas.shade.
"""

import json
import sys
from pathlib import Path

import _acceptance_scene
import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon import scenes  # noqa: E402

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
sphere, torus = _acceptance_scene.build(scenes, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))

report = _acceptance_scene.capture_bake_attach((sphere, torus))
report["views"] = _acceptance_scene.render_views(workdir)
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
