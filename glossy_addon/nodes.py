"""Shader nodes that reproduce bake.atlas.shade: the 3D-map lookup in EEVEE and Cycles.

Four Closest taps per slice with bilinear weights computed in nodes (EEVEE's
Linear filtering is not exact for computed lookups), two slices blended by
tent weights over mu = n.v, lobe centres turned by each slice's offset read
from the atlas's last column. The material's output is an Emission shader of
strength 1, so EEVEE and Cycles both show the looked-up radiance.
"""

import math

import bpy

from .spatial import COAT, DIELECTRIC, GLOSSY, HIGH, LOW, METAL

GROUP_VERSION = 1


#: Node types of a group interface socket, by the type of the socket it carries.
_INTERFACE_TYPES = {"VALUE": "NodeSocketFloat", "VECTOR": "NodeSocketVector",
                    "RGBA": "NodeSocketColor", "SHADER": "NodeSocketShader",
                    "INT": "NodeSocketInt", "BOOLEAN": "NodeSocketBool"}
#: Custom property on the private node groups a large lookup is split into.
PART_TAG = "glossy_lookup_part"
#: Most nodes a lookup puts in one node tree before it goes on in a new private group
#: (each node edit in Blender 5.0 updates its whole tree, so a tree's build grows with
#: the square of its size: 1000 Math nodes in one tree take 7 s, in ten trees 0.4 s).
PART_NODES = 60


class _Part:
    """One private node group of a split lookup: its tree, its group node in the
    material's tree, its Group Input / Output nodes, the sockets it imports and
    exports ({_Builder._key of the socket: interface socket name}) and its nodes'
    x ({name: x})."""

    def __init__(self, tree, node):
        self.tree, self.node = tree, node
        self.group_in = tree.nodes.new("NodeGroupInput")
        self.group_out = tree.nodes.new("NodeGroupOutput")
        self.imported, self.exported, self.placed = {}, {}, {}


class _Builder:
    """Small helpers that create and link nodes in one node tree.

    With ``split`` (a material's tree, in build_lookup), :meth:`checkpoint` moves
    the building on to a new private node group (:class:`_Part`, its group node in
    the material's tree) once the current tree holds ``split`` nodes; :meth:`link`
    carries a socket of another tree through the groups' interfaces, so the code
    that builds a lookup links sockets as if it were all one tree."""

    def __init__(self, tree, deferred=False, split=None, part_name="Glossy Lookup"):
        """deferred: keep the nodes' x in :attr:`placed` ({node name: x}) for
        :func:`_finish` to set in one call: each ``node.location`` set updates the
        whole tree, so placing the nodes one by one grows with the square of their
        number (a 987-node lookup: seconds)."""
        self.root = tree
        self.tree = tree
        self.x = 0
        self.placed = {} if deferred else None
        self.split = split
        self.part_name = part_name
        self.parts = []
        self._count = 0
        self._pending = False
        self._at_root = False

    @property
    def nodes(self):
        if self._pending and not self._at_root:
            self._new_part()
        return self.tree.nodes

    @property
    def links(self):
        return self.tree.links

    def _place(self, node):
        self._count += 1
        if self.placed is None:
            node.location = (self.x, 0)
        elif node.id_data == self.root:
            self.placed[node.name] = self.x
        else:
            self.parts[-1].placed[node.name] = self.x
        self.x += 30
        return node

    def checkpoint(self):
        """A point between parts of a lookup that only hand sockets forward: with
        ``split``, the next node goes to a new private group once the current tree
        has ``split`` nodes."""
        if self.split is not None and self._count >= self.split and not self._at_root:
            self._pending = True

    def _new_part(self):
        tree = bpy.data.node_groups.new(f".{self.part_name} {len(self.parts) + 1}",
                                        "ShaderNodeTree")
        tree[PART_TAG] = True
        node = self.root.nodes.new("ShaderNodeGroup")
        node.node_tree = tree
        if self.placed is not None:
            self.placed[node.name] = self.x
        self.parts.append(_Part(tree, node))
        self.tree = tree
        self._count = 0
        self._pending = False

    def at_root(self):
        """Context: build in the material's own tree (its output nodes) for a while."""
        builder = self

        class _AtRoot:
            def __enter__(self):
                self.saved = builder.tree, builder._at_root
                builder.tree, builder._at_root = builder.root, True

            def __exit__(self, *exc):
                builder.tree, builder._at_root = self.saved

        return _AtRoot()

    def _part_of(self, tree):
        return next(part for part in self.parts if part.tree == tree)

    @staticmethod
    def _key(socket):
        """A socket by tree, node and identifier: adding a socket to a group's
        interface rebuilds its group nodes' and Group Input's socket lists, so
        neither socket objects nor their pointers may be kept across that."""
        return socket.id_data.name, socket.node.name, socket.identifier

    @staticmethod
    def _interface(part, side, key, socket_type):
        """(name, new): ``part``'s interface socket on ``side`` (``imported`` or
        ``exported``) that carries the socket ``key``; new if it had none."""
        table = getattr(part, side)
        if key in table:
            return table[key], False
        table[key] = f"{side[0]}{len(table)}"
        part.tree.interface.new_socket(table[key], socket_type=_INTERFACE_TYPES[socket_type],
                                       in_out="INPUT" if side == "imported" else "OUTPUT")
        return table[key], True

    def reach(self, socket, tree):
        """``socket`` (of any tree of this lookup, or the material's) as a socket of
        ``tree``: through the group node's outputs and the Group Input's."""
        if socket.id_data == tree:
            return socket
        outer = socket
        if socket.id_data != self.root:  # out of its part, through the group node
            part = self._part_of(socket.id_data)
            name, new = self._interface(part, "exported", self._key(socket), socket.type)
            if new:
                part.tree.links.new(socket, part.group_out.inputs[name])
            outer = part.node.outputs[name]
        if tree == self.root:
            return outer
        part = self._part_of(tree)  # into ``tree``'s part, through its Group Input
        name, new = self._interface(part, "imported", self._key(outer), outer.type)
        if new:
            self.root.links.new(outer, part.node.inputs[name])
        return part.group_in.outputs[name]

    def link(self, socket, target):
        if isinstance(socket, (int, float, tuple)):
            target.default_value = socket
        elif self.parts:
            tree = target.id_data
            tree.links.new(self.reach(socket, tree), target)
        else:
            self.links.new(socket, target)

    def math(self, operation, a, b=None, c=None):
        node = self._place(self.nodes.new("ShaderNodeMath"))
        node.operation = operation
        for index, value in enumerate((a, b, c)):
            if value is not None:
                self.link(value, node.inputs[index])
        return node.outputs[0]

    def vec(self, operation, a, b=None, scale=None):
        node = self._place(self.nodes.new("ShaderNodeVectorMath"))
        node.operation = operation
        self.link(a, node.inputs[0])
        if b is not None:
            self.link(b, node.inputs[1])
        if scale is not None:
            self.link(scale, node.inputs["Scale"])
        outputs = node.outputs
        return outputs["Value"] if operation in ("DOT_PRODUCT", "LENGTH") else outputs["Vector"]

    def separate(self, vector):
        node = self._place(self.nodes.new("ShaderNodeSeparateXYZ"))
        self.link(vector, node.inputs[0])
        return node.outputs[0], node.outputs[1], node.outputs[2]

    def combine(self, x, y, z=0.0):
        node = self._place(self.nodes.new("ShaderNodeCombineXYZ"))
        for socket, value in zip(node.inputs, (x, y, z), strict=True):
            self.link(value, socket)
        return node.outputs[0]

    def select(self, condition, if_true, if_false):
        """condition (0/1) * if_true + (1 - condition) * if_false."""
        difference = self.math("SUBTRACT", if_true, if_false)
        return self.math("MULTIPLY_ADD", condition, difference, if_false)

    def mix(self, weight, a, b):
        """(1 - weight) a + weight b for colours."""
        node = self._place(self.nodes.new("ShaderNodeMix"))
        node.data_type = "RGBA"
        node.blend_type = "MIX"
        self.link(weight, node.inputs["Factor"])
        self.link(a, node.inputs[6])
        self.link(b, node.inputs[7])
        return node.outputs[2]



