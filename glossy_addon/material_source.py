"""What a Glossy material bakes, whatever its BRDF source: the glossy spec, the
diffuse colour and how the diffuse part is weighted by the view.

For the "From Material" source the BRDF is read from the user's own node tree
(glossy_addon.node_reader): from the material's own nodes, which an attach
keeps beside the lookup (from the kept original where an older attach
replaced them).
The full model splits (bake.brdf.split) into the glossy part a map bakes and
a Lambert part D(mu) = colour * weight(mu) baked as irradiance and weighted in
the attached material by the view cosine mu (an RGB curve of 33 knots).

Reads are cached by a signature of the tree (node types, input values, links,
images), so a panel redraw does not read image pixels again.
"""

import json
from dataclasses import dataclass, field

from .node_reader import Derived, NodeReadError, read_material

__all__ = ["Parts", "parts", "derive", "source_material", "changed_inputs", "NodeReadError"]

_CACHE: dict = {}
_CACHE_SIZE = 64


@dataclass
class Parts:
    """glossy_spec: what the map bakes; diffuse: (3,) colour of the irradiance part
    (black: none); weighting: ("one",), ("fresnel", ior) or ("curve", mu, weights)
    with knots mu (K,) and RGB weights (K, 3) in [0, 1]; full_spec: the whole BRDF
    (the NumPy reference's); derived: the node reader's findings (From Material);
    roughness_set: [(roughness, glossy spec), ...] ascending, the maps a roughness
    texture blends per pixel (glossy_addon.spatial; empty: none)."""

    glossy_spec: str
    diffuse: tuple
    weighting: tuple
    full_spec: str
    derived: Derived | None = None
    roughness_set: list = field(default_factory=list)


def source_material(material):
    """The material whose nodes hold the user's BRDF: the material itself (an attach
    keeps the user's nodes beside the lookup), or the kept original where an
    older attach replaced the nodes (no Material Output of the user's left)."""
    from .nodes import user_output

    original = material.glossy.original
    if original is None or user_output(material) is not None:
        return material
    return original


def _socket_value(socket):
    value = getattr(socket, "default_value", None)
    if value is None:
        return None
    try:
        return [round(float(v), 7) for v in value]
    except TypeError:
        return round(float(value), 7) if isinstance(value, (int, float)) else str(value)


def _signature(material) -> str:
    if not material.use_nodes or material.node_tree is None:
        return f"{material.name}:no nodes"
    from .nodes import is_lookup_node

    items = []
    for node in material.node_tree.nodes:
        if is_lookup_node(node):
            continue
        entry = [node.name, node.bl_idname, getattr(node, "distribution", ""),
                 [(s.identifier, _socket_value(s)) for s in node.inputs],
                 [(s.identifier, _socket_value(s)) for s in node.outputs
                  if node.bl_idname in ("ShaderNodeRGB", "ShaderNodeValue")],
                 getattr(node, "is_active_output", False), getattr(node, "target", "")]
        image = getattr(node, "image", None)
        if image is not None:
            entry.append([image.name, image.filepath, list(image.size), image.is_dirty])
        items.append(entry)
    links = [(link.from_node.name, link.from_socket.identifier, link.to_node.name,
              link.to_socket.identifier, link.is_muted) for link in material.node_tree.links
             if not is_lookup_node(link.to_node)]
    items.append(material.get("glossy_user_output", ""))
    return json.dumps([material.name, items, links], default=str)


def derive(material) -> Derived:
    """The node reader's Derived for ``material``'s source (cached); NodeReadError."""
    source = source_material(material)
    key = _signature(source)
    if key not in _CACHE:
        try:
            _CACHE[key] = read_material(source)
        except NodeReadError as error:
            _CACHE[key] = error
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
    found = _CACHE[key]
    if isinstance(found, NodeReadError):
        raise found
    return found


def parts(material) -> Parts:
    """The Parts of ``material`` (its Glossy settings, or its nodes for From Material)."""
    settings = material.glossy
    if settings.model != "MATERIAL":
        spec = settings.brdf_spec()
        diffuse = tuple(float(c) for c in settings.diffuse)
        weighting = ("fresnel", settings.fresnel_ior) if settings.fresnel_ior > 1.0 \
            else ("one",)
        full = spec
        if any(diffuse):
            colour = "/".join(f"{c:g}" for c in diffuse)
            lambert = f"lambert:color={colour}"
            full = (f"fresnel_mix(ior={settings.fresnel_ior:g}; {lambert}; {spec})"
                    if weighting[0] == "fresnel" else f"sum({spec}; {lambert})")
        return Parts(spec, diffuse, weighting, full)
    from ..bake import brdf
    from ..bake.brdf.split import diffuse_curve, split

    derived = derive(material)
    model = brdf.parse(derived.spec)
    glossy, _ = split(model)
    colour, mu, weight = diffuse_curve(model)
    glossy_spec = glossy.spec if glossy is not None else "lambert:color=0"
    weighting = ("curve", mu.tolist(), weight.tolist()) if colour.any() else ("one",)
    return Parts(glossy_spec, tuple(float(c) for c in colour), weighting, derived.spec,
                 derived, _roughness_set(derived) if glossy is not None else [])


def _roughness_set(derived) -> list:
    """[(roughness, glossy spec)] at the knots of a roughness texture (see Parts)."""
    from ..bake import brdf
    from ..bake.brdf.split import split
    from .spatial import roughness_knots, with_roughness

    texture = derived.spatial.get("roughness")
    if not texture or "low" not in texture:
        return []
    out = []
    for roughness in roughness_knots(texture["low"], texture["high"]):
        glossy, _ = split(brdf.parse(with_roughness(derived.spec, roughness)))
        if glossy is None or not glossy.isotropic:
            return []
        out.append((roughness, glossy.spec))
    return out


def changed_inputs(baked_json: str, derived: Derived) -> list:
    """Labels of the BRDF inputs whose values differ from those recorded at the bake."""
    try:
        baked = json.loads(baked_json or "{}")
    except ValueError:
        baked = {}
    now = derived.inputs
    return sorted(label for label in set(baked) | set(now) if baked.get(label) != now.get(label))
