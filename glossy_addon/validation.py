"""Blender side of validation: the true BSDF as a Cycles material, temporary scene
changes that are always undone, a framing camera, and renders with their passes.

Everything the operator changes goes through :class:`SceneChanges`, which
records each original value once and restores them all (and removes every
temporary datablock) however the validation ends: finished, cancelled with
Esc, or failed.
"""

import math
from pathlib import Path

import bpy
import numpy as np
from mathutils import Vector

from ..bake import brdf, exr
from ..bake.errors import BakeError
from .scenes import PIXEL_FILTER, casts_shadows, exact_cycles, render_engine

#: bake.brdf models Cycles' Glossy BSDF renders exactly (CYCLES.md), by distribution.
CYCLES_DISTRIBUTIONS = {"ggx": "GGX", "beckmann": "BECKMANN",
                        "ashikhmin_shirley": "ASHIKHMIN_SHIRLEY", "ggx_multiscatter": "MULTI_GGX"}


def user_copy(material, label):
    """A new material ``<name> (<label>)``: a copy of the user's own nodes of a From
    Material ``material`` (its kept original where an attach replaced them),
    without Glossy's lookup, its own Material Output active."""
    from .material_source import source_material
    from .nodes import strip_lookup

    copy = source_material(material).copy()
    copy.name = f"{material.name} ({label})"
    copy.use_fake_user = False
    strip_lookup(copy)
    if copy.glossy.original is not None:
        copy.glossy.original = None
    return copy


def truth_material(material, tangent=None):
    """(a new material with the true BSDF of ``material``'s Glossy settings, None) or
    (None, why Cycles cannot render it). Glossy BSDF (plus a Diffuse BSDF for the
    diffuse colour, mixed by a Fresnel node when Fresnel IOR > 1, as the lookup is).
    tangent: ("RADIAL", axis) or ("UV_MAP", name) for an anisotropic lobe (default:
    the material's own, glossy_addon.materials.effective_tangent)."""
    settings = material.glossy
    if settings.model == "MATERIAL":  # the user's own material is the truth
        return user_copy(material, "Glossy truth"), None
    try:
        model = brdf.parse(settings.brdf_spec())
    except (BakeError, ValueError) as error:
        return None, f"its BRDF spec is invalid ({error})"
    name = getattr(model, "name", "")
    if name not in CYCLES_DISTRIBUTIONS and name != "lambert":
        return None, f"Cycles has no '{name}' BSDF"
    if name != "lambert" and not model.isotropic and model.params.get("roughness") is None:
        return None, "anisotropic truth needs Blender's Roughness and Anisotropy in the spec"
    truth = bpy.data.materials.new(f"{material.name} (Glossy truth)")
    truth.use_nodes = True
    tree = truth.node_tree
    tree.nodes.clear()
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    if name == "lambert":
        surface = tree.nodes.new("ShaderNodeBsdfDiffuse")
        surface.inputs["Color"].default_value = (*model.params["color"], 1.0)
        surface.inputs["Roughness"].default_value = 0.0
    else:
        surface = tree.nodes.new("ShaderNodeBsdfAnisotropic")
        surface.distribution = CYCLES_DISTRIBUTIONS[name]
        surface.inputs["Roughness"].default_value = math.sqrt(model.ax)  # alpha = roughness^2
        surface.inputs["Anisotropy"].default_value = 0.0
        if not model.isotropic:  # Blender's own parameters; the Tangent socket unconnected
            # means radial about the object's Z, the frame Glossy's lamp terms use
            surface.inputs["Roughness"].default_value = model.params["roughness"]
            surface.inputs["Anisotropy"].default_value = model.params["anisotropy"]
            surface.inputs["Rotation"].default_value = model.params["rotation"]
            tangent = tangent or settings.tangent()
            if tangent != ("RADIAL", "Z"):  # unconnected is Cycles' radial about Z
                node = tree.nodes.new("ShaderNodeTangent")
                node.direction_type = tangent[0]
                if tangent[0] == "RADIAL":
                    node.axis = tangent[1]
                else:
                    node.uv_map = tangent[1]
                tree.links.new(node.outputs["Tangent"], surface.inputs["Tangent"])
        surface.inputs["Color"].default_value = (*model.params["color"], 1.0)
    if any(settings.diffuse) and name != "lambert":
        diffuse = tree.nodes.new("ShaderNodeBsdfDiffuse")
        diffuse.inputs["Color"].default_value = (*settings.diffuse, 1.0)
        diffuse.inputs["Roughness"].default_value = 0.0
        if settings.fresnel_ior > 1.0:
            fresnel = tree.nodes.new("ShaderNodeFresnel")
            fresnel.inputs["IOR"].default_value = settings.fresnel_ior
            mix = tree.nodes.new("ShaderNodeMixShader")
            tree.links.new(fresnel.outputs["Fac"], mix.inputs["Fac"])
            tree.links.new(diffuse.outputs[0], mix.inputs[1])
            tree.links.new(surface.outputs[0], mix.inputs[2])
        else:
            mix = tree.nodes.new("ShaderNodeAddShader")
            tree.links.new(surface.outputs[0], mix.inputs[0])
            tree.links.new(diffuse.outputs[0], mix.inputs[1])
        surface = mix
    tree.links.new(surface.outputs[0], output.inputs["Surface"])
    return truth, None


