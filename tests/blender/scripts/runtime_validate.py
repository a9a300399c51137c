"""Runtime Sampling and Hybrid through the add-on's operators, measured by glossy.validate.

    python runtime_validate.py HDRI WORKDIR [SIZE SAMPLES EEVEE_SAMPLES [SPHERES [CHECKS
        [CAMERA [PROBE]]]]] RESULT.json

As a user's script: isolated spheres (ray visibility off, so none sees
another), each with its own material and World Only probe (64 px faces),
baked, attached and validated together (no scene camera: validation frames
them). SPHERES is a JSON list of [name, method, roughness, anisotropy,
rotation(, samples(, {Principled BSDF input: value}))] (a method ending in
"-nolights" has Probe Lights off; "beckmann/hybrid": a model other than GGX
before the slash); with the last, the
material is From Material, a Principled BSDF with those inputs; the default
is one brushed sphere (GGX 0.3, anisotropy 0.8, Runtime Sampling, tangent
radial about Z). Writes the validation report's
figures per sphere, the operators' reports and the attached node count.
With CHECKS=1 it first tries bad input on a sphere of its own, removed after:
a Ward lobe with Runtime Sampling (refused: no sampler) and a UV-map
tangent on a mesh without UV maps (attached radially, with a warning).
With CAMERA=1 the scene gets a camera (bake.reference.sphere_buffers': at
(0, -6, 0) looking along +Y, 90 mm on a 36 mm sensor) that validation renders
through, so the first sphere fills the frame as in the NumPy benchmarks.
PROBE: the probes' face size (default 64, Fixed); "auto" leaves it to
Auto (the lobe's width, capped by the world image's detail).
GLOSSY_WORLD_MAPPING (environment, JSON {"rotation": [x, y, z] rad,
"strength": s}): the world's image goes through a Mapping node with that
rotation, at that Background Strength.
GLOSSY_MAX_MAP_SIZE (environment): every material's Max Map Size (the upper
bound of Auto's map rows, and of the runtime level stack's).
"""

import json
import os
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
options = sys.argv[3:-1]
size, samples, eevee_samples = (int(a) for a in (options[:3] or (64, 64, 4)))
spheres = json.loads(options[3]) if len(options) > 3 else [["Brushed", "runtime", 0.3, 0.8, 0.0]]
checks = len(options) > 4 and options[4] == "1"
camera = len(options) > 5 and options[5] == "1"
probe_face = options[6] if len(options) > 6 else "64"
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment = environment_world(scene, hdri)
if os.environ.get("GLOSSY_WORLD_MAPPING"):  # {"rotation": [x, y, z] rad, "strength": s}
    mapping_settings = json.loads(os.environ["GLOSSY_WORLD_MAPPING"])
    tree = scene.world.node_tree
    tree.nodes["Background"].inputs["Strength"].default_value = \
        mapping_settings.get("strength", 1.0)
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Rotation"].default_value = mapping_settings.get("rotation", (0, 0, 0))
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["Generated"],
                   mapping.inputs["Vector"])
    tree.links.new(mapping.outputs["Vector"], environment.inputs["Vector"])
scene.render.resolution_x = scene.render.resolution_y = 100
scene.glossy.validate_resolution = size
scene.glossy.validate_samples = samples
scene.glossy.validate_eevee_samples = eevee_samples
result = {"reports": []}


def run(operator):
    try:
        return sorted(operator())
    except RuntimeError as error:  # an operator's ERROR report, in background mode
        result["reports"].append(str(error).strip())
        return ["CANCELLED"]


bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))  # outputs go beside it
if checks:
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, location=(0, 0, -5))
    probe_obj = bpy.context.object
    probe_obj.glossy.probe_source = "WORLD"
    probe_obj.glossy.probe_size_mode = "FIXED"
    probe_obj.glossy.probe_resolution = 16
    bad = bpy.data.materials.new("Ward")
    bad.glossy.model, bad.glossy.method = "ward", "runtime"
    probe_obj.data.materials.append(bad)
    run(bpy.ops.glossy.capture_probes)
    result["no_sampler"] = {"bake": run(bpy.ops.glossy.bake_materials),
                            "bake_path": bad.glossy.bake_path,
                            "files": sorted(p.name for p in (workdir / "glossy").iterdir())}
    bad.glossy.model, bad.glossy.anisotropy = "ggx", 0.5  # a lobe that needs a tangent
    bad.glossy.tangent_type, bad.glossy.tangent_uv_map = "UV_MAP", "UVMap"
    while probe_obj.data.uv_layers:
        probe_obj.data.uv_layers.remove(probe_obj.data.uv_layers[0])
    result["no_uv"] = {"bake": run(bpy.ops.glossy.bake_materials),
                       "attach": run(bpy.ops.glossy.attach_materials),
                       "tangents": sorted({(n.direction_type, n.axis) for n in
                                           bad.node_tree.nodes if n.type == "TANGENT"}),
                       "note": bad.glossy.tangent_note}
    bpy.data.objects.remove(probe_obj)
    bpy.data.materials.remove(bad)
    # What Auto chooses (glossy_addon.method_choice) for BRDFs of each kind.
    from glossy.glossy_addon.method_choice import choose

    result["choices"] = {}
    for label, model, anisotropy in (("ggx", "ggx", 0.0), ("ggx_anisotropic", "ggx", 0.8),
                                     ("beckmann", "beckmann", 0.0), ("ward", "ward", 0.0),
                                     ("principled", "MATERIAL", 0.0),
                                     ("principled_coat", "MATERIAL", 0.0),
                                     ("textured", "MATERIAL", 0.0)):
        probe = bpy.data.materials.new(f"choice_{label}")
        probe.glossy.model, probe.glossy.anisotropy = model, anisotropy
        if probe.node_tree is None:  # Blender before 5.0
            probe.use_nodes = True
        tree = probe.node_tree
        if label == "principled_coat":  # a second GGX lobe
            tree.nodes["Principled BSDF"].inputs["Coat Weight"].default_value = 1.0
        if label == "textured":  # a roughness texture: maps baked at its knots
            picture = bpy.data.images.new("choice_roughness", 4, 4, alpha=False)
            picture.colorspace_settings.name = "Non-Color"
            picture.pixels = [v for k in range(16) for v in (0.2 + 0.025 * k,) * 3 + (1.0,)]
            texture = tree.nodes.new("ShaderNodeTexImage")
            texture.image = picture
            tree.links.new(texture.outputs["Color"],
                           tree.nodes["Principled BSDF"].inputs["Roughness"])
        result["choices"][label] = list(choose(probe.glossy))
        probe.glossy.method = "3d"
        result["choices"][f"{label}_set"] = list(choose(probe.glossy))
        bpy.data.materials.remove(probe)
    # Near-mirror GGX lobes (below the Hybrid table's first roughness, 0.1): Runtime
    # Sampling, unless a colour texture splits the map; Beckmann keeps the Hybrid.
    for label, model, roughness, colour in (
            ("ggx_0.05", "ggx", 0.05, False), ("ggx_0.1", "ggx", 0.1, False),
            ("beckmann_0.05", "beckmann", 0.05, False),
            ("metal_0.05", "MATERIAL", 0.05, False),
            ("metal_0.05_checker", "MATERIAL", 0.05, True)):
        probe = bpy.data.materials.new(f"choice_{label}")
        probe.glossy.model, probe.glossy.roughness = model, roughness
        if probe.node_tree is None:  # Blender before 5.0
            probe.use_nodes = True
        principled = probe.node_tree.nodes["Principled BSDF"]
        principled.inputs["Metallic"].default_value = 1.0
        principled.inputs["Roughness"].default_value = roughness
        if colour:
            from _operators import checker_into
            checker_into(probe.node_tree, principled.inputs["Base Color"])
        result["choices"][label] = list(choose(probe.glossy))
        bpy.data.materials.remove(probe)
    tiny = bpy.data.materials.new("choice_tiny")
    tiny.glossy.model, tiny.glossy.size_mode, tiny.glossy.map_size = "ggx", "FIXED", 8
    result["choices"]["ggx_fixed_8"] = list(choose(tiny.glossy))
    bpy.data.materials.remove(tiny)
