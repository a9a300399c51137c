"""The Blender tests' sphere scenes: a smooth unit sphere at the origin and an
orthographic camera."""

import bpy
from glossy.glossy_addon.scenes import float_exr_output


def add_sphere_and_camera(scene, segments=64, rings=32, ortho_scale=2.4,
                          location=(0.0, 0.0, 5.0), rotation=(0.0, 0.0, 0.0)):
    """Add the sphere (segments x rings, smooth) and an orthographic camera at
    ``location`` turned by Euler ``rotation`` (radians); returns the sphere."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0)
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    camera_data = bpy.data.cameras.new("camera")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = ortho_scale
    camera = bpy.data.objects.new("camera", camera_data)
    camera.location = location
    camera.rotation_euler = rotation
    scene.collection.objects.link(camera)
    scene.camera = camera
    return sphere


def ortho_sphere_scene(size):
    """The lookup tests' scene: the file emptied, the camera looking down -Z (the
    view vector is +Z everywhere), size x size float EXR; returns (scene, sphere)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    float_exr_output(scene, size)
    scene.render.film_transparent = False
    scene.render.filter_size = 0.0
    return scene, add_sphere_and_camera(scene)


def emission_material(name, socket_of, encode=True):
    """A material emitting the socket ``socket_of(tree)`` makes: with ``encode`` a
    vector normalised and encoded as v / 2 + 1/2 (colours clamp negatives), else
    the value as it is (a roughness)."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    source = socket_of(tree)
    if encode:
        unit = tree.nodes.new("ShaderNodeVectorMath")
        unit.operation = "NORMALIZE"
        node = tree.nodes.new("ShaderNodeVectorMath")
        node.operation = "MULTIPLY_ADD"
        node.inputs[1].default_value = node.inputs[2].default_value = (0.5, 0.5, 0.5)
        tree.links.new(source, unit.inputs[0])
        tree.links.new(unit.outputs["Vector"], node.inputs[0])
        source = node.outputs["Vector"]
    emission = tree.nodes.new("ShaderNodeEmission")
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(source, emission.inputs["Color"])
    tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return material


def eevee_renders(scene, sphere, workdir, materials):
    """{name: (H, W, 3) float64} of EEVEE renders (1 sample) of ``sphere`` with each
    material of ``materials`` ({name: material}), written to workdir/<name>.exr."""
    import numpy as np
    from glossy.bake import exr

    if not sphere.data.materials:
        sphere.data.materials.append(None)
    scene.render.engine = "BLENDER_EEVEE"
    scene.eevee.taa_render_samples = 1
    # As validation and captures do: shadow maps only where a light casts a shadow
    # (identical pixels otherwise: tests/blender/test_eevee_shadows.py).
    from glossy.glossy_addon.scenes import casts_shadows
    scene.eevee.use_shadows = scene.eevee.use_shadows and casts_shadows(scene)
    renders = {}
    for name, material in materials.items():
        sphere.data.materials[0] = material
        scene.render.filepath = str(workdir / f"{name}.exr")
        bpy.ops.render.render(write_still=True)
        renders[name] = exr.read(scene.render.filepath)[0][..., :3].astype(np.float64)
    return renders