def colour_plan(material, spec=None):
    """(specs, combine, sockets) where the NumPy reference can follow a Base Color
    texture, a Metallic texture or both per pixel exactly, else None: a From
    Material Principled BSDF alone whose inputs applied per pixel are those and,
    at most, a normal map and a roughness texture (``spec``: the BSDF at one
    roughness; default the read one). specs: the bake.brdf specs to integrate;
    combine(values, colour, mu, metallic): the reflection at each pixel from their
    integrals (a list of (N, 3)), the pixel's colour (N, 3) (None: no colour
    texture), view cosine (N,) and metallic (N,) (None: no metallic texture);
    sockets: {"colour": (node name, input name) or None, "metallic": the same}.
    A metal (Metallic 1) follows bake.colour_response (integrals at base
    colours 0 and 1, the coat alone, the energy term), a dielectric (Metallic 0)
    is affine in its base colour (integrals at 0 and 1), and the Principled BSDF
    is affine in Metallic (integrals at Metallic 0 and 1, mixed per pixel);
    a partly metallic one without a metallic texture is None."""
    if material.glossy.model != "MATERIAL":
        return None
    from ..bake.brdf.principled import Principled
    from ..bake.colour_response import response
    from .material_source import parts as material_parts

    derived = material_parts(material).derived
    spatial = derived.spatial if derived is not None else {}
    entry, metal_entry = spatial.get("colour"), spatial.get("metallic")
    if entry is None and metal_entry is None or \
            not set(spatial) <= {"colour", "metallic", "normal", "roughness"} or \
            entry is not None and entry.get("input") != "Base Color":
        return None
    model = brdf.parse(spec or derived.spec)
    if not isinstance(model, Principled):
        return None

    def at_metallic(metallic):
        """(specs, combine(values, colour, mu)) of the model at this Metallic."""
        part = Principled(**{**model.params, "metallic": metallic})
        if entry is None:
            return [part.spec], lambda values, colour, mu: values[0]
        if metallic == 1.0:
            found = response(part, "base_color")
            if found is None:
                return None
            specs = [spec for spec in (found.low, found.high, found.coat) if spec is not None]

            def combine(values, colour, mu):
                values = list(values)
                low = values.pop(0) if found.low is not None else None
                high = values.pop(0)
                coat = values.pop(0) if found.coat is not None else None
                return found.combine(low, high, colour, mu, coat)

            return specs, combine
        if metallic == 0.0:
            specs = [Principled(**{**part.params, "base_color": value}).spec
                     for value in (0.0, 1.0)]
            return specs, lambda values, colour, mu: values[0] + np.clip(
                colour, 0.0, 1.0) * (values[1] - values[0])
        return None

    sockets = {"colour": (entry["node"], entry["input"]) if entry else None,
               "metallic": (metal_entry["node"], metal_entry["input"]) if metal_entry
               else None}
    if metal_entry is None:
        found = at_metallic(model.metallic) if model.metallic in (0.0, 1.0) else None
        if found is None:
            return None
        return found[0], lambda values, colour, mu, metallic: found[1](values, colour,
                                                                       mu), sockets
    dielectric, metal = at_metallic(0.0), at_metallic(1.0)
    if dielectric is None or metal is None:
        return None
    count = len(dielectric[0])

    def mixed(values, colour, mu, metallic):
        m = np.clip(np.asarray(metallic, dtype=np.float64), 0.0, 1.0)[:, None]
        return (1.0 - m) * dielectric[1](values[:count], colour, mu) + \
            m * metal[1](values[count:], colour, mu)

    return dielectric[0] + metal[0], mixed, sockets


