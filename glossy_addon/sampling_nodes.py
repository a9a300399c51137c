"""Shader nodes that reproduce bake.sampling_runtime.shade: runtime regular sampling.

Per pixel, one shared group (``Glossy Runtime Frame v3``) builds the lobe frame
from the normal, the view and a tangent and the view's terms of Heitz's
visible-normal sampler; per sample, one shared group (``Glossy VNDF Sample v3``)
turns the sample's disk point into a world direction, its weight and its MIP
level. The material holds what node groups cannot: the image taps (the
sample's constants from its texel, four Closest taps per stored level, bilinear
weights from ``Glossy Atlas Taps v1`` fed each level's own rows and first row,
bake.sampling_atlas's "mip" layout: :func:`_level_sizes`; two levels per sample) inside two
repeat zones over the samples (the strongest weight, then the kept sum),
normalised and scaled by the tabulated albedo. EEVEE compiles a repeat zone as
a loop: the shader's size and compile time do not grow with the sample count
(unrolled, 19 samples took 49 s to compile here). The probe lights are a third
repeat zone, each light's constants read from its atlas texels and shaded by
one per-material group (``Glossy Probe Light v4``). nodes.build_lookup attaches
it (methods Runtime Sampling and Hybrid); :func:`hybrid_value` blends it with the 3D map.
A Cycles Beckmann lobe (the atlas meta's ``kind``) has its own sample and light
groups (the names end in " beckmann"): the same GGX visible normals, weighed by
Beckmann's D over GGX's and Cycles' rational Beckmann Lambda
(bake.sampling_runtime's module doc); the GGX groups are unchanged.
"""

import math

import bpy

from ..bake.sampling_runtime import LIGHT_WIDENING, MIN_COS, atlas_rows, table_row
from .nodes import _Builder, _group, _group_node, _io, _tap, atlas_taps_group

GROUP_VERSION = 3
FRAME_GROUP = f"Glossy Runtime Frame v{GROUP_VERSION}"
SAMPLE_GROUP = f"Glossy VNDF Sample v{GROUP_VERSION}"
_FLOAT, _VECTOR = "NodeSocketFloat", "NodeSocketVector"


def _square(b, value):
    """value^2: a float, or a socket's square (a per-pixel alpha)."""
    return value * value if isinstance(value, (int, float)) else b.math("MULTIPLY", value, value)


def _lambda(b, w, ax, ay):
    """GGX Smith Lambda (sqrt(1 + (ax^2 wx^2 + ay^2 wy^2) / wz^2) - 1) / 2 (alphas floats or
    sockets)."""
    x, y, z = b.separate(w)
    top = b.math("ADD", b.math("MULTIPLY", b.math("MULTIPLY", x, x), _square(b, ax)),
                 b.math("MULTIPLY", b.math("MULTIPLY", y, y), _square(b, ay)))
    ratio = b.math("DIVIDE", top, b.math("MAXIMUM", b.math("MULTIPLY", z, z), 1e-12))
    return b.math("MULTIPLY", b.math("SUBTRACT", b.math("SQRT", b.math("ADD", ratio, 1.0)),
                                     1.0), 0.5)


def _lambda_beckmann(b, w, ax, ay):
    """Cycles' rational Beckmann Smith Lambda (bake.brdf.microfacet.beckmann_lambda_cycles):
    with s = (ax^2 wx^2 + ay^2 wy^2) / wz^2 and a = 1 / sqrt(s), (1 - 1.259 a + 0.396 a^2)
    / (3.535 a + 2.181 a^2) where s >= 0.39, else 0 (a taken at s >= 0.39 only, so no
    infinity meets the zero)."""
    x, y, z = b.separate(w)
    top = b.math("ADD", b.math("MULTIPLY", b.math("MULTIPLY", x, x), _square(b, ax)),
                 b.math("MULTIPLY", b.math("MULTIPLY", y, y), _square(b, ay)))
    ratio = b.math("DIVIDE", top, b.math("MAXIMUM", b.math("MULTIPLY", z, z), 1e-12))
    a = b.math("DIVIDE", 1.0, b.math("SQRT", b.math("MAXIMUM", ratio, 0.39)))
    a2 = b.math("MULTIPLY", a, a)
    value = b.math("DIVIDE", b.math("ADD", b.math("SUBTRACT", 1.0, b.math("MULTIPLY", a, 1.259)),
                                    b.math("MULTIPLY", a2, 0.396)),
                   b.math("ADD", b.math("MULTIPLY", a, 3.535), b.math("MULTIPLY", a2, 2.181)))
    return b.math("MULTIPLY", value, b.math("SUBTRACT", 1.0, b.math("LESS_THAN", ratio, 0.39)))


def _kind_suffix(kind):
    """Group-name suffix of a lobe kind: none for GGX (the groups it always had)."""
    if kind not in ("ggx", "beckmann"):
        raise ValueError(f"no runtime-sampling nodes for a {kind} lobe")
    return "" if kind == "ggx" else f" {kind}"


