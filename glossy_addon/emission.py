"""The user's emission, kept in the attached lookup.

Glossy's lookup replaces the material's output by an Emission shader of the
reflected radiance, so whatever the user's nodes emit (a Principled BSDF's
Emission Color and Strength, an Emission shader added or mixed in: screens,
lamps' diffusers, glTF emissive maps) would be lost. The lookup adds it back,
as Cycles emits it (intern/cycles/kernel/svm/closure.h):

- a Principled BSDF emits Emission Color x Emission Strength below its coat:
  times W(mu), the weight of every layer below the coat (the coat's albedo
  at the view and its tint; bake.brdf.principled's ``lower_weights``), as the
  layers below the coat are; with a Coat Tint texture, times T(tint, mu) /
  T(mean, mu) as they are (bake.colour_response.coat_tint_factor);
- an Emission shader emits Color x Strength;
- through an Add Shader unchanged; through a Mix Shader times 1 - Fac (its
  first shader) or Fac (its second), the Fac per pixel from the user's own
  socket when it is linked (a mask, a Fresnel or Layer Weight node); but a
  Mix Shader of a Transparent BSDF at the surface is the lookup's opacity
  (glossy_addon.transparency), applied once, after.

Colours, strengths and factors are the user's sockets where linked
(textures stay per pixel, and follow the user's edits), their values at
attach where unlinked: :func:`values` records them and the Material panel
asks for Attach Lookups again when one changes. (Drivers from the material's
own node tree into its lookup, as the lamps' are driven, make a dependency
cycle in Blender's depsgraph: a node tree reading itself.) Left out, as Glossy leaves them out of
the reflection too (the node reader lists them): the Principled BSDF's
Alpha and Sheen, which also scale its emission in Cycles. A node group on
the way hides what is inside it (the node reader refuses the material).
"""

from dataclasses import dataclass, field

import numpy as np

from ..bake.brdf.principled import Principled
from ..bake.colour_response import MU_KNOTS

__all__ = ["Emitter", "emitters", "emission_value", "values", "emission_changed"]


@dataclass
class Emitter:
    """One node that emits: ``node`` (a Principled BSDF or an Emission shader) and
    ``path``: [(Mix Shader node, 1 or 2: which of its shader inputs leads here)]
    from the Material Output to it."""

    node: object
    path: list = field(default_factory=list)


