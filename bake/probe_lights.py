"""Small bright lights taken out of a probe, to be shaded exactly as directional lights.

A sun or a lamp a few texels wide holds a large share of a probe's energy in
a few texels. Both runtime sampling (a few samples, each a pre-blurred
lookup) and the radially symmetric 3D map are least accurate exactly there
(issue 11: night.exr, the suns of city.exr and sunrise.exr). :func:`extract`
splits the probe into a residual, whose radiance nowhere exceeds a threshold
inside the lights it took, and a few lights, each the energy above the
threshold of one compact cluster of texels, placed at the cluster's
energy-weighted centre. The split is exact in energy: residual + lights =
probe, texel by texel, summed over each cluster. A light is then shaded as a
directional light of irradiance E (W/m^2 facing it): f(l, v) cos(theta_l) E,
the BRDF evaluated exactly instead of sampled (bake.sampling_runtime).

What counts as a light (every figure a constant of this module):
- texels brighter than a threshold times the probe's mean luminance (over
  the sphere, by solid angle): THRESHOLD for :func:`extract`; for a lobe,
  :func:`extract_for` tries THRESHOLDS (20x down to 2x) and keeps the lowest
  at which every bright region fits in MAX_LIGHTS, so that as much of the
  probe as the budget allows is shaded exactly;
- grouped greedily, brightest first, into clusters of radius RADIUS_TEXELS
  texels (the probe's largest texel's angle) around their brightest texel;
  clusters that touch form one bright region;
- a compact region (no texel farther than GROUP_RADIUS_TEXELS texels from
  its energy-weighted centre, and no wider than ``max_spread``) gives one
  light per cluster: a sun, a lamp;
- a wide region (a softbox, a window) is *tiled* when ``tile_radius`` is
  given: its texels are grouped again, brightest first, into tiles of that
  angular radius, one light each, so the region is integrated exactly up to
  the point rule within a tile (:func:`limits_for` a lobe: TILE_FRACTION, a
  quarter of its alpha, of the geometric mean of its two alphas when
  anisotropic); tiles seeded by dimmer texels are wider, up to TILE_GROWTH
  times (:func:`tile_growth`). Without ``tile_radius`` it stays in the probe;
- whole regions are taken, the most energetic first, while the lights stay
  within MAX_LIGHTS (a region needing more tiles than are left stays in the
  probe, where the probe's methods see it).

Why tiles, and how small. In studio.exr 79% of the probe's energy is in its
softboxes, and both probe methods are weakest exactly there (a softbox
crossing a pixel's horizon; the 3D map's symmetric lobe reaching below the
surface). Integrating the bright part exactly would take a sphere's error
against the brute-force integral from 0.144 to 0.017 (GGX 0.3, 64^2-face
probe, 19 samples). Tiled, with tiles of radius k alpha (measured on the
same sphere; /tmp experiment recorded in the README): k = 0.75: 12 lights,
0.137; k = 0.5: 26 lights, 0.079; k = 0.25: 72 lights, 0.019. The point rule
fails for a tile wider than the lobe in light space, which at n.v = 0.2-0.4
is about a third of its width at normal incidence; widening the lobe by the
tile's extent, as for a small light, recovers little of it (0.097 -> 0.074
for the light part at k = 0.5). At GGX 0.6 four to ten tiles take studio
from 0.192 to 0.033, and k = 0.5 measured as well as 0.25 there (0.028);
with the threshold lowered to 2x (38-87 lights of half an alpha) the hybrid
of bake.hybrid measured 0.040 / 0.039 / 0.039 / 0.021 / 0.047 / 0.016 /
0.018 / 0.038 on city / courtyard / forest / interior / night / studio /
sunrise / sunset, against 0.062 / 0.111 / 0.084 / 0.055 / 0.069 / 0.028 /
0.030 / 0.067 at 20x (sunset, city: one light; courtyard: none).

Measured for the small lights alone (GGX 0.3, 64^2-face probes, 19 samples,
a sphere against the brute-force integral over the whole probe): runtime
sampling of the residual plus the exact lights gives city 0.103 -> 0.016,
interior 0.120 -> 0.020, night 0.246 -> 0.032, sunrise 0.123 -> 0.009.

Directions are world space (bake.envmap's axes); irradiance is RGB.
"""

import functools
import math
from dataclasses import dataclass

import numpy as np

from .envmap import get_layout
from .errors import BakeError

