"""Render Cycles' Glossy BSDF on tilted planes under a sun lamp and in a white furnace.

    python cycles_glossy.py WORKDIR RESULT.json

Each plane of a 4 x 4 grid has its own normal, explicit world-space tangent
(a constant vector into the Tangent socket), distribution, roughness,
anisotropy and rotation. An orthographic camera looks straight down (the
direction to the viewer is +Z everywhere). Filter Glossy is 0.

- sun renders (two sun directions): world black, max bounces 0, a delta sun of
  strength 1, shadows off: a plane's pixel is exactly f(l, v) (n.l);
- furnace renders (two seeds): world white, one bounce, planes invisible to
  glossy rays: a plane's pixel is its directional albedo, with Monte Carlo
  noise that the script measures from the pixels and the two seeds.

Writes per plane: its settings, n, T, sun directions, and the measured
means and standard errors; pytest computes the library's predictions.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

workdir, result_path = Path(sys.argv[1]), sys.argv[2]
repo = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(repo))

import _checkout  # noqa: E402,F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from glossy.glossy_addon.scenes import exact_cycles, float_exr_output  # noqa: E402
from mathutils import Vector  # noqa: E402

from bake import exr  # noqa: E402

GRID, CELL = 5, 16
DISTRIBUTIONS = {"ggx": "GGX", "beckmann": "BECKMANN", "ashikhmin_shirley": "ASHIKHMIN_SHIRLEY",
                 "ggx_multiscatter": "MULTI_GGX"}
KINDS = ["ggx", "beckmann", "ashikhmin_shirley"] * 5 + ["principled_metallic"] * 5 \
    + ["ggx_multiscatter"] * 5
SETTINGS = [  # (roughness, anisotropy, rotation)
    (0.25, 0.0, 0.0), (0.5, 0.0, 0.0), (0.4, 0.7, 0.15), (0.6, -0.5, 0.3), (0.35, 0.9, 0.6),
]
SUNS = [np.array([0.5, 0.3, 0.8]), np.array([0.9, -0.2, 0.35])]

rng = np.random.default_rng(12)
configs = []
for index in range(GRID * GRID):
    name = KINDS[index]
    roughness, anisotropy, rotation = SETTINGS[index % len(SETTINGS)]
    if name == "principled_metallic":
        anisotropy = abs(anisotropy)  # the Principled node takes [0, 1]
    sun = SUNS[0] / np.linalg.norm(SUNS[0])
    half = sun + np.array([0.0, 0.0, 1.0])
    normal = half / np.linalg.norm(half) + rng.normal(scale=0.12, size=3)
    normal /= np.linalg.norm(normal)
    tangent = rng.normal(size=3)
    configs.append({"distribution": name, "roughness": roughness, "anisotropy": anisotropy,
                    "rotation": rotation, "normal": normal.tolist(), "tangent": tangent.tolist(),
                    "base_color": rng.uniform(0.2, 1.0, 3).round(3).tolist(),
                    "specular_tint": rng.uniform(0.3, 1.0, 3).round(3).tolist()})

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
exact_cycles(scene, 4)
cycles = scene.cycles
cycles.caustics_reflective = True
float_exr_output(scene, GRID * CELL)

world = bpy.data.worlds.new("world")
world.use_nodes = True
scene.world = world
background = world.node_tree.nodes["Background"]

camera_data = bpy.data.cameras.new("camera")
camera_data.type = "ORTHO"
camera_data.ortho_scale = float(GRID)
camera = bpy.data.objects.new("camera", camera_data)
camera.location = (0.0, 0.0, 10.0)
scene.collection.objects.link(camera)
scene.camera = camera


def plane_rotation(normal):
    """Euler angles turning +Z onto ``normal``."""
    return Vector((0, 0, 1)).rotation_difference(Vector(normal)).to_euler()


for index, config in enumerate(configs):
    row, col = divmod(index, GRID)
    bpy.ops.mesh.primitive_plane_add(size=0.6, location=(col - GRID / 2 + 0.5,
                                                         GRID / 2 - 0.5 - row, 0.0))
    plane = bpy.context.object
    plane.rotation_euler = plane_rotation(config["normal"])
    plane.visible_shadow = False
    plane.visible_glossy = False
    material = bpy.data.materials.new(f"m{index}")
    material.use_nodes = True
    nodes, links = material.node_tree.nodes, material.node_tree.links
    nodes.clear()
    if config["distribution"] == "principled_metallic":
        glossy = nodes.new("ShaderNodeBsdfPrincipled")
        glossy.distribution = "GGX"
        glossy.inputs["Metallic"].default_value = 1.0
        glossy.inputs["Base Color"].default_value = (*config["base_color"], 1.0)
        glossy.inputs["Specular Tint"].default_value = (*config["specular_tint"], 1.0)
        glossy.inputs["Roughness"].default_value = config["roughness"]
        glossy.inputs["Anisotropic"].default_value = config["anisotropy"]
        glossy.inputs["Anisotropic Rotation"].default_value = config["rotation"]
    else:
        glossy = nodes.new("ShaderNodeBsdfAnisotropic")
        glossy.distribution = DISTRIBUTIONS[config["distribution"]]
        glossy.inputs["Color"].default_value = (1, 1, 1, 1)
        glossy.inputs["Roughness"].default_value = config["roughness"]
        glossy.inputs["Anisotropy"].default_value = config["anisotropy"]
        glossy.inputs["Rotation"].default_value = config["rotation"]
    tangent = nodes.new("ShaderNodeCombineXYZ")
    for axis, value in zip("XYZ", config["tangent"], strict=True):
        tangent.inputs[axis].default_value = value
    links.new(tangent.outputs["Vector"], glossy.inputs["Tangent"])
    output = nodes.new("ShaderNodeOutputMaterial")
    links.new(glossy.outputs[0], output.inputs["Surface"])
    plane.data.materials.append(material)
    bpy.context.view_layer.update()
    config["normal_blender"] = list(plane.matrix_world.to_3x3() @ Vector((0, 0, 1)))


def render(name):
    scene.render.filepath = str(workdir / f"{name}.exr")
    bpy.ops.render.render(write_still=True)
    image, _ = exr.read(workdir / f"{name}.exr")
    windows = []
    for index in range(GRID * GRID):
        row, col = divmod(index, GRID)
        centre_r, centre_c = row * CELL + CELL // 2, col * CELL + CELL // 2
        windows.append(image[centre_r - 3:centre_r + 3, centre_c - 3:centre_c + 3, :3])
    return np.stack(windows)


report = {"configs": configs, "suns": [], "furnace": {}}
# Sun renders: direct light only, no noise from a delta light.
cycles.samples = 4
cycles.max_bounces = 0
background.inputs["Color"].default_value = (0, 0, 0, 1)
sun_data = bpy.data.lights.new("sun", "SUN")
sun_data.energy = 1.0
sun_data.angle = 0.0
sun = bpy.data.objects.new("sun", sun_data)
scene.collection.objects.link(sun)
for k, direction in enumerate(SUNS):
    direction = direction / np.linalg.norm(direction)
    sun.rotation_euler = Vector((0, 0, 1)).rotation_difference(Vector(direction)).to_euler()
    windows = render(f"sun{k}")
    spread = windows.max(axis=(1, 2)) - windows.min(axis=(1, 2))
    report["suns"].append({"direction": direction.tolist(),
                           "mean": windows.mean(axis=(1, 2)).tolist(), "spread": spread.tolist()})
sun_data.energy = 0.0
sun.hide_render = True

# Furnace renders: white world, one glossy bounce, two seeds.
cycles.samples = 256
cycles.max_bounces = 1
cycles.glossy_bounces = 1
background.inputs["Color"].default_value = (1, 1, 1, 1)
seeds = []
for seed in (1, 2):
    cycles.seed = seed
    seeds.append(render(f"furnace{seed}"))
pixels = np.concatenate(seeds, axis=1)  # (planes, 12, 6, 3)
count = pixels.shape[1] * pixels.shape[2]
report["furnace"] = {
    "mean": pixels.mean(axis=(1, 2)).tolist(),
    "stderr": (pixels.std(axis=(1, 2), ddof=1) / math.sqrt(count)).tolist(),
    "seed_difference": np.abs(seeds[0].mean(axis=(1, 2)) - seeds[1].mean(axis=(1, 2))).tolist(),
}
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
