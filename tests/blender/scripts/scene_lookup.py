"""The whole Blender path on a small scene, as #5's acceptance test describes it.

    python scene_lookup.py WORKDIR HDRI RESULT.json

A sphere (GGX 0.3) and a torus (Ward 0.15) over a plane, the world from a
bundled HDRI. Glossy captures a probe at both centres (Cycles renders, the
other objects visible), bakes both materials and attaches the lookups; EEVEE
renders the scene. Two more EEVEE renders of the same view give each pixel's
shading normal (encoded as n / 2 + 1/2) and which object it shows, so the
rendered radiance can be compared with bake.atlas.shade at exactly the normal
EEVEE shaded with and the orthographic camera's view vector.
"""

import json
import sys
from pathlib import Path

import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np
from glossy.bake import atlas, exr  # noqa: E402
from glossy.bake.brdf import fresnel  # noqa: E402
from glossy.glossy_addon.scenes import environment_world, float_exr_output  # noqa: E402
from mathutils import Vector  # noqa: E402

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
scene.view_settings.view_transform = "Standard"
scene.cycles.device = "CPU"
scene.cycles.use_denoising = False
environment_world(scene, hdri)

bpy.ops.mesh.primitive_plane_add(size=12.0, location=(0.0, 0.0, -1.2))
bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, location=(-1.3, 0.0, 0.0))
sphere = bpy.context.object
bpy.ops.object.shade_smooth()
bpy.ops.mesh.primitive_torus_add(location=(1.3, 0.0, 0.0), rotation=(1.1, 0.0, 0.3))
torus = bpy.context.object
bpy.ops.object.shade_smooth()
for obj, model, roughness in ((sphere, "ggx", 0.3), (torus, "ward", 0.15)):
    material = bpy.data.materials.new(f"{obj.name}_glossy")
    material.glossy.model = model
    material.glossy.roughness = roughness
    material.glossy.map_size = 32
    material.glossy.slices = 8
    obj.data.materials.append(material)
    obj.glossy.probe_resolution = 32
    obj.glossy.capture_samples = 8
sphere.data.materials[0].glossy.diffuse = (0.3, 0.2, 0.1)  # a diffuse part on the sphere,
sphere.data.materials[0].glossy.fresnel_ior = 1.5  # blended by Fresnel (Heidrich 3.1.1)
sphere.data.materials[0].glossy.lobes = 2  # a two-lobe fit: two lookups, summed
torus.data.materials[0].glossy.method = "2d"  # the torus uses the 2D lobe + k(theta_o)

camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
camera.data.type = "ORTHO"
camera.data.ortho_scale = 5.5
camera.location = (0.0, -6.0, 3.0)
camera.rotation_euler = (-camera.location).to_track_quat("-Z", "Y").to_euler()
scene.collection.objects.link(camera)
scene.camera = camera
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))

bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
torus.select_set(True)
report = {"capture": sorted(bpy.ops.glossy.capture_probes())}
report["centres"] = {o.name: [list(o.glossy.probe_centre), list(o.matrix_world.translation)]
                     for o in (sphere, torus)}
atlases = {}
for obj in (sphere, torus):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.glossy.bake_materials()
    bpy.ops.glossy.attach_materials()
    settings = obj.data.materials[0].glossy
    atlases[obj.name] = [exr.read(settings.bake_path)]
    if settings.diffuse_path:
        atlases[obj.name].append(exr.read(settings.diffuse_path))
report["node_groups"] = {group.name: group.users for group in bpy.data.node_groups}


def emission_material(name, color=None, encode_normal=False):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    if encode_normal:
        geometry = tree.nodes.new("ShaderNodeNewGeometry")
        encode = tree.nodes.new("ShaderNodeVectorMath")
        encode.operation = "MULTIPLY_ADD"
        encode.inputs[1].default_value = (0.5, 0.5, 0.5)
        encode.inputs[2].default_value = (0.5, 0.5, 0.5)
        tree.links.new(geometry.outputs["Normal"], encode.inputs[0])
        tree.links.new(encode.outputs["Vector"], emission.inputs["Color"])
    else:
        emission.inputs["Color"].default_value = (*color, 1.0)
    return material


scene.render.engine = "BLENDER_EEVEE"
scene.eevee.taa_render_samples = 1
scene.render.filter_size = 0.0
float_exr_output(scene, 96)


def render(name):
    scene.render.filepath = str(workdir / f"{name}.exr")
    bpy.ops.render.render(write_still=True)
    return exr.read(scene.render.filepath)[0][..., :3].astype(np.float64)


radiance = render("lookup")
looks = {obj.name: obj.data.materials[0] for obj in (sphere, torus)}
normal_material = emission_material("normal", encode_normal=True)
for obj in (sphere, torus):
    obj.data.materials[0] = normal_material
normals = render("normals") * 2.0 - 1.0
for obj, color in ((sphere, (1.0, 0.0, 0.0)), (torus, (0.0, 1.0, 0.0))):
    obj.data.materials[0] = emission_material(f"id_{obj.name}", color)
ids = render("ids")
view = np.array(camera.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0)))
for index, obj in enumerate((sphere, torus)):
    mask = (ids[..., index] > 0.99) & (ids[..., 1 - index] < 0.01)
    mask &= np.abs(np.linalg.norm(normals, axis=-1) - 1.0) < 0.01
    looked_up = [atlas.shade(image, meta, normals[mask], view) for image, meta in atlases[obj.name]]
    if len(looked_up) == 2:  # Fresnel blend, Heidrich 3.1.1, exact dielectric F(n.v)
        unit = normals[mask] / np.linalg.norm(normals[mask], axis=-1, keepdims=True)
        f = fresnel.dielectric(unit @ view, 1.5)[:, None]
        predicted = fresnel.blend(f, looked_up[0], looked_up[1])
    else:
        predicted = looked_up[0]
    report[f"{obj.name}_maps"] = len(atlases[obj.name])
    relative = np.abs(radiance[mask] - predicted) / np.maximum(np.abs(predicted), 1e-3)
    report[obj.name] = {"pixels": int(mask.sum()), "median": float(np.median(relative)),
                        "p95": float(np.percentile(relative, 95)),
                        "max": float(relative.max())}
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
