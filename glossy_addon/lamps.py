"""Blender's lamps in Glossy's materials: separable BRDF factors (Kautz & McCool 1999).

For each lamp that lights the object the attached material adds
sum_k s_k g_k(u) h_k(v) cos(theta_i) E, with (u, v) the factorization's
parameterization of (light, view) in the surface's tangent frame (Cycles'
convention: Y = normalize(n x T), X = Y x n, T = the Tangent node, radial
about the object's Z, which is what Cycles' Glossy BSDF uses unconnected),
and g_k averaged over a cap as wide as the lamp seen from the point
(bake.lamp_spread: the light of a lamp of angular radius alpha reaches the
BRDF over a cone of light directions; two of the baked cap levels blended by
the ``Glossy Spread Level`` and ``Glossy Spread Texel`` groups; bake.lamp_term
is the NumPy twin of these nodes).

E is the irradiance a surface facing the lamp receives, converted as Cycles
5.0 does (measured with a white Lambert plane under each lamp, Cycles at 256
samples; tests/blender/test_lamps.py checks the four kinds together against
Cycles renders of the true BSDF):

- point, power P, radius r at distance d: E = P / (4 pi (d^2 + r^2))
  (Cycles treats the sphere as a disc facing the point) and alpha = atan(r /
  d); with Soft Falloff off a sphere of radiance P / (4 pi^2 r^2): E = P / (4
  pi d^2) and alpha = asin(r / d) (before stop 54 the disc's E: 4% dim at r /
  d = 0.2);
- spot: the point's E times smoothstep(0, 1, (cos a - cos(size / 2)) /
  ((1 - cos(size / 2)) blend)), a the angle from the lamp's -Z (no extra
  cosine); the object's scale, which Cycles uses to squash the cone, is ignored;
- sun, strength S: E = S along the lamp's -Z, alpha = its Angle / 2;
- area, power P: split into near-square cells (bake.lamp_spread.area_cells,
  fixed at attach: about 2 x 2 for a square, one per unit of aspect for a
  long rectangle, one for a disk), each a Lambertian emitter of its share s of
  the power at its centre, E = P s cos(a) / (pi d^2), alpha the cap of its
  projected area. Spread below 180 degrees is not converted (the lamp is
  skipped and the panel says so).

Before stop 54 every lamp was a point (and an area lamp one point at its
centre): a GGX 0.3 sphere under a point lamp of radius 0.5, a 10-degree sun
and a 1.2 x 0.6 area lamp was 36% from Cycles, now 4.7% (native EEVEE 2.3%;
tests/blender/test_lamps.py, with a sphere lamp added there).

The colour is Color times the Temperature's colour where Use Temperature is
on, the power Power x 2^Exposure (and, for a point or spot lamp without
Normalize, x 4 pi r^2: its power is then per square metre of its sphere), as
Cycles 5.0 renders them (measured with a white Lambert plane; an area lamp
without Normalize is skipped and named). Before stop 53 Exposure and
Temperature were ignored: a lamp at Exposure 1 lit the material at half its
brightness in Cycles, a 3200 K one white instead of orange.

Colour, power, radius, cone, a sun's angle, an area lamp's size and scale,
position and direction are read live through drivers (simple expressions: no
Python needs to run), so moving, re-aiming, resizing or re-colouring a lamp
needs no re-bake or re-attach; adding or removing one, or changing an area
lamp's shape or the number of its cells, needs a re-attach (the panel says
when the set changed). Lamps with their own
node trees (textures, IES) are skipped and named.

Shadows: EEVEE gives a material no per-lamp visibility (Shader to RGB returns
the sum over every lamp and the world), so the lamp term is unshadowed; the
cos(theta_i) clamp removes the self-shadowed side of a convex object only.
"""

import json
import math

import bpy

from .nodes import _Builder, _group, _group_node, _io

GROUP_VERSION = 2
KINDS = ("POINT", "SPOT", "SUN", "AREA")
#: The coordinates' shared groups, and the cap levels' (bake.lamp_spread).
COORDS_VERSION = 1
SPREAD_VERSION = 1


# --- which lamps ----------------------------------------------------------------------
def _node_tree_problem(light):
    tree = getattr(light, "node_tree", None)
    if tree is None or not getattr(light, "use_nodes", True):
        return None
    kinds = {node.type for node in tree.nodes}
    if not kinds <= {"EMISSION", "OUTPUT_LIGHT"}:
        return "its node tree has nodes Glossy cannot convert (textures, IES, ...)"
    for node in tree.nodes:
        if node.type == "EMISSION":
            color = tuple(node.inputs["Color"].default_value)[:3]
            if node.inputs["Color"].is_linked or node.inputs["Strength"].is_linked or \
                    abs(node.inputs["Strength"].default_value - 1.0) > 1e-6 or \
                    any(abs(c - 1.0) > 1e-6 for c in color):
                return "its Emission node changes the lamp's colour or strength"
    return None