SLICE_GROUP = f"Glossy Slice Blend v{GROUP_VERSION}"
TAPS_GROUP = f"Glossy Atlas Taps v{GROUP_VERSION}"


def _group(name, inputs, outputs):
    """An empty shader node group with the given float/vector sockets, or None if it exists."""
    if name in bpy.data.node_groups:
        return None
    tree = bpy.data.node_groups.new(name, "ShaderNodeTree")
    for socket_name, kind in inputs:
        tree.interface.new_socket(socket_name, in_out="INPUT", socket_type=kind)
    for socket_name, kind in outputs:
        tree.interface.new_socket(socket_name, in_out="OUTPUT", socket_type=kind)
    tree.nodes.new("NodeGroupInput")
    tree.nodes.new("NodeGroupOutput")
    return tree


def _io(tree):
    group_in = next(n for n in tree.nodes if n.type == "GROUP_INPUT")
    group_out = next(n for n in tree.nodes if n.type == "GROUP_OUTPUT")
    return group_in.outputs, group_out.inputs


def _frame(b, normal, view):
    normal = b.vec("NORMALIZE", normal)
    view = b.vec("NORMALIZE", view)
    mu = b.math("MINIMUM", b.math("MAXIMUM", b.vec("DOT_PRODUCT", normal, view), 0.0), 1.0)
    r = b.vec("NORMALIZE", b.vec("SUBTRACT", b.vec("SCALE", normal, scale=b.math(
        "MULTIPLY", mu, 2.0)), view))
    toward = b.vec("NORMALIZE", b.vec("SUBTRACT", b.vec("SCALE", r, scale=mu), normal))
    return mu, r, toward


def slice_blend_group():
    """Shared group: mu = n.v -> the two slices K0, K1 around it, weight T, and the
    atlas UVs of their offsets (column Offset Column, row (First Slice + k) Stride)
    and of their 2D weights (the next column); slices at mu = k / (K - 1), the
    first at Mu0. First Slice selects a lobe sequence (j K) of a multi-lobe atlas."""
    float_, vector = "NodeSocketFloat", "NodeSocketVector"
    tree = _group(SLICE_GROUP, [("Normal", vector), ("Incoming", vector), ("Slices", float_),
                                ("Mu0", float_), ("Stride", float_), ("Atlas Rows", float_),
                                ("Atlas Cols", float_), ("Offset Column", float_),
                                ("First Slice", float_)],
                  [("K0", float_), ("K1", float_), ("T", float_), ("Offset UV0", vector),
                   ("Offset UV1", vector), ("Weight UV0", vector), ("Weight UV1", vector)])
    if tree is None:
        return bpy.data.node_groups[SLICE_GROUP]
    b = _Builder(tree)
    inputs, outputs = _io(tree)
    count, mu0 = inputs["Slices"], inputs["Mu0"]
    mu, _, _ = _frame(b, inputs["Normal"], inputs["Incoming"])
    last = b.math("SUBTRACT", count, 1.0)
    first = b.math("DIVIDE", 1.0, last)
    linear = b.math("MULTIPLY", mu, last)
    ramp = b.math("MINIMUM", b.math("MAXIMUM", b.math(
        "DIVIDE", b.math("SUBTRACT", mu, mu0), b.math("SUBTRACT", first, mu0)), 0.0), 1.0)
    s = b.select(b.math("GREATER_THAN", mu, b.math("SUBTRACT", first, 1e-7)), linear, ramp)
    k0 = b.math("MINIMUM", b.math("FLOOR", s), last)
    k1 = b.math("MINIMUM", b.math("ADD", k0, 1.0), last)
    rows, cols = inputs["Atlas Rows"], inputs["Atlas Cols"]
    u_offset = b.math("DIVIDE", b.math("ADD", inputs["Offset Column"], 0.5), cols)
    u_weight = b.math("DIVIDE", b.math("ADD", inputs["Offset Column"], 1.5), cols)
    for k, suffix in ((k0, "0"), (k1, "1")):
        base = b.math("MULTIPLY", b.math("ADD", k, inputs["First Slice"]), inputs["Stride"])
        v = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", base, 0.5), rows))
        b.link(b.combine(u_offset, v), outputs["Offset UV" + suffix])
        b.link(b.combine(u_weight, v), outputs["Weight UV" + suffix])
    b.link(k0, outputs["K0"])
    b.link(k1, outputs["K1"])
    b.link(b.math("SUBTRACT", s, k0), outputs["T"])
    return tree


