"""A World Only probe's lights, re-measured on the world's own lat-long texels.

bake.probe_lights takes a probe's small bright lights out of the *cube* the
world was resampled to. The cube is already a filtered copy of the world:
a sun one or two texels of the HDRI wide is spread over the cube's texels,
split between a core tile and satellite tiles, and its energy and centroid
move with the cube's grid. :func:`from_world` keeps the cube's decisions
(the threshold and which lights there are) and measures each light again on
the texels of the image the probe was resampled from: every lat-long texel
brighter than the same threshold (times the *world's* mean luminance, by
solid angle) within REACH_SPREADS of a light's spread plus REACH_TEXELS of
the cube's texels from its direction belongs to the nearest light, whose
irradiance, direction and spread are recomputed from those texels; the
texels are clamped to the threshold (hue kept) in the world's residual,
which the caller resamples to the cube as the probe was. The split is exact
in energy on the world: residual + lights = world, texel by texel. A cube
light that no world texel reaches is dropped (its energy is still in the
residual).

Measured (a one-off script recorded in README "Stop 45": the Hybrid of
bake.hybrid with 19 samples, a 64^2 px sphere of 2 x 2 sub-pixels, against
the integral over the HDRI's bilinear reconstruction, each bundled HDRI at
the face Auto captures for it): better than the cube's lights on 8 of 8
HDRIs at GGX 0.3 and 0.6 (geometric mean of the error 0.69x and 0.86x),
7 of 8 at GGX 0.2 and 0.45; sunrise.exr at GGX 0.2 0.90% -> 0.21%, studio at
0.3 1.58% -> 0.67%. Not at GGX 0.1 (3 of 8, 1.77x): there a tile (a quarter
of alpha, 0.0025 rad) is smaller than the HDRI's texel (0.006 rad), several
of the cube's tiles share one world texel and lights are lost, and night's
one-texel lamps at GGX 0.2 become points narrower than the light widening
was fitted for (4.0% -> 15.5%). :func:`resolves` is that rule: use the
world's texels only where the lobe's tiles are at least the world's texel.

Directions are world space (bake.envmap's axes); ``to_texture`` (3, 3) maps a
world direction to the direction the Environment Texture looks up (a
rotation-only Mapping node: bake.world_mapping), identity by default.
"""

import math

import numpy as np

from . import probe_lights
from .envmap import get_layout
from .errors import BakeError

__all__ = ["from_world", "resolves", "REACH_SPREADS", "REACH_TEXELS"]

#: A world texel belongs to a light within this many of the light's spreads ...
REACH_SPREADS = 2.0
#: ... plus this many of the cube's largest texel's angle.
REACH_TEXELS = 1.5
LUMINANCE = probe_lights.LUMINANCE


def resolves(world_shape, alpha) -> bool:
    """Whether a GGX lobe of smallest alpha ``alpha`` tiles at least as coarsely as
    the world's texel (lat-long (H, 2H)): probe_lights.TILE_FRACTION alpha against
    the equator texel's angle pi / H; only then are the world's texels the
    better measure of the lights (module doc)."""
    height = int(world_shape[0])
    return probe_lights.TILE_FRACTION * float(alpha) >= math.pi / height


def from_world(lights, world, cube_face, to_texture=None, strength=1.0):
    """(residual (H, 2H, 3) float32 lat-long, lights) of the lat-long ``world``
    (H, 2H, 3) radiance, for the ``lights`` bake.probe_lights took from the cube
    of ``cube_face`` px faces that the world was resampled to (through the
    Mapping ``to_texture`` and the Background's ``strength``, both applied to
    the result as to the probe: the residual is in the world image's own
    texels, times ``strength``). Lights are returned brightest region first as
    given, each with its irradiance (W/m^2, RGB), direction and spread
    re-measured on the world's texels (module doc)."""
    image = np.asarray(world, dtype=np.float64)[..., :3] * float(strength)
    if image.ndim != 3 or image.shape[1] != 2 * image.shape[0]:
        raise BakeError(f"a lat-long world is (H, 2H, 3), not {np.shape(world)}")
    if not np.all(np.isfinite(image)):
        raise BakeError("the world image has non-finite texels (NaN or infinity)")
    residual = image.astype(np.float32)
    if not lights:
        return residual, []
    thresholds = {float(light.threshold) for light in lights}
    if len(thresholds) != 1:
        raise BakeError("lights of one extraction share one threshold")
    layout = get_layout("latlong")
    shape = image.shape[:2]
    directions = layout.texel_directions(shape).reshape(-1, 3)
    if to_texture is not None:  # texture directions -> world: the rotation's transpose
        directions = directions @ np.asarray(to_texture, dtype=np.float64)
    omega = layout.solid_angles(shape).reshape(-1)
    radiance = image.reshape(-1, 3)
    luminance = radiance @ LUMINANCE
    mean = float(np.sum(np.maximum(luminance, 0.0) * omega) / (4.0 * np.pi))
    level = thresholds.pop() * mean
    bright = np.nonzero(luminance > level)[0]
    centres = np.array([light.direction for light in lights], dtype=np.float64)
    cube_texel = 2.0 / float(cube_face)  # the cube's largest texel's angle (rad)
    reach = np.array([REACH_SPREADS * light.spread + REACH_TEXELS * cube_texel
                      for light in lights])
    cosines = directions[bright] @ centres.T
    nearest = np.argmax(cosines, axis=1)
    angle = np.arccos(np.clip(cosines[np.arange(len(bright)), nearest], -1.0, 1.0))
    inside = angle <= reach[nearest]
    bright, nearest = bright[inside], nearest[inside]
    flat = residual.reshape(-1, 3)
    out = []
    for k, light in enumerate(lights):
        texels = bright[nearest == k]
        if len(texels) == 0:
            continue
        scale = level / luminance[texels]
        excess = radiance[texels] * (1.0 - scale)[:, None] * omega[texels, None]
        weights = excess @ LUMINANCE
        direction = directions[texels].T @ weights
        direction /= np.linalg.norm(direction)
        centre = np.arccos(np.clip(directions[texels] @ direction, -1.0, 1.0))
        own = float(np.sum(weights * omega[texels] / 6.0) / np.sum(weights))
        spread = float(np.sqrt(np.sum(weights * centre ** 2) / np.sum(weights) + own))
        out.append(probe_lights.Light(direction, excess.sum(axis=0), float(omega[texels].sum()),
                                      spread, light.tile, light.threshold, math.sqrt(own)))
        flat[texels] = (radiance[texels] * scale[:, None]).astype(np.float32)
    return residual, out