def frame_group(ax, ay):
    """Per-material group (the lobe's alphas are constants): inputs Normal, Incoming,
    Tangent, Angle, MinCos, Stretched (1: turn a stretched pattern, 0: not); outputs
    the lobe frame X, Y, N (world), Wo (lobe frame, z floored at MinCos), the VNDF
    basis Vh, T1, T2, S, the view's Lambda and the cosine and sine of the pattern's
    turn (bake.sampling_runtime._stretch_angle; 0 unless Stretched)."""
    name = f"{FRAME_GROUP} {ax:.6g} {ay:.6g}"
    tree = _group(name, [("Normal", _VECTOR), ("Incoming", _VECTOR), ("Tangent", _VECTOR),
                         ("Angle", _FLOAT), ("MinCos", _FLOAT), ("Stretched", _FLOAT)],
                  [("X", _VECTOR), ("Y", _VECTOR), ("N", _VECTOR), ("Wo", _VECTOR),
                   ("Vh", _VECTOR), ("T1", _VECTOR), ("T2", _VECTOR), ("S", _FLOAT),
                   ("Lambda", _FLOAT), ("TurnCos", _FLOAT), ("TurnSin", _FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    inputs, outputs = _io(tree)
    n = b.vec("NORMALIZE", inputs["Normal"])
    v = b.vec("NORMALIZE", inputs["Incoming"])
    t = inputs["Tangent"]
    t = b.vec("NORMALIZE", b.vec("SUBTRACT", t, b.vec("SCALE", n, scale=b.vec(
        "DOT_PRODUCT", t, n))))
    y0 = b.vec("CROSS_PRODUCT", n, t)
    cos_a, sin_a = b.math("COSINE", inputs["Angle"]), b.math("SINE", inputs["Angle"])
    x = b.vec("ADD", b.vec("SCALE", t, scale=cos_a), b.vec("SCALE", y0, scale=sin_a))
    y = b.vec("CROSS_PRODUCT", n, x)
    wo = b.vec("NORMALIZE", b.combine(b.vec("DOT_PRODUCT", v, x), b.vec("DOT_PRODUCT", v, y),
                                      b.math("MAXIMUM", b.vec("DOT_PRODUCT", v, n),
                                             inputs["MinCos"])))
    wx, wy, wz = b.separate(wo)
    vh = b.vec("NORMALIZE", b.combine(b.math("MULTIPLY", wx, ax), b.math("MULTIPLY", wy, ay),
                                      wz))
    hx, hy, hz = b.separate(vh)
    lensq = b.math("ADD", b.math("MULTIPLY", hx, hx), b.math("MULTIPLY", hy, hy))
    has = b.math("GREATER_THAN", lensq, 0.0)
    inv = b.math("DIVIDE", 1.0, b.math("SQRT", b.math("MAXIMUM", lensq, 1e-30)))
    t1 = b.combine(b.select(has, b.math("MULTIPLY", b.math("MULTIPLY", hy, -1.0), inv), 1.0),
                   b.select(has, b.math("MULTIPLY", hx, inv), 0.0), 0.0)
    t2 = b.vec("CROSS_PRODUCT", vh, t1)
    s = b.math("MULTIPLY", b.math("ADD", hz, 1.0), 0.5)
    t1x, t1y, _ = b.separate(t1)
    t2x, t2y, _ = b.separate(t2)
    a1, b1 = b.math("MULTIPLY", t1x, ax), b.math("MULTIPLY", t1y, ay)
    a2 = b.math("MULTIPLY", b.math("MULTIPLY", t2x, ax), s)
    b2 = b.math("MULTIPLY", b.math("MULTIPLY", t2y, ay), s)
    m11 = b.math("ADD", b.math("MULTIPLY", a1, a1), b.math("MULTIPLY", b1, b1))
    m22 = b.math("ADD", b.math("MULTIPLY", a2, a2), b.math("MULTIPLY", b2, b2))
    m12 = b.math("ADD", b.math("MULTIPLY", a1, a2), b.math("MULTIPLY", b1, b2))
    turn = b.math("MULTIPLY", b.math("MULTIPLY", b.math(
        "ARCTAN2", b.math("MULTIPLY", m12, 2.0), b.math("SUBTRACT", m11, m22)), 0.5),
        inputs["Stretched"])
    for socket, value in (("X", x), ("Y", y), ("N", n), ("Wo", wo), ("Vh", vh), ("T1", t1),
                          ("T2", t2), ("S", s), ("Lambda", _lambda(b, wo, ax, ay)),
                          ("TurnCos", b.math("COSINE", turn)),
                          ("TurnSin", b.math("SINE", turn))):
        b.link(value, outputs[socket])
    return tree


def sample_group(ax, ay, kind="ggx"):
    """Per-material group: one sample's world Direction, Weight (prob G2, 0 when
    invalid) and MIP Level (clamped to [0, Levels - 1]) from its disk point P1, P2
    (turned by TurnCos, TurnSin) and cell probability Prob
    (bake.sampling_runtime's module doc). ``kind`` "beckmann": the GGX visible
    normal weighs prob G2_B D_B / D_GGX (bake.sampling_runtime.proposal_ratio),
    Beckmann's Lambda of Wo computed here (the input Lambda stays GGX's, the
    proposal's, for the footprint)."""
    name = f"{SAMPLE_GROUP} {ax:.6g} {ay:.6g}{_kind_suffix(kind)}"
    names = ["X", "Y", "N", "Wo", "Vh", "T1", "T2"]
    tree = _group(name, [(s, _VECTOR) for s in names]
                  + [(s, _FLOAT) for s in ("S", "Lambda", "P1", "P2", "Prob", "Bias", "Levels",
                                           "Texel", "Pole", "TurnCos", "TurnSin")],
                  [("Direction", _VECTOR), ("Weight", _FLOAT), ("Level", _FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, outputs = _io(tree)
    s = i["S"]
    p1 = b.math("SUBTRACT", b.math("MULTIPLY", i["P1"], i["TurnCos"]),
                b.math("MULTIPLY", i["P2"], i["TurnSin"]))
    p2_disk = b.math("ADD", b.math("MULTIPLY", i["P1"], i["TurnSin"]),
                     b.math("MULTIPLY", i["P2"], i["TurnCos"]))
    root1 = b.math("SQRT", b.math("MAXIMUM", b.math("SUBTRACT", 1.0, b.math("MULTIPLY", p1, p1)),
                                  0.0))
    p2 = b.math("ADD", b.math("MULTIPLY", b.math("SUBTRACT", 1.0, s), root1),
                b.math("MULTIPLY", s, p2_disk))
    rest = b.math("SQRT", b.math("MAXIMUM", b.math("SUBTRACT", b.math(
        "SUBTRACT", 1.0, b.math("MULTIPLY", p1, p1)), b.math("MULTIPLY", p2, p2)), 0.0))
    nh = b.vec("ADD", b.vec("ADD", b.vec("SCALE", i["T1"], scale=p1),
                            b.vec("SCALE", i["T2"], scale=p2)), b.vec("SCALE", i["Vh"], scale=rest))
    nx, ny, nz = b.separate(nh)
    h = b.vec("NORMALIZE", b.combine(b.math("MULTIPLY", nx, ax), b.math("MULTIPLY", ny, ay),
                                     b.math("MAXIMUM", nz, 0.0)))
    wo = i["Wo"]
    wo_h = b.vec("DOT_PRODUCT", wo, h)
    wi = b.vec("SUBTRACT", b.vec("SCALE", h, scale=b.math("MULTIPLY", wo_h, 2.0)), wo)
    wix, wiy, wiz = b.separate(wi)
    valid = b.math("MULTIPLY", b.math("GREATER_THAN", wiz, 0.0),
                   b.math("GREATER_THAN", wo_h, 0.0))
    hx, hy, hz = b.separate(h)
    t = b.math("ADD", b.math("ADD", b.math("MULTIPLY", b.math("MULTIPLY", hx, hx), 1 / ax ** 2),
                             b.math("MULTIPLY", b.math("MULTIPLY", hy, hy), 1 / ay ** 2)),
               b.math("MULTIPLY", hz, hz))
    if kind == "ggx":
        g2 = b.math("DIVIDE", 1.0, b.math("ADD", b.math("ADD", _lambda(b, wi, ax, ay),
                                                        i["Lambda"]), 1.0))
        weight = b.math("MULTIPLY", i["Prob"], g2)
    else:
        g2 = b.math("DIVIDE", 1.0, b.math("ADD", b.math("ADD", _lambda_beckmann(b, wi, ax, ay),
                                                        _lambda_beckmann(b, wo, ax, ay)), 1.0))
        # D_B / D_GGX = exp(1 - q) q^2, q = t / hz^2 = 1 + tau
        q = b.math("DIVIDE", t, b.math("MAXIMUM", b.math("MULTIPLY", hz, hz), 1e-12))
        ratio = b.math("MULTIPLY", b.math("EXPONENT", b.math("SUBTRACT", 1.0, q)),
                       b.math("MULTIPLY", q, q))
        weight = b.math("MULTIPLY", b.math("MULTIPLY", i["Prob"], g2), ratio)
    b.link(b.math("MULTIPLY", valid, weight), outputs["Weight"])
    world = b.vec("ADD", b.vec("ADD", b.vec("SCALE", i["X"], scale=wix),
                               b.vec("SCALE", i["Y"], scale=wiy)),
                  b.vec("SCALE", i["N"], scale=wiz))
    b.link(world, outputs["Direction"])
    _, _, woz = b.separate(wo)
    # Omega = prob 4 wo_z (1 + Lambda_o) / D(h), D = 1 / (pi ax ay t^2)
    omega = b.math("MULTIPLY", b.math("MULTIPLY", b.math("MULTIPLY", i["Prob"], woz),
                                      b.math("ADD", i["Lambda"], 1.0)),
                   b.math("MULTIPLY", b.math("MULTIPLY", t, t), 4.0 * math.pi * ax * ay))
    _, _, dz = b.separate(world)
    sin_theta = b.math("SQRT", b.math("MAXIMUM", b.math("SUBTRACT", 1.0, b.math(
        "MULTIPLY", dz, dz)), 0.0))
    texel = b.math("MULTIPLY", i["Texel"], b.math("MAXIMUM", sin_theta, i["Pole"]))
    level = b.math("ADD", b.math("MULTIPLY", b.math("LOGARITHM", b.math(
        "DIVIDE", omega, texel), 2.0), 0.5), i["Bias"])
    level = b.math("MINIMUM", b.math("MAXIMUM", level, 0.0),
                   b.math("SUBTRACT", i["Levels"], 1.0))
    b.link(b.math("MULTIPLY", level, valid), outputs["Level"])
    return tree


#: The light group's own version (v4: the light's extent widens the highlight across
#: the plane of incidence by 1 / (wo.h), bake.sampling_runtime.widened_d).
LIGHT_GROUP_VERSION = 4
LIGHT_GROUP = f"Glossy Probe Light v{LIGHT_GROUP_VERSION}"


def light_group(ax, ay, kind="ggx"):
    """Per-material group: one probe light's radiance before the scale rho / A_ss
    (bake.sampling_runtime.light_radiance): inputs the lobe frame X, Y, N (world),
    Wo and the view's Lambda (from :func:`frame_group`), the light's world
    Direction and Irradiance (RGB as a vector), the widened alphas BX, BY and
    the light's Spread (RMS radius, rad); output Radiance = D_B(h) / (4 wo_z (1 +
    Lambda_o + Lambda(l))) E, zero where the light is below the surface (D_B:
    the lobe's D averaged over the light's extent, bake.sampling_runtime.widened_d).
    ``kind`` "beckmann": Beckmann's D, and its Lambdas (of Wo computed here).
    ``ax`` None: the lobe's alphas are inputs AX, AY too (a per-pixel roughness,
    bake.knot_lights), one group for every material of the kind."""
    varying = ax is None
    name = f"{LIGHT_GROUP} {'varying' if varying else f'{ax:.6g} {ay:.6g}'}{_kind_suffix(kind)}"
    tree = _group(name, [(s, _VECTOR) for s in ("X", "Y", "N", "Wo", "Direction",
                                                  "Irradiance")]
                  + [(s, _FLOAT) for s in ("Lambda", "BX", "BY", "Spread")
                     + (("AX", "AY") if varying else ())],
                  [("Radiance", _VECTOR)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, outputs = _io(tree)
    if varying:
        ax, ay = i["AX"], i["AY"]
    d = i["Direction"]
    wi = b.combine(b.vec("DOT_PRODUCT", d, i["X"]), b.vec("DOT_PRODUCT", d, i["Y"]),
                   b.vec("DOT_PRODUCT", d, i["N"]))
    wo = i["Wo"]
    h = b.vec("NORMALIZE", b.vec("ADD", wi, wo))
    _, _, wiz = b.separate(wi)
    valid = b.math("MULTIPLY", b.math("GREATER_THAN", wiz, 0.0),
                   b.math("GREATER_THAN", b.vec("DOT_PRODUCT", wo, h), 0.0))
    hx, hy, hz = b.separate(h)
    # The slopes' covariance S = diag(BX^2, BY^2) + e q q^T (widened_d): e =
    # (LIGHT_WIDENING Spread)^2 (1 / c^2 - 1), c = max(wo.h, MIN_COS), q the unit
    # tangent-plane part of wi x wo (zero where it has none).
    cos_d = b.math("MAXIMUM", b.vec("DOT_PRODUCT", wo, h), MIN_COS)
    spread = b.math("MULTIPLY", i["Spread"], LIGHT_WIDENING)
    extra = b.math("MULTIPLY", b.math("MULTIPLY", spread, spread), b.math(
        "SUBTRACT", b.math("DIVIDE", 1.0, b.math("MULTIPLY", cos_d, cos_d)), 1.0))
    px, py, _ = b.separate(b.vec("CROSS_PRODUCT", wi, wo))
    length = b.math("SQRT", b.math("ADD", b.math("MULTIPLY", px, px),
                                    b.math("MULTIPLY", py, py)))
    length = b.math("MAXIMUM", length, 1e-30)
    qx, qy = b.math("DIVIDE", px, length), b.math("DIVIDE", py, length)
    sxx = b.math("ADD", b.math("MULTIPLY", i["BX"], i["BX"]),
                 b.math("MULTIPLY", extra, b.math("MULTIPLY", qx, qx)))
    syy = b.math("ADD", b.math("MULTIPLY", i["BY"], i["BY"]),
                 b.math("MULTIPLY", extra, b.math("MULTIPLY", qy, qy)))
    sxy = b.math("MULTIPLY", extra, b.math("MULTIPLY", qx, qy))
    det = b.math("SUBTRACT", b.math("MULTIPLY", sxx, syy), b.math("MULTIPLY", sxy, sxy))
    form = b.math("SUBTRACT", b.math("ADD", b.math("MULTIPLY", syy, b.math("MULTIPLY", hx, hx)),
                                     b.math("MULTIPLY", sxx, b.math("MULTIPLY", hy, hy))),
                  b.math("MULTIPLY", b.math("MULTIPLY", sxy, 2.0), b.math("MULTIPLY", hx, hy)))
    t = b.math("ADD", b.math("DIVIDE", form, b.math("MAXIMUM", det, 1e-30)),
               b.math("MULTIPLY", hz, hz))
    root_det = b.math("SQRT", b.math("MAXIMUM", det, 0.0))
    _, _, woz = b.separate(wo)
    if kind == "ggx":
        # D_B = 1 / (pi sqrt(det S) t^2); the denominator 4 wo_z (1 + L_o + L_i) pi
        # sqrt(det S) t^2
        denominator = b.math("MULTIPLY", b.math("MULTIPLY", b.math("MULTIPLY", root_det,
                                                                   b.math("MULTIPLY", t, t)),
                                                4.0 * math.pi),
            b.math("MULTIPLY", woz, b.math("ADD", b.math("ADD", i["Lambda"], 1.0),
                                           _lambda(b, wi, ax, ay))))
        value = b.math("DIVIDE", valid, b.math("MAXIMUM", denominator, 1e-30))
    else:
        # D_B = exp(1 - t / hz^2) / (pi sqrt(det S) hz^4) (t / hz^2 = 1 + tau), over
        # 4 wo_z (1 + L_o + L_i) with Beckmann's Lambdas
        hz2 = b.math("MAXIMUM", b.math("MULTIPLY", hz, hz), 1e-12)
        numerator = b.math("EXPONENT", b.math("SUBTRACT", 1.0, b.math("DIVIDE", t, hz2)))
        denominator = b.math("MULTIPLY", b.math("MULTIPLY", b.math("MULTIPLY", root_det,
                                                                   b.math("MULTIPLY", hz2, hz2)),
                                                4.0 * math.pi),
            b.math("MULTIPLY", woz, b.math("ADD", b.math(
                "ADD", _lambda_beckmann(b, wo, ax, ay), 1.0), _lambda_beckmann(b, wi, ax, ay))))
        value = b.math("DIVIDE", b.math("MULTIPLY", valid, numerator),
                       b.math("MAXIMUM", denominator, 1e-30))
    b.link(b.vec("SCALE", i["Irradiance"], scale=value), outputs["Radiance"])
    return tree


def _light_loop(b, image, meta, count):
    """(state, result, after, texels): a repeat zone summing a vector "Sum" over
    ``count`` lights and, inside it, the iteration's light's first three texels from
    row ``meta["light_row"]`` (bake.sampling_runtime.light_texels, bake.knot_lights),
    ``meta["light_texels"]`` (3 if absent) each. With four, the first texel is the
    direction's half-float part and the fourth its remainder: their sum stands for
    the first."""
    per = int(meta.get("light_texels", 3))
    state, result, after = _repeat_zone(b, count, [("VECTOR", "Sum", (0.0, 0.0, 0.0))])
    first = b.math("MULTIPLY", state["Iteration"], float(per))
    texels = [_texel(b, image, meta, float(meta["light_row"]), b.math("ADD", first, float(c)))
              for c in range(per)]
    if per == 4:
        texels[0] = b.vec("ADD", texels[0], texels.pop())
    return state, result, after, tuple(texels)


def _lights_value(b, image, meta, frame):
    """The probe lights' radiance (colour socket), or None without lights: a repeat
    zone over the lights, each read from its three atlas texels (direction,
    irradiance, widened alphas and spread; bake.sampling_runtime.light_texels) and shaded by
    :func:`light_group`, then scaled by rho / A_ss."""
    lights = meta.get("lights") or []
    if not lights:
        return None
    ax, ay = float(meta["ax"]), float(meta["ay"])
    group = light_group(ax, ay, meta.get("kind", "ggx"))
    state, result, after, (direction, irradiance, alphas) = _light_loop(
        b, image, meta, len(lights))
    bx, by, spread = b.separate(alphas)
    node = _group_node(b, group, {
        "X": frame["X"], "Y": frame["Y"], "N": frame["N"], "Wo": frame["Wo"],
        "Lambda": frame["Lambda"], "Direction": direction, "Irradiance": irradiance,
        "BX": bx, "BY": by, "Spread": spread})
    b.link(b.vec("ADD", state["Sum"], node["Radiance"]), result["Sum"])
    return b.vec("MULTIPLY", after["Sum"], _albedo(b, image, meta, frame["Wo"], table=1))


def _repeat_zone(b, iterations, items):
    """A repeat zone (Blender's repeat zone in shader nodes; EEVEE compiles it as a
    loop, so the shader's size does not grow with ``iterations``). items: list of
    (socket type, name, initial value or socket). Returns (zone input node's
    outputs, zone output node's inputs, zone output node's outputs)."""
    start = b._place(b.nodes.new("GeometryNodeRepeatInput"))
    end = b._place(b.nodes.new("GeometryNodeRepeatOutput"))
    start.pair_with_output(end)
    end.repeat_items.clear()
    for kind, name, _ in items:
        end.repeat_items.new(kind, name)
    start.inputs["Iterations"].default_value = int(iterations)
    for _, name, initial in items:
        if isinstance(initial, tuple):
            start.inputs[name].default_value = initial
        else:
            b.link(initial, start.inputs[name])
    return start.outputs, end.inputs, end.outputs


def _texel(b, image, meta, first_row, index):
    """The atlas texel (colour socket) number ``index`` (a socket) of a run of texels
    from row ``first_row``: row first_row + index div W, column 1 + index mod W
    (bake.sampling_runtime's layout of samples and lights)."""
    width = int(meta["slice_width"])
    rows, cols = float(atlas_rows(meta)), float(width + 3)
    row = b.math("ADD", b.math("FLOOR", b.math("DIVIDE", b.math("ADD", index, 0.5), width)),
                 first_row + 0.5)
    column = b.math("ADD", b.math("FLOORED_MODULO", index, float(width)), 1.5)
    return _tap(b, b.combine(b.math("DIVIDE", column, cols),
                             b.math("SUBTRACT", 1.0, b.math("DIVIDE", row, rows))), image)


def _sample_data(b, image, meta, index):
    """(P1, P2, Prob) of sample ``index`` (a socket) from its texel (module doc of
    bake.sampling_runtime: row sample_row + index div W, column 1 + index mod W)."""
    return b.separate(_texel(b, image, meta, float(meta["sample_row"]), index))


def knot_lights_sum(b, image, meta, normal, view, roughness=None):
    """(S, Wo): the probe lights' sum S(alpha) before each map's scale (vector socket)
    and the lobe-frame view, for a bake.knot_lights texture (its twin:
    bake.knot_lights.shade), alpha = clamp(roughness, MIN_ROUGHNESS, 1)^2 from the
    user's ``roughness`` socket (None: the meta's constant alpha). A repeat zone over
    the lights, each read from its three texels and shaded by the varying
    :func:`light_group`; None for S where the bake took no lights."""
    from ..bake.knot_lights import MIN_ROUGHNESS

    lights = meta.get("lights") or []
    kind = meta.get("kind", "ggx")
    if roughness is None:
        alpha = float(meta["alpha"])
    else:
        r = b.math("MINIMUM", b.math("MAXIMUM", roughness, MIN_ROUGHNESS), 1.0)
        alpha = b.math("MULTIPLY", r, r)
    # An isotropic lobe: any tangent frame (the radial one, as the Hybrid's default).
    frame = _group_node(b, frame_group(0.1, 0.1), {
        "Normal": normal, "Incoming": view, "Tangent": tangent_socket(b, ("RADIAL", "Z")),
        "Angle": 0.0, "MinCos": float(meta["min_cos"]), "Stretched": 0.0})
    if not lights:
        return None, frame["Wo"]
    state, result, after, (direction, irradiance, extent) = _light_loop(
        b, image, meta, len(lights))
    spread, _, _ = b.separate(extent)
    widen = b.math("MULTIPLY", spread, LIGHT_WIDENING)
    widened = b.math("SQRT", b.math("ADD", _square(b, alpha), b.math("MULTIPLY", widen, widen)))
    node = _group_node(b, light_group(None, None, kind), {
        "X": frame["X"], "Y": frame["Y"], "N": frame["N"], "Wo": frame["Wo"],
        "Lambda": _lambda(b, frame["Wo"], alpha, alpha), "Direction": direction,
        "Irradiance": irradiance, "BX": widened, "BY": widened, "Spread": spread,
        "AX": alpha, "AY": alpha})
    b.link(b.vec("ADD", state["Sum"], node["Radiance"]), result["Sum"])
    return after["Sum"], frame["Wo"]


def knot_light_scale(b, image, meta, wo, index):
    """Table ``index``'s rho / A_ss (colour socket) at the lobe-frame view ``wo`` of a
    bake.knot_lights texture: two Closest taps, linear in mu between them."""
    count_mu = int(meta["albedo_mu"])
    height, width = int(meta["slice_height"]), int(meta["slice_width"])
    rows, cols = float(height + 2), float(width + 3)
    min_cos = float(meta["min_cos"])
    _, _, wz = b.separate(wo)
    x = b.math("MULTIPLY", b.math("MINIMUM", b.math("MAXIMUM", b.math(
        "DIVIDE", b.math("SUBTRACT", wz, min_cos), 1.0 - min_cos), 0.0), 1.0), count_mu - 1)
    x0 = b.math("MINIMUM", b.math("FLOOR", x), count_mu - 2)
    v = 1.0 - (1 + index + 0.5) / rows
    u0 = b.math("DIVIDE", b.math("ADD", x0, 1.5), cols)
    u1 = b.math("DIVIDE", b.math("ADD", x0, 2.5), cols)
    return b.mix(b.math("SUBTRACT", x, x0), _tap(b, b.combine(u0, v), image),
                 _tap(b, b.combine(u1, v), image))


def runtime_value(b, image, meta, normal, view, tangent):
    """The runtime-sampling radiance (colour socket) of a bake.sampling_runtime atlas,
    the probe's lights included (:func:`runtime_parts`)."""
    sampled, lights = runtime_parts(b, image, meta, normal, view, tangent)
    return sampled if lights is None else b.vec("ADD", sampled, lights)


def runtime_parts(b, image, meta, normal, view, tangent):
    """(sampled, lights) colour sockets of a bake.sampling_runtime atlas: the
    estimate of the (residual) probe, and the probe lights' exact term (None
    without lights).

    Two repeat zones over the samples (their constants read from the atlas): the
    first finds the strongest weight, the second sums the kept weights and their
    weighted radiance (two stored levels, four Closest taps each)."""
    if "sample_row" not in meta or (meta.get("lights") and "light_row" not in meta):
        raise ValueError("this runtime-sampling texture predates the looped nodes: bake again")
    ax, ay = float(meta["ax"]), float(meta["ay"])
    levels, height, width = int(meta["levels"]), int(meta["slice_height"]), \
        int(meta["slice_width"])
    slices = int(meta["slices"])
    count = len(meta["prob"])
    frame = _group_node(b, frame_group(ax, ay), {
        "Normal": normal, "Incoming": view, "Tangent": tangent, "Angle": float(meta["angle"]),
        "MinCos": float(meta["min_cos"]),
        "Stretched": 1.0 if meta.get("pattern") == "stretched" else 0.0})
    shared = {k: frame[k] for k in ("X", "Y", "N", "Wo", "Vh", "T1", "T2", "S", "Lambda",
                                    "TurnCos", "TurnSin")}
    constants = {"Bias": float(meta["bias"]), "Levels": float(levels),
                 "Texel": (math.pi / height) * (2.0 * math.pi / width),
                 "Pole": math.sin(math.pi / (2.0 * height))}
    sizes = {"Slices": float(slices), "Slice Height": float(height),
             "Slice Width": float(width), "Atlas Cols": float(width + 3)}

    def sample(index):
        p1, p2, prob = _sample_data(b, image, meta, index)
        return _group_node(b, sample_group(ax, ay, meta.get("kind", "ggx")),
                           {**shared, **constants, "P1": p1, "P2": p2, "Prob": prob})

    state, result, after = _repeat_zone(b, count, [("FLOAT", "Strongest", 0.0)])
    b.link(b.math("MAXIMUM", state["Strongest"], sample(state["Iteration"])["Weight"]),
           result["Strongest"])
    threshold = b.math("MULTIPLY", after["Strongest"], float(meta["xi0"]))
    state, result, after = _repeat_zone(b, count, [("FLOAT", "Total", 0.0),
                                                   ("VECTOR", "Sum", (0.0, 0.0, 0.0))])
    out = sample(state["Iteration"])
    low = b.math("FLOOR", out["Level"])
    high = b.math("MINIMUM", b.math("ADD", low, 1.0), float(levels - 1))
    values = []
    for k in (low, high):
        taps = _group_node(b, atlas_taps_group(), {
            "Normal": out["Direction"], "Incoming": out["Direction"], "Offset": 0.0,
            **_level_sizes(b, meta, k, sizes)})
        top = b.mix(taps["FX"], _tap(b, taps["UV00"], image), _tap(b, taps["UV01"], image))
        bottom = b.mix(taps["FX"], _tap(b, taps["UV10"], image), _tap(b, taps["UV11"], image))
        values.append(b.mix(taps["FY"], top, bottom))
    radiance = b.mix(b.math("SUBTRACT", out["Level"], low), values[0], values[1])
    weight = out["Weight"]
    kept = b.math("MULTIPLY", weight, b.math("SUBTRACT", 1.0, b.math(
        "LESS_THAN", weight, threshold)))
    b.link(b.math("ADD", state["Total"], kept), result["Total"])
    b.link(b.vec("ADD", state["Sum"], b.vec("SCALE", radiance, scale=kept)), result["Sum"])
    mean = b.vec("SCALE", after["Sum"], scale=b.math("DIVIDE", 1.0, b.math(
        "MAXIMUM", after["Total"], 1e-30)))
    return (b.vec("MULTIPLY", mean, _albedo(b, image, meta, frame["Wo"])),
            _lights_value(b, image, meta, frame))


def _level_sizes(b, meta, k, sizes):
    """The ``Glossy Atlas Taps`` inputs that read whole level ``k`` (a socket) of the
    level stack: ``sizes`` and K itself for an atlas of equal slices (before stop
    75); for bake.sampling_atlas's "mip" layout the level's own rows H_k = H 2^-k and
    columns 2 H_k, and K and Slices such that the group's K (H_k + 2) is the
    level's first row r_k = 2 H (1 - 2^-k) + 2 k and its Slices (H_k + 2) the
    atlas's rows (fractions are fine: the group only multiplies them; every
    value is exact in float32 but the quotients, whose rounding, below 1e-3 rows,
    leaves each Closest tap on its texel's centre)."""
    if meta.get("level_layout") != "mip":
        return {**sizes, "K": k}
    top = float(meta["slice_height"])
    scale = b.math("POWER", 2.0, b.math("MULTIPLY", k, -1.0))
    rows = b.math("MULTIPLY", scale, top)
    padded = b.math("ADD", rows, 2.0)
    first = b.math("ADD", b.math("SUBTRACT", 2.0 * top, b.math("MULTIPLY", rows, 2.0)),
                   b.math("MULTIPLY", k, 2.0))
    return {"K": b.math("DIVIDE", first, padded),
            "Slices": b.math("DIVIDE", float(atlas_rows(meta)), padded),
            "Slice Height": rows, "Slice Width": b.math("MULTIPLY", rows, 2.0),
            "Atlas Cols": sizes["Atlas Cols"]}


def _albedo(b, image, meta, wo, table=0):
    """rho(wo) from the table slice (``table`` 1: the lights' scale rho / A_ss, the
    rows after rho's): four Closest taps, bilinear weights."""
    count_mu, count_phi = int(meta["albedo_mu"]), int(meta["albedo_phi"])
    width = int(meta["slice_width"])
    rows, cols = float(atlas_rows(meta)), float(width + 3)
    base = table_row(meta) + table * count_phi
    min_cos = float(meta["min_cos"])
    wx, wy, wz = b.separate(wo)
    x = b.math("MULTIPLY", b.math("MINIMUM", b.math("MAXIMUM", b.math(
        "DIVIDE", b.math("SUBTRACT", wz, min_cos), 1.0 - min_cos), 0.0), 1.0), count_mu - 1)
    x0 = b.math("MINIMUM", b.math("FLOOR", x), count_mu - 2)
    fx = b.math("SUBTRACT", x, x0)
    if count_phi > 1:
        phi = b.math("ARCTAN2", b.math("ABSOLUTE", wy), b.math("ABSOLUTE", wx))
        y = b.math("MULTIPLY", b.math("MINIMUM", b.math("MAXIMUM", b.math(
            "DIVIDE", phi, 0.5 * math.pi), 0.0), 1.0), count_phi - 1)
        y0 = b.math("MINIMUM", b.math("FLOOR", y), count_phi - 2)
        fy, step = b.math("SUBTRACT", y, y0), 1.0
    else:
        y0, fy, step = 0.0, 0.0, 0.0
    u0 = b.math("DIVIDE", b.math("ADD", x0, 1.5), cols)
    u1 = b.math("DIVIDE", b.math("ADD", x0, 2.5), cols)
    row0 = b.math("ADD", y0, base + 0.5)
    v0 = b.math("SUBTRACT", 1.0, b.math("DIVIDE", row0, rows))
    v1 = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", row0, step), rows))
    top = b.mix(fx, _tap(b, b.combine(u0, v0), image), _tap(b, b.combine(u1, v0), image))
    bottom = b.mix(fx, _tap(b, b.combine(u0, v1), image), _tap(b, b.combine(u1, v1), image))
    return b.mix(fy, top, bottom)


def tangent_socket(b, tangent):
    """Blender's Tangent node set to ("RADIAL", axis) or ("UV_MAP", name): its output."""
    node = b._place(b.nodes.new("ShaderNodeTangent"))
    node.direction_type = tangent[0]
    if tangent[0] == "RADIAL":
        node.axis = tangent[1]
    else:
        node.uv_map = tangent[1]
    return node.outputs["Tangent"]


def hybrid_value(b, meta, normal, view, map_value, runtime_value_socket):
    """(1 - w) map + w runtime, w(mu = n.v) piecewise linear through the runtime
    meta's knots (bake.hybrid.blend_curve's arithmetic)."""
    centres = [float(c) for c in meta["blend_mu"]]
    weights = [float(w) for w in meta["blend_weight"]]
    mu = b.vec("DOT_PRODUCT", b.vec("NORMALIZE", normal), b.vec("NORMALIZE", view))
    weight = weights[0]
    for i in range(len(centres) - 1):
        step = weights[i + 1] - weights[i]
        if step == 0.0:
            continue
        t = b.math("MINIMUM", b.math("MAXIMUM", b.math("DIVIDE", b.math(
            "SUBTRACT", mu, centres[i]), centres[i + 1] - centres[i]), 0.0), 1.0)
        weight = b.math("ADD", b.math("MULTIPLY", t, step), weight)
    return b.mix(weight, map_value, runtime_value_socket)


def build_runtime(material, image, meta, tangent=("RADIAL", "Z")):
    """Replace ``material``'s nodes by the runtime-sampling lookup of ``image``
    (a bake.sampling_runtime atlas). tangent: ("RADIAL", axis) or ("UV_MAP", name),
    Blender's Tangent node (as Cycles takes an anisotropic BSDF's tangent)."""
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    b = _Builder(tree)
    geometry = b._place(tree.nodes.new("ShaderNodeNewGeometry"))
    value = runtime_value(b, image, meta, geometry.outputs["Normal"],
                          geometry.outputs["Incoming"], tangent_socket(b, tangent))
    emission = b._place(tree.nodes.new("ShaderNodeEmission"))
    b.link(value, emission.inputs["Color"])
    output = b._place(tree.nodes.new("ShaderNodeOutputMaterial"))
    b.link(emission.outputs[0], output.inputs["Surface"])
    material["glossy_runtime_version"] = GROUP_VERSION
    return material