objects = []
for index, (name, method, roughness, anisotropy, rotation, *extra) in enumerate(spheres):
    budget, principled = extra[:1], (extra[1] if len(extra) > 1 else None)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=96, ring_count=48, radius=1.0,
                                         location=(2.5 * index, 0.0, 0.0))
    bpy.ops.object.shade_smooth()
    obj = bpy.context.object
    obj.name = name
    obj.visible_glossy = obj.visible_diffuse = obj.visible_transmission = False
    obj.glossy.probe_source = "WORLD"
    if probe_face == "auto":
        obj.glossy.probe_size_mode, obj.glossy.probe_resolution = "AUTO", 1024
    else:
        obj.glossy.probe_size_mode = "FIXED"
        obj.glossy.probe_resolution = int(probe_face)
    material = bpy.data.materials.new(name)
    settings = material.glossy
    # "hybrid-nolights": the method with Probe Lights off (bake.probe_lights);
    # "beckmann/hybrid": the Material panel's model before the slash (default GGX).
    model, _, method = method.rpartition("/")
    settings.probe_lights = not method.endswith("-nolights")
    settings.model, settings.method = model or "ggx", method.removesuffix("-nolights")
    settings.roughness, settings.anisotropy, settings.rotation = roughness, anisotropy, rotation
    if principled is not None:  # From Material: a Principled BSDF with these inputs
        settings.model = "MATERIAL"
        if material.node_tree is None:  # Blender before 5.0
            material.use_nodes = True
        bsdf = material.node_tree.nodes["Principled BSDF"]
        bsdf.inputs["Roughness"].default_value = roughness
        for socket, value in principled.items():
            if isinstance(value, (int, float)) and \
                    hasattr(bsdf.inputs[socket].default_value, "__len__"):
                value = (value, value, value, 1.0)  # a grey colour
            bsdf.inputs[socket].default_value = value
    if budget:
        settings.samples = int(budget[0])
    if os.environ.get("GLOSSY_MAX_MAP_SIZE"):  # Max Map Size (Auto's bound), rows
        settings.map_size = int(os.environ["GLOSSY_MAX_MAP_SIZE"])
    obj.data.materials.append(material)
    objects.append(obj)
    result[name] = {"capture": run(bpy.ops.glossy.capture_probes),
                    "bake": run(bpy.ops.glossy.bake_materials),
                    "attach": run(bpy.ops.glossy.attach_materials),
                    "nodes": len(material.node_tree.nodes),
                    "bake_path": settings.bake_path, "runtime_path": settings.runtime_path,
                    "method_used": settings.method_used(),
                    "size_reason": settings.size_reason,
                    "probe_reason": obj.glossy.probe_reason}
if camera:
    view = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    view.data.lens, view.data.sensor_width, view.data.sensor_fit = 90.0, 36.0, "HORIZONTAL"
    view.location, view.rotation_euler = (0.0, -6.0, 0.0), (0.5 * 3.141592653589793, 0.0, 0.0)
    scene.collection.objects.link(view)
    scene.camera = view
bpy.ops.object.select_all(action="DESELECT")
for obj in objects:
    obj.select_set(True)
result["validate"] = run(bpy.ops.glossy.validate)
report = json.loads((Path(scene.glossy.last_report).with_suffix(".json")).read_text()) \
    if scene.glossy.last_report else {}
for entry in report.get("objects", []):
    result[entry["object"]]["figures"] = entry["figures"]
result["notes"] = report.get("notes", [])
result_path.write_text(json.dumps(result, indent=1, default=str))
