"""A large lookup split into private node groups, through its whole life.

    python lookup_parts.py HDRI WORKDIR RESULT.json

One isolated sphere (World Only probe of 32 px faces), a Principled metal with
a Checker Texture's Base Color and its Roughness from an image of four bands
(0.15-0.5): the bake gives maps at seven roughness knots, each split at Base
Color 0 and 1, so the lookup runs to about a thousand nodes. Records, after
capture, bake and attach: the nodes in the material's tree and in each private
group (glossy_addon.nodes.PART_TAG), the lookup's node count (nodes.lookup_nodes)
and the attach's seconds (for information, not asserted); then what a
validation's truth copy (validation.user_copy) leaves, a re-attach, and
glossy.clear.
"""

import json
import sys
import time
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import (  # noqa: E402
    checker_into,
    isolated_sphere,
    roughness_image,
    validation_scene,
)
from glossy.glossy_addon import validation  # noqa: E402
from glossy.glossy_addon.nodes import PART_TAG, is_lookup_node, lookup_nodes  # noqa: E402

validation_scene(hdri, workdir, 32)
obj = isolated_sphere("Rough", 0.0, face=32)
material = bpy.data.materials.new("Rough")
material.use_nodes = True
tree = material.node_tree
principled = tree.nodes["Principled BSDF"]
principled.inputs["Metallic"].default_value = 1.0
checker_into(tree, principled.inputs["Base Color"])
texture = tree.nodes.new("ShaderNodeTexImage")
texture.image = roughness_image()
tree.links.new(texture.outputs["Color"], principled.inputs["Roughness"])
material.glossy.model = "MATERIAL"
obj.data.materials.append(material)
bpy.context.view_layer.objects.active = obj
obj.select_set(True)
user_nodes = sorted(node.name for node in tree.nodes)
result = {"capture": sorted(bpy.ops.glossy.capture_probes()),
          "bake": sorted(bpy.ops.glossy.bake_materials())}


def parts():
    return sorted(group.name for group in bpy.data.node_groups if group.get(PART_TAG))


def state():
    used = [node.node_tree for node in material.node_tree.nodes
            if is_lookup_node(node) and node.bl_idname == "ShaderNodeGroup"
            and node.node_tree is not None and node.node_tree.get(PART_TAG)]
    return {"root": len(material.node_tree.nodes),
            "part_nodes": [len(group.nodes) for group in used],
            "used_parts": sorted(group.name for group in used),
            "parts": parts(), "lookup": len(lookup_nodes(material)),
            "maps": len(material.glossy.roughness_map_list()),
            "user_nodes": sorted(node.name for node in material.node_tree.nodes
                                 if not is_lookup_node(node)) == user_nodes}


start = time.perf_counter()
result["attach"] = sorted(bpy.ops.glossy.attach_materials())
result["attach_s"] = time.perf_counter() - start
result["attached"] = state()
copy = validation.user_copy(material, "truth")
result["copy"] = {"nodes": sorted(node.bl_idname for node in copy.node_tree.nodes),
                  "lookup": len(lookup_nodes(copy)), "parts": parts()}
bpy.data.materials.remove(copy)
start = time.perf_counter()
result["reattach"] = sorted(bpy.ops.glossy.attach_materials())
result["reattach_s"] = time.perf_counter() - start
result["reattached"] = state()
result["clear"] = sorted(bpy.ops.glossy.clear())
result["cleared"] = state()
result_path.write_text(json.dumps(result, indent=1))
