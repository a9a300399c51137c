"""Metallic BSDF materials captured, baked, attached and validated, as a user's script
drives it: both spheres selected, each operator called once.

    python validate_metallic.py HDRI WORKDIR RESULT.json

Two isolated spheres under World Only probes (64 px faces), each with a Metallic
BSDF read From Material: "F82" (F82 Tint, Multiscatter GGX, Roughness 0.3, an
Edge Tint, its Base Color from a Checker Texture of two colours far apart) and
"Gold" (Physical Conductor with gold's n and k, Multiscatter GGX, Roughness
0.25). Neither is in the other's reflections or shadows. Cycles 2 x 256 spp,
128 px, EEVEE 4 samples. Writes the steps, each sphere's figures, method and
spec, and the notes.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import isolated_sphere, validation_scene, whole_pipeline  # noqa: E402
from glossy.glossy_addon.material_source import parts  # noqa: E402

scene = validation_scene(hdri, workdir, 128)


def sphere(name, x):
    """(object, its material's tree, its Metallic BSDF node) of a new sphere."""
    obj = isolated_sphere(name, x)
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.remove(tree.nodes["Principled BSDF"])
    node = tree.nodes.new("ShaderNodeBsdfMetallic")
    tree.links.new(node.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    obj.data.materials.append(material)
    return obj, tree, node


f82, tree, node = sphere("F82", -1.25)
node.inputs["Roughness"].default_value = 0.3
node.inputs["Edge Tint"].default_value = (0.7, 0.85, 1.0, 1.0)
checker = tree.nodes.new("ShaderNodeTexChecker")
checker.inputs["Scale"].default_value = 5.0
checker.inputs["Color1"].default_value = (0.95, 0.55, 0.1, 1.0)
checker.inputs["Color2"].default_value = (0.05, 0.2, 0.6, 1.0)
tree.links.new(checker.outputs["Color"], node.inputs["Base Color"])
gold, _, node = sphere("Gold", 1.25)
node.fresnel_type = "PHYSICAL_CONDUCTOR"
node.inputs["Roughness"].default_value = 0.25
node.inputs["IOR"].default_value = (0.143, 0.374, 1.442)
node.inputs["Extinction"].default_value = (3.983, 2.385, 1.603)

steps, report = whole_pipeline([f82, gold], workdir)
result_path.write_text(json.dumps({
    "steps": steps, "notes": report["notes"],
    "figures": {entry["object"]: entry["figures"] for entry in report["objects"]},
    "methods": {obj.name: obj.data.materials[0].glossy.method_used() for obj in (f82, gold)},
    "specs": {obj.name: parts(obj.data.materials[0]).derived.spec for obj in (f82, gold)}}))
