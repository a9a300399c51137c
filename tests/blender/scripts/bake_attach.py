"""Bake bookkeeping and attach, as a pipeline script drives them.

    python bake_attach.py REPO WORKDIR HDRI RESULT.json
"""

import json
import sys
from pathlib import Path

repo, workdir, hdri, result_path = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
bpy.ops.mesh.primitive_uv_sphere_add(location=(1.0, 2.0, 0.5))
sphere = bpy.context.object
report = {"poll_no_material": bpy.ops.glossy.bake_materials.poll()}
material = bpy.data.materials.new("Shiny")
sphere.data.materials.append(material)
material.glossy.model, material.glossy.method = "ggx", "3d"  # the 3D map's lookup nodes
material.glossy.roughness = 0.3
material.glossy.slices = 3
material.glossy.map_size = 8
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_resolution = 16
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
report["bake_without_probe"] = ""
try:
    bpy.ops.glossy.bake_materials()
except RuntimeError as error:
    report["bake_without_probe"] = str(error)
report["capture"] = sorted(bpy.ops.glossy.capture_probes())


def status():
    return bake_status(material.glossy, sphere.glossy.probe_path)


report["before"] = status()
report["bake1"] = sorted(bpy.ops.glossy.bake_materials())
path = Path(material.glossy.bake_path)
first = path.stat().st_mtime_ns
report["after_bake"] = status()
bpy.ops.glossy.bake_materials()
report["rebake_did_no_work"] = path.stat().st_mtime_ns == first

bpy.ops.wm.save_mainfile()
bpy.ops.wm.open_mainfile(filepath=str(workdir / "scene.blend"))
sphere = bpy.data.objects["Sphere"]
material = bpy.data.materials["Shiny"]
bpy.context.view_layer.objects.active = sphere
report["after_reload"] = status()
bpy.ops.glossy.bake_materials()
report["reload_rebake_did_no_work"] = path.stat().st_mtime_ns == first

material.glossy.roughness = 0.5
report["after_change"] = status()
bpy.ops.glossy.bake_materials()
report["after_rebake"] = status()
path.unlink()
report["after_delete"] = status()
bpy.ops.glossy.bake_materials()
report["restored"] = path.exists() and status() == "up to date"
report["attach"] = sorted(bpy.ops.glossy.attach_materials())
types = sorted({node.type for node in material.node_tree.nodes})
report["node_types"] = types
report["image_taps"] = sum(node.type == "TEX_IMAGE" for node in material.node_tree.nodes)
tapped = next(n.image for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
report["atlas_precision"] = exr.read(material.glossy.bake_path)[1]["precision"]
report["atlas_use_half_precision"] = tapped.use_half_precision
report["size_reason"] = material.glossy.size_reason
report["chosen_size"] = material.glossy.chosen_size
material.glossy.map_size = 0
try:
    bpy.ops.glossy.bake_materials()
    report["size_zero"] = "no error"
except RuntimeError as error:
    report["size_zero"] = str(error)
material.glossy.map_size = 8

# A baked texture missing on reload: status says so, a re-bake and attach restore it.
bpy.ops.wm.save_mainfile()
Path(material.glossy.bake_path).unlink()
bpy.ops.wm.open_mainfile(filepath=str(workdir / "scene.blend"))
sphere = bpy.data.objects["Sphere"]
material = bpy.data.materials["Shiny"]
bpy.context.view_layer.objects.active = sphere
report["reload_missing_status"] = status()
image = next(n.image for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
report["image_has_data_missing"] = bool(image.has_data and image.size[0] > 0)
report["rebake"] = sorted(bpy.ops.glossy.bake_materials())
report["reattach"] = sorted(bpy.ops.glossy.attach_materials())
image = next(n.image for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
report["image_size_after"] = list(image.size)
material.glossy.method = "split-sum"  # the same 2D node path, fed by the GGX MIP chain
report["split_sum_status_before"] = status()
report["split_sum"] = sorted(bpy.ops.glossy.bake_materials()) + sorted(
    bpy.ops.glossy.attach_materials())
report["split_sum_file"] = Path(material.glossy.bake_path).name

# An unsaved file and no extension user folder (this checkout is not an
# installed extension): the capture reports it and writes nothing.
bpy.ops.wm.read_homefile(use_empty=True)
environment_world(bpy.context.scene, hdri)
bpy.ops.mesh.primitive_uv_sphere_add()
bpy.context.object.glossy.probe_source = "WORLD"
bpy.context.object.glossy.probe_resolution = 16
try:
    bpy.ops.glossy.capture_probes()
    report["unsaved"] = "no error"
except RuntimeError as error:
    report["unsaved"] = str(error)
report["unsaved_probe_path"] = bpy.context.object.glossy.probe_path
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
