"""The lookup tests' scene: a smooth unit sphere under an orthographic camera
looking down -Z (the view vector is +Z everywhere), rendered to float EXR."""

import bpy
from glossy.glossy_addon.scenes import float_exr_output


def ortho_sphere_scene(size):
    """Empty the file, build the scene at size x size pixels; returns (scene, sphere)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    float_exr_output(scene, size)
    scene.render.film_transparent = False
    scene.render.filter_size = 0.0
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
    sphere = bpy.context.object
    bpy.ops.object.shade_smooth()
    camera_data = bpy.data.cameras.new("ortho")
    camera_data.type = "ORTHO"
    camera_data.ortho_scale = 2.4
    camera = bpy.data.objects.new("ortho", camera_data)
    camera.location = (0.0, 0.0, 5.0)
    scene.collection.objects.link(camera)
    scene.camera = camera
    return scene, sphere
