"""glossy.validate on materials with a Base Color texture, as a user's script drives it.

    python validate_textured.py HDRI WORKDIR RESULT.json

Four isolated spheres under a World Only probe (64 px faces): "Metal" (a
Principled metal, Roughness 0.3) and "Plastic" (a Principled dielectric,
Roughness 0.3), each with its Base Color from a Checker Texture of two
colours far apart (what a single value cannot stand for), and "Bumpy" (the
metal in one colour, its Normal from a Bump node over a Noise Texture), read
From Material, and "Rough" (the checker metal with its Roughness from an image
of four bands, 0.15-0.5). Plastic's upper half has a second material, "Red metal" (GGX
0.3): the reference shades each face with its own. Neither sphere is in
the other's reflections or shadows (ray visibility, as
tests/blender/scripts/validate_scene.py). Cycles 2 x 256 spp, 128 px, EEVEE 4
samples. Writes each sphere's figures and the notes.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import (  # noqa: E402
    checker_into,
    isolated_sphere,
    roughness_image,
    shader_material,
    validation_scene,
)

scene = validation_scene(hdri, workdir, 128)


def sphere(name, x, metallic, bump=False, rough=False):
    obj = isolated_sphere(name, x)
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    principled = tree.nodes["Principled BSDF"]
    principled.inputs["Metallic"].default_value = metallic
    principled.inputs["Roughness"].default_value = 0.3
    if bump:  # a plain colour, the normal from a Bump node over a Noise Texture
        principled.inputs["Base Color"].default_value = (0.9, 0.75, 0.6, 1.0)
        noise = tree.nodes.new("ShaderNodeTexNoise")
        noise.inputs["Scale"].default_value = 2.0
        noise.inputs["Detail"].default_value = 0.0
        relief = tree.nodes.new("ShaderNodeBump")
        relief.inputs["Strength"].default_value = 1.0
        relief.inputs["Distance"].default_value = 0.5
        tree.links.new(noise.outputs["Fac"], relief.inputs["Height"])
        tree.links.new(relief.outputs["Normal"], principled.inputs["Normal"])
        # A Roughness through a Math node (0.3 + 0: the socket's own value), which
        # Glossy and the reference take at the unlinked value, and say so.
        same = tree.nodes.new("ShaderNodeMath")
        same.inputs[0].default_value, same.inputs[1].default_value = 0.3, 0.0
        tree.links.new(same.outputs[0], principled.inputs["Roughness"])
    else:
        checker_into(tree, principled.inputs["Base Color"])
    if rough:  # and the roughness from an image, as a PBR texture set has it
        texture = tree.nodes.new("ShaderNodeTexImage")
        texture.image = roughness_image()
        tree.links.new(texture.outputs["Color"], principled.inputs["Roughness"])
        # Its 16 maps (8 roughness knots x 2 colours) at Auto up to 128 rows, not the
        # default 384: the test checks the reference and the method, not this map's
        # figure, and the narrow knots at 384 rows took 60% of the script's time.
        material.glossy.map_size = 128
    obj.data.materials.append(material)
    return obj


spheres = [sphere("Metal", -3.75, 1.0), sphere("Plastic", -1.25, 0.0),
           sphere("Bumpy", 1.25, 1.0, bump=True), sphere("Rough", 3.75, 1.0, rough=True)]
# Two materials on one mesh: Plastic's upper half a red GGX 0.3 metal of its own.
upper, _, red = shader_material("Red metal")
for name, value in (("Base Color", (0.9, 0.2, 0.15, 1.0)), ("Metallic", 1.0),
                    ("Roughness", 0.3)):
    red.inputs[name].default_value = value
plastic = spheres[1]
plastic.data.materials.append(upper)
for polygon in plastic.data.polygons:
    polygon.material_index = 1 if polygon.center.z > 0.0 else 0
steps = {}
for obj in spheres:
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    for name, operator in (("capture", bpy.ops.glossy.capture_probes),
                           ("bake", bpy.ops.glossy.bake_materials),
                           ("attach", bpy.ops.glossy.attach_materials)):
        steps[f"{obj.name} {name}"] = sorted(operator())
for obj in spheres:
    obj.select_set(True)
steps["validate"] = sorted(bpy.ops.glossy.validate())
folder = workdir / "glossy" / "validation"
report = json.loads((folder / "report.json").read_text())
result_path.write_text(json.dumps({
    "steps": steps, "notes": report["notes"], "folder": str(folder),
    "figures": {entry["object"]: entry["figures"] for entry in report["objects"]},
    "methods": {obj.name: obj.data.materials[0].glossy.method_used() for obj in spheres}}))
