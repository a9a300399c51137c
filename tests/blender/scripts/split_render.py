"""A split lookup renders the pixels of the same lookup in one tree.

    python split_render.py HDRI WORKDIR RESULT.json

An orthographic sphere (World Only probe of 32 px faces) and two Principled
metals of Roughness 0.3, read From Material:

- "Chain": the 3D map (8 slices) with its Base Color through a node chain (a
  Gamma node fed by an RGB node; colour_split.py's "Chain"): maps at Base
  Color 0 and 1 and the split per pixel, 80 nodes. Attached split after every
  12 nodes (many small groups, the last nodes after a pending split included),
  then in one tree; rendered by EEVEE and by Cycles.
- "Checker": the Hybrid (its maps split at Base Color 0 and 1 for a Checker
  Texture, its runtime part scaled per pixel, its probe lights in repeat
  zones), about 300 nodes, attached as Glossy splits it
  (glossy_addon.nodes.PART_NODES) and in one tree; rendered by EEVEE only
  (Cycles compiles neither: its SVM stack is too small for this lookup).

EEVEE at 1 sample and Cycles at 1 sample without pixel filter (the lookup is
an Emission shader: no noise). Writes the renders' paths and each lookup's
tree sizes.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import checker_into  # noqa: E402
from _ortho_sphere import eevee_renders, ortho_sphere_scene  # noqa: E402
from glossy.glossy_addon import nodes  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

scene, sphere = ortho_sphere_scene(48)
import glossy  # noqa: E402

glossy.register()
environment_world(scene, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_size_mode = "FIXED"
sphere.glossy.probe_resolution = 32
sphere.data.materials.append(None)
bpy.context.view_layer.objects.active = sphere
sphere.select_set(True)
result = {"capture": sorted(bpy.ops.glossy.capture_probes()), "steps": []}
DEFAULT_PART_NODES = nodes.PART_NODES


def metal(name):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    principled = tree.nodes["Principled BSDF"]
    principled.inputs["Metallic"].default_value = 1.0
    principled.inputs["Roughness"].default_value = 0.3
    if name == "Chain":
        principled.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        rgb = tree.nodes.new("ShaderNodeRGB")
        rgb.outputs[0].default_value = (0.06, 0.25, 0.05, 1.0)
        gamma = tree.nodes.new("ShaderNodeGamma")
        gamma.inputs["Gamma"].default_value = 1.0
        tree.links.new(rgb.outputs[0], gamma.inputs["Color"])
        tree.links.new(gamma.outputs[0], principled.inputs["Base Color"])
        material.glossy.method = "3d"
        material.glossy.slices = 8
    else:
        checker_into(tree, principled.inputs["Base Color"], 3.0, (0.9, 0.6, 0.2),
                     (0.1, 0.3, 0.8))
    material.glossy.model = "MATERIAL"
    return material


def trees(lookup):
    groups = [node.node_tree for node in lookup.node_tree.nodes
              if nodes.is_lookup_node(node) and getattr(node, "node_tree", None) is not None
              and node.node_tree.get(nodes.PART_TAG)]
    return {"root": len(lookup.node_tree.nodes), "parts": [len(g.nodes) for g in groups],
            "lookup": len(nodes.lookup_nodes(lookup))}


materials = {}
for name, threshold in (("Chain", 12), ("Checker", DEFAULT_PART_NODES)):
    material = metal(name)
    sphere.data.materials[0] = material
    nodes.PART_NODES = threshold
    result["steps"] += [sorted(bpy.ops.glossy.bake_materials()),
                        sorted(bpy.ops.glossy.attach_materials())]
    split = material.copy()  # keeps the split lookup (its groups too) for the renders
    split.name = f"{name} split"
    nodes.PART_NODES = 10**9
    result["steps"].append(sorted(bpy.ops.glossy.attach_materials()))
    result[name] = {"method": material.glossy.method_used(), "split": trees(split),
                    "whole": trees(material)}
    materials[f"{name} split"], materials[f"{name} whole"] = split, material
nodes.PART_NODES = DEFAULT_PART_NODES
eevee_renders(scene, sphere, workdir, materials)
result["eevee"] = {name: str(workdir / f"{name}.exr") for name in materials}
scene.render.engine = "CYCLES"
scene.cycles.samples = 1
scene.cycles.use_denoising = False
result["cycles"] = {}
for name in ("Chain split", "Chain whole"):
    sphere.data.materials[0] = materials[name]
    scene.render.filepath = str(workdir / f"cycles {name}.exr")
    bpy.ops.render.render(write_still=True)
    result["cycles"][name] = scene.render.filepath
result_path.write_text(json.dumps(result, indent=1))
