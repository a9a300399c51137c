"""The method a material's "Auto" method bakes with, and why (issue 11: the
Hybrid is the default wherever it is better).

Measured in EEVEE against Cycles on an isolated sphere in every bundled HDRI
(benchmarks/runtime_validate.py, 19 samples, each roughness at the Hybrid's
Auto probe face, all three methods from that probe; docs/HISTORY.md, "Stop 33"): for
isotropic GGX 0.1 / 0.2 / 0.3 / 0.45 / 0.6 the Hybrid is below both the 3D
map and Runtime Sampling in 30 of 40 cases, level with the better one to a
tenth of a point in 9 and above Runtime by 0.1 point once; it is below the
3D map in all 40 (1.1-10.7% against 3.6-52%). For a Principled BSDF at
roughness 0.3 (64 px probe, an earlier stop) it was below the 3D map on all
eight too, as a plastic (0.9-22.9% against 1.0-23.9%) and as a metal
(2.7-23.0% against 3.8-35.1%). Its 1-sample EEVEE frame measured 0.91-1.02x
native's (benchmarks/sampling_eevee.py; per sample 2.3-3.5x on software GL)
and its shader compiles in under a second.

The Hybrid's runtime part samples one GGX lobe (or Cycles' Beckmann lobe,
through GGX's visible normals: bake.sampling_runtime) and scales it by the
material's colour at its bake-time value. So Auto keeps the 3D map where
that is not the whole story:

- a BRDF with no single GGX or Beckmann lobe (Ward, Phong,
  Ashikhmin-Shirley, the Kurt model, a Principled BSDF with a coat, a custom
  sum): runtime sampling in shader nodes samples GGX's visible normals only
  (bake.sampling_runtime.check; a Principled BSDF without a coat is one GGX
  lobe, and in NumPy its Hybrid measured below the 3D map as GGX's does:
  tests/bake/test_hybrid.py);
- a From Material tree whose roughness or metallic texture the 3D map
  follows per pixel through maps baked at knots (glossy_addon.spatial.
  map_variants), where the runtime part would take one value for the whole
  surface. Since stop 57 Auto's maps there are of the probe without its small
  bright lights, which are shaded exactly beside them at the pixel's own
  roughness (bake.knot_lights; Probe Lights on): a plastic with a 0.25-0.55
  roughness texture in night.exr went from 12.2% to 6.9% from Cycles (the
  NumPy reference 6.2%). A 3D Map chosen by hand stays the map alone.

A colour texture (a metal's Base Color, a Specular Tint) keeps the Hybrid
since stop 54: its map part is split at colours 0 and 1 as the 3D map's is,
and its runtime part, baked at the mean colour, is scaled per pixel by the
split's value over its value at the mean (the same lobe's colour response;
glossy_addon.nodes.build_lookup). A metal with a checker Base Color in
forest.exr measured 2.50% from Cycles this way against the 3D map's 4.38%
(the NumPy reference 2.05%, Cycles' noise 1.63%; the Hybrid with the colour
as a plain factor c / mean: 2.62%).

An anisotropic lobe gets Runtime Sampling (the 3D map needs an isotropic
lobe). Everything else with an isotropic GGX or Beckmann lobe gets the
Hybrid, in a Blender whose shader nodes have repeat zones (5.0) and at a map
size that holds runtime sampling's texture. A Beckmann Hybrid blends with
weights measured for Beckmann (bake/hybrid_errors_beckmann.json). Measured
in NumPy against the brute-force integral (64 px isolated sphere, every
bundled HDRI at the face Auto captures, Probe Lights on, 19 samples, leave one
out: benchmarks/hybrid.py --brdf beckmann): below both the 3D map of the
residual probe with the lights' exact term and runtime sampling in 35 of 40
cases, and far below the 3D map of the whole probe that Auto gave Beckmann
before (e.g. interior 0.3: 39.6% with GGX's table already down to 1.9%).
In EEVEE against Cycles: docs/HISTORY.md, "Stop 37".

Near-mirror GGX lobes (roughness below 0.1, the first row of the Hybrid's
table: :func:`near_mirror_alpha`) get Runtime Sampling since stop 73, and
near-mirror Beckmann lobes since stop 74, unless a colour texture splits the
map. The table's weights there are 0.1's, measured for a wider lobe. At GGX
0.05 in EEVEE against Cycles (328 px probes, Max Map Size 384, courtyard /
night / sunset) Runtime Sampling measured 4.3 / 11.0 / 0.9%, the Hybrid 4.6 /
11.5 / 1.1%, the 3D map 5.8 / 61.6 / 21.7% and careful native EEVEE 9.6 / 38.1
/ 29.6%. In NumPy, against the world's own integral (benchmarks/stack_rows.py),
Runtime Sampling was at or below the Hybrid in all eight HDRIs. A row measured
at 0.05 gave no blend below both methods, leaving one HDRI out, in any of the
eight (benchmarks/hybrid.py --roughness 0.05 --truth bilinear). Beckmann 0.05
(stop 74, the same measure, both at 384 rows): Runtime Sampling 6.1 / 12.0 /
1.7%, the Hybrid 6.1 / 12.7 / 1.8% (courtyard 0.05 point lower), the 3D map 6.3
/ 80.3 / 29.7%, careful native 12.0 / 46.9 / 46.2%.

At 384 rows both methods carried the rows' limit in courtyard (Beckmann 0.05:
0.51x careful native). So since stop 74 Runtime Sampling's level stack for a
near-mirror lobe, its only texture and not filtered, may take twice Max Map
Size's rows under Auto (bake.sampling_runtime.stack_height, ``alone``, and
near_mirror): 512 from a 328 px probe at the default 384. Courtyard then
measured 2.9% at GGX 0.05 and 4.5% at Beckmann 0.05; GGX 0.05 on all eight
HDRIs (city / courtyard / forest / interior / night / studio / sunrise /
sunset) 1.2 / 2.9 / 6.8 / 3.7 / 10.7 / 2.2 / 2.1 / 0.8%, at most 0.30x careful
native, Beckmann 0.05 at most 0.38x (README "Stop 74").
"""

