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
- texels brighter than THRESHOLD times the probe's mean luminance (over the
  sphere, by solid angle);
- grouped greedily, brightest first, into clusters of radius RADIUS_TEXELS
  texels (the probe's largest texel's angle) around their brightest texel;
- a cluster is kept only when it is isolated: no texel above the threshold
  outside it lies within twice that radius of its centre. A wide bright
  region (a softbox, a window, an overcast sky) breaks into adjacent
  clusters and is left in the probe, where its size makes a point light a
  poor model and the probe's methods are accurate;
- at most MAX_LIGHTS, the most energetic first.

Measured in NumPy (GGX 0.3, 64^2-face probes, 19 samples, a sphere against
the brute-force integral over the whole probe; /tmp experiment recorded in
the README): runtime sampling of the residual plus the exact lights gives
city 0.103 -> 0.016, interior 0.120 -> 0.020, night 0.246 -> 0.032, sunrise
0.123 -> 0.009.

Directions are world space (bake.envmap's axes); irradiance is RGB.
"""

from dataclasses import dataclass

import numpy as np

from .envmap import get_layout
from .errors import BakeError

__all__ = ["Light", "extract", "extract_kept", "describe", "THRESHOLD", "RADIUS_TEXELS",
           "MAX_LIGHTS"]

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
#: Texels brighter than this many times the probe's mean luminance may be lights.
THRESHOLD = 20.0
#: Cluster radius, in texels (the probe's largest texel's angular size).
RADIUS_TEXELS = 3.0
#: Lights taken from one probe at most (the most energetic).
MAX_LIGHTS = 8
#: Texels of two clusters closer than this many texels touch (one bright region).
ADJACENT_TEXELS = 1.5
#: A bright region whose texels reach farther than this many texels from its
#: energy-weighted centre is wide: it stays in the probe.
GROUP_RADIUS_TEXELS = 3.0
#: Lights wider than this many times a GGX lobe's smallest alpha stay in the probe.
SPREAD_PER_ALPHA = 1.5


@dataclass
class Light:
    """A directional light taken from a probe: ``direction`` (3,) unit, world, from
    the surface toward the light; ``irradiance`` (3,) RGB W/m^2 on a surface
    facing it (the cluster's radiance above the threshold times solid angle);
    ``solid_angle`` sr and ``spread`` rad (the energy-weighted RMS angle of its
    texels from the direction) of the cluster, for reports."""

    direction: np.ndarray
    irradiance: np.ndarray
    solid_angle: float
    spread: float

    def to_json(self) -> dict:
        return {"direction": [float(x) for x in self.direction],
                "irradiance": [float(x) for x in self.irradiance],
                "solid_angle": float(self.solid_angle), "spread": float(self.spread)}

    @classmethod
    def from_json(cls, data) -> "Light":
        return cls(np.asarray(data["direction"], dtype=np.float64),
                   np.asarray(data["irradiance"], dtype=np.float64),
                   float(data.get("solid_angle", 0.0)), float(data.get("spread", 0.0)))


def extract(probe, layout="cube", threshold=THRESHOLD, radius_texels=RADIUS_TEXELS,
            max_lights=MAX_LIGHTS, max_spread=None):
    """(residual, lights) of a probe (H, W, 3) in ``layout`` (module doc).

    residual: float32 (H, W, 3), the probe with each kept cluster's texels
    scaled down (hue kept) to the threshold's luminance; lights: a list of
    :class:`Light`, most energetic first (empty when nothing qualifies, and
    the residual is then the probe itself). ``max_spread`` (rad): a bright
    region whose RMS angular radius (:class:`Light`'s spread) exceeds it stays
    in the probe (:func:`max_spread_for` a lobe).
    """
    image = np.asarray(probe)
    if image.ndim != 3 or image.shape[2] < 3:
        raise BakeError(f"a probe is (H, W, 3), not {image.shape}")
    if not np.all(np.isfinite(image[..., :3])):
        raise BakeError("the probe has non-finite texels (NaN or infinity)")
    if threshold <= 1.0 or radius_texels <= 0 or max_lights < 0:
        raise BakeError("threshold must exceed 1, radius_texels be positive and max_lights "
                        "at least 0")
    grid = get_layout(layout)
    shape = image.shape[:2]
    directions = grid.texel_directions(shape).reshape(-1, 3)
    omega = grid.solid_angles(shape).reshape(-1)
    radiance = image[..., :3].reshape(-1, 3).astype(np.float64)
    luminance = radiance @ LUMINANCE
    mean = float(np.sum(np.maximum(luminance, 0.0) * omega) / (4.0 * np.pi))
    residual = image[..., :3].astype(np.float32).copy()
    if mean <= 0.0 or max_lights == 0:
        return residual, []
    level = threshold * mean
    bright = np.nonzero(luminance > level)[0]
    bright = bright[np.argsort(-luminance[bright], kind="stable")]
    radius = radius_texels * float(np.sqrt(omega.max()))
    cos_radius = np.cos(radius)
    centre_array = np.empty((len(bright), 3))
    members: list = []
    for index in bright:
        if members:
            near = centre_array[:len(members)] @ directions[index]
            best = int(np.argmax(near))
            if near[best] >= cos_radius:
                members[best].append(index)
                continue
        centre_array[len(members)] = directions[index]
        members.append([index])
    centres = list(centre_array[:len(members)])
    # Clusters that touch (texels within ADJACENT_TEXELS of each other) form one
    # bright region; a region wider than GROUP_RADIUS_TEXELS stays in the probe.
    texel_angle = float(np.sqrt(omega.max()))
    cos_touch = np.cos(ADJACENT_TEXELS * texel_angle)
    parent = list(range(len(centres)))

    def root(k):
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    centre_array = centre_array[:len(members)]
    reach = np.cos(min(2.0 * radius + ADJACENT_TEXELS * texel_angle, np.pi))
    for k in range(len(centres)):
        for m in np.nonzero(centre_array[k + 1:] @ centre_array[k] >= reach)[0] + k + 1:
            if root(k) != root(m) and np.max(directions[members[k]]
                                             @ directions[members[m]].T) >= cos_touch:
                parent[root(m)] = root(k)
    groups: dict = {}
    for k in range(len(centres)):
        groups.setdefault(root(k), []).append(k)
    cos_group = np.cos(GROUP_RADIUS_TEXELS * texel_angle)
    candidates = []
    for group in groups.values():
        texels = np.concatenate([members[k] for k in group])
        weights = np.maximum(luminance[texels] - level, 0.0) * omega[texels]
        middle = directions[texels].T @ weights
        middle /= np.linalg.norm(middle)
        if np.min(directions[texels] @ middle) < cos_group:
            continue  # a wide bright region: left in the probe
        if max_spread is not None and _spread(directions[texels], omega[texels], weights,
                                              middle) > max_spread:
            continue  # wider than the lobe can take as one light: left in the probe
        for k in group:
            texels = np.asarray(members[k])
            scale = level / luminance[texels]
            excess = radiance[texels] * (1.0 - scale)[:, None] * omega[texels, None]
            candidates.append((float(np.sum(excess @ LUMINANCE)), texels, scale, excess))
    candidates.sort(key=lambda c: -c[0])
    lights = []
    flat = residual.reshape(-1, 3)
    for _, texels, scale, excess in candidates[:max_lights]:
        weights = excess @ LUMINANCE
        direction = directions[texels].T @ weights
        direction /= np.linalg.norm(direction)
        spread = _spread(directions[texels], omega[texels], weights, direction)
        lights.append(Light(direction, excess.sum(axis=0), float(omega[texels].sum()), spread))
        flat[texels] = (radiance[texels] * scale[:, None]).astype(np.float32)
    return residual, lights


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
    keep it."""
    return SPREAD_PER_ALPHA * float(alpha)


def extract_kept(probe, layout="cube", max_spread=None):
    """:func:`extract` with the module's defaults, computed once per probe content
    and ``max_spread`` (bake.probe_maps.ProbeMaps.kept): the materials of one probe
    share it. Do not modify the residual."""
    from .probe_maps import probe_maps

    key = None if max_spread is None else round(float(max_spread), 9)
    return probe_maps(probe, layout).kept(
        ("probe lights", THRESHOLD, RADIUS_TEXELS, MAX_LIGHTS, ADJACENT_TEXELS,
         GROUP_RADIUS_TEXELS, key), lambda: extract(probe, layout, max_spread=max_spread))


def describe(lights) -> str:
    """One line for a panel or a report: how many lights, the brightest's
    irradiance (luminance, W/m^2) and their largest RMS radius (degrees)."""
    if not lights:
        return "no small bright light in the probe"
    lights = [Light.from_json(x) if isinstance(x, dict) else x for x in lights]
    brightest = max(float(light.irradiance @ LUMINANCE) for light in lights)
    widest = max(light.spread for light in lights)
    return (f"{len(lights)} light(s) taken from the probe (brightest {brightest:.3g} W/m^2, "
            f"at most {np.degrees(widest):.2g} degrees RMS)")
