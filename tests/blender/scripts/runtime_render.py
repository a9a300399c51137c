"""Render the runtime-sampling material with EEVEE and record it beside
bake.sampling_runtime.shade evaluated at each pixel's own normal and tangent.

    python runtime_render.py REPO WORKDIR HDRI SPEC [lights] RESULT.json

With ``lights``, the probe's bright lights are taken out
(bake.probe_lights) and four more lights are added, so the exact light term
(a loop over the lights' atlas texels) is part of what is compared.

A sphere under an orthographic camera (view +Z everywhere), its tangent
Blender's radial one about Z. Three renders with identical settings: the
lookup, an emission of the Geometry normal and one of the Tangent node's
output, so the twin is evaluated at the vectors EEVEE shaded with (half floats).
"""

import json
import sys
from pathlib import Path

import numpy as np

repo, workdir, hdri, spec, result_path = (Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3],
                                          sys.argv[4], sys.argv[-1])
with_lights = sys.argv[5:-1] == ["lights"]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _ortho_sphere import eevee_renders, emission_material, ortho_sphere_scene  # noqa: E402
from glossy.bake import envmap, exr, probe_lights, sampling_runtime  # noqa: E402
from glossy.glossy_addon.nodes import load_atlas  # noqa: E402
from glossy.glossy_addon.sampling_nodes import build_runtime  # noqa: E402

environment, _ = exr.read(hdri)
probe = envmap.convert(environment, "latlong", "cube", 16)
lights = []
if with_lights:
    probe, lights = probe_lights.extract_for(probe, "cube", 0.09)
    # Lights seen in highlights by the +Z view, as small lights and tiles are: the
    # nodes loop over them, reading each from the atlas.
    for k, (x, y) in enumerate(((0.35, -0.2), (-0.3, 0.25), (0.1, 0.4), (-0.15, -0.35))):
        direction = np.array([x, y, 0.9])
        lights.append(probe_lights.Light(direction / np.linalg.norm(direction),
                                         np.array([3.0, 2.0, 1.0]) / (1 + k), 1e-3,
                                         0.03 * k, tile=k > 1))
image_data, meta = sampling_runtime.pack(probe, spec, lights=lights)
atlas_path = workdir / "runtime.exr"
exr.write(atlas_path, image_data, meta)

scene, sphere = ortho_sphere_scene(48)

lookup = bpy.data.materials.new("lookup")
build_runtime(lookup, load_atlas(atlas_path), meta, ("RADIAL", "Z"))
# The same lobe at the largest budget: the graph must not grow with the samples.
large_data, large_meta = sampling_runtime.pack(probe, spec, budget=64)
exr.write(workdir / "large.exr", large_data, large_meta)
large = build_runtime(bpy.data.materials.new("large"), load_atlas(workdir / "large.exr"),
                      large_meta, ("RADIAL", "Z"))
graphs = {name: {"nodes": len(material.node_tree.nodes), "samples": len(m["prob"]),
                 "iterations": sorted(n.inputs["Iterations"].default_value
                                      for n in material.node_tree.nodes
                                      if n.bl_idname == "GeometryNodeRepeatInput")}
          for name, material, m in (("budget", lookup, meta), ("large", large, large_meta))}


def radial(tree):
    node = tree.nodes.new("ShaderNodeTangent")
    node.direction_type, node.axis = "RADIAL", "Z"
    return node.outputs["Tangent"]


normals = emission_material(
    "normals", lambda tree: tree.nodes.new("ShaderNodeNewGeometry").outputs["Normal"])
tangents = emission_material("tangents", radial)
# EEVEE: the material is its target (Cycles' SVM runs out of stack space on
# graphs of this many live values; Cycles renders the true BSDF instead).
renders = eevee_renders(scene, sphere, workdir, {"lookup": lookup, "normal": normals,
                                                 "tangent": tangents})
n = renders["normal"] * 2.0 - 1.0
t = renders["tangent"] * 2.0 - 1.0
on_sphere = (np.abs(np.linalg.norm(n, axis=-1) - 1.0) < 0.01) & (n[..., 2] > 0.05)
on_sphere &= np.abs(np.linalg.norm(t, axis=-1) - 1.0) < 0.01
views = np.broadcast_to([0.0, 0.0, 1.0], n[on_sphere].shape)
predicted = sampling_runtime.shade(image_data, meta, n[on_sphere], views, t[on_sphere])
unlit = sampling_runtime.shade(image_data, {**meta, "lights": []}, n[on_sphere], views,
                               t[on_sphere])
rendered = renders["lookup"][on_sphere]
relative = np.abs(rendered - predicted) / np.maximum(np.abs(predicted), 1e-3)
with open(result_path, "w") as handle:
    json.dump({"pixels": int(on_sphere.sum()), "median": float(np.median(relative)),
               "p99": float(np.percentile(relative, 99)), "max": float(relative.max()),
               "mean_value": float(np.mean(predicted)), "graphs": graphs,
               "lights": len(lights), "first_level": int(meta.get("first_level", 0)),
               "slice_height": int(meta["slice_height"]),
               "light_share": float(1.0 - np.mean(unlit) / np.mean(predicted)),
               "light_peak": float(np.max((predicted - unlit) @ [0.2126, 0.7152, 0.0722]))},
              handle, indent=1)