#: Neighbouring roughness knots of the reference's per-pixel roughness are at most
#: this ratio apart (the lookup's maps: 1.25), and there are at most REFERENCE_KNOTS.
REFERENCE_ROUGHNESS_RATIO = 1.1
REFERENCE_KNOTS = 24


def roughness_weights(roughness):
    """(knots (K,), weights (N, K)): geometric roughness knots spanning the pixels'
    roughness values (N,) at most REFERENCE_ROUGHNESS_RATIO apart, and each pixel's
    linear weights in log roughness on its two neighbouring knots (rows sum to
    1). The reference at each knot, weighed so, follows the texture per pixel to
    second order in the knots' spacing."""
    from .spatial import MIN_ROUGHNESS

    roughness = np.clip(np.asarray(roughness, dtype=np.float64), MIN_ROUGHNESS, 1.0)
    low, high = float(roughness.min()), float(roughness.max())
    count = 1 if high / low < 1.0 + 1e-6 else min(
        REFERENCE_KNOTS,
        max(2, int(np.ceil(np.log(high / low) / np.log(REFERENCE_ROUGHNESS_RATIO))) + 1))
    knots = low * (high / low) ** (np.arange(count) / max(count - 1, 1))
    weights = np.zeros((len(roughness), count))
    if count == 1:
        weights[:, 0] = 1.0
        return knots, weights
    position = np.log(roughness / low) / np.log(high / low) * (count - 1)
    lower = np.clip(np.floor(position).astype(int), 0, count - 2)
    fraction = np.clip(position - lower, 0.0, 1.0)
    rows = np.arange(len(roughness))
    weights[rows, lower] = 1.0 - fraction
    weights[rows, lower + 1] += fraction
    return knots, weights


def spatial_socket(material, kind):
    """(node name, input name) of the input of ``kind`` ("normal": a normal or bump
    map; "roughness": a roughness image of a BSDF alone) the lookup of a From
    Material ``material`` applies per pixel, or None."""
    if material.glossy.model != "MATERIAL":
        return None
    from .material_source import parts as material_parts

    derived = material_parts(material).derived
    entry = (derived.spatial if derived is not None else {}).get(kind)
    return (entry["node"], entry["input"]) if entry else None


def decode_normals(image):
    """(..., 3) unit world normals from a normal pass (:func:`input_pass_material`)."""
    normals = 2.0 * np.asarray(image, dtype=np.float64)[..., :3] - 1.0
    return normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-12)


def input_pass_material(material, socket, kind="colour"):
    """A new material: ``material``'s own nodes (without Glossy's lookup) with their
    Material Output showing, as an Emission of strength 1, what feeds input
    ``socket`` = (node name, input name): a render of it is that input's value per
    pixel (kind "colour"), or the world-space normal n as n / 2 + 1 / 2 (kind
    "normal"; :func:`decode_normals`). None where the link is gone."""
    from .nodes import user_output
    from .spatial import input_socket

    copy = user_copy(material, f"Glossy {kind} pass")
    feed = input_socket(copy, *socket)
    output = user_output(copy)
    if feed is None or output is None:
        bpy.data.materials.remove(copy)
        return None
    emission = copy.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    if kind == "normal":
        encode = copy.node_tree.nodes.new("ShaderNodeVectorMath")
        encode.operation = "MULTIPLY_ADD"
        encode.inputs[1].default_value = (0.5, 0.5, 0.5)
        encode.inputs[2].default_value = (0.5, 0.5, 0.5)
        copy.node_tree.links.new(feed, encode.inputs[0])
        feed = encode.outputs["Vector"]
    copy.node_tree.links.new(feed, emission.inputs["Color"])
    copy.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return copy


