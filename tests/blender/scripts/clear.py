"""glossy.clear after capture, bake and attach, as a pipeline script drives it.

    python clear.py WORKDIR HDRI RESULT.json
"""

import json
import sys
from pathlib import Path

import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
report = {"poll_nothing_selected": bpy.ops.glossy.clear.poll()}

bpy.ops.mesh.primitive_uv_sphere_add(location=(0.5, 0.0, 0.0))
sphere = bpy.context.object
material = bpy.data.materials.new("Paint")
material.use_nodes = True
principled = material.node_tree.nodes["Principled BSDF"]
principled.inputs["Base Color"].default_value = (0.8, 0.1, 0.05, 1.0)
principled.name = "Mine"
sphere.data.materials.append(material)
material.glossy.model = "ggx"
material.glossy.roughness = 0.4
material.glossy.diffuse = (0.2, 0.2, 0.2)
material.glossy.slices = 3
material.glossy.map_size = 8
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_resolution = 16
# A second object shares the material.
bpy.ops.mesh.primitive_cube_add(location=(3.0, 0.0, 0.0))
cube = bpy.context.object
cube.data.materials.append(material)
bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
bpy.context.view_layer.objects.active = sphere

bpy.ops.glossy.capture_probes()
bpy.ops.glossy.bake_materials()
bpy.ops.glossy.attach_materials()
settings = bpy.data.materials["Paint"].glossy
written = [sphere.glossy.probe_path, settings.bake_path, settings.diffuse_path]
attached_tree = bpy.data.materials["Paint"].node_tree
report["attached_nodes_have_mine"] = "Mine" in attached_tree.nodes
report["attached_lookup_active"] = bool(attached_tree.get_output_node("ALL").get("glossy_lookup"))
# The user edits their own node in the attached material: Clear must keep the edit.
attached_tree.nodes["Mine"].inputs["Base Color"].default_value = (0.7, 0.2, 0.1, 1.0)
report["stash"] = settings.original.name if settings.original else None
bpy.ops.glossy.attach_materials()  # a second attach keeps the first stash
report["stashes_after_reattach"] = sorted(m.name for m in bpy.data.materials)

# A file Glossy did not write, that the object's probe path now points at.
foreign = workdir / "glossy" / "foreign.exr"
import OpenEXR  # noqa: E402

OpenEXR.File({"type": OpenEXR.scanlineimage},
             {"RGB": np.ones((4, 4, 3), np.float32)}).write(str(foreign))
cube.glossy.probe_path = str(foreign)
cube.select_set(True)

report["clear"] = sorted(bpy.ops.glossy.clear())
paint = bpy.data.materials["Paint"]
report["after"] = {
    "materials": sorted(m.name for m in bpy.data.materials),
    "slots_are_paint": [obj.material_slots[0].material == paint for obj in (sphere, cube)],
    "has_mine": "Mine" in paint.node_tree.nodes,
    "lookup_nodes": sum(bool(n.get("glossy_lookup")) for n in paint.node_tree.nodes),
    "user_output_active": paint.node_tree.get_output_node("ALL").name,
    "base_color": list(paint.node_tree.nodes["Mine"].inputs["Base Color"].default_value),
    "settings_kept": [paint.glossy.roughness, list(paint.glossy.diffuse)],
    "status": bake_status(paint.glossy, sphere.glossy.probe_path),
    "paths": [sphere.glossy.probe_path, cube.glossy.probe_path, paint.glossy.bake_path,
              paint.glossy.diffuse_path],
    "written_exist": [Path(p).exists() for p in written],
    "foreign_exists": foreign.exists(),
    "foreign_readable": exr.read(foreign)[0].shape == (4, 4, 3),
    "images": sorted(i.name for i in bpy.data.images),
    "original": paint.glossy.original is not None,
}
# The whole path works again after a clear.
bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
bpy.context.view_layer.objects.active = sphere
report["again"] = [sorted(bpy.ops.glossy.capture_probes()), sorted(bpy.ops.glossy.bake_materials()),
                   sorted(bpy.ops.glossy.attach_materials())]
report["again_stash"] = paint.glossy.original.name if paint.glossy.original else None
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