__all__ = ["Light", "extract", "extract_for", "extract_kept", "limits_for", "tile_growth",
           "max_spread_for", "compact_spread_for",
           "describe", "THRESHOLD", "THRESHOLDS", "THRESHOLDS_ABOVE", "RADIUS_TEXELS", "MAX_LIGHTS",
           "TILE_FRACTION", "TILE_RADIUS_MAX", "tile_radius_for"]

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: Texels brighter than this many times the probe's mean luminance may be lights.
THRESHOLD = 20.0
#: Cluster radius, in texels (the probe's largest texel's angular size).
RADIUS_TEXELS = 3.0
#: Lights taken from one probe at most (whole regions, the most energetic first):
#: the nodes loop over them, each light costing about a third of a sample.
MAX_LIGHTS = 96
#: Texels of two clusters closer than this many texels touch (one bright region).
ADJACENT_TEXELS = 1.5
#: A bright region whose texels reach farther than this many texels from its
#: energy-weighted centre is wide: it stays in the probe.
GROUP_RADIUS_TEXELS = 3.0
#: Lights wider than this many times a GGX lobe's smallest alpha stay in the probe
#: (or are tiled): max_spread_for.
SPREAD_PER_ALPHA = 0.125
#: ... unless the probe cannot resolve them: a light at most this many times one
#: texel's own spread (sqrt(omega / 6) of the probe's largest texel) stays one
#: light, up to SPREAD_CAP_PER_ALPHA alphas (compact_spread_for).
UNRESOLVED_SPREADS = 2.0
SPREAD_CAP_PER_ALPHA = 0.5
#: Tiles of a wide region's brightest texels have a radius of this fraction of the
#: lobe's alpha (limits_for); dimmer texels' tiles are wider (tile_growth).
TILE_FRACTION = 0.25
#: ... and at most this radius (rad; tile_radius_for): without it GGX 1's tiles were
#: 0.25 rad (14 degrees) and their dimmer ones up to four times that, each one
#: direction standing for a region the horizon and G2 cut in part.
TILE_RADIUS_MAX = 0.1
#: Steps per octave of the threshold ladders below (extract_for's rule is "the
#: lowest threshold at which every bright region fits"; the ladder is its
#: discretisation).
LADDER_STEPS_PER_OCTAVE = 4


def _ladder(start, stop):
    """Thresholds from ``start`` to ``stop`` (both kept) in equal ratios of about
    2^(1/LADDER_STEPS_PER_OCTAVE), rounded to 4 significant digits."""
    steps = round(abs(math.log2(stop / start)) * LADDER_STEPS_PER_OCTAVE)
    return tuple(float(f"{start * (stop / start) ** (k / steps):.4g}") for k in range(steps + 1))


#: Thresholds (times the probe's mean luminance) tried from the highest; the
#: lowest at which every bright region fits in MAX_LIGHTS is used (extract_for):
#: 20x down to 2x in 13 equal ratios of 1.19 (about four per octave: 20, 16.75,
#: 14.03, ..., 2.388, 2).
THRESHOLDS = _ladder(20.0, 2.0)
#: Thresholds tried upward, the lowest that fits kept, when THRESHOLDS[0] does not
#: fit (extract_for): 23.78x up to 640x in ratios of 2^(1/4).
THRESHOLDS_ABOVE = _ladder(20.0, 640.0)[1:]
#: Halvings (in log) of the ratio between the rung that fits and the one below that
#: does not, tried by extract_for: the lights taken are not monotone in the
#: threshold, so the rung below can fail where a threshold just above it fits.
REFINE_STEPS = 3
#: Probes of at most this many texels keep what the ladder reads between lobes
#: (extract_kept): 6 faces of 512^2.
KEPT_TEXELS = 6 * 512 * 512
#: Tiles of texels at least TILE_EXCESS times the threshold's luminance above it
#: have the lobe's tile radius; dimmer ones up to TILE_GROWTH times it (tile_growth).
TILE_EXCESS = 32.0
TILE_GROWTH = 4.0


