"""Build #5's acceptance scene inside a ``blender`` executable, with the Glossy
extension installed in the user directory, and save it.

    blender --background --python binary_scene.py -- WORKDIR

The world is Blender's own forest.exr (its datafiles). Writes WORKDIR/scene.blend
with the sphere and torus selected, ready for the README's pipeline command.
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _acceptance_scene  # noqa: E402
import bpy  # noqa: E402
from bl_ext.user_default.glossy.glossy_addon import scenes  # noqa: E402

workdir = Path(sys.argv[sys.argv.index("--") + 1])
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
hdri = Path(bpy.utils.system_resource("DATAFILES"), "studiolights", "world", "forest.exr")
_acceptance_scene.build(scenes, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
print("Glossy test scene saved:", workdir / "scene.blend", bpy.app.version_string)