def atlas_taps_group():
    """Shared group: for slice K with offset Offset, the UVs of the four Closest taps
    around the lobe centre in the padded atlas and the bilinear weights FX, FY."""
    float_, vector = "NodeSocketFloat", "NodeSocketVector"
    tree = _group(TAPS_GROUP, [("Normal", vector), ("Incoming", vector), ("K", float_),
                               ("Offset", float_), ("Slices", float_), ("Slice Height", float_),
                               ("Slice Width", float_), ("Atlas Cols", float_)],
                  [("UV00", vector), ("UV01", vector), ("UV10", vector), ("UV11", vector),
                   ("FX", float_), ("FY", float_)])
    if tree is None:
        return bpy.data.node_groups[TAPS_GROUP]
    b = _Builder(tree)
    inputs, outputs = _io(tree)
    height, width = inputs["Slice Height"], inputs["Slice Width"]
    _, r, toward = _frame(b, inputs["Normal"], inputs["Incoming"])
    offset = inputs["Offset"]
    centre = b.vec("NORMALIZE", b.vec("ADD", b.vec("SCALE", r, scale=b.math("COSINE", offset)),
                                      b.vec("SCALE", toward, scale=b.math("SINE", offset))))
    cx, cy, cz = b.separate(centre)
    u = b.math("SUBTRACT", 0.5, b.math("DIVIDE", b.math("ARCTAN2", cy, cx), 2 * math.pi))
    y = b.math("MULTIPLY", b.math("DIVIDE", b.math("ARCCOSINE", b.math(
        "MINIMUM", b.math("MAXIMUM", cz, -1.0), 1.0)), math.pi), height)
    px = b.math("MINIMUM", b.math("MAXIMUM", b.math("MULTIPLY_ADD", u, width, 0.5), 0.0),
                b.math("ADD", width, 1.0))
    low = b.math("MULTIPLY", y, 2.0)
    high = b.math("SUBTRACT", b.math("MULTIPLY", y, 2.0), b.math("SUBTRACT", height, 1.0))
    middle = b.math("ADD", y, 0.5)
    py = b.select(b.math("LESS_THAN", y, 0.5), low,
                  b.select(b.math("GREATER_THAN", y, b.math("SUBTRACT", height, 0.5)), high,
                           middle))
    py = b.math("MINIMUM", b.math("MAXIMUM", py, 0.0), b.math("ADD", height, 1.0))
    x0 = b.math("MINIMUM", b.math("FLOOR", px), width)
    y0 = b.math("MINIMUM", b.math("FLOOR", py), height)
    b.link(b.math("SUBTRACT", px, x0), outputs["FX"])
    b.link(b.math("SUBTRACT", py, y0), outputs["FY"])
    rows = b.math("MULTIPLY", inputs["Slices"], b.math("ADD", height, 2.0))
    cols = inputs["Atlas Cols"]
    base = b.math("MULTIPLY", inputs["K"], b.math("ADD", height, 2.0))
    for dy in (0, 1):
        row = b.math("ADD", base, b.math("ADD", y0, dy))
        v = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", row, 0.5), rows))
        for dx in (0, 1):
            u_tap = b.math("DIVIDE", b.math("ADD", x0, dx + 0.5), cols)
            b.link(b.combine(u_tap, v), outputs[f"UV{dy}{dx}"])
    return tree


def _group_node(b, tree, values):
    node = b._place(b.nodes.new("ShaderNodeGroup"))
    node.node_tree = tree
    for name, value in values.items():
        b.link(value, node.inputs[name])
    return node.outputs