@dataclass
class Light:
    """A directional light taken from a probe: ``direction`` (3,) unit, world, from
    the surface toward the light; ``irradiance`` (3,) RGB W/m^2 on a surface
    facing it (the cluster's radiance above the threshold times solid angle);
    ``solid_angle`` sr and ``spread`` rad (the energy-weighted RMS angle of its
    texels from the direction) of the cluster, for reports; ``tile``: one tile of
    a wide bright region (module doc) rather than a small light; ``threshold``:
    the multiple of the probe's mean luminance above which it was taken;
    ``texel_spread`` rad: the part of ``spread`` that is its texels' own extent
    (sqrt of the energy-weighted omega / 6), which :attr:`extent` leaves out."""

    direction: np.ndarray
    irradiance: np.ndarray
    solid_angle: float
    spread: float
    tile: bool = False
    threshold: float = THRESHOLD
    texel_spread: float = 0.0

    @property
    def extent(self) -> float:
        """RMS angle (rad) of the light's texel centres about its direction: its
        spread without its texels' own extent. A lamp the probe cannot resolve (one
        texel: extent 0) is narrower than the texel, and is shaded as a point; a
        resolved region keeps nearly all of its spread. This is what widens its
        highlight (bake.sampling_runtime.widened_d): with the texels' extent,
        night.exr's one-texel lamps at GGX 0.1 (328 px faces) widened across the
        plane of incidence at grazing views to twice the relative RMS error
        against the HDRI's own integral (0.175 against 0.087 whole sphere)."""
        return float(np.sqrt(max(self.spread ** 2 - self.texel_spread ** 2, 0.0)))

    def to_json(self) -> dict:
        return {"direction": [float(x) for x in self.direction],
                "irradiance": [float(x) for x in self.irradiance],
                "solid_angle": float(self.solid_angle), "spread": float(self.spread),
                "tile": bool(self.tile), "threshold": float(self.threshold),
                "texel_spread": float(self.texel_spread)}

    @classmethod
    def from_json(cls, data) -> "Light":
        return cls(np.asarray(data["direction"], dtype=np.float64),
                   np.asarray(data["irradiance"], dtype=np.float64),
                   float(data.get("solid_angle", 0.0)), float(data.get("spread", 0.0)),
                   bool(data.get("tile", False)), float(data.get("threshold", THRESHOLD)),
                   float(data.get("texel_spread", 0.0)))


def extract(probe, layout="cube", threshold=THRESHOLD, radius_texels=RADIUS_TEXELS,
            max_lights=MAX_LIGHTS, max_spread=None, tile_radius=None, require_all=False,
            prepared=None):
    """(residual, lights) of a probe (H, W, 3) in ``layout`` (module doc).

    residual: float32 (H, W, 3), the probe with each taken texel scaled down
    (hue kept) to the threshold's luminance; lights: a list of :class:`Light`,
    region by region, the most energetic region first (empty when nothing
    qualifies, and the residual is then the probe itself). ``max_spread``
    (rad): a bright region whose RMS angular radius (:class:`Light`'s spread)
    exceeds it is wide. ``tile_radius`` (rad): wide regions are tiled into
    lights of this radius (None: they stay in the probe). :func:`limits_for`
    gives both for a lobe. ``require_all``: return None, as soon as it is
    known, when some bright region cannot be taken within ``max_lights``
    (:func:`extract_for`'s ladder of thresholds). ``prepared``: this probe's
    :func:`_prepare` (the ladder computes it once), else computed here.
    """
    prepared = prepared or _prepare(probe, layout)
    image, directions, omega, radiance, luminance, mean = prepared[:6]
    if threshold <= 1.0 or radius_texels <= 0 or max_lights < 0:
        raise BakeError("threshold must exceed 1, radius_texels be positive and max_lights "
                        "at least 0")
    if tile_radius is not None and not tile_radius > 0:
        raise BakeError(f"tile_radius must be positive, not {tile_radius}")
    if mean <= 0.0 or max_lights == 0:
        return image[..., :3].astype(np.float32).copy(), []
    level = threshold * mean
    texel_angle = float(np.sqrt(omega.max()))
    members, regions = _bright_regions(prepared, float(threshold), float(radius_texels))
    cos_group = np.cos(GROUP_RADIUS_TEXELS * texel_angle)
    candidates = []  # (energy, [(texels, is_tile)])
    count = 0
    for group in regions:
        texels = np.concatenate([members[k] for k in group])
        weights = np.maximum(luminance[texels] - level, 0.0) * omega[texels]
        middle = directions[texels].T @ weights
        middle /= np.linalg.norm(middle)
        wide = np.min(directions[texels] @ middle) < cos_group or (
            max_spread is not None
            and _spread(directions[texels], omega[texels], weights, middle) > max_spread)
        if not wide:
            parts = [(np.asarray(members[k]), False) for k in group]
        elif tile_radius is not None:
            ordered = texels[np.argsort(-luminance[texels], kind="stable")]
            radii = tile_radius * tile_growth(luminance[ordered] / level - 1.0)
            parts = [(np.asarray(tile), True)
                     for tile in _clusters(ordered, directions, radii)]
        elif require_all:
            return None
        else:
            continue  # a wide bright region, not tiled: left in the probe
        count += len(parts)
        if require_all and count > max_lights:
            return None
        candidates.append((float(np.sum(weights)), parts))
    candidates.sort(key=lambda c: -c[0])
    lights = []
    residual = image[..., :3].astype(np.float32).copy()
    flat = residual.reshape(-1, 3)
    for _, parts in candidates:
        if len(lights) + len(parts) > max_lights:
            continue  # this region needs more lights than are left: it stays
        for texels, tile in parts:
            scale = level / luminance[texels]
            excess = radiance[texels] * (1.0 - scale)[:, None] * omega[texels, None]
            weights = excess @ LUMINANCE
            direction = directions[texels].T @ weights
            direction /= np.linalg.norm(direction)
            spread = _spread(directions[texels], omega[texels], weights, direction)
            own = float(np.sqrt(np.sum(weights * omega[texels] / 6.0) / np.sum(weights)))
            lights.append(Light(direction, excess.sum(axis=0), float(omega[texels].sum()),
                                spread, tile, float(threshold), own))
            flat[texels] = (radiance[texels] * scale[:, None]).astype(np.float32)
    return residual, lights


