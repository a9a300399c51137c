"""Small helpers the Blender test scripts share: running an operator as a user's
script does, giving an object a World Only probe, and a one-shader material."""

import math

import bpy


def run(operator, **kwargs):
    """(sorted result set, "") or (["CANCELLED"], the ERROR report) of an operator
    called headless (background mode raises an operator's ERROR as RuntimeError)."""
    try:
        return sorted(operator(**kwargs)), ""
    except RuntimeError as error:
        return ["CANCELLED"], str(error).strip()


def whole_pipeline(objects, workdir):
    """(steps, validation report): ``objects`` selected (the first active), then one
    call each of Capture Probes, Bake Materials, Attach Lookups and Validate, as a
    user's script drives a scene."""
    import json

    bpy.ops.object.select_all(action="DESELECT")
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    steps = {name: run(operator) for name, operator in (
        ("capture", bpy.ops.glossy.capture_probes), ("bake", bpy.ops.glossy.bake_materials),
        ("attach", bpy.ops.glossy.attach_materials), ("validate", bpy.ops.glossy.validate))}
    report = (workdir / "glossy" / "validation" / "report.json").read_text()
    return steps, json.loads(report)


def world_probe(obj, resolution=16):
    """Capture ``obj``'s probe from the world image alone, at a fixed face size."""
    obj.glossy.probe_source = "WORLD"
    obj.glossy.probe_size_mode = "FIXED"
    obj.glossy.probe_resolution = resolution


