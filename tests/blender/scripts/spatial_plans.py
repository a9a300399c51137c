"""What the node reader applies per pixel, for single BSDFs and Mix / Add trees.

    python spatial_plans.py RESULT.json

Builds user materials (no render) and records, for each, the reader's
Derived.spatial (which inputs the lookup takes per pixel), its spec, its
approximated notes and the maps a bake would write (glossy_addon.spatial).
"""

import json
import sys
from pathlib import Path

result_path = Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np  # noqa: E402
from glossy.glossy_addon.material_source import parts  # noqa: E402
from glossy.glossy_addon.spatial import map_variants  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()


def image(name, values):
    """A packed 8 x 8 Non-Color image holding ``values`` (8, 8, 3) in [0, 1]."""
    picture = bpy.data.images.new(name, 8, 8, alpha=False)
    picture.colorspace_settings.name = "Non-Color"
    pixels = np.concatenate([values, np.ones((8, 8, 1))], -1)
    picture.pixels.foreach_set(pixels.astype(np.float32).ravel())
    picture.pack()
    return picture


ramp = np.linspace(0.2, 0.6, 8)
COLOUR = image("colour", np.stack([np.tile(ramp, (8, 1))] * 3, -1))
ROUGHNESS = image("roughness", np.stack([np.tile(ramp, (8, 1)).T] * 3, -1))


class Tree:
    """A material's node tree under construction, one Material Output."""

    def __init__(self, name):
        self.material = bpy.data.materials.new(name)
        self.material.use_nodes = True
        self.tree = self.material.node_tree
        self.tree.nodes.clear()
        self.output = self.tree.nodes.new("ShaderNodeOutputMaterial")
        self.normal_map = None

    def node(self, kind, **inputs):
        node = self.tree.nodes.new(kind)
        for name, value in inputs.items():
            if name == "distribution":
                node.distribution = value
            else:
                node.inputs[name].default_value = value
        return node

    def texture(self, node, input_name, picture=COLOUR):
        texture = self.tree.nodes.new("ShaderNodeTexImage")
        texture.image = picture
        self.tree.links.new(texture.outputs["Color"], node.inputs[input_name])

    def chain(self, node, input_name, colour):
        """An RGB node through a Gamma node (a node chain, not a constant)."""
        rgb = self.tree.nodes.new("ShaderNodeRGB")
        rgb.outputs[0].default_value = (*colour, 1.0)
        gamma = self.tree.nodes.new("ShaderNodeGamma")
        self.tree.links.new(rgb.outputs[0], gamma.inputs["Color"])
        self.tree.links.new(gamma.outputs[0], node.inputs[input_name])

    def normal(self, *nodes):
        if self.normal_map is None:
            self.normal_map = self.tree.nodes.new("ShaderNodeNormalMap")
        for node in nodes:
            self.tree.links.new(self.normal_map.outputs["Normal"], node.inputs["Normal"])

    def combine(self, kind, first, second, fac=0.5):
        node = self.tree.nodes.new(kind)
        if kind == "ShaderNodeMixShader":
            node.inputs["Fac"].default_value = fac
            self.tree.links.new(first.outputs[0], node.inputs[1])
            self.tree.links.new(second.outputs[0], node.inputs[2])
        else:
            self.tree.links.new(first.outputs[0], node.inputs[0])
            self.tree.links.new(second.outputs[0], node.inputs[1])
        return node

    def finish(self, top):
        self.tree.links.new(top.outputs[0], self.output.inputs["Surface"])
        self.material.glossy.model = "MATERIAL"
        return self.material


def mix_diffuse_glossy():
    t = Tree("Mix Diffuse Glossy")
    diffuse = t.node("ShaderNodeBsdfDiffuse")
    glossy_node = t.node("ShaderNodeBsdfGlossy", Roughness=0.3, distribution="GGX")
    t.texture(diffuse, "Color")
    t.normal(diffuse, glossy_node)
    return t.finish(t.combine("ShaderNodeMixShader", diffuse, glossy_node, 0.3))


def two_diffuse():
    t = Tree("Two Diffuse")
    textured = t.node("ShaderNodeBsdfDiffuse")
    t.texture(textured, "Color")
    plain = t.node("ShaderNodeBsdfDiffuse")
    glossy_node = t.node("ShaderNodeBsdfGlossy", Roughness=0.3, distribution="GGX")
    t.normal(textured)  # one BSDF only: not the lookup's normal
    inner = t.combine("ShaderNodeMixShader", textured, plain)
    return t.finish(t.combine("ShaderNodeAddShader", inner, glossy_node))