def _prepare(probe, layout):
    """(image, directions (T, 3), solid angles (T,), radiance (T, 3) float64,
    luminance (T,), mean luminance over the sphere, {}) of a checked probe: what
    :func:`extract` reads, computed once for :func:`extract_for`'s ladder (a probe
    of 1024 px faces is split about 14 times). The dict keeps
    :func:`_bright_regions` per threshold, which no lobe changes: every material
    baked from one probe shares them (:func:`extract_kept`)."""
    image = np.asarray(probe)
    if image.ndim != 3 or image.shape[2] < 3:
        raise BakeError(f"a probe is (H, W, 3), not {image.shape}")
    if not np.all(np.isfinite(image[..., :3])):
        raise BakeError("the probe has non-finite texels (NaN or infinity)")
    directions, omega = _geometry(get_layout(layout).name, image.shape[:2])
    radiance = image[..., :3].reshape(-1, 3).astype(np.float64)
    luminance = radiance @ LUMINANCE
    mean = float(np.sum(np.maximum(luminance, 0.0) * omega) / (4.0 * np.pi))
    return image, directions, omega, radiance, luminance, mean, {}


def _bright_regions(prepared, threshold, radius_texels):
    """(members, regions) of a :func:`_prepare`'d probe at ``threshold`` times its mean
    luminance: its texels brighter than that, brightest first, grouped into
    clusters of ``radius_texels`` texels (:func:`_clusters`: index lists) and the
    clusters that touch joined into regions (:func:`_regions`). They depend on the
    probe alone, not on a lobe, so they are kept in ``prepared``'s dict (the
    rungs of :func:`extract_for`'s ladder are the same for every lobe); do not
    modify them."""
    _, directions, omega, _, luminance, mean, kept = prepared
    key = (threshold, radius_texels, ADJACENT_TEXELS)
    found = kept.get(key)
    if found is None:
        bright = np.nonzero(luminance > threshold * mean)[0]
        bright = bright[np.argsort(-luminance[bright], kind="stable")]
        texel_angle = float(np.sqrt(omega.max()))
        radius = radius_texels * texel_angle
        members = _clusters(bright, directions, radius)
        found = kept.setdefault(key, (members, _regions(members, directions, radius,
                                                         texel_angle)))
    return found


@functools.lru_cache(maxsize=4)
def _geometry(layout, shape):
    """(directions (T, 3), solid angles (T,)) of every texel of a ``layout`` image of
    ``shape`` (H, W), read-only: extract_for's ladder splits one probe many times."""
    grid = get_layout(layout)
    directions = grid.texel_directions(shape).reshape(-1, 3)
    omega = grid.solid_angles(shape).reshape(-1)
    directions.flags.writeable = omega.flags.writeable = False
    return directions, omega


