"""A sphere lit only by lamps (world black), as a user's script would set it up:
Glossy bake + attach, then EEVEE with Glossy, Cycles with the true BSDF (two
seeds) and EEVEE with the true BSDF (native), saved as EXR for the pytest side.

    python lamps_scene.py WORKDIR SPEC LAMPS SIZE TERMS PARAM RESULT.json

LAMPS: comma-separated kinds among point, sun, spot, area, textured (a
point lamp with a texture in its node tree: Glossy must skip it and say so),
warm (a point lamp at Exposure 1 with a 3200 K Temperature colour) and the
lamps of some size wide_point (radius 0.5), wide_sphere (radius 0.4, Soft
Falloff off: a sphere), wide_sun (10 degrees) and
wide_area (a 1.2 x 0.4 rectangle scaled to 1.2 x 0.6). The script also
writes the NumPy twin of the lamp term (bake.lamp_term) at the pixels' hits,
with the lamps' sizes and with every lamp as a point.
Afterwards: a lamp added after attach (the panel's "changed" flag, picked up
by re-attach) and an absurd term count (refused before any work).
"""

import json
import math
import sys
from pathlib import Path

workdir, spec, kinds = Path(sys.argv[1]), sys.argv[2], sys.argv[3].split(",")
size, terms, param, result_path = int(sys.argv[4]), int(sys.argv[5]), sys.argv[6], \
    Path(sys.argv[7])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from _ortho_sphere import add_sphere_and_camera  # noqa: E402
from glossy.glossy_addon import lamps, scenes, validation  # noqa: E402
from glossy.glossy_addon.nodes import lookup_nodes  # noqa: E402

RESOLUTION = 64
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
world = bpy.data.worlds.new("black")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.0
scene.world = world
scene.render.film_transparent = True
sphere = add_sphere_and_camera(scene, 96, 48, 2.2, (0.0, -6.0, 1.5),
                               (math.radians(90 - 14.04), 0.0, 0.0))
camera = scene.camera
LAMPS = {"point": ("POINT", (2.0, -3.0, 2.5), None, {"energy": 400.0, "shadow_soft_size": 0.0}),
         "sun": ("SUN", (0.0, 0.0, 5.0), (math.radians(50), 0.0, math.radians(-130)),
                 {"energy": 2.0, "angle": 0.0}),
         "spot": ("SPOT", (-2.0, -3.0, 1.0), None, {"energy": 600.0, "shadow_soft_size": 0.0,
                                                    "spot_size": math.radians(30),
                                                    "spot_blend": 0.5}),
         "area": ("AREA", (1.0, -4.0, -1.0), None, {"energy": 300.0, "size": 0.2}),
         "textured": ("POINT", (0.0, -3.0, -2.0), None, {"energy": 100.0}),
         # Exposure 1 doubles the power, Use Temperature tints Color (Cycles 5.0)
         "warm": ("POINT", (-2.0, -3.0, 1.5), None, {"energy": 150.0, "shadow_soft_size": 0.0,
                                                     "exposure": 1.0, "use_temperature": True,
                                                     "temperature": 3200.0}),
         "wide_point": ("POINT", (2.0, -3.0, 2.5), None, {"energy": 400.0,
                                                          "shadow_soft_size": 0.5}),
         "wide_sphere": ("POINT", (-2.0, -3.0, 1.0), None, {"energy": 300.0,
                                                            "shadow_soft_size": 0.4,
                                                            "use_soft_falloff": False}),
         "wide_sun": ("SUN", (0.0, 0.0, 5.0), (math.radians(50), 0.0, math.radians(-130)),
                      {"energy": 2.0, "angle": math.radians(10)}),
         "wide_area": ("AREA", (1.0, -4.0, -1.0), None, {"energy": 300.0, "shape": "RECTANGLE",
                                                         "size": 1.2, "size_y": 0.4})}
for name in kinds:
    kind, location, rotation, values = LAMPS[name]
    light = bpy.data.lights.new(name, kind)
    for key, value in values.items():
        setattr(light, key, value)
    if name == "textured":
        light.use_nodes = True
        light.node_tree.nodes.new("ShaderNodeTexNoise")
    obj = bpy.data.objects.new(name, light)
    obj.location = location
    if name == "wide_area":
        obj.scale = (1.0, 1.5, 1.0)
    scene.collection.objects.link(obj)
    if rotation is None:  # aim at the sphere's centre
        direction = -obj.location.normalized()
        obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
    else:
        obj.rotation_euler = rotation
