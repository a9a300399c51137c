"""Render a lookup of maps at two roughness knots with the probe lights beside them
(bake.knot_lights) in EEVEE, and record it beside its NumPy twin.

    python knot_lights_render.py WORKDIR HDRI RESULT.json

The user's material: a Principled BSDF whose Roughness is 0.2-0.6 across the
sphere (Geometry Normal X through a Map Range), so the pixels span both knots
(0.3, 0.5) and beyond them (the maps clamp, the lights do not). The probe's
lights are taken out (bake.probe_lights) and four more added, of several
extents, so the loop over the lights' texels at a per-pixel alpha is what is
compared. Renders: the lookup, an emission of the Geometry normal and one of
the roughness chain, so the twin is evaluated at what EEVEE shaded with (half
floats). The twin: per knot k the 3D map's lookup (bake.atlas.shade) plus
bake.knot_lights.shade at the pixel's roughness, blended as
glossy_addon.nodes._roughness_blend does (geometric, t linear in log r).
"""

import json
import sys
from pathlib import Path

import numpy as np

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[-1]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _ortho_sphere import eevee_renders, emission_material, ortho_sphere_scene  # noqa: E402
from glossy.bake import atlas, envmap, exr, knot_lights, prefilter, probe_lights  # noqa: E402
from glossy.glossy_addon.nodes import (  # noqa: E402
    GEOMETRIC_FLOOR,
    PART_TAG,
    build_lookup,
    load_atlas,
)

KNOTS = (0.3, 0.5)
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def spec(roughness):
    return f"principled:roughness={roughness},metallic=1,base_color=0.9/0.6/0.3"


environment, _ = exr.read(hdri)
probe = envmap.convert(environment, "latlong", "cube", 32)
probe, lights = probe_lights.extract_for(probe, "cube", knot_lights.light_alpha(KNOTS[0]))
for k, (x, y) in enumerate(((0.35, -0.2), (-0.3, 0.25), (0.1, 0.4), (-0.15, -0.35))):
    direction = np.array([x, y, 0.9])
    lights.append(probe_lights.Light(direction / np.linalg.norm(direction),
                                     np.array([3.0, 2.0, 1.0]) / (1 + k), 1e-3, 0.03 * k,
                                     tile=k > 1))
maps = []
for index, knot in enumerate(KNOTS):
    data, meta = atlas.pack(prefilter.prefilter(probe, spec(knot), "3d", 32))
    exr.write(workdir / f"knot{index}.exr", data, meta)
    maps.append((data, meta))
light_data, light_meta = knot_lights.pack(lights, [(r, None, spec(r)) for r in KNOTS])
exr.write(workdir / "lights.exr", light_data, light_meta)

scene, sphere = ortho_sphere_scene(48)


def roughness_chain(tree):
    """Roughness 0.2-0.6 from the Geometry normal's X: the user's node chain."""
    geometry = tree.nodes.new("ShaderNodeNewGeometry")
    separate = tree.nodes.new("ShaderNodeSeparateXYZ")
    ranged = tree.nodes.new("ShaderNodeMapRange")
    ranged.inputs["From Min"].default_value, ranged.inputs["From Max"].default_value = -1, 1
    ranged.inputs["To Min"].default_value, ranged.inputs["To Max"].default_value = 0.2, 0.6
    tree.links.new(geometry.outputs["Normal"], separate.inputs["Vector"])
    tree.links.new(separate.outputs["X"], ranged.inputs["Value"])
    return ranged.outputs["Result"]


lookup = bpy.data.materials.new("lookup")
lookup.use_nodes = True
principled = lookup.node_tree.nodes["Principled BSDF"]
socket = roughness_chain(lookup.node_tree)
lookup.node_tree.links.new(socket, principled.inputs["Roughness"])
build_lookup(lookup, None, None, roughness_maps=(socket, [
    (knot, None, load_atlas(workdir / f"knot{index}.exr"), maps[index][1])
    for index, knot in enumerate(KNOTS)]),
    knot_lights=(load_atlas(workdir / "lights.exr"), light_meta))


normals = emission_material(
    "normals", lambda tree: tree.nodes.new("ShaderNodeNewGeometry").outputs["Normal"])
roughness = emission_material("roughness", roughness_chain, encode=False)
renders = eevee_renders(scene, sphere, workdir, {"lookup": lookup, "normal": normals,
                                                 "roughness": roughness})
n = renders["normal"] * 2.0 - 1.0
on_sphere = (np.abs(np.linalg.norm(n, axis=-1) - 1.0) < 0.01) & (n[..., 2] > 0.05)
n = n[on_sphere]
r = renders["roughness"][on_sphere][:, 0]
views = np.broadcast_to([0.0, 0.0, 1.0], n.shape)
values, unlit = [], []
for index in range(len(KNOTS)):
    environment_value = atlas.shade(*maps[index], n, views)
    unlit.append(environment_value)
    values.append(environment_value + knot_lights.shade(light_data, light_meta, n, views, r,
                                                        index))


def blend(parts):
    t = np.clip(np.log(np.clip(r, *KNOTS) / KNOTS[0]) / np.log(KNOTS[1] / KNOTS[0]), 0, 1)
    low, high = (np.maximum(part, GEOMETRIC_FLOOR) for part in parts)
    return low ** (1.0 - t[:, None]) * high ** t[:, None]


predicted, without = blend(values), blend(unlit)
rendered = renders["lookup"][on_sphere]
relative = np.abs(rendered - predicted) / np.maximum(np.abs(predicted), 1e-3)
with open(result_path, "w") as handle:
    json.dump({"parts": [len(group.nodes) for group in bpy.data.node_groups
                         if group.get(PART_TAG)],
               "root": len(lookup.node_tree.nodes),
               "pixels": int(on_sphere.sum()), "median": float(np.median(relative)),
               "p99": float(np.percentile(relative, 99)), "max": float(relative.max()),
               "lights": len(lights), "roughness": [float(r.min()), float(r.max())],
               "light_share": float(1.0 - np.mean(without) / np.mean(predicted)),
               "light_peak": float(np.max((predicted - without) @ LUMINANCE))},
              handle, indent=1)
