"""Reading the world's environment image into NumPy."""

import os
from collections import OrderedDict

import numpy as np

from .image_colour import linear_rgb

#: World digests (bake.world_lights.digest) of this session by what identifies an
#: image's pixels without reading them (_pixels_signature); at most _DIGESTS_KEPT.
_DIGESTS: "OrderedDict[tuple, str]" = OrderedDict()
_DIGESTS_KEPT = 8


def find_environment_image(world):
    """The image of the Environment Texture node feeding the world output, or None.

    Walks back from the active World Output's Surface input so that a
    disconnected Environment Texture elsewhere in the tree is ignored; falls
    back to the only Environment Texture node when there is exactly one.
    """
    if world is None or not world.use_nodes or world.node_tree is None:
        return None
    tree = world.node_tree
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    active = [n for n in outputs if getattr(n, "is_active_output", False)] or outputs
    seen, stack = set(), [n for n in active]
    while stack:
        node = stack.pop()
        if node.name in seen:
            continue
        seen.add(node.name)
        if node.type == "TEX_ENVIRONMENT" and node.image is not None:
            return node.image
        for socket in node.inputs:
            stack.extend(link.from_node for link in socket.links)
    candidates = [n for n in tree.nodes if n.type == "TEX_ENVIRONMENT" and n.image is not None]
    return candidates[0].image if len(candidates) == 1 else None


def image_pixels(image) -> np.ndarray:
    """Linear float32 pixels (H, W, 3) of a Blender image, row 0 at the top.

    Blender stores pixels bottom row first as RGBA floats; float images
    (EXR, HDR) are scene-linear already, an 8/16-bit sRGB image (PNG, JPEG)
    is decoded (image_colour.linear_rgb); another colour space of such an
    image raises ValueError.
    """
    width, height = image.size
    if width == 0 or height == 0:
        raise ValueError(f"image '{image.name}' has no pixels (missing file?)")
    channels = image.channels
    buffer = np.empty(width * height * channels, dtype=np.float32)
    image.pixels.foreach_get(buffer)
    pixels = buffer.reshape(height, width, channels)[::-1]
    rgb = pixels[:, :, :3] if channels >= 3 else np.repeat(pixels[:, :, :1], 3, axis=2)
    return np.ascontiguousarray(linear_rgb(rgb, image, strict=True), dtype=np.float32)


def _pixels_signature(image):
    """What identifies ``image``'s pixels without reading them, or None where nothing
    does: its session id, size, channels, colour space and alpha mode, and the
    file it was loaded from (path, size, modification time). None for an image
    with unsaved pixel edits (``is_dirty``: set by painting and by writing
    ``pixels``), a packed, generated or movie image, or a file that is gone."""
    import bpy

    if image.is_dirty or image.source != "FILE" or image.packed_file is not None:
        return None
    try:
        path = bpy.path.abspath(image.filepath_raw, library=image.library)
        stat = os.stat(path)
    except (OSError, ValueError):
        return None
    return (image.session_uid, image.name, tuple(image.size), image.channels, image.is_float,
            image.colorspace_settings.name, image.alpha_mode, os.path.realpath(path),
            stat.st_size, stat.st_mtime_ns)


#: The last unedited world image's pixels read this session: (signature, pixels).
_PIXELS: list = [None, None]


def world_pixels(image) -> np.ndarray:
    """:func:`image_pixels` of ``image``, read-only, kept for the session while the image
    is unedited (:func:`_pixels_signature`; only the last image read, an 8192 x 4096
    world's 400 MB): the capture reads the world once for its detail, its cube and
    its digest, and the bake after it (which measures the lights on the world's
    texels) does not read it again (0.5-1 s for an 8k world here)."""
    signature = _pixels_signature(image)
    if signature is not None and _PIXELS[0] == signature:
        return _PIXELS[1]
    pixels = image_pixels(image)
    pixels.flags.writeable = False
    _PIXELS[:] = [signature, pixels] if signature is not None else [None, None]
    return pixels


def world_digest(image, pixels=None) -> str:
    """bake.world_lights.digest of ``image``'s pixels (:func:`image_pixels`, read here
    when ``pixels`` is None), kept for the session by :func:`_pixels_signature`:
    the capture records it and the bake that checks it (an 8192 x 4096 world
    takes 0.4 s to hash here) asks again for the same unchanged image."""
    from ..bake import world_lights

    signature = _pixels_signature(image)
    if signature is not None and signature in _DIGESTS:
        _DIGESTS.move_to_end(signature)
        return _DIGESTS[signature]
    found = world_lights.digest(world_pixels(image) if pixels is None else pixels)
    if signature is not None:
        _DIGESTS[signature] = found
        while len(_DIGESTS) > _DIGESTS_KEPT:
            _DIGESTS.popitem(last=False)
    return found