material = bpy.data.materials.new("Lit")
sphere.data.materials.append(material)
settings = material.glossy
settings.model = "CUSTOM"
settings.spec = spec
settings.lamp_size, settings.lamp_terms, settings.lamp_parameterization = size, terms, param
settings.slices = 4
settings.map_size = 16
settings.size_mode = "FIXED"
sphere.glossy.probe_source = "RENDER"
sphere.glossy.probe_resolution = 8
bpy.context.view_layer.objects.active = sphere
sphere.select_set(True)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "lamps.blend"))
bpy.ops.glossy.capture_probes()
truth, why = validation.truth_material(material)
report = {"truth": why}
bpy.ops.glossy.bake_materials()
bpy.ops.glossy.attach_materials()
report.update({"lamp_error": settings.lamp_error, "lamp_set": json.loads(settings.lamp_set),
               "skipped": json.loads(settings.lamp_skipped),
               "lamp_path": settings.lamp_path, "bake_path": settings.bake_path,
               "groups": sorted(g.name for g in bpy.data.node_groups)})


if "textured" in kinds:  # skipped by Glossy (said above); out of the comparison renders
    bpy.data.objects["textured"].hide_render = True


def render(engine, name, samples=1, seed=0):
    scenes.float_exr_output(scene, RESOLUTION)
    if engine == "CYCLES":
        scenes.exact_cycles(scene, samples)
        scene.cycles.seed = seed
        scene.cycles.max_bounces = 0
    else:
        scene.render.engine = scenes.eevee_engine()
        scene.eevee.taa_render_samples = samples
        scene.render.filter_size = 0.01
        scene.eevee.clamp_surface_indirect = 0.0
    path = workdir / f"{name}.exr"
    validation.render_to(scene, path)
    return str(path)


def numpy_truth(path):
    """f cos(theta_i) E per pixel from the BRDF library and the lamp conversions
    measured against Cycles (written out here, independently of the node groups),
    at the pixel centres' hits on the mesh with Cycles' smooth normals."""
    import numpy as np
    from glossy.bake import exr
    from glossy.bake.brdf import parse

    index, points, normals = validation.pixel_geometry(scene, camera, RESOLUTION, RESOLUTION,
                                                       [sphere])
    _, directions = validation.camera_rays(scene, camera, RESOLUTION, RESOLUTION)
    view = -directions
    tangent = np.stack([-points[..., 1], points[..., 0], 0 * points[..., 0]], -1)
    y_axis = np.cross(normals, tangent)
    y_axis /= np.maximum(np.linalg.norm(y_axis, axis=-1, keepdims=True), 1e-12)
    x_axis = np.cross(y_axis, normals)

    def local(w):
        return np.stack([np.sum(w * x_axis, -1), np.sum(w * y_axis, -1),
                         np.sum(w * normals, -1)], -1)

    model = parse(spec)
    total = np.zeros(points.shape)
    for obj in lamps.scene_lamps(scene)[0]:
        light = obj.data
        matrix = np.array(obj.matrix_world)
        aim = -matrix[:3, 2] / np.linalg.norm(matrix[:3, 2])
        offset = matrix[:3, 3] - points
        distance2 = np.sum(offset * offset, -1, keepdims=True)
        to_lamp = offset / np.sqrt(distance2)
        if light.type == "SUN":
            to_lamp, irradiance = np.broadcast_to(-aim, points.shape), light.energy
        elif light.type == "AREA":
            irradiance = light.energy * np.maximum(-to_lamp @ aim, 0)[..., None] / (
                math.pi * distance2)
        else:
            irradiance = light.energy / (4 * math.pi * (distance2 + light.shadow_soft_size ** 2))
            if light.type == "SPOT":
                half = math.cos(light.spot_size / 2)
                x = np.clip((-to_lamp @ aim - half) / max((1 - half) * light.spot_blend, 1e-9),
                            0, 1)[..., None]
                irradiance = irradiance * x * x * (3 - 2 * x)
        wi, wo = local(to_lamp), local(view)
        colour = np.array(light.color) * (np.array(light.temperature_color)
                                          if light.use_temperature else 1.0)
        total += model.f(wi, wo) * np.maximum(wi[..., 2:], 0) * irradiance * \
            colour * 2.0 ** light.exposure * light.specular_factor
    mask = (index == 1).astype(np.float32)[..., None]
    exr.write(path, np.concatenate([total * mask, mask], -1).astype(np.float32))
    return str(path)


def twin(path, sized):
    """The lamp term as bake.lamp_term computes it from the baked factors and the
    scene's lamps (glossy_addon.lamps.reference_lamps), at the pixels' hits."""
    import numpy as np
    from glossy.bake import exr, lamp_term

    index, points, normals = validation.pixel_geometry(scene, camera, RESOLUTION, RESOLUTION,
                                                       [sphere])
    _, directions = validation.camera_rays(scene, camera, RESOLUTION, RESOLUTION)
    tangents = np.stack([-points[..., 1], points[..., 0], 0 * points[..., 0]], -1)
    inside = index == 1
    image, meta = exr.read(bpy.path.abspath(settings.lamp_path))
    values = lamp_term.radiance(np.asarray(image, np.float64)[..., :3], meta,
                                lamps.reference_lamps(scene)[0], points[inside],
                                normals[inside], -directions[inside], tangents[inside], sized)
    total = np.zeros(points.shape)
    total[inside] = values
    mask = inside.astype(np.float32)[..., None]
    exr.write(path, np.concatenate([total * mask, mask], -1).astype(np.float32))
    return str(path)


