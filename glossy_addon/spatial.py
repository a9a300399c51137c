"""What a From Material lookup applies per pixel, from the user's own nodes.

The node reader (glossy_addon.node_reader) bakes a material at one value of
each input; it also records (Derived.spatial) the inputs the attached lookup
takes per pixel from the user's nodes, which stay in the attached material
untouched. For a single Principled, Glossy or Diffuse BSDF at the output:

- its colour (Base Color / Color) driven by a texture or any node chain, as a
  factor ``colour(x) / baked mean`` of the part that is linear in it: the
  diffuse part of a dielectric Principled or a Diffuse BSDF (exact: Cycles'
  diffuse weight does not depend on the base colour), the glossy part of a
  Glossy BSDF (exact except Multiscatter GGX's energy term). A metal
  (Metallic = 1 Principled) instead gets two maps, baked at base colours 0
  and 1, combined per pixel as (R_0 + c (R_1 - R_0)) m(c, mu) with the
  Multiscatter energy term m (under a coat, of the layers below it, plus a
  map of the coat alone)
  (bake.colour_response: exact, where the ratio is off by 6-70% for dark or
  bright texels, benchmarks/colour_response.py); with a roughness texture
  too, two maps per roughness knot (:func:`map_variants`). A partly metallic
  or metallic-textured surface keeps the mean (listed as approximated);
- its Specular Tint driven by a node chain, on a metal or a dielectric
  (unless the metal's base colour is split already): split in the
  same way, maps at tints 0 and 1 (exact for the reflection; a dielectric's
  diffuse weight keeps the tint's unlinked value);
- its Metallic driven by a chain: maps at Metallic 0 and 1 mixed by it (the
  metal's colour split as above) and the diffuse part scaled by
  (1 - m) / (1 - mean) (exact: the Principled BSDF is affine in it);
- its Coat Tint driven by a chain: a map of the coat alone, and what lies
  below the coat scaled by T(tint, mu) / T(mean, mu)
  (bake.colour_response.coat_tint_factor, exact);
- a Multiscatter GGX Glossy BSDF's Color: a white single-scatter map times
  the colour and the energy term (exact);
- its Normal input (a Normal Map or Bump node): the normal of every lookup
  (environment, diffuse, view weight, runtime sampling, lamps);
- its Roughness from an image: the map is baked at roughness knots spaced
  geometrically from the image's 1st to its 99th percentile and the lookups
  are blended per pixel, geometrically, by the user's roughness value
  (:func:`roughness_knots`).
"""

import math
import re

#: Neighbouring roughness knots differ by at most this factor. Measured by
#: benchmarks/roughness_blend.py (brute-force sphere renders on every bundled
#: HDRI, knots from roughness 0.1 up, worst over the interval): the geometric
#: blend the nodes use stays within 3.1% relative RMS of a render at the pixel's
#: own roughness at ratio 1.25 (1.2% at 1.15, 6.9% at 1.4; a linear blend: 6.2%
#: at 1.25), the worst at roughness 0.1 under studio.exr's small lights. 1.25 puts
#: 6 maps on a 0.2-0.6 texture; the error depends on the ratio of neighbouring
#: roughnesses, not on their difference, hence geometric spacing.
ROUGHNESS_RATIO = 1.25
#: A texture spanning less than this ratio is baked at its mean alone.
ROUGHNESS_SPREAD = 1.05
#: At most this many maps (each a lookup in the shader).
MAX_KNOTS = 8
#: Keys of the maps a From Material bake writes besides one plain map
#: (:func:`map_variants`; each file ends in ``_<key>``): a split colour at 0 and
#: 1, the coat alone, Metallic 0, Metallic 1 (unsplit) and the whole glossy part.
LOW, HIGH, COAT, DIELECTRIC, METAL, GLOSSY = "c0", "c1", "coat", "dielectric", "metal", \
    "glossy"
#: Roughness knots start no lower than this (Cycles' mirror threshold).
MIN_ROUGHNESS = 0.01