def isolated_sphere(name, x, face=64):
    """A smooth UV sphere of radius 1 at (x, 0, 0) that no other object sees in its
    reflections or shadows, with a World Only probe of ``face`` px faces."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0,
                                         location=(x, 0.0, 0.0))
    bpy.ops.object.shade_smooth()
    obj = bpy.context.object
    obj.name = name
    for ray in ("glossy", "diffuse", "transmission", "shadow"):
        setattr(obj, f"visible_{ray}", False)
    obj.glossy.probe_source = "WORLD"
    obj.glossy.probe_size_mode = "FIXED"
    obj.glossy.probe_resolution = face
    return obj


def shader_material(name, shader="ShaderNodeBsdfPrincipled"):
    """(material, its tree, the shader node): one shader into a Material Output."""
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    node = tree.nodes.new(shader)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(node.outputs[0], output.inputs["Surface"])
    return material, tree, node


def validate_each(objects, workdir):
    """{name: (steps, figures)}: each of ``objects`` ({name: object}) alone (the others
    hidden from renders) selected, captured, baked, attached and validated, with
    the step results (:func:`run`) and the figures of its validation report."""
    import json
    from pathlib import Path

    out = {}
    for name, obj in objects.items():
        for other in objects.values():
            other.hide_render = other is not obj
        bpy.ops.object.select_all(action="DESELECT")
        obj.select_set(True)
        bpy.context.view_layer.objects.active = obj
        steps = [run(bpy.ops.glossy.capture_probes), run(bpy.ops.glossy.bake_materials),
                 run(bpy.ops.glossy.attach_materials), run(bpy.ops.glossy.validate)]
        report = json.loads((Path(workdir) / "glossy" / "validation" / "report.json")
                            .read_text())
        out[name] = (steps, report["objects"][0]["figures"])
    return out


def validate_together(objects, workdir, columns, spacing):
    """{name: (steps, figures)} as :func:`validate_each`, for ``objects`` ({name:
    object}, each at the origin) validated in one run: laid out on a grid of
    ``columns`` at ``spacing`` (world units), hidden from each other's glossy,
    diffuse, transmission and shadow rays (each is an isolated object under
    distant light, for Cycles too), and seen by an orthographic camera whose
    pixels fall on every object alike (the spacing is a whole number of
    pixels), so two objects with the same material get the same pixels. The
    steps (capture, bake, attach, validate) run once for all of them."""
    import json
    import math
    from pathlib import Path

    scene = bpy.context.scene
    rows = math.ceil(len(objects) / columns)
    side = max(rows, columns)
    for index, obj in enumerate(objects.values()):
        row, column = divmod(index, columns)
        obj.location = (spacing * (column - 0.5 * (side - 1)), 0.0,
                        spacing * (0.5 * (side - 1) - row))
        obj.visible_glossy = obj.visible_diffuse = False
        obj.visible_transmission = obj.visible_shadow = False
    data = bpy.data.cameras.new("grid camera")
    data.type = "ORTHO"
    data.ortho_scale = spacing * side
    camera = bpy.data.objects.new("grid camera", data)
    scene.collection.objects.link(camera)
    camera.location = (0.0, -10.0 * spacing * side, 0.0)
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)  # looks along +Y, +Z up
    data.clip_end = 20.0 * spacing * side
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = 100  # square; validate sizes it
    scene.glossy.validate_resolution *= side  # the per-object size, times the grid
    def select(active=None):
        bpy.ops.object.select_all(action="DESELECT")
        for obj in objects.values() if active is None else [active]:
            obj.select_set(True)
        bpy.context.view_layer.objects.active = active or next(iter(objects.values()))

    select()
    capture = run(bpy.ops.glossy.capture_probes)  # every selected object
    own = {}
    for name, obj in objects.items():  # bake and attach work on the active object
        select(obj)
        own[name] = [run(bpy.ops.glossy.bake_materials), run(bpy.ops.glossy.attach_materials)]
    select()
    validate = run(bpy.ops.glossy.validate)
    report = json.loads((Path(workdir) / "glossy" / "validation" / "report.json").read_text())
    figures = {entry["object"]: entry["figures"] for entry in report["objects"]}
    return {name: ([capture, *own[name], validate], figures[name]) for name in objects}


def errors(figures):
    """(Glossy's, native EEVEE's best) relative RMS errors against Cycles in a report."""
    methods = figures["methods"]
    return (methods["eevee_glossy"]["relative_rms"],
            min(methods["eevee_native"]["relative_rms"],
                methods.get("eevee_native_careful", {}).get("relative_rms", 1.0)))


def validation_scene(hdri, workdir, resolution, reference=True):
    """A new empty scene lit by ``hdri``, saved as WORKDIR/scene.blend (validation
    writes beside it), with small validation settings: ``resolution`` px, Cycles
    2 x 256 spp, EEVEE 4 samples, the NumPy reference on or off (``reference``:
    off where a test asserts only the figures against Cycles)."""
    import glossy
    from glossy.glossy_addon.scenes import environment_world

    bpy.ops.wm.read_factory_settings(use_empty=True)
    glossy.register()
    scene = bpy.context.scene
    environment_world(scene, hdri)
    bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
    settings = scene.glossy
    settings.validate_resolution = resolution
    settings.validate_samples = 256
    settings.validate_eevee_samples = 4
    settings.validate_reference = reference
    return scene


def roughness_image():
    """A 64 x 32 Non-Color image: Roughness 0.15-0.5 in four smooth bands along U."""
    image = bpy.data.images.new("Roughness bands", 64, 32, float_buffer=True)
    image.colorspace_settings.name = "Non-Color"
    values = []
    for _ in range(32):
        for column in range(64):
            r = 0.15 + 0.35 * (0.5 + 0.5 * math.sin(2.0 * math.pi * 4.0 * (column + 0.5) / 64))
            values += [r, r, r, 1.0]
    image.pixels.foreach_set(values)
    image.pack()
    return image


def checker_into(tree, socket, scale=5.0, first=(0.95, 0.55, 0.1), second=(0.05, 0.2, 0.6)):
    """Link a new Checker Texture of two colours far apart (what one value cannot
    stand for) at ``scale`` into ``socket`` (a Base Color) of ``tree``."""
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = scale
    checker.inputs["Color1"].default_value = (*first, 1.0)
    checker.inputs["Color2"].default_value = (*second, 1.0)
    tree.links.new(checker.outputs["Color"], socket)
    return checker