scenes.float_exr_output(scene, RESOLUTION)  # the camera rays need the render size
report["numpy_truth"] = numpy_truth(workdir / "numpy_truth.exr")
report["twin"] = twin(workdir / "twin.exr", True)
report["twin_points"] = twin(workdir / "twin_points.exr", False)
report["glossy"] = render("EEVEE", "glossy")
# Move the point lamp: the drivers follow it without a re-attach.
if "point" in kinds:
    lamp = bpy.data.objects["point"]
    lamp.location = (-2.0, -3.0, 1.0)
    report["glossy_moved"] = render("EEVEE", "glossy_moved")
    report["truth_moved"] = None
    if truth is not None:
        sphere.material_slots[0].material = truth
        report["truth_moved"] = render("CYCLES", "truth_moved", 64)
        sphere.material_slots[0].material = material
    lamp.location = (2.0, -3.0, 2.5)
if truth is not None:
    sphere.material_slots[0].material = truth
    report["cycles"] = [render("CYCLES", f"cycles{seed}", 64, seed) for seed in (1, 2)]
    report["native"] = render("EEVEE", "native", 16)
elif spec.startswith("ward:"):  # what a user has natively: Blender's nearest GGX + diffuse
    from glossy.bake.brdf import parse
    ward = parse(spec)
    ax, ay = ward.ax, ward.ay
    alpha = math.sqrt(ax * ay)
    stand_in = bpy.data.materials.new("Ward stand-in")
    tree = stand_in.node_tree
    tree.nodes.clear()
    glossy_node = tree.nodes.new("ShaderNodeBsdfAnisotropic")
    glossy_node.distribution = "GGX"
    glossy_node.inputs["Roughness"].default_value = math.sqrt(alpha)
    # A < 0: ax = alpha / (1 + A), ay = alpha (1 + A) (CYCLES.md), and the reverse.
    glossy_node.inputs["Anisotropy"].default_value = (ay / alpha - 1) if ax >= ay else \
        (1 - ax / alpha)
    glossy_node.inputs["Color"].default_value = (*ward.params["ks"], 1.0)
    diffuse_node = tree.nodes.new("ShaderNodeBsdfDiffuse")
    diffuse_node.inputs["Color"].default_value = (*ward.params["kd"], 1.0)
    add = tree.nodes.new("ShaderNodeAddShader")
    tree.links.new(glossy_node.outputs[0], add.inputs[0])
    tree.links.new(diffuse_node.outputs[0], add.inputs[1])
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(add.outputs[0], output.inputs["Surface"])
    sphere.material_slots[0].material = stand_in
    report["native"] = render("EEVEE", "native", 16)
sphere.material_slots[0].material = material
report["changed_before"] = lamps.lamp_set_changed(material, scene)
if "wide_area" in kinds:  # resized: the drivers follow; a new cell layout needs an attach
    area_light = bpy.data.objects["wide_area"].data
    area_light.size_y = 0.42
    report["changed_after_resizing"] = lamps.lamp_set_changed(material, scene)
    area_light.size = 3.0
    report["changed_after_reshaping"] = lamps.lamp_set_changed(material, scene)
    area_light.size, area_light.size_y = 1.2, 0.4
late = bpy.data.objects.new("late", bpy.data.lights.new("late", "POINT"))
scene.collection.objects.link(late)
report["changed_after_adding"] = lamps.lamp_set_changed(material, scene)
bpy.ops.glossy.attach_materials()
report["changed_after_reattach"] = lamps.lamp_set_changed(material, scene)
report["lamp_nodes"] = sorted(n.get("glossy_lamp", "") for n in lookup_nodes(material)
                              if "glossy_lamp" in n)
report["lamps_in_groups"] = sorted(n.get("glossy_lamp", "") for n in lookup_nodes(material)
                                   if "glossy_lamp" in n and n.id_data != material.node_tree)
settings.lamp_terms = 0
before = sorted(p.name for p in (workdir / "glossy").iterdir())
try:
    bpy.ops.glossy.bake_materials()
    report["zero_terms"] = ""
except RuntimeError as error:
    report["zero_terms"] = str(error)
report["files_unchanged"] = before == sorted(p.name for p in (workdir / "glossy").iterdir())
result_path.write_text(json.dumps(report))