def lamp_problem(obj):
    """Why Glossy cannot convert this lamp object, or None."""
    light = obj.data
    if light.type not in KINDS:
        return f"lamp type {light.type} is not supported"
    if light.type == "AREA" and getattr(light, "spread", math.pi) < math.pi - 1e-6:
        return "an area lamp's spread below 180 degrees is not converted"
    if light.type == "AREA" and not getattr(light, "normalize", True):
        return "an area lamp without Normalize (power per square metre) is not converted"
    return _node_tree_problem(light)


def scene_lamps(scene):
    """(lamps, skipped): the lamp objects that render in ``scene`` and that Glossy
    converts (sorted by name), and (name, reason) for those it skips."""
    lamps, skipped = [], []
    for obj in sorted(scene.objects, key=lambda o: o.name):
        if obj.type != "LIGHT" or obj.hide_render:
            continue
        problem = lamp_problem(obj)
        if problem:
            skipped.append((obj.name, problem))
        else:
            lamps.append(obj)
    return lamps, skipped


def area_extents(obj):
    """(width, height): an area lamp's full extents along its X and Y in world
    units (Size, or Size X and Size Y, times the object's world scale)."""
    light = obj.data
    scale = obj.matrix_world.to_scale()
    height = light.size_y if light.shape in ("RECTANGLE", "ELLIPSE") else light.size
    return float(light.size) * abs(scale[0]), float(height) * abs(scale[1])


def area_layout(obj):
    """The cells (bake.lamp_spread.area_cells) an area lamp is split into, as
    attached: [(u, v, share)]; a zero-sized lamp is one cell."""
    from ..bake.lamp_spread import area_cells

    width, height = area_extents(obj)
    if width <= 0.0 or height <= 0.0:
        return [(0.0, 0.0, 1.0)]
    return area_cells(obj.data.shape, width, height)


def _lamp_kind(obj):
    """A lamp's type, with an area lamp's shape and cell count (its layout is
    fixed at attach: a new shape or aspect needs a re-attach)."""
    if obj.data.type != "AREA":
        return obj.data.type
    return f"AREA {obj.data.shape} {len(area_layout(obj))}"


def lamp_set(lamps):
    """The JSON signature of a set of lamps (names and kinds) kept at attach."""
    return json.dumps(sorted([obj.name, _lamp_kind(obj)] for obj in lamps))


def lamp_set_changed(material, scene):
    """True when the scene's converted lamps differ from the ones attached."""
    if not material.glossy.lamp_set:
        return False
    return lamp_set(scene_lamps(scene)[0]) != material.glossy.lamp_set


def reference_lamps(scene):
    """([bake.lamp_reference.Lamp], [note]): every lamp that renders in ``scene`` as
    the validation's NumPy reference integrates it (its emitter as Cycles 5.0
    has it, the object's world transform at the current frame), and a note for
    each lamp it leaves out or takes only in part. Colour is Color (times the
    Temperature's colour where Use Temperature is on) x Power x 2^Exposure, as
    measured in Cycles; without Normalize a point or spot lamp's power is per
    square metre of its sphere, an area lamp's per square metre of its area."""
    from ..bake.lamp_reference import Lamp

    lamps, notes = [], []
    for obj in sorted(scene.objects, key=lambda o: o.name):
        if obj.type != "LIGHT" or obj.hide_render:
            continue
        light = obj.data
        problem = _node_tree_problem(light) if light.type in KINDS else \
            f"lamp type {light.type} is not supported"
        if light.type == "AREA" and getattr(light, "spread", math.pi) < math.pi - 1e-6:
            problem = "an area lamp's spread below 180 degrees is not integrated"
        if problem:
            notes.append(f"lamp {obj.name} is left out of the NumPy reference ({problem})")
            continue
        colour = [float(c) for c in light.color]
        if getattr(light, "use_temperature", False):
            colour = [c * float(t) for c, t in zip(colour, light.temperature_color, strict=True)]
        scale = float(light.energy) * 2.0 ** float(getattr(light, "exposure", 0.0))
        matrix = obj.matrix_world
        columns = [matrix.col[axis].to_3d() for axis in range(3)]
        lengths = [max(column.length, 1e-12) for column in columns]
        axes = tuple(tuple(column / length) for column, length in zip(columns, lengths,
                                                                         strict=True))
        values = {"kind": light.type, "position": tuple(matrix.translation), "axes": axes,
                  "name": obj.name}
        normalized = getattr(light, "normalize", True)
        if light.type in ("POINT", "SPOT"):
            radius = float(light.shadow_soft_size)
            values.update(radius=radius, sphere=not getattr(light, "use_soft_falloff", True))
            if not normalized:
                scale *= 4.0 * math.pi * radius ** 2
            if light.type == "SPOT":
                values.update(spot_size=float(light.spot_size),
                              spot_blend=float(light.spot_blend))
        elif light.type == "SUN":
            values.update(angle=float(light.angle))
        else:
            width = float(light.size) * lengths[0]
            height = (float(light.size_y) if light.shape in ("RECTANGLE", "ELLIPSE")
                      else float(light.size)) * lengths[1]
            values.update(shape=light.shape, size=(width, height))
            if not normalized:
                scale *= width * height * (math.pi / 4.0 if light.shape in ("DISK", "ELLIPSE")
                                           else 1.0)
        values["colour"] = tuple(c * scale for c in colour)
        lamps.append(Lamp(**values))
        factors = [name for name, value in (("Diffuse", light.diffuse_factor),
                                            ("Specular", light.specular_factor))
                   if abs(float(value) - 1.0) > 1e-6]
        if factors:
            notes.append(f"lamp {obj.name}: its {' and '.join(factors)} factor is not "
                         f"applied by the NumPy reference")
    return lamps, notes


