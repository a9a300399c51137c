"""Render the 3D-map lookup material with EEVEE (and Cycles) and record it beside
bake.atlas.shade evaluated at each pixel's own normal.

    python lookup_render.py REPO WORKDIR HDRI RESULT.json

A sphere under an orthographic camera (the view vector is +Z everywhere). Each
engine renders twice with identical settings: once the lookup material, once
an emission of the Geometry normal, so the comparison uses the normals the
engine itself shaded with.
"""

import json
import sys
from pathlib import Path

import numpy as np

repo, workdir, hdri, result_path = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3], sys.argv[4]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _ortho_sphere import ortho_sphere_scene  # noqa: E402
from glossy.bake import atlas, envmap, exr, prefilter  # noqa: E402
from glossy.glossy_addon.nodes import build_lookup, load_atlas  # noqa: E402
from glossy.glossy_addon.scenes import exact_cycles  # noqa: E402

forest, _ = exr.read(hdri)
probe = envmap.convert(forest, "latlong", "cube", 24)
baked = prefilter.prefilter(probe, "ggx:roughness=0.5", "3d", 16, slices=5)
image_data, meta = atlas.pack(baked)
atlas_path = workdir / "atlas.exr"
exr.write(atlas_path, image_data, meta)

scene, sphere = ortho_sphere_scene(64)

lookup = bpy.data.materials.new("lookup")
build_lookup(lookup, load_atlas(atlas_path), meta)
normals = bpy.data.materials.new("normals")
normals.use_nodes = True
tree = normals.node_tree
tree.nodes.clear()
geometry = tree.nodes.new("ShaderNodeNewGeometry")
encode = tree.nodes.new("ShaderNodeVectorMath")  # colours clamp negatives: store n / 2 + 1/2
encode.operation = "MULTIPLY_ADD"
encode.inputs[1].default_value = (0.5, 0.5, 0.5)
encode.inputs[2].default_value = (0.5, 0.5, 0.5)
emission = tree.nodes.new("ShaderNodeEmission")
output = tree.nodes.new("ShaderNodeOutputMaterial")
tree.links.new(geometry.outputs["Normal"], encode.inputs[0])
tree.links.new(encode.outputs["Vector"], emission.inputs["Color"])
tree.links.new(emission.outputs[0], output.inputs["Surface"])
sphere.data.materials.append(lookup)

report = {}
for engine in ("BLENDER_EEVEE", "CYCLES"):
    scene.render.engine = engine
    if engine == "CYCLES":
        exact_cycles(scene, 1)
    else:
        scene.eevee.taa_render_samples = 1
    renders = {}
    for name, material in (("lookup", lookup), ("normal", normals)):
        sphere.data.materials[0] = material
        scene.render.filepath = str(workdir / f"{engine}_{name}.exr")
        bpy.ops.render.render(write_still=True)
        renders[name] = exr.read(scene.render.filepath)[0][..., :3]
    n = renders["normal"].astype(np.float64) * 2.0 - 1.0
    length = np.linalg.norm(n, axis=-1)
    on_sphere = (np.abs(length - 1.0) < 0.01) & (n[..., 2] > 0.05)
    predicted = atlas.shade(image_data, meta, n[on_sphere], np.array([0.0, 0.0, 1.0]))
    rendered = renders["lookup"][on_sphere]
    relative = np.abs(rendered - predicted) / np.maximum(np.abs(predicted), 1e-3)
    report[engine] = {"pixels": int(on_sphere.sum()),
                      "median": float(np.median(relative)),
                      "p95": float(np.percentile(relative, 95)),
                      "max": float(relative.max())}
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