import bpy

from ..bake import brdf
from ..bake.errors import BakeError
from ..bake.sampling import lobe_of
from ..bake.sampling_runtime import MIN_STACK_ROWS, check

#: Blender version whose shader nodes have repeat zones (glossy_addon.sampling_nodes).
SHADER_LOOPS = (5, 0, 0)
#: Models of the Material panel with no lobe the runtime-sampling nodes sample.
NOT_GGX = ("ashikhmin_shirley", "ward", "phong", "lambert", "BUMP")
#: Smallest level stack (rows) that holds the albedo table (bake.sampling_runtime).
MIN_RUNTIME_ROWS = MIN_STACK_ROWS


def choose(settings) -> tuple:
    """(method, reason) for ``settings`` (a Material's ``glossy``): its own method
    and '' unless it is "auto"; for Auto, the rule of the module doc and one
    line saying why. A BRDF that cannot be read gives the 3D map, whose bake
    then reports the error."""
    if settings.method != "auto":
        return settings.method, ""
    if settings.model in NOT_GGX:  # decided without parsing (a bump BRDF computes a table)
        return "3d", (f"3D Map: {settings.model} has no GGX or Beckmann lobe (runtime "
                      f"sampling in shader nodes samples those)")
    try:
        spec = settings.brdf_spec()
        if spec.startswith("bump:"):
            return "3d", "3D Map: a bump-map BRDF has no GGX lobe"
        model = brdf.parse(spec)
    except (BakeError, ValueError):
        return "3d", "3D Map: the BRDF could not be read"
    try:
        lobe = lobe_of(model)
    except BakeError:
        return "3d", "3D Map: the BRDF has no single lobe to sample at runtime"
    try:
        check(spec)
    except BakeError:
        return "3d", (f"3D Map: the BRDF's {lobe.kind} lobe (runtime sampling in shader nodes "
                      f"samples GGX and Cycles' Beckmann)")
    if bpy.app.version < SHADER_LOOPS:
        return "3d", (f"3D Map: runtime sampling's shader loop needs Blender "
                      f"{'.'.join(map(str, SHADER_LOOPS))} or newer")
    if lobe.anisotropic:
        return "runtime", "Runtime Sampling: an anisotropic lobe (the 3D map needs an " \
                          "isotropic one)"
    if settings.size_mode == "FIXED" and settings.map_size < MIN_RUNTIME_ROWS:
        return "3d", (f"3D Map: a fixed map size below {MIN_RUNTIME_ROWS} is too small for "
                      f"runtime sampling's texture")
    texture = _per_pixel_texture(settings)
    if texture:
        return "3d", (f"3D Map: the {texture} texture is followed per pixel by maps baked "
                      f"at its knots (the Hybrid's runtime part would take one value)"
                      + ("; the probe's small bright lights beside them, shaded exactly at "
                         "the pixel's roughness (Probe Lights)"
                         if knot_lights_apply(settings) else ""))
    if lobe.mx < near_mirror_alpha(lobe.kind) and not _colour_split(settings):
        name = "GGX" if lobe.kind == "ggx" else "Beckmann"
        return "runtime", (f"Runtime Sampling: a near-mirror {name} lobe (alpha "
                           f"{lobe.mx:.2g}, roughness below "
                           f"{near_mirror_alpha(lobe.kind) ** 0.5:g}, the Hybrid's table), "
                           f"where it measured below the Hybrid and the 3D map; its level "
                           f"stack up to twice Max Map Size")
    if lobe.kind == "beckmann":
        return "hybrid", ("Hybrid: an isotropic Beckmann lobe (sampled through GGX's "
                          "visible normals), where it measured below the 3D map")
    return "hybrid", "Hybrid: an isotropic GGX lobe, where it measured below the 3D map"