def _source(socket):
    """The node feeding ``socket`` (through reroutes), or None."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        node = link.from_node
        if node.bl_idname != "NodeReroute":
            return node
        socket = node.inputs[0]
    return None


def _linked(node, name):
    return name in node.inputs and _source(node.inputs[name]) is not None


def _emits(node) -> bool:
    """Whether ``node`` emits anything (an unlinked colour of zero or strength of
    zero emits nothing)."""
    if node.bl_idname == "ShaderNodeBsdfPrincipled":
        colour, strength = "Emission Color", "Emission Strength"
    elif node.bl_idname == "ShaderNodeEmission":
        colour, strength = "Color", "Strength"
    else:
        return False
    if colour not in node.inputs or strength not in node.inputs:
        return False
    lit = _linked(node, colour) or any(node.inputs[colour].default_value[:3])
    strong = _linked(node, strength) or float(node.inputs[strength].default_value) != 0.0
    return bool(lit and strong)


def emitters(surface) -> list:
    """[Emitter] of the shaders reaching ``surface`` (a Material Output's Surface
    input) through Add and Mix Shaders, in the order met (a Mix Shader whose Fac
    is an unlinked 0 or 1 hides the side it does not show)."""
    found = []

    def walk(socket, path):
        node = _source(socket)
        if node is None:
            return
        if node.bl_idname == "ShaderNodeAddShader":
            for child in node.inputs:
                if child.type == "SHADER":
                    walk(child, path)
        elif node.bl_idname == "ShaderNodeMixShader":
            fac = None if _linked(node, "Fac") else float(node.inputs["Fac"].default_value)
            if fac is None or fac < 1.0:
                walk(node.inputs[1], path + [(node, 1)])
            if fac is None or fac > 0.0:
                walk(node.inputs[2], path + [(node, 2)])
        elif _emits(node):
            found.append(Emitter(node, path))

    from .transparency import transparent_mix

    cut = transparent_mix(surface)  # its Fac is the lookup's final opacity
    if cut is not None:
        walk(cut[0].inputs[cut[1]], [])
    else:
        walk(surface, [])
    return found


def _input(node, name):
    """The socket feeding input ``name`` of the user's ``node``, or its value ((3,)
    for a colour)."""
    socket = node.inputs[name]
    if socket.is_linked and socket.links[0].is_valid and not socket.links[0].is_muted:
        return socket.links[0].from_socket
    value = socket.default_value
    return tuple(float(v) for v in value[:3]) if hasattr(value, "__len__") else float(value)


def values(surface) -> list:
    """The emission inputs of the shaders at ``surface`` as [[node name, input
    name, value or "linked"], ...], and the Alpha the lookup applies
    (glossy_addon.transparency): what the lookup holds as constants
    (:func:`emission_value`); the panel asks for a re-attach when they change."""
    from .transparency import alpha_values

    out = alpha_values(surface)
    for emitter in emitters(surface):
        node = emitter.node
        names = ["Emission Color", "Emission Strength"] \
            if node.bl_idname == "ShaderNodeBsdfPrincipled" else ["Color", "Strength"]
        if node.bl_idname == "ShaderNodeBsdfPrincipled":
            names += ["Coat Weight", "Coat Roughness", "Coat IOR", "Coat Tint"]
        for mix, _ in emitter.path:
            out.append([mix.name, "Fac", _rounded(_input(mix, "Fac"))])
        out += [[node.name, name, _rounded(_input(node, name))] for name in names]
    return out


def _rounded(value):
    if isinstance(value, tuple):
        return [round(v, 6) for v in value]
    return round(value, 6) if isinstance(value, float) else "linked"


def coat_weights(node, tint=None):
    """(mu (K,), W(mu) (K, 3)) of a Principled BSDF node's coat, the weight Cycles
    gives everything below it (its emission included), from the node's coat
    inputs (a linked one at its unlinked value; ``tint`` (3,) in place of the
    Coat Tint's), or None without a coat."""
    coat = float(node.inputs["Coat Weight"].default_value)
    if coat <= 0.0:
        return None
    if tint is None:
        tint = tuple(float(c) for c in node.inputs["Coat Tint"].default_value[:3])
    model = Principled(coat_weight=min(coat, 1.0),
                       coat_roughness=float(node.inputs["Coat Roughness"].default_value),
                       coat_ior=float(node.inputs["Coat IOR"].default_value),
                       coat_tint=tuple(float(c) for c in tint), diffuse=0.0)
    mu = np.linspace(0.0, 1.0, MU_KNOTS) ** 2
    return mu, model.lower_weights(mu)[0]


def emission_value(b, surface, coat_tint=None):
    """The radiance the user's shaders at ``surface`` emit, as a colour socket built
    with ``b`` (glossy_addon.nodes._Builder), or None where nothing emits.
    ``coat_tint``: build_lookup's spatial["coat_tint"] (socket, mean, coat, ior),
    the per-pixel factor of everything below a textured coat tint."""
    from .nodes import _view_curve, coat_tint_factor

    total = None
    for emitter in emitters(surface):
        node = emitter.node
        principled = node.bl_idname == "ShaderNodeBsdfPrincipled"
        colour = _input(node, "Emission Color" if principled else "Color")
        strength = _input(node, "Emission Strength" if principled else "Strength")
        if isinstance(colour, tuple):
            colour = b.combine(*colour)
        value = b.vec("SCALE", colour, scale=strength)
        if principled:
            weights = coat_weights(node, None if coat_tint is None else coat_tint[1])
            if weights is not None:
                mu, under = weights
                value = b.vec("MULTIPLY", value, _view_curve(
                    b, mu, [[float(w) for w in row] for row in under]))
                if coat_tint is not None:
                    value = b.vec("MULTIPLY", value, coat_tint_factor(b, *coat_tint))
        for mix, side in emitter.path:
            fac = _input(mix, "Fac")
            if isinstance(fac, float):
                fac = min(max(fac, 0.0), 1.0)
                weight = fac if side == 2 else 1.0 - fac
            else:
                fac = b.math("MINIMUM", b.math("MAXIMUM", fac, 0.0), 1.0)
                weight = fac if side == 2 else b.math("SUBTRACT", 1.0, fac)
            value = b.vec("SCALE", value, scale=weight)
        total = value if total is None else b.vec("ADD", total, value)
    return total


def emission_changed(material) -> bool:
    """Whether ``material``'s unlinked emission inputs differ from those its lookup
    holds (recorded at attach in ``glossy.emission_set``)."""
    import json

    from .nodes import user_output

    recorded = material.glossy.emission_set
    if not recorded:
        return False
    output = user_output(material)
    current = values(output.inputs["Surface"]) if output is not None else []
    return current != json.loads(recorded)
