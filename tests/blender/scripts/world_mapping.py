"""World Only probes of worlds a user has turned and brightened, against Cycles.

    python world_mapping.py ZIP WORKDIR RESULT.json   (bpy module)

For each world variant (an Environment Texture through a Mapping node's
rotation, a Background Strength, both, a muted Mapping node, a world hidden
from the camera), two empty cubes at the origin: one
captured with Cycles (the world as it renders), one resampled from the world
image (World Only, no render); the same for an 8-bit sRGB PNG world and for
the turned world behind a Mix Shader that shows the camera a plain colour
(Light Path's Is Camera Ray), and a Cycles capture beside two emitting cubes,
one seen only by reflections, one only by the camera, and a point lamp; the
tilted world through Export Environment.
Writes their probe paths, and the operator's report for a world that World
Only cannot resample; a Hybrid sphere's bake reasons in the tilted world, as
captured and after the world is turned (its lights measured on the world's
texels, then on the probe's).
"""

import json
import math
import sys
from pathlib import Path

from _installed import install  # hides the venv's OpenEXR

install(sys.argv[1])
workdir, result_path = Path(sys.argv[2]), sys.argv[3]

# isort: split
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from bl_ext.user_default.glossy.glossy_addon import scenes  # noqa: E402

VARIANTS = {
    "plain": {},
    "turned": {"rotation": (0.0, 0.0, math.radians(70.0))},
    "tilted": {"rotation": (math.radians(25.0), math.radians(-15.0), math.radians(200.0)),
               "strength": 2.5},
    "texture": {"rotation": (0.0, math.radians(30.0), math.radians(-40.0)), "type": "TEXTURE",
                "strength": 0.4},
    # A muted Mapping node passes its Vector through: the world as loaded.
    "muted": {"rotation": (0.0, 0.0, math.radians(70.0)), "mute": True},
    # Hidden from the camera, seen in reflections (World > Ray Visibility).
    "hidden": {"camera": False},
}


def world_for(variant):
    scene = bpy.context.scene
    node = scenes.environment_world(
        scene, Path(bpy.utils.system_resource("DATAFILES"), "studiolights", "world",
                    "sunset.exr"), name=variant)
    tree = scene.world.node_tree
    settings = VARIANTS[variant]
    tree.nodes["Background"].inputs["Strength"].default_value = settings.get("strength", 1.0)
    scene.world.cycles_visibility.camera = settings.get("camera", True)
    if "rotation" in settings:
        coords = tree.nodes.new("ShaderNodeTexCoord")
        mapping = tree.nodes.new("ShaderNodeMapping")
        mapping.vector_type = settings.get("type", "POINT")
        mapping.inputs["Rotation"].default_value = settings["rotation"]
        tree.links.new(coords.outputs["Generated"], mapping.inputs["Vector"])
        tree.links.new(mapping.outputs["Vector"], node.inputs["Vector"])
        mapping.mute = settings.get("mute", False)
    return tree


def probe_pair(variant):
    paths = {}
    for name, source in (("cycles", "RENDER"), ("world", "WORLD")):
        bpy.ops.mesh.primitive_cube_add(size=0.1)
        obj = bpy.context.object
        obj.name = f"{variant}_{name}"
        obj.hide_render = True
        settings = obj.glossy
        settings.probe_source, settings.capture_engine = source, "CYCLES"
        settings.probe_size_mode = "FIXED"
        settings.probe_resolution = 32
        settings.capture_samples = 16
        settings.centre_mode = "ORIGIN"
        paths[name] = obj
    bpy.ops.object.select_all(action="DESELECT")
    for obj in paths.values():
        obj.select_set(True)
    outcome = sorted(bpy.ops.glossy.capture_probes())
    return outcome, {name: bpy.path.abspath(obj.glossy.probe_path) for name, obj in paths.items()}


for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
report = {"variants": {}}
for variant in VARIANTS:
    world_for(variant)
    outcome, paths = probe_pair(variant)
    report["variants"][variant] = {"capture": outcome, "probes": paths}

# Export Environment writes the world as it renders, as World Only resamples it.
world_for("tilted")
glossy_scene = bpy.context.scene.glossy
glossy_scene.export_layout, glossy_scene.export_size, glossy_scene.export_mip = "cube", 32, "none"
report["export"] = {"status": sorted(bpy.ops.glossy.export_environment()),
                    "path": bpy.path.abspath(glossy_scene.last_export)}

# The Hybrid of a World Only probe measures its lights on the tilted world's own
# texels; once the world is turned after the capture, on the probe's (and says why).
bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1)
sphere = bpy.context.object
sphere.name = "lit"
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_size_mode, sphere.glossy.probe_resolution = "FIXED", 32
shiny = bpy.data.materials.new("shiny")
shiny.glossy.model, shiny.glossy.method, shiny.glossy.roughness = "ggx", "hybrid", 0.3
sphere.data.materials.append(shiny)
bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
bpy.context.view_layer.objects.active = sphere
report["world_lights"] = {"capture": sorted(bpy.ops.glossy.capture_probes()),
                          "bake": sorted(bpy.ops.glossy.bake_materials()),
                          "reason": shiny.glossy.size_reason}
