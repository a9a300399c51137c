"""Small helpers the Blender test scripts share: running an operator as a user's
script does, giving an object a World Only probe, and a one-shader material."""

import bpy


def run(operator, **kwargs):
    """(sorted result set, "") or (["CANCELLED"], the ERROR report) of an operator
    called headless (background mode raises an operator's ERROR as RuntimeError)."""
    try:
        return sorted(operator(**kwargs)), ""
    except RuntimeError as error:
        return ["CANCELLED"], str(error).strip()


def world_probe(obj, resolution=16):
    """Capture ``obj``'s probe from the world image alone, at a fixed face size."""
    obj.glossy.probe_source = "WORLD"
    obj.glossy.probe_size_mode = "FIXED"
    obj.glossy.probe_resolution = resolution


def shader_material(name, shader="ShaderNodeBsdfPrincipled"):
    """(material, its tree, the shader node): one shader into a Material Output."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    node = tree.nodes.new(shader)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    return material, tree, node