def emission_pass_material(material):
    """A new material: ``material``'s own nodes (without Glossy's lookup) with their
    Material Output showing, as an Emission of strength 1, what its shaders emit
    (glossy_addon.emission, the term the lookup adds): a render of it is the
    emitted radiance per pixel, which the NumPy reference adds to the reflection.
    None where nothing emits."""
    from .emission import emission_value, emitters
    from .nodes import _Builder, user_output

    output = user_output(material)
    if output is None or not emitters(output.inputs["Surface"]):
        return None
    copy = user_copy(material, "Glossy emission pass")
    output = user_output(copy)
    from .material_source import parts as material_parts

    derived = material_parts(material).derived
    tint = (derived.spatial if derived is not None else {}).get("coat_tint")
    coat_tint = None
    if tint:
        from .spatial import input_socket
        socket = input_socket(copy, tint["node"], tint["input"])
        coat_tint = (socket, tint["mean"], tint["coat"], tint["ior"]) if socket else None
    emitted = emission_value(_Builder(copy.node_tree), output.inputs["Surface"], coat_tint)
    emission = copy.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    copy.node_tree.links.new(emitted, emission.inputs["Color"])
    copy.node_tree.links.new(emission.outputs[0], output.inputs["Surface"])
    return copy


def radial_tangents(obj, positions, axis="Z"):
    """(N, 3) world tangents of Blender's radial Tangent node about ``axis`` at world
    points (N, 3) of ``obj``: the generated coordinates' offset from the bounding
    box's centre, turned a quarter about the axis in object space (as Cycles'
    node_tangent), carried to world space. The caller orthogonalises against n."""
    matrix = np.array(obj.matrix_world)
    local = (np.linalg.inv(matrix) @ np.c_[positions, np.ones(len(positions))].T).T[:, :3]
    corners = np.array([tuple(c) for c in obj.bound_box])
    low, high = corners.min(axis=0), corners.max(axis=0)
    generated = (local - low) / np.maximum(high - low, 1e-12) - 0.5
    gx, gy, gz = generated.T
    zero = np.zeros_like(gx)
    tangent = {"X": (zero, -gz, gy), "Y": (gz, zero, -gx), "Z": (-gy, gx, zero)}[axis]
    return np.stack(tangent, -1) @ matrix[:3, :3].T


def reference_parts(material):
    """[(bake.brdf model, weight kind)] whose NumPy references add up to the material:
    the glossy BRDF, and the diffuse colour as Lambert, weighted by the dielectric
    Fresnel term of n.v (F glossy + (1 - F) diffuse) when Fresnel IOR > 1."""
    settings = material.glossy
    if settings.model == "MATERIAL":  # the whole read BRDF, diffuse layer included
        from .material_source import parts as material_parts

        return [(brdf.parse(material_parts(material).full_spec), "one")]
    fresnel = settings.fresnel_ior > 1.0
    parts = [(brdf.parse(settings.brdf_spec()), "fresnel" if fresnel else "one")]
    if any(settings.diffuse):
        colour = "/".join(f"{c:g}" for c in settings.diffuse)
        parts.append((brdf.parse(f"lambert:color={colour}"),
                      "one_minus_fresnel" if fresnel else "one"))
    return parts