_ROUGHNESS = re.compile(r"(?<![a-z_])roughness=([0-9.eE+-]+)")


def roughness_knots(low: float, high: float) -> list:
    """Ascending roughness knots spanning [low, high] with neighbouring ratios at
    most ROUGHNESS_RATIO (geometric spacing), at most MAX_KNOTS of them; [] when
    the range is narrower than ROUGHNESS_SPREAD (one map at the mean is enough)."""
    low = max(float(low), MIN_ROUGHNESS)
    high = max(float(high), low)
    if high / low < ROUGHNESS_SPREAD:
        return []
    count = min(max(2, math.ceil(math.log(high / low) / math.log(ROUGHNESS_RATIO)) + 1),
                MAX_KNOTS)
    return [low * (high / low) ** (k / (count - 1)) for k in range(count)]


def with_roughness(spec: str, roughness: float) -> str:
    """``spec`` with its (single) BSDF's roughness replaced (coat roughness kept)."""
    found = _ROUGHNESS.findall(spec)
    if len(found) != 1:
        raise ValueError(f"expected one roughness in {spec}, found {len(found)}")
    return _ROUGHNESS.sub(f"roughness={roughness:.6g}", spec)


# For several BSDFs reached through Mix and Add Shaders
# (node_reader._Reader.plan_spatial): a colour texture of a BSDF that alone makes
# its part (the only diffuse BSDF's colour for the diffuse part, the only glossy
# BSDF's for the glossy part), as a factor exactly as above; the Normal where
# every BSDF takes the same link; a Roughness image where one BSDF alone has a
# roughness. No split in a mix; anything else is taken at its mean, and listed.


def split_plan(derived) -> tuple:
    """(bake.colour_response parameter, Derived.spatial plan) of the input a From
    Material bake splits per pixel: a metal's base colour, else a specular tint;
    (None, None) if neither."""
    if derived is None:
        return None, None
    colour = derived.spatial.get("colour")
    if colour and colour.get("split"):
        return "base_color", colour
    tint = derived.spatial.get("tint")
    if tint and tint.get("split"):
        return "specular_tint", tint
    return None, None


def split_share(derived) -> float:
    """The split input's mean value (its smallest channel, in [0, 1]) of a From
    Material bake, what bake.prefilter.Companion weighs the low map's error
    against; 0 (the strictest) when the plan records no mean."""
    _, plan = split_plan(derived)
    mean = (plan or {}).get("mean")
    if mean is None:
        return 0.0
    return float(min(max(min(float(v) for v in mean), 0.0), 1.0))


def split_order(variants) -> list:
    """Indices of ``variants`` ((roughness, key, ...) tuples, :func:`map_variants`' order)
    in the order a bake takes them: each knot's :data:`HIGH` map before its
    :data:`LOW` one (whose 3D map may take the high map's lobes,
    bake.prefilter.Companion), the rest as listed."""
    where = {(v[0], v[1]): i for i, v in enumerate(variants)}
    order = []
    for i, (roughness, key, *_) in enumerate(variants):
        if i in order:
            continue
        high = where.get((roughness, HIGH))
        if key == LOW and high is not None and high not in order:
            order.append(high)
        order.append(i)
    return order


def _split_knots(parts, colour=True) -> list:
    """[(roughness or None, dielectric spec or None, glossy model to split or keep,
    ColourResponse or None, coat spec or None), ...] per roughness knot (one None
    knot without a roughness texture), or [] where no map splits: the dielectric
    spec where a metallic texture mixes maps at Metallic 0 and 1 (the model is
    then the metal at 1), the response where a colour is split, the coat alone
    where a coat tint texture scales what lies below the coat."""
    from ..bake import brdf
    from ..bake.colour_response import coat_alone, response, with_metallic

    if not colour or parts.derived is None:
        return []
    parameter, plan = split_plan(parts.derived)
    metallic = "metallic" in parts.derived.spatial
    tinted = "coat_tint" in parts.derived.spatial
    if plan is None and not metallic and not tinted:
        return []
    out = []
    for roughness, spec in parts.roughness_set or [(None, parts.glossy_spec)]:
        model, dielectric = brdf.parse(spec), None
        coat = coat_alone(model) if tinted else None
        if tinted and coat is None:
            return []
        if metallic:
            dielectric = with_metallic(model, 0.0)
            model = with_metallic(model, 1.0)
            if model is None:
                return []
            dielectric = dielectric.spec
        found = response(model, parameter) if plan is not None else None
        if plan is not None and found is None and not metallic and not tinted:
            return []
        out.append((roughness, dielectric, model, found, coat))
    return out


