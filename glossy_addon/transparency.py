"""The user's Alpha, kept in the attached lookup.

A Principled BSDF's Alpha below 1 makes Cycles add a Transparent BSDF of
weight 1 - Alpha and scale everything else (every layer's reflection and the
emission) by Alpha (intern/cycles/kernel/svm/closure.h, before any layer).
Glossy bakes the BRDF without it, so the attached lookup mixes a Transparent
BSDF in by the same Alpha: Mix Shader(Fac = Alpha; Transparent BSDF; the
lookup's Emission), exact for the lookup's radiance. Alpha-masked and
alpha-blended assets (glTF imports link the Base Color image's alpha into
it, through a Math node for a mask) keep their cut-outs and blending; the
material's own Render Method (Dithered or Blended) applies in EEVEE.

Read where the surface is one Principled BSDF (through reroutes), as the rest
of the per-pixel inputs (glossy_addon.spatial); inside Mix or Add Shaders
its Alpha stays listed as ignored. The older set-up, a Mix Shader of a white
Transparent BSDF and a shader, its Fac a mask, at the surface: the node
reader bakes the other shader whole and the lookup mixes the Transparent
BSDF in by the same Fac (the emission below it is then weighted by the final
mix, not again by the Mix Shader: glossy_addon.emission).
"""

__all__ = ["alpha_input", "alpha_values", "transparent_mix"]


def _source(socket):
    """(node, output socket) feeding ``socket`` through reroutes, or (None, None)."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None, None
        if link.from_node.bl_idname != "NodeReroute":
            return link.from_node, link.from_socket
        socket = link.from_node.inputs[0]
    return None, None


def transparent_mix(surface):
    """(Mix Shader node, the side (1 or 2) of its other shader) where ``surface`` is
    fed directly by a Mix Shader one of whose shaders is a white Transparent BSDF
    (unlinked Color) and the other is not: the older way to cut a material by
    a mask; else None."""
    node, _ = _source(surface)
    if node is None or node.bl_idname != "ShaderNodeMixShader":
        return None
    kinds = [(_source(node.inputs[side])[0], side) for side in (1, 2)]
    for (one, _side), (other, other_side) in (kinds, kinds[::-1]):
        if one is not None and one.bl_idname == "ShaderNodeBsdfTransparent" and \
                _source(one.inputs["Color"])[0] is None and \
                all(float(c) == 1.0 for c in one.inputs["Color"].default_value[:3]) and \
                other is not None and other.bl_idname != "ShaderNodeBsdfTransparent":
            return node, other_side
    return None


def alpha_input(surface):
    """(the opacity, inverted) the lookup applies for ``surface`` (a Material
    Output's Surface input), or None: for a Principled BSDF feeding it directly,
    its Alpha (its linked socket, or its value where below 1; inverted False);
    for :func:`transparent_mix`, the Mix Shader's Fac (socket or value), inverted
    (opacity 1 - Fac) where the other shader is its first. None for anything else,
    or an unlinked Alpha of 1."""
    mixed = transparent_mix(surface)
    if mixed is not None:
        node, side = mixed
        fac = node.inputs["Fac"]
        value = fac.links[0].from_socket if _source(fac)[0] is not None else \
            float(fac.default_value)
        return value, side == 1
    node, _ = _source(surface)
    if node is None or node.bl_idname != "ShaderNodeBsdfPrincipled" or \
            "Alpha" not in node.inputs:
        return None
    linked, _ = _source(node.inputs["Alpha"])
    if linked is not None:
        return node.inputs["Alpha"].links[0].from_socket, False
    value = float(node.inputs["Alpha"].default_value)
    return (value, False) if value < 1.0 else None


def alpha_values(surface) -> list:
    """[[node name, "Alpha", value or "linked"]] of :func:`alpha_input`'s Alpha ([]
    without one): what the lookup holds (glossy_addon.emission.values records it
    beside the emission, so the panel asks for a re-attach when it changes)."""
    found = alpha_input(surface)
    if found is None:
        return []
    node, _ = _source(surface)
    alpha = found[0]
    return [[node.name, "Fac" if node.bl_idname == "ShaderNodeMixShader" else "Alpha",
             round(alpha, 6) if isinstance(alpha, float) else "linked"]]