class SceneChanges:
    """Set attributes and create datablocks for a while; :meth:`restore` undoes all."""

    def __init__(self):
        self._saved = []  # (owner, attribute, original value), first change only
        self._seen = set()
        self._created = []  # (collection, datablock)

    def set(self, owner, attribute, value):
        key = (owner.as_pointer(), attribute)
        if key not in self._seen:
            self._seen.add(key)
            self._saved.append((owner, attribute, getattr(owner, attribute)))
        setattr(owner, attribute, value)

    def original(self, owner, attribute):
        """``owner.attribute`` as it was before the first :meth:`set` of it."""
        key = (owner.as_pointer(), attribute)
        for saved_owner, saved_attribute, value in self._saved:
            if key == (saved_owner.as_pointer(), saved_attribute):
                return value
        return getattr(owner, attribute)

    def created(self, collection, block):
        self._created.append((collection, block))
        return block

    def restore(self):
        for owner, attribute, value in reversed(self._saved):
            try:
                setattr(owner, attribute, value)
            except (ReferenceError, AttributeError, TypeError):
                pass  # the owner was removed meanwhile
        self._saved, self._seen = [], set()
        for collection, block in reversed(self._created):
            try:
                collection.remove(block)
            except (ReferenceError, RuntimeError):
                pass
        self._created = []


def framing_camera(changes, scene, objects):
    """A temporary camera that frames ``objects``' world bounding sphere from the
    front (-Y, slightly above); set as the scene camera. Raises BakeError when
    there is nothing to frame."""
    corners = [obj.matrix_world @ Vector(corner) for obj in objects if obj.type == "MESH"
               for corner in obj.bound_box]
    if not corners:
        raise BakeError("the scene has no camera and no mesh to frame: add a camera")
    centre = sum(corners, Vector()) / len(corners)
    radius = max((c - centre).length for c in corners)
    if radius <= 0:
        raise BakeError("the scene has no camera and the selection has no extent to frame")
    data = changes.created(bpy.data.cameras, bpy.data.cameras.new("Glossy validation camera"))
    camera = changes.created(bpy.data.objects, bpy.data.objects.new(data.name, data))
    scene.collection.objects.link(camera)
    fov = data.angle
    distance = 1.15 * radius / math.sin(0.5 * fov)
    direction = Vector((0.0, -1.0, 0.3)).normalized()
    camera.location = centre + direction * distance
    camera.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    data.clip_start = max(1e-3, 0.01 * distance)
    data.clip_end = 10.0 * (distance + radius)
    changes.set(scene, "camera", camera)
    return camera


def prepare_output(changes, scene, resolution):
    """Float RGBA EXR, the longer side ``resolution`` pixels (the scene's aspect kept),
    no compositor, Standard view (the pixels are the radiance)."""
    render = scene.render
    aspect = (render.resolution_x * render.pixel_aspect_x) / max(
        render.resolution_y * render.pixel_aspect_y, 1e-9)
    width, height = (resolution, max(1, round(resolution / aspect))) if aspect >= 1 else \
        (max(1, round(resolution * aspect)), resolution)
    changes.set(render, "resolution_x", width)
    changes.set(render, "resolution_y", height)
    changes.set(render, "resolution_percentage", 100)
    changes.set(render, "pixel_aspect_x", 1.0)
    changes.set(render, "pixel_aspect_y", 1.0)
    changes.set(render, "use_border", False)
    changes.set(render, "use_compositing", False)
    changes.set(render, "use_sequencer", False)
    changes.set(render, "filepath", render.filepath)
    settings = render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5.0
        changes.set(settings, "media_type", "IMAGE")
    changes.set(settings, "file_format", "OPEN_EXR")
    changes.set(settings, "color_mode", "RGBA")
    changes.set(settings, "color_depth", "32")
    changes.set(settings, "exr_codec", "ZIP")
    changes.set(scene.view_settings, "view_transform", "Standard")
    return width, height


def render_to(scene, path: Path) -> np.ndarray:
    """Render the scene to ``path`` (float EXR); returns (H, W, 3) float64 radiance."""
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    if not path.exists():
        raise BakeError(f"the render wrote no file ({path.name})")
    image, _ = exr.read(path)
    return np.asarray(image[..., :3], dtype=np.float64)