def build_lookup(material, image, meta, diffuse=None, fresnel_ior=0.0, lamps=None,
                 runtime=None, tangent=("RADIAL", "Z"), diffuse_curve=None, spatial=None,
                 roughness_maps=None, map_inputs=None, from_material=False,
                 knot_lights=None):
    """Add the atlas lookup of ``image`` (bake.atlas layout) to ``material`` and make
    it the active Material Output's surface.

    The user's own nodes stay in the tree, untouched (their Material Output is
    made inactive; :func:`strip_lookup` makes it active again); Glossy's nodes
    are tagged (:data:`TAG`) and a re-attach replaces only them.
    The arithmetic lives in two shared, versioned node groups (``Glossy Slice
    Blend v1``, ``Glossy Atlas Taps v1``); the material holds the image taps,
    which shader node groups cannot take as inputs. ``diffuse``: an optional
    (image, meta) irradiance atlas (bake.atlas.pack_irradiance) added on top,
    looked up at the normal. ``fresnel_ior`` > 1 blends them as Heidrich 3.1.1,
    F glossy + (1 - F) diffuse, with Blender's Fresnel node (exact dielectric).
    ``lamps``: (image, meta, lamp objects, diffuse colour) of a bake.separable
    atlas: the lamps' glossy and diffuse terms (glossy_addon.lamps) join the
    environment's before that blend. ``image`` None: lamps only (no environment).
    ``runtime``: (image, meta) of a bake.sampling_runtime texture, sampled per
    pixel along ``tangent`` (("RADIAL", axis) or ("UV_MAP", name), Blender's
    Tangent node) by glossy_addon.sampling_nodes; with ``image`` too, the Hybrid:
    (1 - w) map + w runtime, w(mu) the knots in the runtime meta's
    ``blend_mu`` / ``blend_weight`` (bake.hybrid.blend_curve).
    ``diffuse_curve``: (mu knots (K,), RGB weights (K, 3)) of a layered material
    (glossy_addon.material_source): glossy + weight(n.v) diffuse, the weight read
    by an RGB Curves node with linear (vector) handles.
    ``spatial``: the user's sockets applied per pixel (glossy_addon.spatial):
    {"normal": socket} replaces the geometric normal of every lookup;
    {"glossy" | "diffuse": (colour socket, baked mean (3,))} multiplies that part
    by socket / mean; {"metallic": (socket, baked mean)} multiplies the diffuse
    part by (1 - socket) / (1 - mean). ``roughness_maps``: (roughness socket or
    None, [(roughness or None, key or None, image, meta), ...]): the environment
    lookups of maps baked at roughness knots, blended per pixel by the
    socket's value (:func:`_roughness_blend`), and per knot the maps of
    glossy_addon.spatial.map_variants's keys, combined with ``map_inputs`` =
    {"colour": socket, "responses": {roughness or None:
    bake.colour_response.ColourResponse}, "metallic": socket} (a split colour:
    :func:`_colour_split`; a metallic texture: the maps at Metallic 0 and 1
    mixed by it); ``image`` / ``meta`` are then unused.
    ``from_material``: a From Material bake, whose truth is the user's material:
    add what the user's own shaders emit (a Principled BSDF's Emission,
    Emission shaders added or mixed in; glossy_addon.emission) and mix in a
    Transparent BSDF by its Principled BSDF's Alpha (glossy_addon.transparency).
    ``knot_lights``: (image, meta) of a bake.knot_lights texture: the probe lights
    taken out of the ``roughness_maps``' probe, added to each map at the pixel's
    roughness (the roughness socket's; glossy_addon.sampling_nodes.knot_lights_sum).
    """
    material.use_nodes = True
    tree = material.node_tree
    _remove_lookup(tree)
    user_nodes = {node.name for node in tree.nodes}
    user_output = _user_output(tree)
    if user_output is not None:
        material[USER_OUTPUT] = user_output.name
    spatial = spatial or {}
    b = _Builder(tree, deferred=True, split=PART_NODES, part_name=f"Glossy Lookup {material.name}")
    mean_value = None
    if roughness_maps is not None:
        lights = None
        if knot_lights is not None:
            from .sampling_nodes import knot_lights_sum

            geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
            lights = (*knot_lights, *knot_lights_sum(
                b, *knot_lights, geometry.outputs["Normal"], geometry.outputs["Incoming"],
                roughness_maps[0]))
        if runtime is not None and map_inputs and (
                map_inputs.get("colour") is not None or map_inputs.get("metallic") is not None):
            value, mean_value = _combined_maps(b, *roughness_maps, map_inputs, at_mean=True,
                                               lights=lights)
        else:
            value = _combined_maps(b, *roughness_maps, map_inputs, lights=lights)
    else:
        value = _environment(b, image, meta) if image is not None else None
    if runtime is not None:
        from .sampling_nodes import hybrid_value, runtime_parts, tangent_socket

        b.checkpoint()
        geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
        sampled, lights = runtime_parts(b, *runtime, geometry.outputs["Normal"],
                                        geometry.outputs["Incoming"], tangent_socket(b, tangent))
        if mean_value is not None and value is not None:
            # The runtime texture holds the BRDF at the baked means: scaled per pixel
            # by what the maps' split gives at the pixel's colour over at the means
            # (the same lobe's colour response).
            ratio = b.vec("DIVIDE", value, b.vec("MAXIMUM", mean_value, b.combine(
                1e-8, 1e-8, 1e-8)))
            sampled = b.vec("MULTIPLY", sampled, ratio)
            if lights is not None:
                lights = b.vec("MULTIPLY", lights, ratio)
        value = sampled if value is None else hybrid_value(
            b, runtime[1], geometry.outputs["Normal"], geometry.outputs["Incoming"], value,
            sampled)
        if lights is not None:  # the probe's lights, outside the blend (both parts lack them)
            value = _add(b, value, lights)
    lamp_diffuse = None
    if lamps:
        from .lamps import lamp_terms
        lamp_image, lamp_meta, lamp_objects, diffuse_colour = lamps
        b.checkpoint()
        lamp_glossy, lamp_diffuse = lamp_terms(
            b, lamp_image, lamp_meta, lamp_objects,
            diffuse_colour if diffuse is not None else None, tangent)
        if lamp_glossy is not None:
            value = lamp_glossy if value is None else _add(b, value, lamp_glossy)
    if value is None:
        value = b.combine(0.0, 0.0, 0.0)
    if "glossy" in spatial:
        value = _multiply(b, value, _factor(b, *spatial["glossy"]))
    if diffuse is not None:
        b.checkpoint()
        diffuse_value = _irradiance(b, *diffuse)
        if lamp_diffuse is not None:
            diffuse_value = _add(b, diffuse_value, lamp_diffuse)
        if "diffuse" in spatial:
            diffuse_value = _multiply(b, diffuse_value, _factor(b, *spatial["diffuse"]))
        if "coat_tint" in spatial:
            diffuse_value = _multiply(b, diffuse_value, coat_tint_factor(
                b, *spatial["coat_tint"]))
        if "metallic" in spatial:
            socket, mean = spatial["metallic"]
            weight = b.math("DIVIDE", b.math("SUBTRACT", 1.0, b.math(
                "MINIMUM", b.math("MAXIMUM", socket, 0.0), 1.0)), max(1.0 - float(mean), 1e-3))
            diffuse_value = _multiply(b, diffuse_value, b.combine(weight, weight, weight))
        if diffuse_curve is not None:
            value = _add(b, value, _multiply(b, _view_curve(b, *diffuse_curve), diffuse_value))
        elif fresnel_ior > 1.0:
            fresnel = b._place(b.nodes.new("ShaderNodeFresnel"))
            fresnel.inputs["IOR"].default_value = fresnel_ior
            value = b.mix(fresnel.outputs["Fac"], diffuse_value, value)
        else:
            value = _add(b, value, diffuse_value)
    if from_material and user_output is not None:
        from .emission import emission_value
        b.checkpoint()
        emitted = emission_value(b, user_output.inputs["Surface"], spatial.get("coat_tint"))
        if emitted is not None:  # what the user's shaders emit (glossy_addon.emission)
            value = _add(b, value, emitted)
    with b.at_root():  # the shaders and the output: in the material's own tree
        emission = b._place(b.nodes.new("ShaderNodeEmission"))
        b.link(value, emission.inputs["Color"])
        emission.inputs["Strength"].default_value = 1.0
        surface = emission.outputs[0]
        alpha = None
        if from_material and user_output is not None:
            from .transparency import alpha_input
            alpha = alpha_input(user_output.inputs["Surface"])
        if alpha is not None:  # Cycles: Transparent BSDF x (1 - Alpha), the rest x Alpha
            opacity, inverted = alpha
            if inverted:
                opacity = 1.0 - opacity if isinstance(opacity, float) else \
                    b.math("SUBTRACT", 1.0, opacity)
            transparent = b._place(b.nodes.new("ShaderNodeBsdfTransparent"))
            mix = b._place(b.nodes.new("ShaderNodeMixShader"))
            b.link(opacity, mix.inputs["Fac"])
            b.link(transparent.outputs[0], mix.inputs[1])
            b.link(surface, mix.inputs[2])
            surface = mix.outputs[0]
        output = b._place(b.nodes.new("ShaderNodeOutputMaterial"))
        output.target = "ALL"
        b.link(surface, output.inputs["Surface"])
    _finish(tree, user_nodes, output, spatial.get("normal"), b)
    material["glossy_lookup_version"] = GROUP_VERSION
    return material