def _clusters(ordered, directions, radius):
    """Texel indices ``ordered`` (brightest first) grouped greedily: each joins the
    cluster whose first (brightest) texel is nearest, measured in that cluster's
    radius, when within it, else starts one with its own radius. ``radius``
    (rad): one for all, or one per texel of ``ordered``. Returns a list of
    index lists.

    The texels are taken in blocks: a cluster's centre never moves, so every
    texel before the first one of the block that starts a cluster joins one of
    the clusters that exist at the block's start, all found by one product;
    the cost follows the number of clusters, not of texels."""
    ordered = np.asarray(ordered, dtype=np.intp)
    total = len(ordered)
    radii = np.broadcast_to(np.asarray(radius, dtype=np.float64), (total,))
    one_radius = np.ndim(radius) == 0
    points = directions[ordered]
    cos_radii = np.empty(total)
    radii_of = np.empty(total)
    centres = np.empty((total, 3))
    owner = np.empty(total, dtype=np.intp)
    count = position = 0
    block = 32
    while position < total:
        if count:
            near = points[position:position + block] @ centres[:count].T  # (B, clusters)
            inside = near >= cos_radii[:count]
            missing = np.flatnonzero(~inside.any(axis=1))
            joined = int(missing[0]) if missing.size else len(near)
            if joined:
                # Only clusters within their own radius can be the nearest one in
                # radii (at most 1 there, above 1 elsewhere); with one radius for
                # all, the largest cosine is the nearest.
                if one_radius:
                    best = np.where(inside[:joined], near[:joined], -np.inf).argmax(axis=1)
                else:
                    angle = np.arccos(np.minimum(near[:joined], 1.0)) / radii_of[:count]
                    best = np.where(inside[:joined], angle, np.inf).argmin(axis=1)
                owner[position:position + joined] = best
                position += joined
            block = min(4 * block, 4096) if not missing.size else max(16, 2 * joined)
            if position >= total or not missing.size:
                continue
        centres[count] = points[position]
        cos_radii[count] = math.cos(radii[position])
        radii_of[count] = radii[position]
        owner[position] = count
        count += 1
        position += 1
    members: list = [[] for _ in range(count)]
    for index, cluster in zip(ordered.tolist(), owner.tolist(), strict=True):
        members[cluster].append(index)
    return members