# --- shared node groups ----------------------------------------------------------------
FLOAT, VECTOR, COLOR = "NodeSocketFloat", "NodeSocketVector", "NodeSocketColor"


def _colour_scale(b, colour, factor):
    node = b._place(b.nodes.new("ShaderNodeVectorMath"))
    node.operation = "SCALE"
    b.link(colour, node.inputs[0])
    b.link(factor, node.inputs["Scale"])
    return node.outputs["Vector"]


def _point_irradiance(b, inputs):
    """(unit vector to the lamp, distance^2) from the shading point."""
    offset = b.vec("SUBTRACT", inputs["Lamp Location"], inputs["Position"])
    distance2 = b.vec("DOT_PRODUCT", offset, offset)
    return b.vec("NORMALIZE", offset), distance2


def lamp_group(kind):
    """Shared group ``Glossy <Kind> Lamp v2``: Light (unit vector from the shading
    point to the lamp, or to an area lamp's cell, world), Irradiance (W/m^2 on a
    surface facing it, RGB) and Spread (the lamp's or cell's angular radius
    seen from the point, rad: bake.lamp_term's formulas)."""
    name = f"Glossy {kind.title()} Lamp v{GROUP_VERSION}"
    inputs = [("Position", VECTOR), ("Lamp Location", VECTOR), ("Lamp Direction", VECTOR),
              ("Lamp X", VECTOR), ("Lamp Y", VECTOR), ("Color", COLOR), ("Power", FLOAT),
              ("Radius", FLOAT), ("Sphere", FLOAT), ("Cos Half Angle", FLOAT), ("Blend", FLOAT),
              ("Angle", FLOAT), ("Width", FLOAT), ("Height", FLOAT), ("Shape Area", FLOAT),
              ("Cell", VECTOR)]
    tree = _group(name, inputs, [("Light", VECTOR), ("Irradiance", COLOR), ("Spread", FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, o = _io(tree)
    if kind == "SUN":
        light = b.vec("SCALE", b.vec("NORMALIZE", i["Lamp Direction"]), scale=-1.0)
        strength = i["Power"]
        spread = b.math("MULTIPLY", i["Angle"], 0.5)
    elif kind == "AREA":  # a cell (u, v, share): Lambertian, P share cos(a) / (pi d^2)
        u, v, share = b.separate(i["Cell"])
        centre = b.vec("ADD", i["Lamp Location"], b.vec("ADD", b.vec(
            "SCALE", i["Lamp X"], scale=b.math("MULTIPLY", u, i["Width"])), b.vec(
            "SCALE", i["Lamp Y"], scale=b.math("MULTIPLY", v, i["Height"]))))
        offset = b.vec("SUBTRACT", centre, i["Position"])
        distance2 = b.vec("DOT_PRODUCT", offset, offset)
        light = b.vec("NORMALIZE", offset)
        cos_a = b.math("MAXIMUM", b.math("MULTIPLY", b.vec(
            "DOT_PRODUCT", light, b.vec("NORMALIZE", i["Lamp Direction"])), -1.0), 0.0)
        strength = b.math("DIVIDE", b.math("MULTIPLY", b.math("MULTIPLY", i["Power"], share),
                                           cos_a),
                          b.math("MULTIPLY", distance2, math.pi))
        area = b.math("MULTIPLY", b.math("MULTIPLY", b.math("MULTIPLY", i["Width"],
                                                              i["Height"]),
                                         i["Shape Area"]), share)
        spread = b.math("ARCTAN2", b.math("SQRT", b.math("DIVIDE", b.math(
            "MULTIPLY", area, cos_a), math.pi)), b.math("SQRT", distance2))
    else:  # point and spot: P / (4 pi (d^2 + r^2)), a sphere's P / (4 pi d^2)
        light, distance2 = _point_irradiance(b, i)
        radius2 = b.math("MULTIPLY", b.math("MULTIPLY", i["Radius"], i["Radius"]),
                         b.math("SUBTRACT", 1.0, i["Sphere"]))
        strength = b.math("DIVIDE", i["Power"], b.math(
            "MULTIPLY", b.math("ADD", distance2, radius2), 4.0 * math.pi))
        distance = b.math("SQRT", distance2)
        disc = b.math("ARCTAN2", i["Radius"], distance)  # Soft Falloff: a disc facing the point
        sphere = b.math("ARCSINE", b.math("MINIMUM", b.math("DIVIDE", i["Radius"], b.math(
            "MAXIMUM", distance, 1e-12)), 1.0))
        spread = b.select(i["Sphere"], sphere, disc)
        if kind == "SPOT":
            cos_a = b.math("MULTIPLY", b.vec("DOT_PRODUCT", light, b.vec(
                "NORMALIZE", i["Lamp Direction"])), -1.0)
            cos_half = i["Cos Half Angle"]
            width = b.math("MAXIMUM", b.math("MULTIPLY", b.math("SUBTRACT", 1.0, cos_half),
                                             i["Blend"]), 1e-9)
            x = b.math("MINIMUM", b.math("MAXIMUM", b.math(
                "DIVIDE", b.math("SUBTRACT", cos_a, cos_half), width), 0.0), 1.0)
            smooth = b.math("MULTIPLY", b.math("MULTIPLY", x, x),
                            b.math("SUBTRACT", 3.0, b.math("MULTIPLY", x, 2.0)))
            strength = b.math("MULTIPLY", strength, smooth)
    b.link(light, o["Light"])
    b.link(_colour_scale(b, i["Color"], strength), o["Irradiance"])
    b.link(spread, o["Spread"])
    return tree


def _cap_area(b, rho):
    """1 - cos(rho) as 2 sin^2(rho / 2) (no cancellation in single precision)."""
    half = b.math("SINE", b.math("MULTIPLY", rho, 0.5))
    return b.math("MULTIPLY", b.math("MULTIPLY", half, half), 2.0)


def spread_level_group():
    """Shared group ``Glossy Spread Level v1``: a cap radius (rad) -> the two cap
    levels to blend and their weights (bake.lamp_spread.level_weights, the
    same arithmetic)."""
    name = f"Glossy Spread Level v{SPREAD_VERSION}"
    tree = _group(name, [("Spread", FLOAT), ("First Radius", FLOAT), ("Levels", FLOAT),
                         ("Per Octave", FLOAT)],
                  [("Level A", FLOAT), ("Level B", FLOAT), ("Weight A", FLOAT),
                   ("Weight B", FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, o = _io(tree)
    first, count, per_octave = i["First Radius"], i["Levels"], i["Per Octave"]

    def radius(level):  # first 2^((level - 1) / P)
        return b.math("MULTIPLY", first, b.math("POWER", 2.0, b.math(
            "DIVIDE", b.math("SUBTRACT", level, 1.0), per_octave)))

    rho = b.math("MINIMUM", b.math("MAXIMUM", i["Spread"], 0.0), radius(count))
    area = _cap_area(b, rho)
    small = b.math("LESS_THAN", rho, first)
    step = b.math("ADD", b.math("FLOOR", b.math("MULTIPLY", per_octave, b.math(
        "LOGARITHM", b.math("DIVIDE", b.math("MAXIMUM", rho, first), first), 2.0))), 1.0)
    level_a = b.math("MINIMUM", b.math("MAXIMUM", step, 1.0), b.math(
        "MAXIMUM", b.math("SUBTRACT", count, 1.0), 1.0))
    level_b = b.math("MINIMUM", b.math("ADD", level_a, 1.0), count)
    area_a, area_b = _cap_area(b, radius(level_a)), _cap_area(b, radius(level_b))
    t = b.math("MULTIPLY", b.math("MINIMUM", b.math("MAXIMUM", b.math("DIVIDE", b.math(
        "SUBTRACT", area, area_a), b.math("MAXIMUM", b.math("SUBTRACT", area_b, area_a),
                                          1e-30)), 0.0), 1.0),
        b.math("GREATER_THAN", level_b, level_a))
    # the area at rho >= rho_1 keeps both branches bounded (a select of 0 x huge
    # + huge would cancel in single precision)
    floor_area = _cap_area(b, b.math("MAXIMUM", rho, first))
    large_a = b.math("DIVIDE", b.math("MULTIPLY", b.math("SUBTRACT", 1.0, t), area_a),
                     floor_area)
    large_b = b.math("DIVIDE", b.math("MULTIPLY", t, area_b), floor_area)
    s = b.math("MINIMUM", b.math("MAXIMUM", b.math("DIVIDE", area, _cap_area(b, first)),
                                 0.0), 1.0)
    b.link(b.select(small, 0.0, level_a), o["Level A"])
    b.link(b.select(small, 1.0, level_b), o["Level B"])
    b.link(b.select(small, b.math("SUBTRACT", 1.0, s), large_a), o["Weight A"])
    b.link(b.select(small, s, large_b), o["Weight B"])
    return tree


def spread_texel_group():
    """Shared group ``Glossy Spread Texel v1``: the continuous atlas texel (column,
    row) of a term's g at one cap level (0: the factor), from the factor's own
    clamped texel coordinates (bake.lamp_spread.level_layout's closed forms)."""
    name = f"Glossy Spread Texel v{SPREAD_VERSION}"
    tree = _group(name, [("G Column", FLOAT), ("G Row", FLOAT), ("Level", FLOAT),
                         ("Size", FLOAT), ("Terms", FLOAT), ("Term", FLOAT),
                         ("Per Octave", FLOAT)],
                  [("Column", FLOAT), ("Row", FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, o = _io(tree)
    size, level, per_octave = i["Size"], i["Level"], i["Per Octave"]
    is_level = b.math("GREATER_THAN", level, 0.5)
    below = b.math("MAXIMUM", b.math("SUBTRACT", level, 1.0), 0.0)  # j - 1 (0 for level 0)
    q = b.math("FLOOR", b.math("DIVIDE", b.math("ADD", below, 0.5), per_octave))
    r = b.math("SUBTRACT", below, b.math("MULTIPLY", q, per_octave))
    side = b.math("DIVIDE", size, b.math("POWER", 2.0, q))
    tile = b.math("ADD", side, 2.0)
    before = b.math("ADD", b.math("MULTIPLY", per_octave, b.math("ADD", b.math(
        "MULTIPLY", size, b.math("SUBTRACT", 2.0, b.math("POWER", 2.0, b.math(
            "SUBTRACT", 1.0, q)))), b.math("MULTIPLY", q, 2.0))), b.math("MULTIPLY", r, tile))
    column = b.math("ADD", b.math("MULTIPLY", b.math("MULTIPLY", is_level, i["Terms"]), before),
                    b.math("MULTIPLY", i["Term"], tile))
    high = b.math("SUBTRACT", side, 0.5)

    def scaled(coordinate):
        value = b.math("SUBTRACT", b.math("DIVIDE", b.math("MULTIPLY", b.math(
            "ADD", coordinate, 0.5), side), size), 0.5)
        return b.math("MINIMUM", b.math("MAXIMUM", value, -0.5), high)

    b.link(b.math("ADD", b.math("ADD", scaled(i["G Column"]), 1.0), column), o["Column"])
    b.link(b.math("ADD", b.math("ADD", scaled(i["G Row"]), 1.0), b.math(
        "MULTIPLY", is_level, b.math("ADD", size, 2.0))), o["Row"])
    return tree


def _local(b, vector, x_axis, y_axis, normal):
    return (b.vec("DOT_PRODUCT", vector, x_axis), b.vec("DOT_PRODUCT", vector, y_axis),
            b.vec("DOT_PRODUCT", vector, normal))


def _hemisphere_texel(b, x, y, z, size, parabolic):
    """Continuous texel (column, row) of a local unit vector on a hemisphere map,
    clamped to [-0.5, size - 0.5] (bake.separable.hemisphere_coords)."""
    denominator = b.math("ADD", 1.0, b.math("MULTIPLY", parabolic, b.math("MAXIMUM", z, 0.0)))
    X, Y = b.math("DIVIDE", x, denominator), b.math("DIVIDE", y, denominator)
    col = b.math("SUBTRACT", b.math("MULTIPLY", b.math("MULTIPLY", b.math("ADD", X, 1.0), 0.5),
                                    size), 0.5)
    row = b.math("SUBTRACT", b.math("MULTIPLY", b.math("MULTIPLY", b.math("SUBTRACT", 1.0, Y),
                                                       0.5), size), 0.5)
    high = b.math("SUBTRACT", size, 0.5)
    return (b.math("MINIMUM", b.math("MAXIMUM", col, -0.5), high),
            b.math("MINIMUM", b.math("MAXIMUM", row, -0.5), high))


def _angle_texel(b, angle, period, size):
    return b.math("SUBTRACT", b.math("MULTIPLY", angle, b.math("DIVIDE", size, period)), 0.5)


def _azimuth(b, x, y):
    phi = b.math("ARCTAN2", y, x)
    return b.math("ADD", phi, b.math("MULTIPLY", b.math("LESS_THAN", phi, 0.0), 2.0 * math.pi))


def coords_group(parameterization):
    """Shared group ``Glossy Separable <Parameterization> v1``: the continuous texel
    coordinates of (light, view) on the g and h maps (bake.separable._Grid.coords),
    Cos Light = max(n.l, 0) and Valid = 1 where light and view are both above the
    surface."""
    name = f"Glossy Separable {parameterization.title()} v{COORDS_VERSION}"
    tree = _group(name, [("Normal", VECTOR), ("Tangent", VECTOR), ("Incoming", VECTOR),
                         ("Light", VECTOR), ("Size", FLOAT), ("H Size", FLOAT),
                         ("Parabolic", FLOAT)],
                  [("G Column", FLOAT), ("G Row", FLOAT), ("H Column", FLOAT), ("H Row", FLOAT),
                   ("Cos Light", FLOAT), ("Valid", FLOAT)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, o = _io(tree)
    size, size_h, parabolic = i["Size"], i["H Size"], i["Parabolic"]
    normal = b.vec("NORMALIZE", i["Normal"])
    y_axis = b.vec("NORMALIZE", b.vec("CROSS_PRODUCT", normal, i["Tangent"]))
    x_axis = b.vec("CROSS_PRODUCT", y_axis, normal)
    wi = _local(b, b.vec("NORMALIZE", i["Light"]), x_axis, y_axis, normal)
    wo = _local(b, b.vec("NORMALIZE", i["Incoming"]), x_axis, y_axis, normal)
    if parameterization == "incident-view":
        g = _hemisphere_texel(b, *wi, size, parabolic)
        h = _hemisphere_texel(b, *wo, size_h, parabolic)
    elif parameterization == "elevation-azimuth":
        theta_i = b.math("ARCCOSINE", b.math("MINIMUM", b.math("MAXIMUM", wi[2], -1.0), 1.0))
        theta_o = b.math("ARCCOSINE", b.math("MINIMUM", b.math("MAXIMUM", wo[2], -1.0), 1.0))
        g = (_angle_texel(b, theta_o, math.pi / 2, size), _angle_texel(b, theta_i, math.pi / 2,
                                                                       size))
        h = (_angle_texel(b, _azimuth(b, wo[0], wo[1]), 2 * math.pi, size_h),
             _angle_texel(b, _azimuth(b, wi[0], wi[1]), 2 * math.pi, size_h))
    else:
        wi_v, wo_v = b.combine(*wi), b.combine(*wo)
        half = b.vec("NORMALIZE", b.vec("ADD", wi_v, wo_v))
        hx, hy, hz = b.separate(half)
        g = _hemisphere_texel(b, hx, hy, hz, size, parabolic)
        if parameterization == "half-difference":  # wi turned by -phi_h about z, -theta_h about y
            e1 = b.vec("NORMALIZE", b.combine(b.math("ADD", hx, 1e-12), hy, 0.0))
            e1x, e1y, _ = b.separate(e1)
            sin_t = b.math("SQRT", b.math("MAXIMUM", b.math(
                "SUBTRACT", 1.0, b.math("MULTIPLY", hz, hz)), 0.0))
            along = b.math("ADD", b.math("MULTIPLY", wi[0], e1x), b.math("MULTIPLY", wi[1], e1y))
            dx = b.math("SUBTRACT", b.math("MULTIPLY", hz, along), b.math("MULTIPLY", sin_t, wi[2]))
            dy = b.math("SUBTRACT", b.math("MULTIPLY", wi[1], e1x), b.math("MULTIPLY", wi[0], e1y))
            dz = b.vec("DOT_PRODUCT", wi_v, half)
        else:  # gram-schmidt: x' = normalize(x - hx h), y' = h x x', wo in (x', y', h)
            xp = b.vec("NORMALIZE", b.vec("SUBTRACT", b.combine(1.0, 0.0, 0.0),
                                          b.vec("SCALE", half, scale=hx)))
            yp = b.vec("CROSS_PRODUCT", half, xp)
            dx, dy, dz = (b.vec("DOT_PRODUCT", wo_v, xp), b.vec("DOT_PRODUCT", wo_v, yp),
                          b.vec("DOT_PRODUCT", wo_v, half))
        h = _hemisphere_texel(b, dx, dy, dz, size_h, parabolic)
    for name_, value in zip(("G Column", "G Row", "H Column", "H Row"), (*g, *h), strict=True):
        b.link(value, o[name_])
    b.link(b.math("MAXIMUM", wi[2], 0.0), o["Cos Light"])
    b.link(b.math("MULTIPLY", b.math("GREATER_THAN", wi[2], 0.0),
                  b.math("GREATER_THAN", wo[2], 0.0)), o["Valid"])
    return tree


# --- drivers ------------------------------------------------------------------------------
def _driver(socket, index, expression, variables):
    """Drive ``socket.default_value[index]`` (index None: a float socket) by a
    simple expression of driver variables (name, 'TRANSFORM', object, transform
    type) or (name, 'PROP', light data, data path)."""
    curve = socket.driver_add("default_value") if index is None else \
        socket.driver_add("default_value", index)
    driver = curve.driver
    driver.type = "SCRIPTED"
    for name, kind, target_id, what in variables:
        variable = driver.variables.new()
        variable.name = name
        if kind == "TRANSFORM":
            variable.type = "TRANSFORMS"
            target = variable.targets[0]
            target.id = target_id
            target.transform_type = what
            target.transform_space = "WORLD_SPACE"
            target.rotation_mode = "QUATERNION"
        else:
            variable.type = "SINGLE_PROP"
            target = variable.targets[0]
            target.id_type = "LIGHT"
            target.id = target_id
            target.data_path = what
    driver.expression = expression
    return curve


def drive_lamp_inputs(node, obj):
    """Connect a lamp group node's inputs to the lamp object ``obj`` by drivers."""
    light = obj.data
    for axis, name in enumerate("XYZ"):
        _driver(node.inputs["Lamp Location"], axis, "v",
                [("v", "TRANSFORM", obj, f"LOC_{name}")])
    rotation = [(n, "TRANSFORM", obj, f"ROT_{n.upper()}") for n in "wxyz"]
    for axis, expression in enumerate(("-2*(x*z + w*y)", "-2*(y*z - w*x)",
                                       "-(1 - 2*(x*x + y*y))")):  # the lamp's -Z in world
        _driver(node.inputs["Lamp Direction"], axis, expression, rotation)
    for channel in range(3):
        colour = [("v", "PROP", light, f"color[{channel}]")]
        expression = "v"
        if hasattr(light, "use_temperature"):  # Blender 4.5+: Color x the Temperature's
            colour += [("u", "PROP", light, "use_temperature"),
                       ("t", "PROP", light, f"temperature_color[{channel}]")]
            expression = "v * (t if u else 1.0)"
        _driver(node.inputs["Color"], channel, expression, colour)
    power, expression = [("v", "PROP", light, "energy")], "v"
    if hasattr(light, "exposure"):  # Power x 2^Exposure
        power.append(("e", "PROP", light, "exposure"))
        expression = "v * pow(2.0, e)"
    if hasattr(light, "normalize") and light.type in ("POINT", "SPOT"):
        # without Normalize the power is per square metre of the lamp's sphere
        power += [("n", "PROP", light, "normalize"), ("r", "PROP", light, "shadow_soft_size")]
        expression = f"{expression} * (1.0 if n else 4.0 * pi * r * r)"
    _driver(node.inputs["Power"], None, expression, power)
    if light.type in ("POINT", "SPOT"):
        _driver(node.inputs["Radius"], None, "v", [("v", "PROP", light, "shadow_soft_size")])
        if hasattr(light, "use_soft_falloff"):
            _driver(node.inputs["Sphere"], None, "0.0 if v else 1.0",
                    [("v", "PROP", light, "use_soft_falloff")])
    if light.type == "SUN":
        _driver(node.inputs["Angle"], None, "v", [("v", "PROP", light, "angle")])
    if light.type == "AREA":
        for axis, expression in enumerate(("1 - 2*(y*y + z*z)", "2*(x*y + w*z)",
                                           "2*(x*z - w*y)")):  # the lamp's X in world
            _driver(node.inputs["Lamp X"], axis, expression, rotation)
        for axis, expression in enumerate(("2*(x*y - w*z)", "1 - 2*(x*x + z*z)",
                                           "2*(y*z + w*x)")):  # its Y
            _driver(node.inputs["Lamp Y"], axis, expression, rotation)
        second = "size_y" if light.shape in ("RECTANGLE", "ELLIPSE") else "size"
        for socket, path, scale in (("Width", "size", "SCALE_X"), ("Height", second, "SCALE_Y")):
            _driver(node.inputs[socket], None, "v * abs(k)",
                    [("v", "PROP", light, path), ("k", "TRANSFORM", obj, scale)])
        node.inputs["Shape Area"].default_value = \
            math.pi / 4.0 if light.shape in ("DISK", "ELLIPSE") else 1.0
    if light.type == "SPOT":
        _driver(node.inputs["Cos Half Angle"], None, "cos(v / 2)",
                [("v", "PROP", light, "spot_size")])
        _driver(node.inputs["Blend"], None, "v", [("v", "PROP", light, "spot_blend")])


def _factor_value(b, light, path):
    node = b._place(b.nodes.new("ShaderNodeValue"))
    node.label = f"{light.name} {path}"
    _driver(node.outputs[0], None, "v", [("v", "PROP", light, path)])
    return node.outputs[0]


def atlas_tap_group(image, width, height):
    """The group ``Glossy Lamp Taps <image> <width>x<height>`` of one lamp atlas:
    the bilinear value at continuous atlas texel coordinates (Column, Row) from
    four Closest taps (EEVEE's Linear filtering picks mip levels from the
    coordinates' screen derivatives: blurred, wrong values for computed
    lookups). One per atlas, so that a material's many taps are one node each
    (building a tree costs time with its size: 1900 nodes took 20 s to attach)."""
    name = f"Glossy Lamp Taps {image.name} {width}x{height}"
    tree = _group(name, [("Column", FLOAT), ("Row", FLOAT)], [("Color", COLOR)])
    if tree is None:
        return bpy.data.node_groups[name]
    b = _Builder(tree)
    i, o = _io(tree)

    def texel(column, row):
        node = b._place(b.nodes.new("ShaderNodeTexImage"))
        node.image = image
        node.interpolation = "Closest"
        node.extension = "EXTEND"
        u = b.math("DIVIDE", b.math("ADD", column, 0.5), float(width))
        v = b.math("SUBTRACT", 1.0, b.math("DIVIDE", b.math("ADD", row, 0.5), float(height)))
        b.link(b.combine(u, v), node.inputs["Vector"])
        return node.outputs["Color"]

    column, row = i["Column"], i["Row"]
    x0, y0 = b.math("FLOOR", column), b.math("FLOOR", row)
    fx, fy = b.math("SUBTRACT", column, x0), b.math("SUBTRACT", row, y0)
    x1, y1 = b.math("ADD", x0, 1.0), b.math("ADD", y0, 1.0)
    top = b.mix(fx, texel(x0, y0), texel(x1, y0))
    bottom = b.mix(fx, texel(x0, y1), texel(x1, y1))
    b.link(b.mix(fy, top, bottom), o["Color"])
    return tree


# --- the material's lamp term ---------------------------------------------------------------
def lamp_terms(b, image, meta, lamps, diffuse_colour=None, tangent=("RADIAL", "Z")):
    """Add the lamp terms to the material being built by ``b``: returns (glossy,
    diffuse) colour sockets (diffuse None without ``diffuse_colour``), summed
    over ``lamps``. ``image``: the bake.separable.pack atlas; ``meta``: its
    metadata; ``tangent``: the Tangent node's setting (("RADIAL", axis) or
    ("UV_MAP", name))."""
    size, terms = float(meta["size"]), int(meta["terms"])
    size_h = float(meta.get("size_h", meta["size"]))
    tile_g, tile_h = int(meta["tile_g"]), int(meta["tile_h"])
    h_row = int(meta.get("h_row", tile_g))
    levels = int(meta.get("levels", 0))
    height, width = h_row + tile_h, int(meta.get("atlas_width", terms * max(tile_g, tile_h)))
    scale = meta["scale"]
    geometry = b._place(b.nodes.new("ShaderNodeNewGeometry"))
    from .sampling_nodes import tangent_socket

    tangent_output = tangent_socket(b, tangent)
    coords_tree = coords_group(meta["parameterization"])
    glossy = diffuse = None

    tap_tree = atlas_tap_group(image, width, height)

    def tap(column, row):
        return _group_node(b, tap_tree, {"Column": column, "Row": row})["Color"]

    def multiply(a, c):
        node = b._place(b.nodes.new("ShaderNodeMix"))
        node.data_type = "RGBA"
        node.blend_type = "MULTIPLY"
        node.inputs["Factor"].default_value = 1.0
        b.link(a, node.inputs[6])
        if isinstance(c, (tuple, list)):
            node.inputs[7].default_value = (*c, 1.0)
        else:
            b.link(c, node.inputs[7])
        return node.outputs[2]

    def add(a, c):
        if a is None:
            return c
        node = b._place(b.nodes.new("ShaderNodeVectorMath"))
        node.operation = "ADD"
        b.link(a, node.inputs[0])
        b.link(c, node.inputs[1])
        return node.outputs["Vector"]

    def scaled(colour, factor):
        return _colour_scale(b, colour, factor)

    def g_value(coords, k, level):
        """g_k: the factor itself, or blended from two cap levels by the lamp's Spread."""
        if level is None:
            return tap(b.math("ADD", coords.outputs["G Column"], 1.0 + k * tile_g),
                       b.math("ADD", coords.outputs["G Row"], 1.0))
        total = None
        for which in ("A", "B"):
            texel = _group_node(b, spread_texel_group(), {
                "G Column": coords.outputs["G Column"], "G Row": coords.outputs["G Row"],
                "Level": level[f"Level {which}"], "Size": size, "Terms": float(terms),
                "Term": float(k), "Per Octave": float(meta.get("per_octave", 1))})
            total = add(total, scaled(tap(texel["Column"], texel["Row"]),
                                      level[f"Weight {which}"]))
        return total

    for obj in lamps:
        cells = area_layout(obj) if obj.data.type == "AREA" else [(0.0, 0.0, 1.0)]
        for u, v, share in cells:
            b.checkpoint()
            lamp = b._place(b.nodes.new("ShaderNodeGroup"))
            lamp.node_tree = lamp_group(obj.data.type)
            lamp.label = f"Glossy lamp {obj.name}" + (f" cell {u:+.2f} {v:+.2f}"
                                                       if len(cells) > 1 else "")
            lamp["glossy_lamp"] = obj.name
            lamp.inputs["Cell"].default_value = (u, v, share)
            b.link(geometry.outputs["Position"], lamp.inputs["Position"])
            drive_lamp_inputs(lamp, obj)
            coords = b._place(b.nodes.new("ShaderNodeGroup"))
            coords.node_tree = coords_tree
            for socket, value in (("Normal", geometry.outputs["Normal"]),
                                  ("Tangent", tangent_output),
                                  ("Incoming", geometry.outputs["Incoming"]),
                                  ("Light", lamp.outputs["Light"]), ("Size", size),
                                  ("H Size", size_h),
                                  ("Parabolic", 1.0 if meta["map"] == "parabolic" else 0.0)):
                b.link(value, coords.inputs[socket])
            level = None
            if levels:
                level = _group_node(b, spread_level_group(), {
                    "Spread": b.math("MULTIPLY", lamp.outputs["Spread"],
                                     float(meta["spread_scale"])),
                    "First Radius": float(meta["first_radius"]), "Levels": float(levels),
                    "Per Octave": float(meta.get("per_octave", 1))})
            total = None
            for k in range(terms):
                g = g_value(coords, k, level)
                h = tap(b.math("ADD", coords.outputs["H Column"], 1.0 + k * tile_h),
                        b.math("ADD", coords.outputs["H Row"], 1.0 + h_row))
                total = add(total, multiply(multiply(g, h), tuple(float(s) for s in scale[k])))
            weight = b.math("MULTIPLY", coords.outputs["Cos Light"], coords.outputs["Valid"])
            lit = _colour_scale(b, lamp.outputs["Irradiance"], weight)
            specular = _factor_value(b, obj.data, "specular_factor")
            glossy = add(glossy, _colour_scale(b, multiply(total, lit), specular))
            if diffuse_colour is not None:
                lambert = tuple(float(c) / math.pi for c in diffuse_colour)
                lit_diffuse = _colour_scale(b, multiply(lit, lambert),
                                            _factor_value(b, obj.data, "diffuse_factor"))
                diffuse = add(diffuse, lit_diffuse)
    return glossy, diffuse