#: Custom property on every node Glossy adds to a material (re-attach and
#: strip_lookup remove exactly these).
TAG = "glossy_lookup"
#: Material property: the name of the user's Material Output Glossy made inactive.
USER_OUTPUT = "glossy_user_output"


def is_lookup_node(node) -> bool:
    return bool(node.get(TAG))


def _user_output(tree):
    """The user's Material Output: the active one, else the first (None if none)."""
    outputs = [n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial"
               and not is_lookup_node(n)]
    active = [n for n in outputs if n.is_active_output]
    return (active or outputs or [None])[0]


def user_output(material):
    """The Material Output of the user's own nodes in ``material`` (the one that
    was active before Glossy attached), or None."""
    if not material.use_nodes or material.node_tree is None:
        return None
    tree = material.node_tree
    name = material.get(USER_OUTPUT)
    node = tree.nodes.get(name) if name else None
    if node is not None and not is_lookup_node(node):
        return node
    return _user_output(tree)


def _remove_lookup(tree):
    """Remove Glossy's nodes and the drivers on them (the lamp terms') from ``tree``,
    and the private groups of a split lookup (:data:`PART_TAG`) no material uses
    any more (a copy of the material still does)."""
    lookup = [node for node in tree.nodes if is_lookup_node(node)]
    names = {node.name for node in lookup}
    parts = {node.node_tree.name: node.node_tree for node in lookup
             if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None
             and node.node_tree.get(PART_TAG)}
    data = tree.animation_data
    if data is not None:
        for curve in list(data.drivers):
            path = curve.data_path
            if path.startswith('nodes["') and path[7:path.find('"]')] in names:
                data.drivers.remove(curve)
    for node in lookup:
        tree.nodes.remove(node)
    for group in parts.values():
        if group.users == 0:
            bpy.data.node_groups.remove(group)


def lookup_nodes(material):
    """Every node of ``material``'s lookup: Glossy's nodes in its tree and those in
    the private groups a large lookup is split into (not the shared groups')."""
    if material.node_tree is None:
        return []
    found = []
    for node in material.node_tree.nodes:
        if not is_lookup_node(node):
            continue
        group = getattr(node, "node_tree", None)
        if group is not None and group.get(PART_TAG):
            found.extend(n for n in group.nodes
                         if n.bl_idname not in ("NodeGroupInput", "NodeGroupOutput"))
        else:
            found.append(node)
    return found


def strip_lookup(material) -> bool:
    """Remove Glossy's lookup from ``material`` and make the user's Material Output
    active again; True if the material still has an output of its own."""
    if not material.use_nodes or material.node_tree is None:
        return False
    output = user_output(material)
    _remove_lookup(material.node_tree)
    if USER_OUTPUT in material:
        del material[USER_OUTPUT]
    if output is None:
        return False
    output.is_active_output = True
    return True