def _regions(members, directions, radius, texel_angle):
    """Clusters (index lists) that touch (texels within ADJACENT_TEXELS texels of
    each other) joined into bright regions: a list of lists of cluster numbers."""
    centres = np.array([directions[m[0]] for m in members]).reshape(-1, 3)
    cos_touch = np.cos(ADJACENT_TEXELS * texel_angle)
    parent = list(range(len(members)))

    def root(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    reach = np.cos(min(2.0 * radius + ADJACENT_TEXELS * texel_angle, np.pi))
    for k in range(len(members)):
        for m in np.nonzero(centres[k + 1:] @ centres[k] >= reach)[0] + k + 1:
            if root(k) != root(m) and np.max(directions[members[k]]
                                             @ directions[members[m]].T) >= cos_touch:
                parent[root(m)] = root(k)
    groups: dict = {}
    for k in range(len(members)):
        groups.setdefault(root(k), []).append(k)
    return list(groups.values())


def _spread(directions, omega, weights, centre):
    """RMS angle (rad) of energy ``weights`` at texels (directions (T, 3), solid angles
    (T,)) from ``centre``: between texel centres, plus each texel's own extent (a
    square of side sqrt(omega): second moment omega / 6 about its centre)."""
    angle = np.arccos(np.clip(directions @ centre, -1.0, 1.0))
    return float(np.sqrt(np.sum(weights * (angle ** 2 + omega / 6.0)) / np.sum(weights)))


def max_spread_for(alpha):
    """The widest light (RMS radius, rad) a GGX lobe of smallest alpha ``alpha``
    takes as a directional light: SPREAD_PER_ALPHA alpha. Wider, the light's own
    shape shows in the lobe and a widened point (bake.sampling_runtime's
    light_radiance) misplaces it; the probe's methods, which see its shape,
    keep it, unless it is tiled. An eighth of an alpha, because at grazing
    views the lobe is much narrower in light space than at normal incidence
    (at n.v 0.2-0.4 about a third as wide) while a widened point keeps its
    normal-incidence width.

    Measured at the probe faces Auto captures (runtime sampling, 19 samples,
    with the lights, a 64^2 px sphere against the brute-force integral over
    the whole probe; a one-off sweep over the eight bundled HDRIs, figures in
    the README): from 0.5 alpha to 0.25 alpha, studio.exr at GGX 0.3 (72 px
    faces) went 0.030 -> 0.008 and interior.exr at GGX 0.2 (104 px) 0.089 ->
    0.010; from 0.25 to 0.125, studio at GGX 0.45 (48 px) 0.078 -> 0.048; no
    other HDRI at GGX 0.1 / 0.2 / 0.3 / 0.45 / 0.6 moved by more than 0.002.
    The regions that stop being one light become tiles (studio at GGX 0.45: 22
    -> 31 lights). Earlier, at 64 px faces for all: 1.5 -> 0.5 alpha took one
    of studio's softbox corners (1.5 degrees RMS) off a single point at GGX
    0.2 (0.093 -> 0.012 for the hybrid of bake.hybrid) and interior at GGX
    0.1 from 0.238 to 0.037."""
    return SPREAD_PER_ALPHA * float(alpha)


def compact_spread_for(alpha, largest_texel):
    """The widest light (RMS radius, rad) taken as one directional light from a
    probe whose largest texel has solid angle ``largest_texel`` (sr), for a GGX
    lobe of smallest alpha ``alpha``: :func:`max_spread_for`, or, when larger,
    UNRESOLVED_SPREADS times one texel's own spread (sqrt(omega / 6)) capped at
    SPREAD_CAP_PER_ALPHA alphas. A lamp a texel or two wide has no shape the
    probe resolves: as tiles (a texel each, once the tiles are smaller than a
    texel) it keeps the texels' aliasing, as one light at its energy centroid
    it keeps where the lamp is. Measured against the brute-force integral over
    a 320 px probe of the same HDRI (closer to Cycles than the probe itself;
    runtime sampling with the lights, 19 samples, a 64^2 px sphere, the Auto
    faces): interior.exr at GGX 0.2 (104 px faces) 0.076 with an eighth of
    alpha alone, 0.038 with the floor (12 of 72 lights compact); at GGX 0.1
    (200 px) 0.083 -> 0.065; night.exr at GGX 0.1 0.140 with the cap, 0.224
    without it (the floor, 2 texels, is 0.8 alpha there). In EEVEE against
    Cycles, interior at GGX 0.2 measured 3.2% with half an alpha and 5.3%
    with an eighth alone."""
    floor = UNRESOLVED_SPREADS * math.sqrt(float(largest_texel) / 6.0)
    return max(max_spread_for(alpha), min(SPREAD_CAP_PER_ALPHA * float(alpha), floor))


def tile_growth(excess):
    """Factor (>= 1) on the tile radius for texels ``excess`` (array) times the
    threshold's luminance above it: (TILE_EXCESS / excess)^(1/4), at most
    TILE_GROWTH. The point rule's error in a tile of radius r and excess radiance
    dL grows as dL r^4 (its energy dL r^2 times (r / lobe width)^2); for a given
    number of tiles the summed error is least when r^4 dL is equal across tiles,
    so a softbox's bright core gets small tiles and a sky's dim part large ones.

    Measured (the hybrid of bake.hybrid with 19 samples, 64^2-face probes, a 64^2
    px sphere against the brute-force integral, root mean square over the eight
    bundled HDRIs; a one-off sweep, its figures in the README): one radius for all tiles (a
    quarter of alpha to GGX 0.3, half from 0.6) gave 0.111 / 0.027 / 0.030 /
    0.023 at GGX 0.2 / 0.3 / 0.45 / 0.6; a quarter of alpha grown this way
    0.043 / 0.021 / 0.021 / 0.022 (TILE_EXCESS 16: 0.043 / 0.022 / 0.022 /
    0.024; 64: 0.044 / 0.023 / 0.020 / 0.022). Fewer lights per region lets the
    threshold ladder go lower (night at GGX 0.2: 12 lights above 10x, 0.288,
    against 80 above 5x, 0.021), and the bright cores keep small tiles (studio
    at GGX 0.45: half an alpha for all, 0.057; grown from a quarter, 0.033)."""
    excess = np.maximum(np.asarray(excess, dtype=np.float64), 1e-12)
    return np.clip((TILE_EXCESS / excess) ** 0.25, 1.0, TILE_GROWTH)


def limits_for(ax, ay=None) -> dict:
    """:func:`extract`'s keyword arguments for a GGX lobe of alphas ``ax``, ``ay``
    (``ay`` None: isotropic): ``max_spread`` (:func:`max_spread_for` the smaller)
    and ``tile_radius`` = TILE_FRACTION times sqrt(ax ay). For an
    anisotropic lobe the geometric mean rather than the smaller alpha: on GGX
    0.3 with anisotropy 0.8 (alphas 0.018 and 0.45, 14 samples, studio.exr,
    64^2-face probe) tiles of a quarter of the smaller alpha are single
    texels, 113 of them, more than MAX_LIGHTS allows (0.129 against the
    brute-force integral with the 83 that fit, 0.030 with all 113), and of the
    geometric mean 72 lights, 0.046."""
    ay = ax if ay is None else ay
    mean = float(np.sqrt(ax * ay))
    return {"max_spread": max_spread_for(min(ax, ay)),
            "tile_radius": tile_radius_for(mean)}


def tile_radius_for(alpha) -> float:
    """The tile radius (rad) of the brightest texels of a wide region for a lobe of
    (geometric mean) alpha: TILE_FRACTION alpha, at most TILE_RADIUS_MAX (from
    alpha 0.4, GGX roughness 0.63). Measured (``out/p75/tilecap.py``: the Hybrid's
    parts in NumPy, the 3D map of the residual plus the lights' exact term,
    against the world's own integral, a 64^2 px sphere of 2 x 2 sub-pixels, the
    probe Auto captures; city / courtyard / forest / interior / night / studio /
    sunrise / sunset, relative RMS %, lights in brackets):

    - GGX 1 uncapped: 1.10 (5) / 1.69 (13) / 0.80 (14) / 1.29 (11) / 1.32 (12) /
      0.60 (4) / 1.21 (3) / 1.10 (6);
    - at most 0.1 rad: 0.48 (19) / 0.44 (44) / 0.48 (41) / 1.10 (23) / 0.60 (26) /
      0.60 (4) / 1.25 (12) / 0.53 (21);
    - at most 0.07 rad: 0.45 / 0.31 / 0.47 / 1.09 / 0.60 / 0.60 / 1.26 / 0.50 with up
      to 65 lights; at most 0.05 rad up to 96 (MAX_LIGHTS) and courtyard / forest
      at GGX 0.6 worse (3.53 -> 4.57, 4.01 -> 5.10);
    - GGX 0.8: 1.80 / 2.41 / 1.75 / 2.84 / 3.70 / 1.01 / 2.03 / 2.78 uncapped, within
      0.1 of those at 0.1 rad (1.70 / 2.40 / 1.73 / 2.84 / 3.68 / 1.02 / 2.04 /
      2.74); GGX 0.6 (0.15 rad, under the cap) unchanged.

    0.1 rad takes most of the gain at a third to a half of the lights 0.07 takes
    (each costs the nodes about a third of a sample)."""
    return min(TILE_FRACTION * float(alpha), TILE_RADIUS_MAX)


def extract_for(probe, layout="cube", ax=0.09, ay=None, max_lights=MAX_LIGHTS,
                prepared=None):
    """:func:`extract` for a GGX lobe (:func:`limits_for`, its compact lights up to
    :func:`compact_spread_for` this probe's texels) at the lowest of THRESHOLDS
    at which every bright region is taken within ``max_lights``: the more of the
    probe is shaded exactly, the less is left to the probe's methods. When even
    THRESHOLDS[0] does not fit, the lowest of THRESHOLDS_ABOVE that does: the
    bright cores are taken and the rest of those regions stays in the probe
    (studio.exr at GGX 0.2 from 104 px faces, the hybrid of bake.hybrid on a
    sphere against the brute-force integral: at 20x one softbox needed more
    tiles than were left and stayed whole, up to 679x the mean, 0.131; at 40x,
    the lowest that fits, 0.092; 0.015 at 80x with SPREAD_PER_ALPHA 0.5, where
    its corner is tiled rather than one light); at THRESHOLDS_ABOVE[-1]
    when nothing fits (then whole regions, the most energetic first, as many as
    fit). Between the rung that fits and the one beside it that does not, the
    ratio is halved REFINE_STEPS times (the lights taken are not monotone in
    the threshold). Each light records its threshold.

    The ladder (benchmarks/light_ladder.py, at the faces Auto captures, a
    64^2 px sphere against the brute-force integral over the same probe,
    root mean square over GGX 0.2-0.6 on the eight bundled HDRIs): with the
    rungs of stop 34 (20, 10, 5, 3, 2x; 40 ... 640x) the Hybrid measured 0.0232
    and Runtime Sampling 0.0275; with about four rungs per octave 0.0225 and
    0.0264; refined between rungs 0.0215 and 0.0254 (courtyard.exr at GGX 0.3:
    0.0554 -> 0.0560 -> 0.0425, its lights 66 -> 67 -> 92; studio.exr at GGX
    0.2 is the one case the refinement made worse, 0.0113 -> 0.0143). One
    rung per octave made the lights jump with the probe's face (courtyard at
    GGX 0.45: 96 lights from 40 px faces, 56 from 48 px). The Hybrid's figures
    here use the weights measured before the refinement."""
    limits = limits_for(ax, ay)
    largest = float(get_layout(layout).solid_angles(np.asarray(probe).shape[:2]).max())
    limits["max_spread"] = compact_spread_for(min(ax, ax if ay is None else ay), largest)

    prepared = prepared or _prepare(probe, layout)

    def split_at(threshold):
        return extract(probe, layout, threshold=threshold, max_lights=max_lights,
                       require_all=True, prepared=prepared, **limits)

    fits, fails = None, None  # (threshold, split) of the lowest rung that fits; the rung below
    for threshold in THRESHOLDS:
        split = split_at(threshold)
        if split is None:
            fails = threshold
            break
        fits = (threshold, split)
    if fits is None:
        fails = THRESHOLDS[0]
        for threshold in THRESHOLDS_ABOVE:
            split = split_at(threshold)
            if split is not None:
                fits = (threshold, split)
                break
            fails = threshold
    if fits is None:
        return extract(probe, layout, threshold=THRESHOLDS_ABOVE[-1], max_lights=max_lights,
                       prepared=prepared, **limits)
    if fails is not None:  # between two rungs: REFINE_STEPS halvings of the ratio
        for _ in range(REFINE_STEPS):
            middle = float(f"{math.sqrt(fits[0] * fails):.4g}")
            split = split_at(middle)
            if split is None:
                fails = middle
            else:
                fits = (middle, split)
    return fits[1]


def extract_kept(probe, layout="cube", ax=0.09, ay=None):
    """:func:`extract_for` computed once per probe content and lobe
    (bake.probe_maps.ProbeMaps.kept): the materials of one probe share it, and
    share the bright regions of each threshold between their lobes. Do not
    modify the residual."""
    from .probe_maps import probe_maps

    key = (round(float(ax), 9), round(float(ax if ay is None else ay), 9))
    maps = probe_maps(probe, layout)
    # The probe's texels read once and their bright regions found once per rung of
    # the ladder, for every lobe (_bright_regions), kept with the probe up to
    # KEPT_TEXELS (about 48 bytes a texel).
    prepared = maps.kept(("probe lights prepared",), lambda: _prepare(probe, layout)) \
        if np.asarray(probe).shape[0] * np.asarray(probe).shape[1] <= KEPT_TEXELS else None
    return maps.kept(
        ("probe lights", THRESHOLDS, THRESHOLDS_ABOVE, REFINE_STEPS, RADIUS_TEXELS, MAX_LIGHTS,
         ADJACENT_TEXELS, GROUP_RADIUS_TEXELS, TILE_FRACTION, TILE_RADIUS_MAX, TILE_EXCESS,
         TILE_GROWTH,
         SPREAD_PER_ALPHA, UNRESOLVED_SPREADS, SPREAD_CAP_PER_ALPHA, key),
        lambda: extract_for(probe, layout, ax, ay, prepared=prepared))


def describe(lights) -> str:
    """One line for a panel or a report: how many lights, the brightest's
    irradiance (luminance, W/m^2) and their largest RMS radius (degrees)."""
    if not lights:
        return "no small bright light in the probe"
    lights = [Light.from_json(x) if isinstance(x, dict) else x for x in lights]
    brightest = max(float(light.irradiance @ LUMINANCE) for light in lights)
    widest = max(light.spread for light in lights)
    tiles = sum(1 for light in lights if light.tile)
    kinds = f", {tiles} of them tiles of wide bright regions" if tiles else ""
    above = min(light.threshold for light in lights)
    return (f"{len(lights)} light(s) taken from the probe above {above:g}x its mean "
            f"luminance{kinds} (brightest {brightest:.3g} W/m^2, at most "
            f"{np.degrees(widest):.2g} degrees RMS)")