def add_rough_glossy():
    t = Tree("Add Rough Glossy")
    diffuse = t.node("ShaderNodeBsdfDiffuse")
    glossy_node = t.node("ShaderNodeBsdfGlossy", distribution="GGX")
    t.texture(glossy_node, "Roughness", ROUGHNESS)
    t.texture(glossy_node, "Color")
    return t.finish(t.combine("ShaderNodeAddShader", diffuse, glossy_node))


def glossy_over_plastic():
    t = Tree("Glossy Over Plastic")
    glossy_node = t.node("ShaderNodeBsdfGlossy", Roughness=0.2, distribution="GGX")
    t.texture(glossy_node, "Color")
    plastic = t.node("ShaderNodeBsdfPrincipled", Roughness=0.5)
    return t.finish(t.combine("ShaderNodeMixShader", plastic, glossy_node, 0.5))


def coated_metal():
    t = Tree("Coated Metal")
    metal = t.node("ShaderNodeBsdfPrincipled", Metallic=1.0, Roughness=0.3)
    metal.inputs["Coat Weight"].default_value = 1.0
    t.texture(metal, "Base Color")
    return t.finish(metal)


def tinted_plastic():
    t = Tree("Tinted Plastic")
    plastic = t.node("ShaderNodeBsdfPrincipled", Roughness=0.4)
    t.chain(plastic, "Specular Tint", (0.9, 0.5, 0.2))
    return t.finish(plastic)


def metal_colour_and_tint():
    t = Tree("Metal Colour And Tint")
    metal = t.node("ShaderNodeBsdfPrincipled", Metallic=1.0, Roughness=0.3)
    t.texture(metal, "Base Color")
    t.chain(metal, "Specular Tint", (0.9, 0.5, 0.2))
    return t.finish(metal)


def multiscatter_glossy():
    t = Tree("Multiscatter Glossy")
    glossy_node = t.node("ShaderNodeBsdfGlossy", Roughness=0.4, distribution="MULTI_GGX")
    t.texture(glossy_node, "Color")
    return t.finish(glossy_node)


def coat_tint_texture():
    t = Tree("Coat Tint Texture")
    plastic = t.node("ShaderNodeBsdfPrincipled", Roughness=0.4)
    plastic.inputs["Coat Weight"].default_value = 1.0
    t.texture(plastic, "Coat Tint")
    return t.finish(plastic)


#: A glTF importer's packed image: occlusion in R, roughness in G (0.3 / 0.5 on
#: alternate columns), metallic in B (0 on the first two rows, 1 below).
PACKED = image("packed", np.stack([np.ones((8, 8)), np.tile([0.3, 0.5] * 4, (8, 1)),
                                   np.repeat([0.0] * 2 + [1.0] * 6, 8).reshape(8, 8)], -1))


def gltf_packed():
    """As Blender's glTF importer builds a metallic-roughness material: one image's G
    and B channels into Roughness and Metallic through a Separate Color node."""
    t = Tree("glTF Packed")
    principled = t.node("ShaderNodeBsdfPrincipled")
    packed = t.tree.nodes.new("ShaderNodeTexImage")
    packed.image = PACKED
    separate = t.tree.nodes.new("ShaderNodeSeparateColor")
    t.tree.links.new(packed.outputs["Color"], separate.inputs["Color"])
    t.tree.links.new(separate.outputs["Green"], principled.inputs["Roughness"])
    t.tree.links.new(separate.outputs["Blue"], principled.inputs["Metallic"])
    return t.finish(principled)


result = {}
for build in (gltf_packed, coat_tint_texture, multiscatter_glossy, mix_diffuse_glossy, two_diffuse,
              add_rough_glossy, glossy_over_plastic, coated_metal, tinted_plastic,
              metal_colour_and_tint):
    material = build()
    found = parts(material)
    result[material.name] = {
        "spec": found.derived.spec,
        "spatial": found.derived.spatial,
        "approximated": found.derived.approximated,
        "ignored": found.derived.ignored,
        "maps": [[r, c] for r, c, _ in map_variants(found)],
    }
result_path.write_text(json.dumps(result, indent=1, default=str))
