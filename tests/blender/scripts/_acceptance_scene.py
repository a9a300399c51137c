"""#5's acceptance scene and its EEVEE views, shared by the bpy-module test
(scene_lookup.py) and the ``blender`` executable test (binary_*.py).

Runs inside Blender (the bpy module or the executable's own Python); needs
only bpy and the Glossy add-on's properties. The comparison with
bake.atlas.shade happens on the pytest side (tests/blender/lookup_check.py).
"""

import json
from pathlib import Path

import bpy
from mathutils import Vector

OBJECTS = ("Sphere", "Torus")


def eevee_engine():
    return "BLENDER_EEVEE" if bpy.app.version >= (5, 0, 0) else "BLENDER_EEVEE_NEXT"


def build(scenes_module, hdri, probe_resolution=32):
    """A sphere (GGX 0.3, two lobes, a Fresnel-blended diffuse part) and a torus
    (Ward 0.15, 2D lobe) over a plane, lit by ``hdri``, an orthographic camera;
    both objects and the camera selected. ``scenes_module`` is glossy_addon.scenes."""
    scene = bpy.context.scene
    scene.view_settings.view_transform = "Standard"
    scene.cycles.device = "CPU"
    scene.cycles.use_denoising = False
    scenes_module.environment_world(scene, hdri)
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
        material.glossy.method = "3d"  # the 3D map's lookup is what these views check
        obj.data.materials.append(material)
        obj.glossy.probe_resolution = probe_resolution
        obj.glossy.capture_samples = 8
    sphere.data.materials[0].glossy.diffuse = (0.3, 0.2, 0.1)  # a diffuse part,
    sphere.data.materials[0].glossy.fresnel_ior = 1.5  # blended by Fresnel (Heidrich 3.1.1)
    sphere.data.materials[0].glossy.lobes = 2  # a two-lobe fit: two lookups, summed
    torus.data.materials[0].glossy.method = "2d"  # 2D lobe + k(theta_o)

    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 5.5
    camera.location = (0.0, -6.0, 3.0)
    camera.rotation_euler = (-camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.collection.objects.link(camera)
    scene.camera = camera
    bpy.ops.object.select_all(action="DESELECT")
    sphere.select_set(True)
    torus.select_set(True)
    camera.select_set(True)  # a selection that is not all meshes, as a user's often is
    bpy.context.view_layer.objects.active = sphere
    return sphere, torus


def capture_bake_attach(objects):
    """What a user does next: capture probes for the selection, then bake and
    attach each object's materials; returns the operators' results by name."""
    report = {"capture": sorted(bpy.ops.glossy.capture_probes())}
    for obj in objects:
        bpy.ops.object.select_all(action="DESELECT")
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        report[obj.name] = [sorted(bpy.ops.glossy.bake_materials()),
                            sorted(bpy.ops.glossy.attach_materials())]
    return report


def _emission_material(name, color=None, encode_normal=False):
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


def render_views(workdir, size=96):
    """EEVEE renders of the attached scene into ``workdir``: lookup.exr (the
    Glossy materials), normals.exr (shading normal as n / 2 + 1/2) and ids.exr
    (sphere red, torus green); writes and returns views.json with the camera's
    view vector and each object's baked atlases. Replaces the materials."""
    workdir = Path(workdir)
    scene = bpy.context.scene
    scene.render.engine = eevee_engine()
    scene.eevee.taa_render_samples = 1
    scene.render.filter_size = 0.0
    render = scene.render
    render.resolution_x = render.resolution_y = size
    render.resolution_percentage = 100
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    scene.view_settings.view_transform = "Standard"
    objects = [bpy.data.objects[name] for name in OBJECTS]
    views = {"view": list(scene.camera.matrix_world.to_3x3() @ Vector((0.0, 0.0, 1.0))),
             "atlases": {}, "node_groups": {g.name: g.users for g in bpy.data.node_groups}}
    for obj in objects:
        settings = obj.data.materials[0].glossy
        views["atlases"][obj.name] = {
            "glossy": bpy.path.abspath(settings.bake_path),
            "diffuse": bpy.path.abspath(settings.diffuse_path) if settings.diffuse_path else "",
            "fresnel_ior": settings.fresnel_ior,
            "centre": list(obj.glossy.probe_centre),
            "origin": list(obj.matrix_world.translation),
            "probe": bpy.path.abspath(obj.glossy.probe_path),
            "bake": {"spec": settings.brdf_spec(), "method": settings.method,
                     "size": settings.chosen_size, "size_mode": settings.size_mode,
                     "max_size": settings.map_size, "size_reason": settings.size_reason,
                     "slices": settings.slices,
                     "lobes": settings.lobes if settings.method == "3d" else 1},
        }

    def shoot(name):
        scene.render.filepath = str(workdir / f"{name}.exr")
        bpy.ops.render.render(write_still=True)

    shoot("lookup")
    normal_material = _emission_material("normal", encode_normal=True)
    for obj in objects:
        obj.data.materials[0] = normal_material
    shoot("normals")
    for obj, color in zip(objects, ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), strict=True):
        obj.data.materials[0] = _emission_material(f"id_{obj.name}", color)
    shoot("ids")
    (workdir / "views.json").write_text(json.dumps(views, indent=1))
    return views