def _finish(tree, user_nodes, output, normal=None, builder=None):
    """Tag the nodes added since ``user_nodes``, move them right of the user's
    (``builder``: the deferred _Builder that placed them at y 0, each tree's in
    one ``foreach_set``: node by node, each set updates the whole tree), make
    ``output`` the active one and feed ``normal`` (a socket of the user's nodes)
    to every lookup in place of the geometric normal."""
    import numpy as np

    placed = builder.placed if builder is not None and builder.placed else {}
    parts = builder.parts if builder is not None else []
    nodes = tree.nodes
    locations = np.zeros((len(nodes), 2), np.float32)
    nodes.foreach_get("location", locations.ravel())
    widths = np.zeros(len(nodes), np.float32)
    nodes.foreach_get("width", widths)
    names = [node.name for node in nodes]
    user = np.array([name in user_nodes for name in names], bool)
    right = float((locations[user, 0] + widths[user]).max()) + 400.0 if user.any() else 0.0
    for index, name in enumerate(names):
        if name in placed:
            locations[index] = (placed[name], 0.0)
    locations[~user] += (right, -600.0)
    nodes.foreach_set("location", locations.ravel())
    for part in parts:
        inside = part.tree.nodes
        spots = np.array([part.placed.get(node.name, 0.0) for node in inside], np.float32)
        spots = np.stack([spots - spots.min(), np.zeros_like(spots)], axis=1)
        spots[[node == part.group_out for node in inside], 0] = spots[:, 0].max() + 300.0
        spots[[node == part.group_in for node in inside], 0] = -300.0
        inside.foreach_set("location", spots.ravel())
    for node, is_user in zip(nodes, user, strict=True):
        if not is_user:
            node[TAG] = True
    output.is_active_output = True
    if normal is not None:
        for inner in [tree] + [part.tree for part in parts]:
            for link in list(inner.links):
                if (inner != tree or is_lookup_node(link.from_node)) and \
                        link.from_node.bl_idname == "ShaderNodeNewGeometry" and \
                        link.from_socket.name == "Normal":
                    inner.links.new(builder.reach(normal, inner) if parts else normal,
                                    link.to_socket)


def _factor(b, socket, mean):
    """socket / mean per channel (a colour applied per pixel to a part baked at mean)."""
    return b.vec("DIVIDE", socket, b.combine(*(float(max(c, 1e-6)) for c in mean)))


def _combined_maps(b, roughness, maps, inputs=None, at_mean=False, lights=None):
    """The value of build_lookup's ``roughness_maps`` (see there): per roughness
    knot the map's lookup, or its maps combined (the colour split of the metal's,
    mixed with the map at Metallic 0 by the metallic socket); then the
    roughness blend over the knots (one knot: its value). at_mean: (value, the
    same lookups combined at the baked means of the colour and metallic,
    ``inputs["colour_mean"]`` and ``inputs["metallic_mean"]``, with no coat
    tint texture): what a part baked at those means (the Hybrid's runtime
    texture) is to be scaled by, per pixel and channel, as value / mean value.
    ``lights``: (image, meta, S, Wo) of a bake.knot_lights texture and its sum
    (glossy_addon.sampling_nodes.knot_lights_sum): each map's lookup gets its
    table's rho / A_ss times S before any combination."""
    knots = sorted({r for r, _, _, _ in maps}, key=lambda r: -1.0 if r is None else r)

    def lookup(image, meta, knot, key):
        value = _environment(b, image, meta)
        if lights is None or lights[2] is None:
            return value
        from ..bake.knot_lights import table_index
        from .sampling_nodes import knot_light_scale

        light_image, light_meta, total, wo = lights
        scale = knot_light_scale(b, light_image, light_meta, wo,
                                 table_index(light_meta, knot, key))
        return b.vec("ADD", value, b.vec("MULTIPLY", total, scale))

    lookups = {knot: {key: lookup(image, meta, knot, key)
                      for r, key, image, meta in maps if r == knot} for knot in knots}

    def combined(colour, metallic, tinted):
        values = []
        for knot in knots:
            b.checkpoint()
            found = lookups[knot]
            if None in found or GLOSSY in found:
                value = found.get(None, found.get(GLOSSY))
            else:
                if HIGH in found:
                    value = _colour_split(b, found.get(LOW), found[HIGH], colour,
                                          inputs["responses"][knot], found.get(COAT))
                else:
                    value = found[METAL]
                if DIELECTRIC in found:
                    value = b.mix(b.math("MINIMUM", b.math("MAXIMUM", metallic, 0.0), 1.0),
                                  found[DIELECTRIC], value)
            if tinted and COAT in found:
                # C + T(tint) / T(mean) (V - C): a coat tint texture scales what lies below.
                coat = found[COAT]
                value = b.vec("ADD", coat, b.vec("MULTIPLY", coat_tint_factor(
                    b, *inputs["coat_tint"]), b.vec("SUBTRACT", value, coat)))
            values.append(value)
        if len(knots) == 1:
            return values[0]
        b.checkpoint()
        return _roughness_blend(b, roughness, knots, values)

    inputs = inputs or {}
    value = combined(inputs.get("colour"), inputs.get("metallic"),
                     bool(inputs.get("coat_tint")))
    if not at_mean:
        return value
    colour_mean = inputs.get("colour_mean")
    mean_value = combined(b.combine(*(float(c) for c in colour_mean))
                          if colour_mean is not None else None,
                          float(inputs.get("metallic_mean", 0.0)), False)
    return value, mean_value


