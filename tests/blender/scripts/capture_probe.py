"""glossy.capture_probes on an off-origin, asymmetric mesh, checked independently.

    python capture_probe.py REPO WORKDIR HDRI RESULT.json

Registers the repository as the add-on package ``glossy`` (a symlink, as a
developer's checkout would be), builds a scene, captures a probe with Cycles,
and records: the probe centre against the analytic centroid of a cone, and
each cube face against a separate camera render from that point, compared
pixel by pixel through directions computed from that camera alone.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

repo, workdir, hdri, result_path = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import envmap, exr  # noqa: E402
from glossy.glossy_addon.capture import cycles_face_settings  # noqa: E402
from glossy.glossy_addon.scenes import environment_world, exact_cycles, float_exr_output  # noqa: E402
from mathutils import Matrix, Vector  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
exact_cycles(scene, 1)
scene.cycles.max_bounces = 0
scene.view_settings.view_transform = "Standard"
environment_world(scene, hdri)

# Emissive blocks around the probe, so the faces show scene geometry too.
for index, location in enumerate([(6, -2, 1), (1, 4, 0.5), (2, -1, 5), (-3, -1, -1)]):
    bpy.ops.mesh.primitive_cube_add(size=1.5, location=location)
    material = bpy.data.materials.new(f"glow{index}")
    material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.2 + 0.2 * index, 0.9 - 0.2 * index, 0.5, 1)
    emission.inputs["Strength"].default_value = 3.0
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(emission.outputs[0], output.inputs[0])
    bpy.context.object.data.materials.append(material)

# The object: a cone (centroid a quarter of the height above its base), moved,
# turned and stretched so that centroid, bounding-box centre and origin differ.
bpy.ops.mesh.primitive_cone_add(vertices=48, radius1=1.0, depth=2.0, location=(2.0, -1.0, 0.5),
                                rotation=(0.4, -0.3, 1.1))
cone = bpy.context.object
cone.scale = (1.0, 2.0, 0.5)
bpy.context.view_layer.update()
expected = np.array(cone.matrix_world @ Vector((0.0, 0.0, -0.5)))  # base at -1, tip at +1

settings = cone.glossy
settings.probe_size_mode = "FIXED"  # this checks the capture itself at a known size
settings.probe_resolution = 16
settings.capture_samples = 1
settings.capture_engine = "CYCLES"
bpy.ops.object.select_all(action="DESELECT")
cone.select_set(True)
bpy.context.view_layer.objects.active = cone
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
status = sorted(bpy.ops.glossy.capture_probes())
probe, meta = exr.read(settings.probe_path)
centre = np.array(settings.probe_centre)
bbox = np.array([cone.matrix_world @ Vector(c) for c in cone.bound_box])
report = {
    "status": status, "path": settings.probe_path, "meta": meta, "shape": list(probe.shape),
    "centre": centre.tolist(), "expected": expected.tolist(),
    "bbox_centre": (0.5 * (bbox.min(0) + bbox.max(0))).tolist(),
    "origin": list(cone.matrix_world.translation),
    "cone_hidden_after": cone.hide_render, "camera_after": scene.camera is None,
    "objects_after": sorted(o.name for o in bpy.data.objects),
    "cycles_after": [scene.cycles.pixel_filter_type, round(scene.cycles.filter_width, 6),
                     scene.cycles.samples, scene.cycles.use_adaptive_sampling],
}

# Reference renders: a separate camera at the centre, looking along each axis
# with its own roll, 90 degrees, same resolution; its rays come from its own
# matrix, and the probe is sampled at those rays (nearest texel).
cone.hide_render = True
camera_data = bpy.data.cameras.new("reference")
camera_data.angle = math.pi / 2
camera = bpy.data.objects.new("reference", camera_data)
scene.collection.objects.link(camera)
scene.camera = camera
float_exr_output(scene, 16)
# The capture's own Cycles settings (texel averages through a 1 px box filter, its
# floor of samples per face, adaptive sampling), restored by the capture above.
for name, value in cycles_face_settings(settings.capture_samples, 16).items():
    setattr(scene.cycles, name, value)
cube = envmap.get_layout("cube")
differences = []
for axis in [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]:
    quat = Vector(axis).to_track_quat("-Z", "Y" if abs(axis[1]) < 0.5 else "Z")
    camera.matrix_world = Matrix.Translation(Vector(centre)) @ quat.to_matrix().to_4x4()
    scene.render.filepath = str(workdir / f"ref_{axis}.exr")
    bpy.ops.render.render(write_still=True)
    image, _ = exr.read(scene.render.filepath)
    j = np.arange(16) + 0.5
    xx, yy = np.meshgrid(j / 16 * 2 - 1, 1 - j / 16 * 2)
    rays = np.stack([xx, yy, -np.ones_like(xx)], -1) @ np.array(quat.to_matrix()).T
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    row, col = cube.direction_to_texel(rays, probe.shape[:2])
    difference = np.abs(probe[row, col] - image[..., :3]) / np.maximum(image[..., :3], 1e-3)
    differences.append(difference.max(axis=-1))
differences = np.stack(differences)
report["face_median_relative_difference"] = float(np.median(differences))
report["face_p99_relative_difference"] = float(np.percentile(differences, 99))

# Error paths are reported, not raised; Blender keeps working.
settings.probe_resolution = 0
try:
    bpy.ops.glossy.capture_probes()
    report["resolution_zero"] = "no error"
except RuntimeError as error:
    report["resolution_zero"] = str(error)
settings.probe_resolution = 16
bpy.ops.object.select_all(action="DESELECT")
report["poll_without_mesh"] = bpy.ops.glossy.capture_probes.poll()

# Auto: a sphere with a GGX 0.1 material gets the faces its lobe needs (a face's half
# texel, 1 / N rad, no wider than the lobe), within the world image's detail and the
# maximum; the choice and its reason are stored and shown.
bpy.ops.mesh.primitive_uv_sphere_add(location=(0.0, 3.0, 0.0))
ball = bpy.context.object
material = bpy.data.materials.new("Sharp")
material.glossy.model = "ggx"
material.glossy.roughness = 0.1
ball.data.materials.append(material)
ball.glossy.probe_source = "WORLD"
ball.glossy.probe_resolution = 4096
bpy.ops.glossy.capture_probes()
auto_probe, auto_meta = exr.read(ball.glossy.probe_path)
report["auto_shape"] = list(auto_probe.shape)
report["auto_reason"] = ball.glossy.probe_reason
report["auto_meta_reason"] = auto_meta.get("size_reason")
ball.glossy.probe_resolution = 64
bpy.ops.glossy.capture_probes()
report["auto_capped_shape"] = list(exr.read(ball.glossy.probe_path)[0].shape)
report["auto_capped_reason"] = ball.glossy.probe_reason
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
