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
import sys
from pathlib import Path

import numpy as np

workdir, result_path = Path(sys.argv[1]), sys.argv[2]
repo = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(repo))

import _checkout  # noqa: E402,F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _plane_grid import PlaneGrid  # noqa: E402

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

grid = PlaneGrid(workdir, GRID, CELL)


for index, config in enumerate(configs):
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
    config["normal_blender"] = grid.plane(index, config["normal"], material)


report = {"configs": configs, "suns": grid.sun_renders(SUNS),
          "furnace": grid.furnace_renders(256)}
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