mapping = next(n for n in bpy.context.scene.world.node_tree.nodes if n.type == "MAPPING")
mapping.inputs["Rotation"].default_value[2] += math.radians(10.0)
shiny.glossy.roughness = 0.31  # a change the bake acts on
report["world_lights"]["turned_bake"] = sorted(bpy.ops.glossy.bake_materials())
report["world_lights"]["turned_reason"] = shiny.glossy.size_reason
# The world's image edited in place (its pixels written, as painting does): the
# bake must hash it again (the session keeps digests of unedited images only).
mapping.inputs["Rotation"].default_value[2] -= math.radians(10.0)
shiny.glossy.roughness = 0.3
report["world_lights"]["restored_bake"] = sorted(bpy.ops.glossy.bake_materials())
report["world_lights"]["restored_reason"] = shiny.glossy.size_reason
world_image = next(n for n in bpy.context.scene.world.node_tree.nodes
                   if n.type == "TEX_ENVIRONMENT").image
edited = np.empty(len(world_image.pixels), dtype=np.float32)
world_image.pixels.foreach_get(edited)
edited[:4 * 64] *= 3.0  # a strip of the bottom row
world_image.pixels.foreach_set(edited)
shiny.glossy.roughness = 0.31
report["world_lights"]["edited_bake"] = sorted(bpy.ops.glossy.bake_materials())
report["world_lights"]["edited_reason"] = shiny.glossy.size_reason
bpy.data.objects.remove(sphere)

# An 8-bit sRGB PNG world (stored values 0.2-0.8): Cycles decodes it to linear.
png = bpy.data.images.new("gradient", 64, 32, alpha=False)
rows, cols = np.meshgrid(np.linspace(0.25, 0.75, 32), np.linspace(0.2, 0.8, 64), indexing="ij")
png.pixels.foreach_set(np.stack([cols, rows, np.full_like(rows, 0.5), np.ones_like(rows)],
                                axis=2).astype(np.float32).ravel())
png.filepath_raw, png.file_format = str(workdir / "gradient.png"), "PNG"
png.save()
scenes.environment_world(bpy.context.scene, workdir / "gradient.png", name="png")
outcome, paths = probe_pair("png")
report["png"] = {"capture": outcome, "probes": paths}

# The camera sees a plain colour, everything else the turned HDRI (Mix Shader
# driven by Light Path's Is Camera Ray): World Only follows the HDRI.
tree = world_for("turned")
background = tree.nodes["Background"]
output = next(n for n in tree.nodes if n.type == "OUTPUT_WORLD")
plain = tree.nodes.new("ShaderNodeBackground")
plain.inputs["Color"].default_value = (0.2, 0.2, 0.2, 1.0)
mix = tree.nodes.new("ShaderNodeMixShader")
path = tree.nodes.new("ShaderNodeLightPath")
tree.links.new(path.outputs["Is Camera Ray"], mix.inputs[0])
tree.links.new(background.outputs["Background"], mix.inputs[1])
tree.links.new(plain.outputs["Background"], mix.inputs[2])
tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])
outcome, paths = probe_pair("trick")
fac = mix.inputs[0]
report["camera_trick"] = {"capture": outcome, "probes": paths,
                          "fac_still_linked": bool(fac.is_linked and fac.links[0].from_socket.name
                                                   == "Is Camera Ray"),
                          "fac_default": fac.default_value}

# Two bright cubes beside the probe point: one hidden from the camera but seen in
# reflections (it belongs in the probe), one the other way round (it does not).
world_for("plain")
lamps = {}
for name, camera, glossy, x in (("glossy_only", False, True, 1.0), ("camera_only", True, False,
                                                                     -1.0)):
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(x, 0.0, 0.0))
    cube = bpy.context.object
    cube.name = name
    emit = bpy.data.materials.new(name)
    emit.use_nodes = True
    emit.node_tree.nodes.clear()
    shader = emit.node_tree.nodes.new("ShaderNodeEmission")
    shader.inputs["Strength"].default_value = 100.0
    emit.node_tree.links.new(shader.outputs[0], emit.node_tree.nodes.new(
        "ShaderNodeOutputMaterial").inputs["Surface"])
    cube.data.materials.append(emit)
    cube.visible_camera, cube.visible_glossy = camera, glossy
    lamps[name] = cube
lamp = bpy.data.objects.new("lamp", bpy.data.lights.new("lamp", "POINT"))
lamp.data.energy, lamp.data.shadow_soft_size = 1000.0, 0.25
lamp.location = (0.0, 1.0, 0.0)  # a lamp's term is the lamp path's, not the probe's
bpy.context.scene.collection.objects.link(lamp)
outcome, paths = probe_pair("visibility")
bpy.data.objects.remove(lamp)
report["visibility"] = {"capture": outcome, "probes": paths,
                        "restored": [[o.visible_camera, o.visible_glossy]
                                     for o in lamps.values()]}
for cube in lamps.values():
    bpy.data.objects.remove(cube)

# A world World Only cannot reproduce: the image's colour goes through a node
# Glossy does not evaluate. The capture must refuse it with one message.
tree = world_for("plain")
env = next(n for n in tree.nodes if n.type == "TEX_ENVIRONMENT")
curve = tree.nodes.new("ShaderNodeHueSaturation")
tree.links.new(env.outputs["Color"], curve.inputs["Color"])
tree.links.new(curve.outputs["Color"], tree.nodes["Background"].inputs["Color"])
bpy.ops.mesh.primitive_cube_add(size=0.1)
obj = bpy.context.object
obj.name = "refused"
obj.glossy.probe_source = "WORLD"
bpy.ops.object.select_all(action="DESELECT")
obj.select_set(True)
try:
    refused = sorted(bpy.ops.glossy.capture_probes())
    message = ""
except RuntimeError as error:
    refused, message = ["ERROR"], str(error)
report["refused"] = {"outcome": refused, "message": message,
                     "probe_path": obj.glossy.probe_path}
Path(result_path).write_text(json.dumps(report, indent=1))
