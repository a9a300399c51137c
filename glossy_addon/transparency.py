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
its Alpha stays listed as ignored.
"""

__all__ = ["alpha_input", "alpha_values"]


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


def alpha_input(surface):
    """The Alpha of the Principled BSDF feeding ``surface`` (a Material Output's
    Surface input) directly: its linked socket, or its value where below 1; None
    where the surface is anything else or the Alpha is an unlinked 1."""
    node, _ = _source(surface)
    if node is None or node.bl_idname != "ShaderNodeBsdfPrincipled" or \
            "Alpha" not in node.inputs:
        return None
    linked, _ = _source(node.inputs["Alpha"])
    if linked is not None:
        return node.inputs["Alpha"].links[0].from_socket
    value = float(node.inputs["Alpha"].default_value)
    return value if value < 1.0 else None


def alpha_values(surface) -> list:
    """[[node name, "Alpha", value or "linked"]] of :func:`alpha_input`'s Alpha ([]
    without one): what the lookup holds (glossy_addon.emission.values records it
    beside the emission, so the panel asks for a re-attach when it changes)."""
    alpha = alpha_input(surface)
    if alpha is None:
        return []
    node, _ = _source(surface)
    return [[node.name, "Alpha", round(alpha, 6) if isinstance(alpha, float) else "linked"]]