def camera_rays(scene, camera, width, height):
    """Origins and unit directions (H, W, 3) of the rays through the pixel centres
    (row 0 at the top), world space: the rays Cycles traces with a 0.01 px filter."""
    data = camera.data
    top_right, _, bottom_left, top_left = (np.array(c) for c in data.view_frame(scene=scene))
    u = ((np.arange(width) + 0.5) / width)[None, :, None]
    v = ((np.arange(height) + 0.5) / height)[:, None, None]
    points = top_left + u * (top_right - top_left) + v * (bottom_left - top_left)
    matrix = np.array(camera.matrix_world)
    rotation, location = matrix[:3, :3], matrix[:3, 3]
    if data.type == "ORTHO":
        origins = points.copy()
        origins[..., 2] = 0.0
        origins = origins @ rotation.T + location
        directions = np.broadcast_to(-rotation[:, 2], origins.shape).copy()
    else:
        directions = points @ rotation.T
        origins = np.broadcast_to(location, directions.shape).copy()
    directions /= np.linalg.norm(directions, axis=-1, keepdims=True)
    return origins, directions


def _corner_geometry(obj_eval):
    """World vertex positions (V, 3), triangles' corners (T, 3) and vertices (T, 3),
    their polygons (T,) and world corner normals (C, 3) of an evaluated mesh."""
    mesh = obj_eval.data
    mesh.calc_loop_triangles()
    matrix = np.array(obj_eval.matrix_world)
    positions = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", positions)
    positions = positions.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
    count = len(mesh.loop_triangles)
    corners = np.empty(count * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("loops", corners)
    verts = np.empty(count * 3, dtype=np.int64)
    mesh.loop_triangles.foreach_get("vertices", verts)
    polygons = np.empty(count, dtype=np.int64)
    mesh.loop_triangles.foreach_get("polygon_index", polygons)
    normals = np.empty(len(mesh.loops) * 3)
    mesh.corner_normals.foreach_get("vector", normals)
    normals = normals.reshape(-1, 3) @ np.linalg.inv(matrix[:3, :3])  # inverse transpose
    return positions, corners.reshape(-1, 3), verts.reshape(-1, 3), polygons, normals


def pixel_geometry(scene, camera, width, height, objects, slots=False):
    """Per pixel: the number (1..N) of the object of ``objects`` its centre ray meets
    first (0: another object or nothing), the world position there and the shading
    normal (corner normals interpolated over the hit triangle, as Cycles shades a
    smooth mesh): (H, W), (H, W, 3), (H, W, 3); with ``slots``, also the material
    slot index of the face hit (H, W) (-1 where no object of ``objects`` is)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    origins, directions = camera_rays(scene, camera, width, height)
    index = np.zeros((height, width), dtype=int)
    positions = np.zeros((height, width, 3))
    normals = np.zeros((height, width, 3))
    faces = np.full((height, width), -1, dtype=int)
    wanted = {obj.name: number + 1 for number, obj in enumerate(objects)}
    for row in range(height):
        for col in range(width):
            hit, location, face, hit_obj = _camera_hit(scene, depsgraph, origins[row, col],
                                                       directions[row, col])
            if hit and hit_obj.original.name in wanted:
                index[row, col] = wanted[hit_obj.original.name]
                positions[row, col] = location
                faces[row, col] = face
    slot = np.full((height, width), -1, dtype=int)
    for obj in objects:
        pixels = index == wanted[obj.name]
        if pixels.any():
            evaluated = obj.evaluated_get(depsgraph)
            normals[pixels] = _smooth_normals(evaluated, positions[pixels], faces[pixels])
            polygons = evaluated.data.polygons
            material_index = np.zeros(len(polygons), dtype=int)
            polygons.foreach_get("material_index", material_index)
            slot[pixels] = material_index[faces[pixels]]
    if slots:
        return index, positions, normals, slot
    return index, positions, normals


def lamp_visibility(scene, lamps, positions, normals, reach=1e-4):
    """(N, len(lamps)): the fraction of bake.lamp_reference.shadow_rays from each
    point to each lamp, of those above its horizon, that no object casting
    shadows in Cycles blocks (ones for a lamp whose Cast Shadow is off).
    positions, normals: (N, 3) world. Each
    ray starts ``reach`` times the scene's size off the surface along the normal;
    objects hidden from renders or from shadow rays are stepped through."""
    from ..bake.lamp_reference import shadow_rays

    depsgraph = bpy.context.evaluated_depsgraph_get()
    visible = np.ones((len(positions), len(lamps)))
    if not len(positions):
        return visible
    size = float(np.ptp(positions, axis=0).max()) + 1.0
    owners = {obj.name: obj for obj in scene.objects}
    origins = positions + normals * (reach * size)
    for index, lamp in enumerate(lamps):
        owner = owners.get(lamp.name)
        if owner is not None and not owner.data.use_shadow:
            continue
        directions, distances = shadow_rays(lamp, origins)
        distances = np.minimum(distances, 1e30)
        # Rays below the pixel's horizon carry no light (the cosine is 0 there), so
        # the fraction counts those above it: a lamp half below the horizon is not
        # half shadowed.
        above = np.einsum("nkj,nj->nk", directions, normals) > 0.0
        for pixel in np.flatnonzero(above.any(axis=1)):
            rays = np.flatnonzero(above[pixel])
            reached = sum(_unblocked(scene, depsgraph, Vector(origins[pixel]),
                                     Vector(directions[pixel, ray]),
                                     float(distances[pixel, ray]), reach * size)
                          for ray in rays)
            visible[pixel, index] = reached / len(rays)
    return visible


def lamp_ray_test(scene, lamps, reach=1e-4):
    """A bake.lamp_reference ``unblocked`` function: a ray cast from each point
    (moved off the surface along its normal) along each sample's direction, as
    far as the lamp, through the scene's shadow casters (none for a lamp whose
    Cast Shadow is off)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    owners = {obj.name: obj for obj in scene.objects}

    def unblocked(lamp_index, points, normals, directions, distances):
        owner = owners.get(lamps[lamp_index].name)
        if owner is not None and not owner.data.use_shadow:
            return np.ones(directions.shape[:2])
        size = float(np.ptp(points, axis=0).max()) + 1.0
        origins = points + normals * (reach * size)
        out = np.zeros(directions.shape[:2])
        for pixel, row in enumerate(directions):
            origin = Vector(origins[pixel])
            for sample in np.flatnonzero(distances[pixel] > 0.0):
                out[pixel, sample] = _unblocked(scene, depsgraph, origin,
                                                Vector(row[sample]),
                                                float(min(distances[pixel, sample], 1e30)),
                                                reach * size)
        return out

    return unblocked