def coat_tint_factor(b, tint, mean, coat, ior):
    """T(tint, mu) / T(mean, mu) per channel (vector socket), the factor by which a
    coat tint ``tint`` (the user's socket) changes what lies below a coat baked at
    tint ``mean`` (3,): T = 1 + coat (tint^(1 / cos_t) - 1), cos_t = sqrt(1 - (1 -
    mu^2) / ior^2), mu = n.v (bake.colour_response.coat_tint_factor in NumPy)."""
    geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
    mu = b.math("MINIMUM", b.math("MAXIMUM", b.vec("DOT_PRODUCT", geometry.outputs["Normal"],
                                                   geometry.outputs["Incoming"]), 0.0), 1.0)
    sine = b.math("DIVIDE", b.math("SUBTRACT", 1.0, b.math("MULTIPLY", mu, mu)),
                  float(ior) ** 2)
    cos_t = b.math("SQRT", b.math("MAXIMUM", b.math("SUBTRACT", 1.0, sine), 1e-12))
    exponent = b.math("DIVIDE", 1.0, cos_t)
    power = b.combine(exponent, exponent, exponent)
    one = b.combine(1.0, 1.0, 1.0)

    def weight(t):
        return b.vec("ADD", one, b.vec("SCALE", b.vec("SUBTRACT", b.vec("POWER", t, power),
                                                       one), scale=float(coat)))

    t = b.vec("MINIMUM", b.vec("MAXIMUM", tint, b.combine(0.0, 0.0, 0.0)), one)
    return b.vec("DIVIDE", weight(t), b.vec("MAXIMUM", weight(b.combine(
        *(float(c) for c in mean))), b.combine(1e-6, 1e-6, 1e-6)))


def _colour_split(b, low, high, colour, found, coat=None):
    """C + W(mu) (low + c (high - low)) m(c, mu) per channel, c the user's colour
    clamped to [0, 1] (``low`` None: a black map), C the ``coat`` lookup and
    W(mu) an RGB curve of
    ``found.under`` (C = 0, W = 1 without a coat), and m the Multiscatter
    energy term of ``found`` (a bake.colour_response.ColourResponse, whose
    ``combine`` is this in NumPy):
    m = 1 + Fms (1 / E(mu) - 1), Fms = Fss E_avg / (1 - Fss (1 - E_avg)),
    Fss = offset + slope c, E(mu) an RGB curve over mu = n.v."""
    c = b.vec("MINIMUM", b.vec("MAXIMUM", colour, b.combine(0.0, 0.0, 0.0)),
              b.combine(1.0, 1.0, 1.0))
    value = b.vec("MULTIPLY", c, high) if low is None else \
        b.vec("ADD", low, b.vec("MULTIPLY", c, b.vec("SUBTRACT", high, low)))
    if found.multiscatter:
        value = b.vec("MULTIPLY", value, _energy_term(b, c, found))
    if coat is None:
        return value
    under = _view_curve(b, found.mu, [[float(w) for w in row] for row in found.under])
    return b.vec("ADD", coat, b.vec("MULTIPLY", under, value))


def _energy_term(b, c, found):
    """m(c, mu) of :func:`_colour_split` (vector socket)."""
    one = b.combine(1.0, 1.0, 1.0)
    albedo = b.vec("MAXIMUM", _view_curve(b, found.mu, [[float(e)] * 3 for e in found.albedo]),
                   b.combine(1e-6, 1e-6, 1e-6))
    fss = b.vec("ADD", b.vec("MULTIPLY", c, b.combine(*map(float, found.slope))),
                b.combine(*map(float, found.offset)))
    fms = b.vec("DIVIDE", b.vec("SCALE", fss, scale=found.average),
                b.vec("SUBTRACT", one, b.vec("SCALE", fss, scale=1.0 - found.average)))
    return b.vec("ADD", one, b.vec("MULTIPLY", fms, b.vec("SUBTRACT", b.vec(
        "DIVIDE", one, albedo), one)))


def _roughness_blend(b, roughness, knots, values):
    """Lookups ``values`` of maps baked at ascending roughnesses ``knots``, blended
    per pixel by the ``roughness`` socket (clamped to their range): between knots
    r0 < r1, the geometric blend L0^(1 - t) L1^t per channel with t linear in
    log r (glossy_addon.spatial: three times closer to a map baked at r than a
    linear blend where a bright light's peak grows as the lobe narrows)."""
    knots = [float(r) for r in knots]
    r = b.math("MINIMUM", b.math("MAXIMUM", roughness, knots[0]), knots[-1])
    log_r = b.math("LOGARITHM", r, math.e)
    value = values[0]
    for k in range(1, len(knots)):
        t = b.math("MINIMUM", b.math("MAXIMUM", b.math("DIVIDE", b.math(
            "SUBTRACT", log_r, math.log(knots[k - 1])), math.log(knots[k] / knots[k - 1])),
            0.0), 1.0)
        keep = b.math("SUBTRACT", 1.0, t)
        value = b.vec("MULTIPLY", b.vec("POWER", b.vec("MAXIMUM", value, b.combine(
            *(GEOMETRIC_FLOOR,) * 3)), b.combine(keep, keep, keep)), b.vec("POWER", b.vec(
                "MAXIMUM", values[k], b.combine(*(GEOMETRIC_FLOOR,) * 3)), b.combine(t, t, t)))
    return value


#: Radiance below this is taken as this in the geometric roughness blend (log of 0).
GEOMETRIC_FLOOR = 1e-6


def _add(b, a, c):
    return _mix_rgb(b, "ADD", a, c)


def _multiply(b, a, c):
    return _mix_rgb(b, "MULTIPLY", a, c)


def _mix_rgb(b, blend_type, a, c):
    node = b._place(b.nodes.new("ShaderNodeMix"))
    node.data_type = "RGBA"
    node.blend_type = blend_type
    node.inputs["Factor"].default_value = 1.0
    b.link(a, node.inputs[6])
    b.link(c, node.inputs[7])
    return node.outputs[2]


