"""The probe lights' exact term beside maps baked at roughness knots.

A From Material bake whose roughness (or metallic) texture the 3D map follows
per pixel bakes one map per roughness knot and colour or metallic variant
(glossy_addon.spatial.map_variants), and the nodes blend them per pixel. Such
a material cannot take the Hybrid (its runtime part samples one lobe for the
whole surface), and before this module its maps held the probe's small bright
lights too, which a map blurs and widens: a plastic with a 0.25-0.55 roughness
texture in night.exr was 12.2% from Cycles where the same plastic untextured
(the Hybrid, lights taken out) was 5.0%.

Here the lights (bake.probe_lights, taken from the probe at the narrowest
knot's lobe, so that every knot's lobe is at least as wide as the tiles) leave
the probe, every knot's maps are baked from the residual, and the lights are
added exactly, as bake.sampling_runtime.light_radiance adds them, at the
pixel's own roughness: for each map (knot k, variant v)

    L_kv = M_kv + (rho_kv / A_ss,k)(wo) S(alpha),
    S(alpha) = sum over lights of D_B(h) G2(l, wo) / (4 wo_z) E,

with alpha = clamp(r, MIN_ROUGHNESS, 1)^2 from the user's roughness socket r
(Cycles' alpha for the Principled and Glossy BSDFs: :func:`pack` checks each
knot's lobe against it), D_B the lobe's D widened by the light's extent
(bake.sampling_runtime.widened_d, the widened alphas computed per pixel as
sqrt(alpha^2 + (LIGHT_WIDENING spread)^2)), and rho_kv / A_ss,k the variant's
directional albedo over the untinted single-scattering albedo at the knot's
alpha (the Fresnel, tint and multiple scattering of the map it joins, as the
Hybrid's lights carry them). The nodes then combine and blend the L_kv
exactly as they do the maps (glossy_addon.nodes._combined_maps), so the
colour split, the metallic mix and the geometric roughness blend apply to the
lights too. At a knot's roughness the term is the runtime atlas's light term
for that knot's spec to the tables' float32 rounding
(tests/bake/test_knot_lights.py).

The texture (one padded slice, bake.sampling_runtime's texel conventions):
row 1 + t, columns 1 .. ALBEDO_MU: table t's rho / A_ss at mu_j = MIN_COS + (1 -
MIN_COS) j / (ALBEDO_MU - 1) (isotropic lobes: no azimuth); from row
``light_row``, LIGHT_TEXELS texels per light: the world direction, the
irradiance and (spread, 0, 0) (bake.probe_lights.Light.extent, rad).
"""

import numpy as np

from . import brdf, probe_lights
from .atlas import _pad
from .errors import BakeError
from .sampling_runtime import (
    ALBEDO_MU,
    ALBEDO_SAMPLES,
    LIGHT_TEXELS_BEFORE,
    LIGHT_WIDENING,
    MIN_COS,
    _lobe_directions,
    check,
    light_sum,
    single_scatter_albedo,
)

__all__ = ["MODE", "pack", "shade", "light_alpha", "table_index", "MIN_ROUGHNESS"]

#: Texels per light: three, the direction whole (the texture is always float32).
LIGHT_TEXELS = LIGHT_TEXELS_BEFORE

MODE = "atlas_knot_lights"
#: Texels per row of the texture (at least ALBEDO_MU).
WIDTH = 64
#: The nodes' per-pixel roughness is clamped to [MIN_ROUGHNESS, 1] (Cycles'
#: mirror threshold, as glossy_addon.spatial's knots).
MIN_ROUGHNESS = 0.01


def light_alpha(roughness):
    """Cycles' GGX / Beckmann alpha of the Principled and Glossy BSDFs' roughness
    (any shape): clamp(r, MIN_ROUGHNESS, 1)^2."""
    r = np.clip(np.asarray(roughness, dtype=np.float64), MIN_ROUGHNESS, 1.0)
    return r * r


