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