def _view_curve(b, mu, weights):
    """RGB weights at mu = n.v (clamped to [0, 1]) from knots: an RGB Curves node fed
    (mu, mu, mu), one piecewise-linear curve per channel, the combined curve identity."""
    geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
    mu_socket = b.math("MAXIMUM", b.vec("DOT_PRODUCT", geometry.outputs["Normal"],
                                        geometry.outputs["Incoming"]), 0.0)
    node = b._place(b.nodes.new("ShaderNodeRGBCurve"))
    node.inputs["Fac"].default_value = 1.0
    b.link(b.combine(mu_socket, mu_socket, mu_socket), node.inputs["Color"])
    mapping = node.mapping
    mapping.use_clip = True
    for channel in range(3):
        curve = mapping.curves[channel]
        while len(curve.points) > 2:
            curve.points.remove(curve.points[-1])
        curve.points[0].location = (float(mu[0]), float(weights[0][channel]))
        curve.points[1].location = (float(mu[-1]), float(weights[-1][channel]))
        for x, row in zip(mu[1:-1], weights[1:-1], strict=True):
            curve.points.new(float(x), float(row[channel]))
        for point in curve.points:
            point.handle_type = "VECTOR"
    mapping.update()
    return node.outputs["Color"]


def _tap(b, uv, source):
    node = b._place(b.nodes.new("ShaderNodeTexImage"))
    node.image = source
    node.interpolation = "Closest"
    node.extension = "EXTEND"
    b.link(uv, node.inputs["Vector"])
    return node.outputs["Color"]


def _environment(b, image, meta):
    """The 3D/2D map lookup of the environment (colour socket)."""
    count = int(meta["slices"])
    height, width = int(meta["slice_height"]), int(meta["slice_width"])
    two_d = meta.get("mode") == "atlas2d"
    mus = [float(m) for m in meta["mu"]]
    if count < 2 or any(abs(mus[k] - k / (count - 1)) > 1e-9 for k in range(1, count)):
        raise ValueError("the atlas's slices must sit at mu = k / (K - 1)")
    b.checkpoint()
    geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
    normal, view = geometry.outputs["Normal"], geometry.outputs["Incoming"]
    lobes = 1 if two_d else int(meta.get("lobes", 1))
    atlas_cols = float(width + (4 if two_d else 3))
    atlas_slices = 1 if two_d else count * lobes
    sizes = {"Slices": float(atlas_slices), "Slice Height": float(height),
             "Slice Width": float(width), "Atlas Cols": atlas_cols}

    def tap(uv, source=image):
        return _tap(b, uv, source)

    def blend(kind, a, c):
        node = b._place(b.nodes.new("ShaderNodeMix"))
        node.data_type = "RGBA"
        node.blend_type = kind
        node.inputs["Factor"].default_value = 1.0
        b.link(a, node.inputs[6])
        b.link(c, node.inputs[7])
        return node.outputs[2]

    value = None
    for lobe in range(lobes):  # a multi-lobe fit: one lookup per lobe sequence, summed
        first = float(lobe * count)
        slice_blend = _group_node(b, slice_blend_group(), {
            "Normal": normal, "Incoming": view, "Slices": float(count), "Mu0": mus[0],
            "Stride": 1.0 if two_d else float(height + 2),
            "Atlas Rows": float(atlas_slices * (height + 2)) if not two_d else float(height + 2),
            "Atlas Cols": atlas_cols, "Offset Column": float(width + 2), "First Slice": first})
        values = []
        for suffix in ("0", "1"):
            offset = b.separate(tap(slice_blend["Offset UV" + suffix]))[0]
            k = 0.0 if two_d else b.math("ADD", slice_blend["K" + suffix], first)
            taps = _group_node(b, atlas_taps_group(), {
                "Normal": normal, "Incoming": view, "K": k, "Offset": offset, **sizes})
            top = b.mix(taps["FX"], tap(taps["UV00"]), tap(taps["UV01"]))
            bottom = b.mix(taps["FX"], tap(taps["UV10"]), tap(taps["UV11"]))
            sample = b.mix(taps["FY"], top, bottom)
            if two_d:  # one map, scaled by the slice's weight k(theta_o)
                sample = blend("MULTIPLY", sample, tap(slice_blend["Weight UV" + suffix]))
            values.append(sample)
        lobe_value = b.mix(slice_blend["T"], values[0], values[1])
        value = lobe_value if value is None else blend("ADD", value, lobe_value)
    return value


def _irradiance(b, diffuse_image, diffuse_meta):
    """The irradiance atlas looked up at the normal (colour socket)."""
    geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
    normal, view = geometry.outputs["Normal"], geometry.outputs["Incoming"]
    # Offset -acos(mu) turns r onto the normal: the irradiance lookup.
    mu = b.math("MINIMUM", b.math("MAXIMUM", b.vec("DOT_PRODUCT", b.vec("NORMALIZE", normal),
                                                   b.vec("NORMALIZE", view)), 0.0), 1.0)
    offset = b.math("MULTIPLY", b.math("ARCCOSINE", mu), -1.0)
    taps = _group_node(b, atlas_taps_group(), {
        "Normal": normal, "Incoming": view, "K": 0.0, "Offset": offset, "Slices": 1.0,
        "Slice Height": float(diffuse_meta["slice_height"]),
        "Slice Width": float(diffuse_meta["slice_width"]),
        "Atlas Cols": float(diffuse_meta["slice_width"] + 3)})
    top = b.mix(taps["FX"], _tap(b, taps["UV00"], diffuse_image),
                _tap(b, taps["UV01"], diffuse_image))
    bottom = b.mix(taps["FX"], _tap(b, taps["UV10"], diffuse_image),
                   _tap(b, taps["UV11"], diffuse_image))
    return b.mix(taps["FY"], top, bottom)


def load_atlas(path, meta_name=None, precision="float32"):
    """Load (or reuse) the atlas EXR as a Non-Color float image.

    precision: the atlas meta's ``precision``; a ``float32`` atlas (one
    brighter than a half float holds, or a diffuse map) stays 32-bit on the
    GPU (Blender's default uploads float images as half floats).
    """
    image = bpy.data.images.load(str(path), check_existing=True)
    image.colorspace_settings.name = "Non-Color"
    image.use_half_precision = precision == "half"
    image.reload()  # a re-bake rewrote the file (or restored a missing one)
    return image