def colour_responses(parts) -> dict:
    """{roughness knot or None: bake.colour_response.ColourResponse} of a From
    Material glossy part with an input split per pixel (:func:`split_plan`; the
    metal at Metallic 1 where a metallic texture mixes maps); {} where there is
    none (or the split does not apply)."""
    return {r: found for r, _, _, found, _ in _split_knots(parts) if found is not None}


def map_variants(parts, colour=True) -> list:
    """[(roughness or None, key or None, glossy spec), ...]: the maps a From Material
    bake writes, one per roughness knot (Parts.roughness_set) and, with
    ``colour``, per knot: the map at Metallic 0 (:data:`DIELECTRIC`) where a
    metallic texture mixes maps, then either the maps of a split colour
    (:data:`LOW` and :data:`HIGH`, at colours 0 and 1, and :data:`COAT`, the
    coat alone, where needed) or the metal's map (:data:`METAL`) or the whole
    glossy part's (:data:`GLOSSY`), and the coat alone (:data:`COAT`) where a
    coat tint texture needs it; [] for one map of Parts.glossy_spec."""
    knots = _split_knots(parts, colour)
    if not knots:
        return [(r, None, spec) for r, spec in parts.roughness_set]
    out = []
    for roughness, dielectric, model, found, coat in knots:
        if dielectric is not None:
            out.append((roughness, DIELECTRIC, dielectric))
        if found is not None:
            out += [(roughness, key, spec) for key, spec in
                    ((LOW, found.low), (HIGH, found.high), (COAT, found.coat))
                    if spec is not None]
        else:
            out.append((roughness, METAL if dielectric is not None else GLOSSY, model.spec))
        if coat is not None and (found is None or found.coat is None):
            out.append((roughness, COAT, coat))
    return out


def input_socket(material, node_name: str, input_name: str):
    """The output socket feeding input ``input_name`` of node ``node_name`` in
    ``material`` (the user's node, kept beside the lookup), or None."""
    tree = material.node_tree if material.use_nodes else None
    node = tree.nodes.get(node_name) if tree is not None else None
    socket = node.inputs.get(input_name) if node is not None else None
    if socket is None or not socket.is_linked:
        return None
    link = socket.links[0]
    return link.from_socket if link.is_valid and not link.is_muted else None


def lookup_sockets(material, spatial: dict) -> dict:
    """build_lookup's ``spatial`` for ``material``: {"normal": socket} and
    {part: (colour socket, mean)} and {"metallic": (socket, mean)} for the inputs
    recorded in Derived.spatial whose links still exist in ``material``."""
    out = {}
    normal = spatial.get("normal")
    if normal:
        socket = input_socket(material, normal["node"], normal["input"])
        if socket is not None:
            out["normal"] = socket
    colour = spatial.get("colour")
    if colour:
        socket = input_socket(material, colour["node"], colour["input"])
        if socket is not None:
            out[colour["part"]] = (socket, colour["mean"])
    metallic = spatial.get("metallic")
    if metallic:
        socket = input_socket(material, metallic["node"], metallic["input"])
        if socket is not None:
            out["metallic"] = (socket, metallic["mean"])
    tint = spatial.get("coat_tint")
    if tint:
        socket = input_socket(material, tint["node"], tint["input"])
        if socket is not None:
            out["coat_tint"] = (socket, tint["mean"], tint["coat"], tint["ior"])
    return out