def knot_lights_apply(settings) -> bool:
    """Whether a From Material bake whose maps follow a texture per pixel (the 3D
    map's knots) takes the probe's small bright lights out and shades them exactly
    beside the maps (bake.knot_lights): the Auto method (which chose the 3D map
    for the texture; a 3D Map chosen by hand stays the map alone), Probe Lights
    on and one isotropic GGX or Beckmann lobe that the lights' nodes evaluate."""
    if not settings.probe_lights or settings.model != "MATERIAL" or settings.method != "auto":
        return False
    try:
        lobe = check(settings.brdf_spec())[0]
    except (BakeError, ValueError):
        return False
    return not lobe.anisotropic


def near_mirror_alpha(kind="ggx") -> float:
    """The alpha below which a GGX or Beckmann lobe (``kind``) is a near-mirror and
    Auto bakes Runtime Sampling rather than the Hybrid (bake.hybrid.near_mirror_alpha:
    the square of the lowest roughness the Hybrid's table of that kind measured;
    module doc, "near-mirror lobes")."""
    from ..bake.hybrid import near_mirror_alpha as measured

    return measured(kind)


def _colour_split(settings) -> bool:
    """Whether a From Material tree's colour texture splits the map (the Hybrid follows
    it per pixel through its map part; glossy_addon.spatial.map_variants)."""
    if settings.model != "MATERIAL":
        return False
    from .material_source import parts
    from .spatial import map_variants

    return bool(map_variants(parts(settings.id_data), colour=True))


def _per_pixel_texture(settings) -> str:
    """'roughness' or 'metallic' if a From Material tree has such a texture, which
    the 3D map follows through maps baked at knots and the Hybrid's runtime part
    would take at one value; '' otherwise (a colour texture included: the
    Hybrid splits it too)."""
    if settings.model != "MATERIAL":
        return ""
    from .material_source import parts
    from .spatial import DIELECTRIC, map_variants

    found = parts(settings.id_data)
    if found.roughness_set:
        return "roughness"
    if any(key == DIELECTRIC for _, key, _ in map_variants(found, colour=True)):
        return "metallic"
    return ""