class WorldNotReadable(ValueError):
    """The world's shader is one World Only cannot resample (the message says why)."""


def _single_link(socket):
    links = [link for link in socket.links if getattr(link, "is_valid", True)
             and not getattr(link, "is_muted", False)]
    return links[0] if links else None


def _source(socket):
    """(node, output socket) that feeds ``socket`` as Blender evaluates it: through
    reroutes and muted nodes (their internal links), or (None, None) when nothing
    does (an unlinked input, or a muted node that passes nothing on)."""
    link = _single_link(socket)
    while link is not None:
        node, output = link.from_node, link.from_socket
        if node.type != "REROUTE" and not node.mute:
            return node, output
        inner = node.inputs[0] if node.type == "REROUTE" else next(
            (inner_link.from_socket for inner_link in node.internal_links
             if inner_link.to_socket == output), None)
        link = _single_link(inner) if inner is not None else None
    return None, None


def _unlinked_value(node, name):
    socket = node.inputs[name]
    source, _ = _source(socket)
    if source is not None:
        raise WorldNotReadable(f"the world's {node.name} has its {name} linked to "
                               f"'{source.name}'")
    return socket.default_value


def _mapping_of(env_node):
    """(vector_type, location, rotation, scale) of the Mapping node feeding the
    Environment Texture's Vector (the identity when it is unlinked or fed
    straight by Texture Coordinate's Generated or Object output)."""
    identity = ("POINT", (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    node, output = _source(env_node.inputs["Vector"])
    if node is None:
        return identity
    if node.type != "MAPPING":
        _check_coordinates(node, output)
        return identity
    into, into_output = _source(node.inputs["Vector"])
    if into is None:
        raise WorldNotReadable(f"the world's {node.name} has no Vector input (every "
                               "direction would show one texel)")
    _check_coordinates(into, into_output)
    values = [tuple(_unlinked_value(node, name)) if name in node.inputs else default
              for name, default in (("Location", identity[1]), ("Rotation", identity[2]),
                                    ("Scale", identity[3]))]
    if node.vector_type in ("VECTOR", "NORMAL"):
        values[0] = identity[1]  # these types have no Location
    return (node.vector_type, *values)


def _check_coordinates(node, output):
    if node.type != "TEX_COORD" or output.name not in ("Generated", "Object") \
            or getattr(node, "object", None) is not None:
        raise WorldNotReadable(f"the world's Environment Texture is looked up through "
                               f"'{node.name}' ({output.name}); World Only reads Texture "
                               "Coordinate's Generated or Object output, optionally "
                               "through one Mapping node")


def _background_of(world):
    """The Background node feeding the active World Output's Surface."""
    tree = world.node_tree
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_WORLD"]
    active = [n for n in outputs if getattr(n, "is_active_output", False)] or outputs
    if not active:
        raise WorldNotReadable("the world has no World Output node")
    node, _ = _source(active[0].inputs["Surface"])
    while node is not None and node.type == "MIX_SHADER":
        # The common "camera sees a plain colour" set-up: Fac from Light Path's
        # Is Camera Ray, which is 0 for every ray a probe or a reflection sees,
        # so they see the first shader.
        fac, fac_output = _source(node.inputs[0])
        if fac is None or fac.type != "LIGHT_PATH" or fac_output.name != "Is Camera Ray":
            raise WorldNotReadable(f"the world's Surface is mixed by '{node.name}' (World "
                                   "Only follows a Mix Shader only when Light Path's Is "
                                   "Camera Ray drives it)")
        node, _ = _source(node.inputs[1])
    if node is None or node.type != "BACKGROUND":
        name = f"'{node.name}'" if node is not None else "nothing"
        raise WorldNotReadable(f"the world's Surface comes from {name}, not a Background "
                               "node")
    return node


def world_environment(world):
    """(image, bake.world_mapping.WorldMapping) of a world World Only can resample:
    World Output <- Background (an unlinked Strength) <- Environment Texture
    (equirectangular) <- optionally a Mapping node <- Texture Coordinate
    (Generated or Object), through reroutes and muted nodes as Blender passes
    them, and a Mix Shader driven by Light Path's Is Camera Ray (its first
    shader: what every non-camera ray sees). Raises WorldNotReadable, naming
    the node, for any other world: its probe would not be what Cycles renders."""
    from ..bake.errors import BakeError
    from ..bake.world_mapping import WorldMapping

    if world is None or not world.use_nodes or world.node_tree is None:
        raise WorldNotReadable("the scene's world has no shader nodes")
    background = _background_of(world)
    strength = float(_unlinked_value(background, "Strength"))
    env, output = _source(background.inputs["Color"])
    if env is None or env.type != "TEX_ENVIRONMENT" or output.name != "Color":
        name = f"'{env.name}'" if env is not None else "nothing"
        raise WorldNotReadable(f"the world's Background colour comes from {name}, not an "
                               "Environment Texture's Color")
    if env.image is None:
        raise WorldNotReadable(f"the world's {env.name} has no image")
    if env.projection != "EQUIRECTANGULAR":
        raise WorldNotReadable(f"the world's {env.name} uses the {env.projection.lower()} "
                               "projection; World Only reads equirectangular images")
    vector_type, location, rotation, scale = _mapping_of(env)
    try:
        return env.image, WorldMapping(vector_type, tuple(location), tuple(rotation),
                                       tuple(scale), strength)
    except BakeError as error:
        raise WorldNotReadable(str(error)) from None


def world_cube(world, size: int) -> np.ndarray:
    """(size, 6 size, 3) float32: the world resampled to a Glossy cube (DESIGN.md's
    layout) as Cycles shows it to reflection rays: its Environment Texture's image
    (:func:`world_pixels`) through the Mapping node, times the Background's
    Strength, each texel the mean radiance over its solid angle
    (bake.envmap.convert), so a sun far smaller than a texel keeps its energy.
    Raises WorldNotReadable for a world :func:`world_environment` cannot read.

    The last cube made is kept for the session while its image is unedited
    (:func:`_pixels_signature`), with the same Mapping, Strength and size: an EEVEE
    capture in the UI asks once per face. Each call returns its own copy."""
    import json

    from ..bake import envmap

    image, mapping = world_environment(world)
    signature = _pixels_signature(image)
    key = None if signature is None else \
        (signature, json.dumps(mapping.to_meta(), sort_keys=True), int(size))
    if key is not None and _CUBE[0] == key:
        return _CUBE[1].copy()
    transform = mapping.texture_directions if mapping.moves_directions else None
    pixels = world_pixels(image)
    world_digest(image, pixels)  # kept for the probe's metadata and the bake (unchanged image)
    cube = None
    if transform is None:  # the probe Auto's measure made at this face, if it did
        from ..bake import probe_detail

        cube = probe_detail.measured_probe(pixels, size)
    if cube is None:
        cube = envmap.convert(pixels, "latlong", "cube", int(size), transform=transform)
    if mapping.strength != 1.0:
        cube *= np.float32(mapping.strength)
    _CUBE[:] = [key, cube.copy()] if key is not None else [None, None]
    return cube


#: The last world cube :func:`world_cube` made: (key, cube).
_CUBE: list = [None, None]


class CameraRayMixesOpen:
    """For a capture: the world's Mix Shaders driven by Light Path's Is Camera Ray
    show their first shader, as they do to every ray a probe stands for.

    A probe's face is rendered with camera rays, so a world that shows the camera
    a plain colour (the common Is Camera Ray set-up) would put that colour in the
    probe, where reflections see the HDRI. Inside the ``with`` block those links
    are cut and each Fac set to 0; on exit the links and Fac values come back.
    """

    def __init__(self, world):
        self.world = world
        self._cut = []

    def __enter__(self):
        world = self.world
        if world is None or not world.use_nodes or world.node_tree is None:
            return self
        tree = world.node_tree
        for node in tree.nodes:
            if node.type != "MIX_SHADER":
                continue
            link = _single_link(node.inputs[0])
            if node.mute or link is None or link.from_node.type != "LIGHT_PATH" \
                    or link.from_socket.name != "Is Camera Ray":
                continue
            self._cut.append((node.name, link.from_node.name, link.from_socket.identifier,
                              node.inputs[0].default_value))
            tree.links.remove(link)
            node.inputs[0].default_value = 0.0
        return self

    def __exit__(self, *exc):
        if not self._cut:
            return False
        tree = self.world.node_tree
        for mix_name, path_name, identifier, fac in reversed(self._cut):
            mix, path = tree.nodes.get(mix_name), tree.nodes.get(path_name)
            if mix is None or path is None:
                continue
            mix.inputs[0].default_value = fac
            output = next(s for s in path.outputs if s.identifier == identifier)
            tree.links.new(output, mix.inputs[0])
        self._cut = []
        return False