def _unblocked(scene, depsgraph, origin, direction, distance, step_past):
    """True if no object that casts shadows in Cycles lies on the ray."""
    for _ in range(8):  # step past objects hidden from renders or shadow rays
        hit, location, _, _, obj, _ = scene.ray_cast(depsgraph, origin, direction,
                                                     distance=distance)
        if not hit:
            return True
        original = obj.original
        if not original.hide_render and original.visible_shadow:
            return False
        step = (location - origin).length + step_past
        origin = origin + direction * step
        distance -= step
        if distance <= 0.0:
            return True
    return True


def _camera_hit(scene, depsgraph, origin, direction):
    """(hit, location, face, object) of the first object a camera ray meets that the
    renders show to the camera (objects hidden from renders or from camera rays,
    a shadow caster say, are stepped through)."""
    origin, direction = Vector(origin), Vector(direction)
    for _ in range(8):
        hit, location, _, face, obj, _ = scene.ray_cast(depsgraph, origin, direction)
        if not hit:
            break
        original = obj.original
        if not original.hide_render and original.visible_camera:
            return hit, location, face, obj
        origin = location + direction * 1e-5 * max(1.0, location.length)
    return False, None, -1, None


def _smooth_normals(obj_eval, points, polys):
    """(P, 3) shading normals at world points on the given polygons."""
    verts, corners, tri_verts, polygons, corner_normals = _corner_geometry(obj_eval)
    order = np.argsort(polygons, kind="stable")
    first = np.searchsorted(polygons[order], polys)
    best = np.zeros(len(points), dtype=np.int64)
    best_weights = np.full((len(points), 3), 1.0 / 3.0)
    score = np.full(len(points), -np.inf)
    for offset in range(16):  # the triangles of each hit polygon (an n-gon has n - 2)
        slot = np.minimum(first + offset, len(order) - 1)
        tri = order[slot]
        valid = polygons[tri] == polys
        if not valid.any():
            break
        weights = _barycentric(points, verts[tri_verts[tri]])
        inside = np.min(weights, axis=1)
        better = valid & (inside > score)
        best[better], score[better] = tri[better], inside[better]
        best_weights[better] = weights[better]
    shading = np.einsum("pk,pkj->pj", best_weights, corner_normals[corners[best]])
    return shading / np.maximum(np.linalg.norm(shading, axis=1, keepdims=True), 1e-30)


