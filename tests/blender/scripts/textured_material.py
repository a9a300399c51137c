"""A textured Principled material on Suzanne, From Material, against Cycles.

    python textured_material.py HDRI WORKDIR [metal] RESULT.json

Two Suzannes (subdivided once, smooth) with a user's Principled plastic
(MULTI_GGX, metallic 0): "Textured" has an image texture on Base Color, a
tangent-space normal map through a Normal Map node, and a roughness texture
from 0.2 to 0.6; "Plain" has the textures' means and no normal map. Each is
captured (World Only), baked, attached and validated alone (the other hidden
from renders), and the report's relative RMS errors of EEVEE with Glossy and
of native EEVEE against Cycles are recorded. The roughness blend's own error:
maps baked at the geometric midpoints between neighbouring knots, against
the geometric blend of the knots' maps, on an orthographic sphere.

"metal": the same with Metallic 1, a base colour of gold and dark-iron
stripes (a texture the F82 Fresnel is far from linear in: maps at base colours
0 and 1 per roughness knot, bake.colour_response) and roughness from 0.28 to
0.4 (three knots); the blend-error part is skipped.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
METAL = "metal" in sys.argv[3:-1]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from _operators import (  # noqa: E402
    errors,
    shader_material,
    validate_each,
    validation_scene,
    world_probe,
)
from glossy.bake import exr, prefilter  # noqa: E402
from glossy.glossy_addon.material_source import parts  # noqa: E402

SIZE = 64
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])

validation_scene(hdri, workdir, 80, reference=False)  # only the figures against Cycles
result = {}

# --- the user's textures (64 x 64, tiled over Suzanne's UVs) -------------------------------
u, v = np.meshgrid((np.arange(SIZE) + 0.5) / SIZE, (np.arange(SIZE) + 0.5) / SIZE)
stripes = 0.5 + 0.5 * np.sin(2 * np.pi * 3 * u)
low_colour, high_colour = ((0.08, 0.08, 0.09), (1.0, 0.77, 0.34)) if METAL else \
    ((0.8, 0.25, 0.1), (0.1, 0.35, 0.8))
colour = (1 - stripes)[..., None] * np.array(low_colour) + \
    stripes[..., None] * np.array(high_colour)
low_roughness, high_roughness = (0.28, 0.4) if METAL else (0.2, 0.6)
roughness = low_roughness + (high_roughness - low_roughness) * \
    (0.5 + 0.5 * np.sin(2 * np.pi * 2 * v))
# A gentle bump: height 0.02 sin sin over a UV tile, its tangent-space normals.
k = 2 * np.pi * 4
dh_du = 0.02 * k * np.cos(k * u) * np.sin(k * v)
dh_dv = 0.02 * k * np.sin(k * u) * np.cos(k * v)
normal = np.stack([-dh_du, -dh_dv, np.ones_like(u)], -1)
normal /= np.linalg.norm(normal, axis=-1, keepdims=True)


def image(name, rgb, colour_space):
    """A packed image of (SIZE, SIZE, 3) values in [0, 1] (sRGB-encoded for "sRGB")."""
    picture = bpy.data.images.new(name, SIZE, SIZE, alpha=False)
    picture.colorspace_settings.name = colour_space
    if colour_space == "sRGB":
        rgb = np.where(rgb <= 0.0031308, rgb * 12.92, 1.055 * rgb ** (1 / 2.4) - 0.055)
    pixels = np.concatenate([rgb, np.ones((SIZE, SIZE, 1))], -1)
    picture.pixels.foreach_set(pixels.astype(np.float32).ravel())
    picture.pack()
    return picture


images = {"colour": image("colour", colour, "sRGB"),
          "normal": image("normal", 0.5 * normal + 0.5, "Non-Color"),
          "roughness": image("roughness", np.repeat(roughness[..., None], 3, -1), "Non-Color")}


def principled_material(name, textured):
    material, tree, bsdf = shader_material(name)
    if textured:
        for key, socket in (("colour", "Base Color"), ("roughness", "Roughness")):
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = images[key]
            tree.links.new(node.outputs["Color"], bsdf.inputs[socket])
        node = tree.nodes.new("ShaderNodeTexImage")
        node.image = images["normal"]
        normal_map = tree.nodes.new("ShaderNodeNormalMap")
        tree.links.new(node.outputs["Color"], normal_map.inputs["Color"])
        tree.links.new(normal_map.outputs["Normal"], bsdf.inputs["Normal"])
    else:
        bsdf.inputs["Base Color"].default_value = (*colour.reshape(-1, 3).mean(0), 1.0)
        bsdf.inputs["Roughness"].default_value = float(roughness.mean())
    if METAL:
        bsdf.inputs["Metallic"].default_value = 1.0
    material.glossy.model = "MATERIAL"
    material.glossy.slices = 8
    return material


suzannes = {}
for index, name in enumerate(("Plain", "Textured")):
    bpy.ops.mesh.primitive_monkey_add(location=(4.0 * index, 0.0, 0.0), rotation=(0.3, 0.0, 0.4))
    obj = bpy.context.object
    obj.name = name
    obj.modifiers.new("subdivision", "SUBSURF").levels = 1
    obj.modifiers["subdivision"].render_levels = 1
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(principled_material(name, name == "Textured"))
    world_probe(obj, 64)
    suzannes[name] = obj


for name, (steps, figures) in validate_each(suzannes, workdir).items():
    material = suzannes[name].material_slots[0].material
    glossy_error, native_error = errors(figures)
    result[name] = {
        "steps": steps, "spec": material.glossy.brdf_spec(),
        "approximated": list(parts(material).derived.approximated),
        "glossy": glossy_error, "native": native_error, "noise": figures["cycles_noise"],
        "knots": sorted({r for r, _, _ in material.glossy.roughness_map_list()
                         if r is not None}),
        "colours": sorted({c for _, _, c in material.glossy.roughness_map_list()
                           if c is not None}),
        "maps": len(material.glossy.roughness_map_list()),
        "size_reason": material.glossy.size_reason,
        "user_nodes": sorted(n.bl_idname for n in material.node_tree.nodes
                             if not n.get("glossy_lookup")),
    }

if METAL:
    result_path.write_text(json.dumps(result, indent=1, default=str))
    sys.exit(0)

# --- the roughness blend's own error ------------------------------------------------------
textured = suzannes["Textured"].material_slots[0].material
probe, probe_meta = exr.read(bpy.path.abspath(suzannes["Textured"].glossy.probe_path))
layout = probe_meta.get("layout", "cube")
x = (np.arange(24) + 0.5) / 24 * 2 - 1
gx, gz = np.meshgrid(x, -x)
inside = gx**2 + gz**2 < 0.98
normals = np.stack([gx[inside], -np.sqrt(1 - gx[inside]**2 - gz[inside]**2), gz[inside]], -1)
views = np.broadcast_to([0.0, -1.0, 0.0], normals.shape)
knots = parts(textured).roughness_set
spec_of = dict(knots)
from glossy.glossy_addon.spatial import with_roughness  # noqa: E402


def shade(spec):
    baked = prefilter.prefilter(probe, spec, "3d", "auto", slices=8, layout=layout,
                                max_size=256)
    return baked.shade(normals, views)


errors = []
for (low, low_spec), (high, high_spec) in zip(knots[:-1], knots[1:], strict=True):
    middle = float(np.sqrt(low * high))
    truth = shade(with_roughness(low_spec, middle)) @ LUMINANCE
    blend = (np.maximum(shade(low_spec), 1e-6) ** 0.5 *
             np.maximum(shade(high_spec), 1e-6) ** 0.5) @ LUMINANCE
    errors.append([low, high, float(np.sqrt(np.mean((blend - truth) ** 2) /
                                            np.mean(truth**2)))])
result["blend_errors"] = errors
result_path.write_text(json.dumps(result, indent=1, default=str))