def pack(lights, tables):
    """(atlas (H, W, 3) float32, meta) of the lights' term for maps baked at knots.

    lights: bake.probe_lights.Light's (or their JSON) taken out of the probe the
    maps were baked from; tables: [(roughness or None, key or None, spec), ...],
    one per map (glossy_addon.spatial.map_variants: roughness None for a surface
    without a roughness texture, key None for a plain map). BakeError for a spec
    with no isotropic GGX or Cycles' Beckmann lobe, for kinds that differ, or for a
    lobe whose alpha is not :func:`light_alpha` of its roughness knot (the nodes
    compute the pixel's alpha that way)."""
    if not tables:
        raise BakeError("no maps to add the probe lights to")
    mu = MIN_COS + (1.0 - MIN_COS) * np.linspace(0.0, 1.0, ALBEDO_MU)
    wo = _lobe_directions(mu[None, :], np.zeros((1, 1)))[0]  # (M, 3) lobe frame
    kinds, rows, described = set(), [], []
    constant = None
    for roughness, key, spec in tables:
        lobe = check(spec)[0]
        if lobe.anisotropic:
            raise BakeError(f"{spec}: the probe lights beside roughness knots need an "
                            f"isotropic lobe")
        kinds.add(lobe.kind)
        if roughness is not None:
            expected = float(light_alpha(roughness))
            # The spec prints the knot to 6 digits (glossy_addon.spatial.with_roughness).
            if abs(lobe.mx - expected) > 1e-4 * max(expected, 1e-4):
                raise BakeError(f"{spec}: lobe alpha {lobe.mx:.6g} is not the roughness "
                                f"knot {roughness:.6g} squared")
        else:
            constant = float(lobe.mx)
        model = brdf.parse(spec)
        rho = model.albedo(wo, samples=ALBEDO_SAMPLES)  # (M, 3)
        a_ss = single_scatter_albedo(wo, lobe.mx, lobe.my, kind=lobe.kind)
        rows.append(rho / np.maximum(a_ss, 1e-6)[:, None])
        described.append([roughness, key, float(lobe.mx)])
    if len(kinds) > 1:
        raise BakeError(f"the knots' lobes differ in kind ({', '.join(sorted(kinds))})")
    count = len(lights)
    light_first = len(rows) + 2
    light_rows = -(-LIGHT_TEXELS * count // WIDTH)
    height = max(light_first + light_rows - 1, 1)
    slice_ = np.zeros((height, WIDTH, 3), np.float32)
    padded = np.concatenate([_pad(slice_), np.zeros((height + 2, 1, 3), np.float32)], 1)
    for t, row in enumerate(rows):
        padded[1 + t, 1:1 + ALBEDO_MU] = row
    for j, light in enumerate(lights):
        data = light.to_json() if hasattr(light, "to_json") else light
        spread = probe_lights.Light.from_json(data).extent
        for c, value in enumerate((data["direction"], data["irradiance"], (spread, 0.0, 0.0))):
            t = LIGHT_TEXELS * j + c
            padded[light_first + t // WIDTH, 1 + t % WIDTH] = value
    meta = {"mode": MODE, "kind": kinds.pop(), "slices": 1, "slice_height": height,
            "slice_width": WIDTH, "light_row": light_first, "albedo_mu": ALBEDO_MU,
            "min_cos": MIN_COS, "tables": described, "alpha": constant,
            "lights": [light.to_json() if hasattr(light, "to_json") else light
                       for light in lights]}
    return padded.astype(np.float32), meta


def table_index(meta, roughness, key) -> int:
    """The row of the map (roughness knot or None, key or None) in ``meta["tables"]``;
    KeyError where the bake has no such map."""
    for index, (r, k, _) in enumerate(meta["tables"]):
        if k == key and (r is None if roughness is None else
                         r is not None and abs(r - roughness) <= 1e-9 * max(abs(r), 1.0)):
            return index
    raise KeyError((roughness, key))


def _lights(atlas, meta):
    """(directions (N, 3), irradiances (N, 3), spreads (N,)) as the nodes read them."""
    count = len(meta.get("lights") or [])
    t = np.arange(LIGHT_TEXELS * count)
    texels = np.asarray(atlas)[int(meta["light_row"]) + t // WIDTH, 1 + t % WIDTH, :3]
    texels = texels.astype(np.float64).reshape(count, LIGHT_TEXELS, 3)
    return texels[:, 0], texels[:, 1], texels[:, 2, 0]


def _scale(atlas, meta, wo, index):
    """(B, 3) table ``index``'s rho / A_ss at lobe-frame views wo (B, 3), linear in
    mu between its two nearest entries (as the nodes: two Closest taps)."""
    x = np.clip((wo[:, 2] - MIN_COS) / (1.0 - MIN_COS), 0.0, 1.0) * (ALBEDO_MU - 1)
    x0 = np.minimum(np.floor(x), ALBEDO_MU - 2)
    fx = (x - x0)[:, None]
    x0 = x0.astype(int) + 1
    row = np.asarray(atlas, dtype=np.float64)[1 + index]
    return row[x0] * (1.0 - fx) + row[x0 + 1] * fx


def shade(atlas, meta, normals, views, roughness=None, index=0, tangent_hint=(0.3, 0.5, 0.8)):
    """(N, 3) the lights' term the nodes add to map ``index`` of ``meta["tables"]``
    for world-space unit normals and views (surface to viewer) (N, 3) each, at the
    pixels' roughness (N,) (None: the meta's constant alpha, a surface without a
    roughness texture): (rho / A_ss)_index(wo) S(alpha) (module doc)."""
    from .reference import _frames, pixel_arrays

    if meta.get("mode") != MODE:
        raise BakeError(f"not a knot lights texture (mode {meta.get('mode')!r})")
    normals, views, _ = pixel_arrays(normals, views)
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    views = views / np.linalg.norm(views, axis=1, keepdims=True)
    frames = _frames(normals, None, tangent_hint)
    wo = np.einsum("bij,bj->bi", frames, views)
    wo[:, 2] = np.maximum(wo[:, 2], MIN_COS)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    if roughness is None:
        if meta.get("alpha") is None:
            raise BakeError("this texture's maps follow a roughness texture: give the "
                            "pixels' roughness")
        alpha = np.full(len(wo), float(meta["alpha"]))
    else:
        alpha = light_alpha(np.broadcast_to(np.asarray(roughness, np.float64), (len(wo),)))
    directions, irradiances, spreads = _lights(atlas, meta)
    widened = [np.sqrt(alpha * alpha + (LIGHT_WIDENING * s) ** 2) for s in spreads]
    total = light_sum(directions, irradiances, widened, widened, spreads, frames, wo, alpha,
                      alpha, meta.get("kind", "ggx"))
    return total * _scale(atlas, meta, wo, index)

