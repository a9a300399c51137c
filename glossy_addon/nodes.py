"""Shader nodes that reproduce bake.atlas.shade: the 3D-map lookup in EEVEE and Cycles.

Four Closest taps per slice with bilinear weights computed in nodes (EEVEE's
Linear filtering is not exact for computed lookups), two slices blended by
tent weights over mu = n.v, lobe centres turned by each slice's offset read
from the atlas's last column. The material's output is an Emission shader of
strength 1, so EEVEE and Cycles both show the looked-up radiance.
"""

import math

import bpy

GROUP_VERSION = 1


class _Builder:
    """Small helpers that create and link nodes in one node tree."""

    def __init__(self, tree):
        self.tree = tree
        self.nodes = tree.nodes
        self.links = tree.links
        self.x = 0

    def _place(self, node):
        node.location = (self.x, 0)
        self.x += 30
        return node

    def link(self, socket, target):
        if isinstance(socket, (int, float)):
            target.default_value = socket
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

    def tap(self, image, u, v):
        node = self._place(self.nodes.new("ShaderNodeTexImage"))
        node.image = image
        node.interpolation = "Closest"
        node.extension = "EXTEND"
        self.link(self.combine(u, v), node.inputs["Vector"])
        return node.outputs["Color"]


def build_lookup(material, image, meta):
    """Replace ``material``'s nodes by the atlas lookup of ``image`` (bake.atlas layout)."""
    count = int(meta["slices"])
    height, width = int(meta["slice_height"]), int(meta["slice_width"])
    rows, cols = count * (height + 2), width + 3
    mus = [float(m) for m in meta["mu"]]
    if count < 2 or any(abs(mus[k] - k / (count - 1)) > 1e-9 for k in range(1, count)):
        raise ValueError("the atlas's slices must sit at mu = k / (K - 1)")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    b = _Builder(tree)
    geometry = b._place(tree.nodes.new("ShaderNodeNewGeometry"))
    normal = b.vec("NORMALIZE", geometry.outputs["Normal"])
    view = b.vec("NORMALIZE", geometry.outputs["Incoming"])
    mu = b.math("MINIMUM", b.math("MAXIMUM", b.vec("DOT_PRODUCT", normal, view), 0.0), 1.0)
    r = b.vec("NORMALIZE", b.vec("SUBTRACT", b.vec("SCALE", normal, scale=b.math(
        "MULTIPLY", mu, 2.0)), view))
    toward = b.vec("NORMALIZE", b.vec("SUBTRACT", b.vec("SCALE", r, scale=mu), normal))
    # s: position of mu among the slice nodes (the first node sits at mus[0]).
    first = 1.0 / (count - 1)
    linear = b.math("MULTIPLY", mu, count - 1)
    ramp = b.math("MINIMUM", b.math("MAXIMUM", b.math("DIVIDE", b.math("SUBTRACT", mu, mus[0]),
                                                           first - mus[0]), 0.0), 1.0)
    s = b.select(b.math("GREATER_THAN", mu, first - 1e-7), linear, ramp)
    k0 = b.math("MINIMUM", b.math("FLOOR", s), count - 1)
    k1 = b.math("MINIMUM", b.math("ADD", k0, 1.0), count - 1)
    t = b.math("SUBTRACT", s, k0)

    def slice_value(k):
        base = b.math("MULTIPLY", k, height + 2)  # atlas row of the slice's top
        offset_v = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", base, 0.5), rows))
        offset = b.separate(b.tap(image, (cols - 0.5) / cols, offset_v))[0]
        centre = b.vec("NORMALIZE", b.vec("ADD", b.vec("SCALE", r, scale=b.math("COSINE", offset)),
                                          b.vec("SCALE", toward, scale=b.math("SINE", offset))))
        cx, cy, cz = b.separate(centre)
        u = b.math("SUBTRACT", 0.5, b.math("DIVIDE", b.math("ARCTAN2", cy, cx), 2 * math.pi))
        y = b.math("MULTIPLY", b.math("ARCCOSINE", b.math("MINIMUM", b.math("MAXIMUM", cz, -1.0),
                                                          1.0)), height / math.pi)
        px = b.math("MINIMUM", b.math("MAXIMUM", b.math("MULTIPLY_ADD", u, width, 0.5), 0.0),
                    width + 1.0)
        low = b.math("MULTIPLY", y, 2.0)
        high = b.math("SUBTRACT", b.math("MULTIPLY", y, 2.0), height - 1.0)
        middle = b.math("ADD", y, 0.5)
        py = b.select(b.math("LESS_THAN", y, 0.5), low,
                      b.select(b.math("GREATER_THAN", y, height - 0.5), high, middle))
        py = b.math("MINIMUM", b.math("MAXIMUM", py, 0.0), height + 1.0)
        x0 = b.math("MINIMUM", b.math("FLOOR", px), float(width))
        y0 = b.math("MINIMUM", b.math("FLOOR", py), float(height))
        fx, fy = b.math("SUBTRACT", px, x0), b.math("SUBTRACT", py, y0)
        taps = []
        for dy in (0, 1):
            row = b.math("ADD", base, b.math("ADD", y0, dy))
            v = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", row, 0.5), rows))
            for dx in (0, 1):
                u_tap = b.math("DIVIDE", b.math("ADD", x0, dx + 0.5), cols)
                taps.append(b.tap(image, u_tap, v))
        top = b.mix(fx, taps[0], taps[1])
        bottom = b.mix(fx, taps[2], taps[3])
        return b.mix(fy, top, bottom)

    value = b.mix(t, slice_value(k0), slice_value(k1))
    emission = b._place(tree.nodes.new("ShaderNodeEmission"))
    b.link(value, emission.inputs["Color"])
    emission.inputs["Strength"].default_value = 1.0
    output = b._place(tree.nodes.new("ShaderNodeOutputMaterial"))
    b.link(emission.outputs[0], output.inputs["Surface"])
    material["glossy_lookup_version"] = GROUP_VERSION
    return material


def load_atlas(path, meta_name=None):
    """Load (or reuse) the atlas EXR as a Non-Color float image."""
    image = bpy.data.images.load(str(path), check_existing=True)
    image.colorspace_settings.name = "Non-Color"
    image.reload()  # a re-bake rewrote the file (or restored a missing one)
    return image
