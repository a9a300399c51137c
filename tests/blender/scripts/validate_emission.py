"""Emissive and glTF-style materials captured, baked, attached and validated, as a
user's script drives it (the user's own node tree kept): all spheres selected,
each operator called once.

    python validate_emission.py HDRI WORKDIR RESULT.json

Isolated spheres under World Only probes (64 px faces), read From Material:
"Panel" (a coated gold Principled BSDF, Roughness 0.3, Coat Weight 0.6 and
Coat Roughness 0.1, whose Emission Color comes from a Checker Texture at
Emission Strength 0.6: a glowing panel under lacquer) and "Rim" (a Mix Shader of
a red Emission shader of Strength 0.5 and a Principled plastic, its Fac a Fresnel
node of IOR 1.45: the glow 1 - F, strongest facing the camera, the plastic
F). A third, "Packed", is a metallic-roughness material as Blender's glTF
importer builds it (one image's G and B channels into Roughness and Metallic
through a Separate Color node); a fourth, "Cutout", a metal whose Alpha is a
checker mask; a fifth, "Masked", the older cut-out: a Mix Shader of a
Transparent BSDF and a glowing Principled metal by such a mask. Cycles 2 x 256
spp, 128 px, EEVEE 4 samples.
Then the Panel's unlinked Emission Strength is edited to 1.5: the panel's
check asks for a re-attach. Writes the steps, each sphere's figures, the
notes, the reader's lines about emission, the check before and after the edit
and what the attach recorded.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from _operators import (  # noqa: E402
    isolated_sphere,
    shader_material,
    validation_scene,
    whole_pipeline,
)
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.material_source import parts  # noqa: E402
from glossy.glossy_addon.nodes import lookup_nodes  # noqa: E402

if "without" in sys.argv[3:-1]:  # the lookup without the emission (the figures before)
    from glossy.operators import bake_materials

    plain = bake_materials.build_lookup
    bake_materials.build_lookup = lambda *a, **k: plain(*a, **{**k, "from_material": False})
scene = validation_scene(hdri, workdir, 128)



def checker(tree, scale, first):
    """A Checker Texture in ``tree`` of ``first`` (3,) and black at ``scale``."""
    node = tree.nodes.new("ShaderNodeTexChecker")
    node.inputs["Scale"].default_value = scale
    node.inputs["Color1"].default_value = (*first, 1.0)
    node.inputs["Color2"].default_value = (0.0, 0.0, 0.0, 1.0)
    return node


panel = isolated_sphere("Panel", -1.25)
material, tree, node = shader_material("Panel")
node.inputs["Base Color"].default_value = (0.95, 0.7, 0.3, 1.0)
node.inputs["Metallic"].default_value = 1.0
node.inputs["Roughness"].default_value = 0.3
node.inputs["Coat Weight"].default_value = 0.6
node.inputs["Coat Roughness"].default_value = 0.1
tree.links.new(checker(tree, 4.0, (0.1, 0.6, 1.0)).outputs["Color"],
               node.inputs["Emission Color"])
node.inputs["Emission Strength"].default_value = 0.6
panel.data.materials.append(material)

rim = isolated_sphere("Rim", 1.25)
material, tree, plastic = shader_material("Rim")
plastic.inputs["Base Color"].default_value = (0.2, 0.25, 0.3, 1.0)
plastic.inputs["Roughness"].default_value = 0.25
glow = tree.nodes.new("ShaderNodeEmission")
glow.inputs["Color"].default_value = (1.0, 0.1, 0.05, 1.0)
glow.inputs["Strength"].default_value = 0.5
mix = tree.nodes.new("ShaderNodeMixShader")
fresnel = tree.nodes.new("ShaderNodeFresnel")
fresnel.inputs["IOR"].default_value = 1.45
output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
tree.links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
tree.links.new(glow.outputs[0], mix.inputs[1])
tree.links.new(plastic.outputs[0], mix.inputs[2])
tree.links.new(mix.outputs[0], output.inputs["Surface"])
rim.data.materials.append(material)

# "Packed": a metallic-roughness material as Blender's glTF importer builds it:
# one Non-Color image's G (roughness 0.25 / 0.55 in stripes) and B (metallic 0 /
# 1 in bands) through a Separate Color node, a grey-blue Base Color.
packed = isolated_sphere("Packed", 3.75)
material, tree, node = shader_material("Packed")
node.inputs["Base Color"].default_value = (0.6, 0.65, 0.8, 1.0)
size = 64
column, row = np.meshgrid(np.arange(size), np.arange(size))
pixels = np.ones((size, size, 4), np.float32)
pixels[..., 1] = np.where((column // 8) % 2 == 0, 0.25, 0.55)
pixels[..., 2] = np.where((row // 16) % 2 == 0, 0.0, 1.0)
picture = bpy.data.images.new("packed", size, size, alpha=True, float_buffer=True)
picture.colorspace_settings.name = "Non-Color"
picture.pixels.foreach_set(pixels.ravel())
picture.pack()
texture = tree.nodes.new("ShaderNodeTexImage")
texture.image = picture
separate = tree.nodes.new("ShaderNodeSeparateColor")
tree.links.new(texture.outputs["Color"], separate.inputs["Color"])
tree.links.new(separate.outputs["Green"], node.inputs["Roughness"])
tree.links.new(separate.outputs["Blue"], node.inputs["Metallic"])
packed.data.materials.append(material)


def masked_metal(name, x, colour):
    """(sphere, its material's tree, its Principled metal at Roughness 0.3, a mask:
    the Greater Than 0.5 of a Checker Texture, as a glTF importer's alpha mask)."""
    obj = isolated_sphere(name, x)
    material, tree, node = shader_material(name)
    node.inputs["Base Color"].default_value = (*colour, 1.0)
    node.inputs["Metallic"].default_value = 1.0
    node.inputs["Roughness"].default_value = 0.3
    greater = tree.nodes.new("ShaderNodeMath")
    greater.operation = "GREATER_THAN"
    greater.inputs[1].default_value = 0.5
    tree.links.new(checker(tree, 3.0, (1.0, 1.0, 1.0)).outputs["Fac"], greater.inputs[0])
    obj.data.materials.append(material)
    return obj, tree, node, greater.outputs[0]


# "Cutout": a metal whose Alpha is the mask: its holes show the inside of the sphere.
cutout, tree, node, mask = masked_metal("Cutout", 6.25, (0.9, 0.5, 0.3))
tree.links.new(mask, node.inputs["Alpha"])

# "Masked": the older cut-out, a Mix Shader of a Transparent BSDF and a glowing
# metal by the same kind of mask (the emission is to be weighted by the mask
# once, by the lookup's final mix).
masked, tree, node, mask = masked_metal("Masked", 8.75, (0.5, 0.6, 0.9))
node.inputs["Emission Color"].default_value = (1.0, 0.5, 0.1, 1.0)
node.inputs["Emission Strength"].default_value = 0.3
output = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial")
hole = tree.nodes.new("ShaderNodeBsdfTransparent")
cut = tree.nodes.new("ShaderNodeMixShader")
tree.links.new(mask, cut.inputs["Fac"])
tree.links.new(hole.outputs[0], cut.inputs[1])
tree.links.new(node.outputs[0], cut.inputs[2])
tree.links.new(cut.outputs[0], output.inputs["Surface"])

# Two rows (3 over 2), so the framing camera sees each sphere about as large as
# three in a row.
for obj, location in ((panel, (-2.5, 0.0, 1.25)), (rim, (0.0, 0.0, 1.25)),
                      (packed, (2.5, 0.0, 1.25)), (cutout, (-1.25, 0.0, -1.25)),
                      (masked, (1.25, 0.0, -1.25))):
    obj.location = location
steps, report = whole_pipeline([panel, rim, packed, cutout, masked], workdir)
masked_material = masked.data.materials[0]
mask_links = sorted(link.to_node.bl_idname for link in mask.links
                    if link.to_node.get("glossy_lookup"))
masked_lines = [line for line in parts(masked_material).derived.approximated
                + parts(masked_material).derived.ignored if "Transparent" in line]
masked_spec = parts(masked_material).derived.spec

# An edit of the unlinked strength: the panel's check asks for a re-attach.
from glossy.glossy_addon.emission import emission_changed  # noqa: E402

material = panel.data.materials[0]
changed_before = emission_changed(material)
material.node_tree.nodes["Principled BSDF"].inputs["Emission Strength"].default_value = 1.5
changed_after = emission_changed(material)
cutout_material = cutout.data.materials[0]
alpha_lines = [line for line in parts(cutout_material).derived.approximated
               + parts(cutout_material).derived.ignored if "lpha" in line]
alpha_changed = [emission_changed(cutout_material)]
cutout_material.node_tree.links.remove(
    cutout_material.node_tree.nodes["Principled BSDF"].inputs["Alpha"].links[0])
alpha_changed.append(emission_changed(cutout_material))  # now an unlinked 1
result_path.write_text(json.dumps({
    "steps": steps, "notes": report["notes"],
    "figures": {entry["object"]: entry["figures"] for entry in report["objects"]},
    "lines": {obj.name: [line for line in parts(obj.data.materials[0]).derived.approximated
                         + parts(obj.data.materials[0]).derived.ignored
                         if "mission" in line] for obj in (panel, rim)},
    "alpha": alpha_lines,
    "mask_links": mask_links, "masked_lines": masked_lines, "masked_spec": masked_spec,
    "spatial": sorted(parts(packed.data.materials[0]).derived.spatial),
    "packed_bake": {"method": packed.data.materials[0].glossy.method_used(),
                    "lights_path": packed.data.materials[0].glossy.runtime_path,
                    "lights_precision": exr.read_meta(
                        packed.data.materials[0].glossy.runtime_path).get("precision"),
                    "reason": packed.data.materials[0].glossy.size_reason,
                    "groups": sorted({node.node_tree.name for node in
                                      lookup_nodes(packed.data.materials[0])
                                      if node.bl_idname == "ShaderNodeGroup"})},
    "changed": [changed_before, changed_after],
    "alpha_changed": alpha_changed,
    "cutout_set": json.loads(cutout_material.glossy.emission_set),
    "emission_set": json.loads(material.glossy.emission_set)}))