def _barycentric(points, triangles):
    """(P, 3) barycentric weights of points in triangles (P, 3, 3)."""
    a, b, c = triangles[:, 0], triangles[:, 1], triangles[:, 2]
    v0, v1, v2 = b - a, c - a, points - a
    d00, d01, d11 = np.sum(v0 * v0, 1), np.sum(v0 * v1, 1), np.sum(v1 * v1, 1)
    d20, d21 = np.sum(v2 * v0, 1), np.sum(v2 * v1, 1)
    denominator = d00 * d11 - d01**2
    denominator = np.where(np.abs(denominator) > 1e-30, denominator, 1e-30)
    v = (d11 * d20 - d01 * d21) / denominator
    w = (d00 * d21 - d01 * d20) / denominator
    return np.stack([1.0 - v - w, v, w], axis=1)


def configure_cycles(changes, scene, samples, seed):
    for attribute, value in (("engine", "CYCLES"),):
        changes.set(scene.render, attribute, value)
    cycles = scene.cycles
    for attribute in ("device", "samples", "use_denoising", "blur_glossy", "pixel_filter_type",
                      "filter_width", "sample_clamp_direct", "sample_clamp_indirect",
                      "use_adaptive_sampling", "seed"):
        changes.set(cycles, attribute, getattr(cycles, attribute))
    exact_cycles(scene, samples)
    cycles.seed = seed


def configure_eevee(changes, scene, samples, careful):
    """EEVEE with the scene's own settings and ``samples``; ``careful``: world sun
    extraction off and no indirect clamp, the strongest native EEVEE."""
    changes.set(scene.render, "engine", render_engine("BLENDER_EEVEE"))
    changes.set(scene.eevee, "taa_render_samples", samples)
    # Pixel centres, as the Cycles truth is rendered (exact_cycles: a 0.01 px
    # filter): EEVEE's own 1.5 px film filter would blur a sharp highlight
    # across its neighbours and count the blur as shading error.
    changes.set(scene.render, "filter_size", PIXEL_FILTER)
    # EEVEE packs vertex normals into 10 bits per axis unless asked not to: about
    # 0.1 degree of error, which moves a GGX 0.1 sun highlight by a fraction of
    # a pixel (forest.exr at GGX 0.1: 9.8% against Cycles with packed normals).
    if hasattr(scene.render, "use_high_quality_normals"):
        changes.set(scene.render, "use_high_quality_normals", True)
    if careful:
        if hasattr(scene.eevee, "clamp_surface_indirect"):
            changes.set(scene.eevee, "clamp_surface_indirect", 0.0)
        if scene.world is not None and hasattr(scene.world, "sun_threshold"):
            changes.set(scene.world, "sun_threshold", 0.0)
    # Shadows only where a light casts one: without such a light EEVEE's shadow maps
    # change no pixel (measured: identical to the bit) but cost most of a small
    # render in software GL (a 48 px sphere at 4 samples: 9.5 s with, 2.8 s without).
    changes.set(scene.eevee, "use_shadows", changes.original(scene.eevee, "use_shadows")
                and casts_shadows(scene))



def careful_differs(scene) -> bool:
    """Whether the scene's EEVEE extracts a sun or clamps indirect light."""
    sun = scene.world is not None and getattr(scene.world, "sun_threshold", 0.0) > 0.0
    clamp = getattr(scene.eevee, "clamp_surface_indirect", 0.0) > 0.0
    return sun or clamp
