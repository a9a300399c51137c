"""Render users' node-tree materials in Cycles under a sun lamp and in a white furnace,
and derive each one's spec with glossy_addon.node_reader.

    python cycles_principled.py WORKDIR RESULT.json

Sixteen materials as a user builds them (Principled rough metal, smooth metal
with specular tint, plastics, coated metal and plastic, brushed anisotropic
metal, a half-metal, a Value-driven roughness, Mix of Diffuse and Glossy by a
constant and by a Fresnel node, Add of Diffuse and Glossy; Metallic BSDFs: F82
Tint with GGX, brushed F82 Tint with Multiscatter GGX, Physical Conductor with
GGX and with Multiscatter GGX), each on two tilted planes (cycles_glossy.py's
set-up: orthographic camera straight down, a delta sun of strength 1 with
shadows off, Filter Glossy 0; furnace: white world, one bounce, two seeds).
Writes per plane the material's derived spec, ignored and approximated lists,
n, T, and the measured pixels.
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
from glossy.glossy_addon.node_reader import read_material  # noqa: E402

GRID, CELL = 6, 16
SUNS = [np.array([0.5, 0.3, 0.8]), np.array([0.9, -0.2, 0.35])]


def principled(nodes, distribution="GGX", **inputs):
    node = nodes.new("ShaderNodeBsdfPrincipled")
    node.distribution = distribution
    for name, value in inputs.items():
        socket = node.inputs[name.replace("_", " ")]
        socket.default_value = (*value, 1.0) if isinstance(value, tuple) else value
    return node


def glossy(nodes, distribution, roughness, color=(1, 1, 1)):
    node = nodes.new("ShaderNodeBsdfAnisotropic")
    node.distribution = distribution
    node.inputs["Roughness"].default_value = roughness
    node.inputs["Color"].default_value = (*color, 1.0)
    return node


def metallic(nodes, distribution, fresnel_type, **inputs):
    node = nodes.new("ShaderNodeBsdfMetallic")
    node.distribution = distribution
    node.fresnel_type = fresnel_type
    for name, value in inputs.items():
        socket = node.inputs[name.replace("_", " ")]
        socket.default_value = (*value, 1.0) if socket.type == "RGBA" else value
    return node


def tangent_link(nodes, links, node, tangent_vector):
    tangent = nodes.new("ShaderNodeCombineXYZ")
    for axis, value in zip("XYZ", tangent_vector, strict=True):
        tangent.inputs[axis].default_value = value
    links.new(tangent.outputs["Vector"], node.inputs["Tangent"])


def diffuse(nodes, color):
    node = nodes.new("ShaderNodeBsdfDiffuse")
    node.inputs["Color"].default_value = (*color, 1.0)
    node.inputs["Roughness"].default_value = 0.0
    return node


def build(kind, tree, tangent_vector):
    """The surface node of material ``kind`` in ``tree`` (links made)."""
    nodes, links = tree.nodes, tree.links
    if kind == "rough_metal":
        return principled(nodes, Metallic=1.0, Base_Color=(0.9, 0.6, 0.3), Roughness=0.5)
    if kind == "tinted_metal":
        return principled(nodes, "MULTI_GGX", Metallic=1.0, Base_Color=(0.95, 0.9, 0.8),
                          Roughness=0.22, Specular_Tint=(0.5, 0.7, 0.9))
    if kind == "plastic":
        return principled(nodes, "MULTI_GGX", Base_Color=(0.2, 0.4, 0.8), Roughness=0.35)
    if kind == "plastic_level":
        return principled(nodes, Base_Color=(0.7, 0.2, 0.1), Roughness=0.3, IOR=1.45,
                          Specular_IOR_Level=0.8, Specular_Tint=(1.0, 0.8, 0.6))
    if kind == "coated_metal":
        return principled(nodes, "MULTI_GGX", Metallic=1.0, Base_Color=(0.8, 0.3, 0.2),
                          Roughness=0.45, Coat_Weight=0.8, Coat_Roughness=0.15, Coat_IOR=1.6,
                          Coat_Tint=(0.9, 0.85, 0.7))
    if kind == "coated_plastic":
        return principled(nodes, Base_Color=(0.1, 0.5, 0.2), Roughness=0.5, Coat_Weight=1.0,
                          Coat_Roughness=0.1)
    if kind == "brushed":
        node = principled(nodes, Metallic=1.0, Base_Color=(0.9, 0.9, 0.9), Roughness=0.4,
                          Anisotropic=0.7, Anisotropic_Rotation=0.2)
        tangent = nodes.new("ShaderNodeCombineXYZ")
        for axis, value in zip("XYZ", tangent_vector, strict=True):
            tangent.inputs[axis].default_value = value
        links.new(tangent.outputs["Vector"], node.inputs["Tangent"])
        return node
    if kind == "metallic_f82":
        return metallic(nodes, "GGX", "F82", Base_Color=(0.9, 0.7, 0.4), Edge_Tint=(0.6, 0.8, 1.0),
                        Roughness=0.35)
    if kind == "metallic_brushed":
        node = metallic(nodes, "MULTI_GGX", "F82", Base_Color=(0.95, 0.95, 0.9),
                        Edge_Tint=(1.0, 0.9, 0.8), Roughness=0.45, Anisotropy=0.6, Rotation=0.15)
        tangent_link(nodes, links, node, tangent_vector)
        return node
    if kind == "conductor":  # Blender's default n and k (a silver-like metal)
        return metallic(nodes, "GGX", "PHYSICAL_CONDUCTOR", Roughness=0.3)
    if kind == "conductor_multi":  # gold
        return metallic(nodes, "MULTI_GGX", "PHYSICAL_CONDUCTOR", Roughness=0.5,
                        IOR=(0.143, 0.374, 1.442), Extinction=(3.983, 2.385, 1.603))
    if kind == "half_metal":
        return principled(nodes, "MULTI_GGX", Metallic=0.5, Base_Color=(0.6, 0.6, 0.3),
                          Roughness=0.4)
    if kind == "value_roughness":
        node = principled(nodes, Base_Color=(0.5, 0.5, 0.5), Roughness=0.9)
        value = nodes.new("ShaderNodeValue")
        value.outputs[0].default_value = 0.3
        links.new(value.outputs[0], node.inputs["Roughness"])
        return node
    if kind == "mix_constant":
        mix = nodes.new("ShaderNodeMixShader")
        mix.inputs["Fac"].default_value = 0.4
        links.new(diffuse(nodes, (0.6, 0.3, 0.2)).outputs[0], mix.inputs[1])
        links.new(glossy(nodes, "GGX", 0.3).outputs[0], mix.inputs[2])
        return mix
    if kind == "mix_fresnel":
        mix = nodes.new("ShaderNodeMixShader")
        fresnel = nodes.new("ShaderNodeFresnel")
        fresnel.inputs["IOR"].default_value = 1.45
        links.new(fresnel.outputs[0], mix.inputs["Fac"])
        links.new(diffuse(nodes, (0.3, 0.5, 0.2)).outputs[0], mix.inputs[1])
        links.new(glossy(nodes, "BECKMANN", 0.4).outputs[0], mix.inputs[2])
        return mix
    if kind == "add":
        add = nodes.new("ShaderNodeAddShader")
        links.new(diffuse(nodes, (0.2, 0.2, 0.3)).outputs[0], add.inputs[0])
        links.new(glossy(nodes, "MULTI_GGX", 0.3, (0.5, 0.5, 0.5)).outputs[0], add.inputs[1])
        return add
    raise ValueError(kind)


KINDS = ["rough_metal", "tinted_metal", "plastic", "plastic_level", "coated_metal",
         "coated_plastic", "brushed", "half_metal", "value_roughness", "mix_constant",
         "mix_fresnel", "add", "metallic_f82", "metallic_brushed", "conductor",
         "conductor_multi"]

rng = np.random.default_rng(31)
configs = []
for index in range(GRID * GRID):
    kind = KINDS[index % len(KINDS)]
    sun = SUNS[index % 2] / np.linalg.norm(SUNS[index % 2])
    half = sun + np.array([0.0, 0.0, 1.0])
    normal = half / np.linalg.norm(half) + rng.normal(scale=0.15, size=3)
    normal /= np.linalg.norm(normal)
    configs.append({"kind": kind, "normal": normal.tolist(),
                    "tangent": rng.normal(size=3).tolist()})

grid = PlaneGrid(workdir, GRID, CELL)

for index, config in enumerate(configs):
    material = bpy.data.materials.new(f"{config['kind']}_{index}")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    surface = build(config["kind"], tree, config["tangent"])
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(surface.outputs[0], output.inputs["Surface"])
    derived = read_material(material)
    config.update({"spec": derived.spec, "ignored": derived.ignored,
                   "approximated": derived.approximated})
    config["normal_blender"] = grid.plane(index, config["normal"], material)


report = {"configs": configs, "suns": grid.sun_renders(SUNS),
          "furnace": grid.furnace_renders(512)}
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
