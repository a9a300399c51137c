"""Scene set-up that scripts, tests, benchmarks and the demo share.

Small and public so pipeline scripts can use it too: an environment world from
an image file, and float EXR output that stores radiance as rendered.
"""

import bpy


def environment_world(scene, image_path, name="world"):
    """Give ``scene`` a new world lit by the environment image; returns the
    Environment Texture node (its image already loaded)."""
    world = bpy.data.worlds.new(name)
    world.use_nodes = True
    scene.world = world
    tree = world.node_tree
    node = tree.nodes.new("ShaderNodeTexEnvironment")
    node.image = bpy.data.images.load(str(image_path))
    tree.links.new(node.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    return node


def eevee_engine() -> str:
    """EEVEE's engine identifier in this Blender: ``BLENDER_EEVEE`` in 5.0,
    ``BLENDER_EEVEE_NEXT`` in 4.2 - 4.5 (settings store the 5.0 name)."""
    return "BLENDER_EEVEE" if bpy.app.version >= (5, 0, 0) else "BLENDER_EEVEE_NEXT"


def render_engine(name: str) -> str:
    """The identifier to assign to ``scene.render.engine`` for a stored engine name."""
    return eevee_engine() if name.startswith("BLENDER_EEVEE") else name


#: Object types that never render as a surface (nothing to cast or catch a shadow).
_NOT_SURFACES = {"LIGHT", "CAMERA", "SPEAKER", "LIGHT_PROBE", "ARMATURE", "LATTICE"}


def casts_shadows(scene) -> bool:
    """Whether a light of ``scene``'s EEVEE render may cast a shadow: a lamp that
    renders with its shadow on, or the sun EEVEE extracts from the world (its
    threshold above 0 and its shadow on), and something that renders and casts
    one (an object other than a lamp, camera, empty without instances, ...,
    with its Shadow ray visibility on; a world volume counts). Conservative: a
    lamp or object hidden by its collection still counts."""
    surfaces = any(not obj.hide_render and obj.type not in _NOT_SURFACES
                   and (obj.type != "EMPTY" or obj.instance_type != "NONE")
                   and getattr(obj, "visible_shadow", True)
                   for obj in scene.objects)
    world = scene.world
    if world is not None and world.node_tree is not None and any(
            node.type == "OUTPUT_WORLD" and node.inputs["Volume"].is_linked
            for node in world.node_tree.nodes):
        surfaces = True  # a world volume catches the sun's shadows too
    if not surfaces:
        return False
    if world is not None and getattr(world, "sun_threshold", 0.0) > 0.0 \
            and getattr(world, "use_sun_shadow", True):
        return True
    return any(obj.type == "LIGHT" and not obj.hide_render
               and getattr(obj.data, "use_shadow", True)
               for obj in scene.objects)


def float_exr_output(scene, width, height=None):
    """Render at width x height (100%) to 32-bit float EXR with the Standard view
    transform, so saved pixels are the scene-linear radiance."""
    render = scene.render
    render.resolution_x = width
    render.resolution_y = height or width
    render.resolution_percentage = 100
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    render.image_settings.exr_codec = "ZIP"  # lossless; bake.exr_codec reads it in Blender
    scene.view_settings.view_transform = "Standard"


#: Pixel filter width (px) of the reference renders: pixel-centre rays (Cycles) and
#: EEVEE's film filter in validation (glossy_addon.validation.configure_eevee).
PIXEL_FILTER = 0.01


def exact_cycles(scene, samples):
    """Cycles as a reference renderer (shared/docs/CYCLES.md): CPU, no denoiser,
    Filter Glossy 0, a 0.01 px Blackman-Harris filter (pixel-centre rays), no
    clamping and no adaptive sampling."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = int(samples)
    cycles.use_denoising = False
    cycles.blur_glossy = 0.0
    cycles.pixel_filter_type = "BLACKMAN_HARRIS"
    cycles.filter_width = PIXEL_FILTER
    cycles.sample_clamp_direct = 0.0
    cycles.sample_clamp_indirect = 0.0
    cycles.use_adaptive_sampling = False
