"""How many texels a lobe needs: the Auto map size and probe resolution.

A filtered map is looked up bilinearly, so its texels must be small against
the lobe that blurred it; and a map finer than the probe it was filtered
from adds nothing the probe had. Both rules are in units of the lobe's half
width at half maximum (HWHM, rad, :func:`lobe_half_width`) and of the
probe's angular spacing (:func:`bake.probe_maps.latlong_detail_rows`):

    rows(lobe)  = ceil(TEXELS_PER_HALF_WIDTH * pi / HWHM)   (the HWHM spans that many texels)
    rows(probe) = ceil(PROBE_OVERSAMPLING * detail rows of the probe)
    map rows    = clamp(min(rows(narrowest lobe), rows(probe)), MIN_ROWS, user's maximum)

The constants come from the curve `benchmarks/resolution_curve.py` measures:
the error of a 3D map against the brute-force integral of the true BRDF
over the probe, on isolated-sphere pixels in sunset.exr (the sun is the
hardest case), as the map's rows grow by factors of sqrt(2), for GGX
roughness 0.05-0.6 and probes of 32-128 texel faces. The error falls until
the lobe's HWHM spans about 2 texels and is flat (within 3%) beyond 3; past
1.5x the probe's detail rows it no longer falls for lobes narrower than a
probe texel. TEXELS_PER_HALF_WIDTH = 3 and PROBE_OVERSAMPLING = 1.5 put the
Auto size on the flat part: doubling it changes the error by under 5%
(tests/bake/test_resolution.py asserts the issue's 1.2x bound).

The probe face that a lobe needs follows by inverting the probe rule; a
world-only probe is further capped by the world image's own detail.
"""

import math

import numpy as np

from .errors import BakeError
from .probe_maps import latlong_detail_rows

__all__ = ["TEXELS_PER_HALF_WIDTH", "PROBE_OVERSAMPLING", "MIN_ROWS", "lobe_half_width",
           "latlong_detail_rows",
           "rows_for_half_width", "Choice", "choose_map_rows", "choose_probe_face"]

TEXELS_PER_HALF_WIDTH = 3.0
PROBE_OVERSAMPLING = 1.5
MIN_ROWS = 16


def lobe_half_width(gamma, profile) -> float:
    """A zonal profile's width (rad): the angle from its centre holding 25% of its energy.

    For a GGX lobe this equals its half width at half maximum (the GGX slope
    distribution holds r^2 / (alpha^2 + r^2) of its energy within r); unlike
    the HWHM it ignores narrow spikes that carry no energy (the mean profile
    of a grazing slice, cut by the horizon, drops to half its peak at once).
    gamma: (G,) increasing angles from 0; profile: (G,) values (1/sr),
    interpolated linearly. pi when the profile has no energy.
    """
    gamma = np.asarray(gamma, dtype=np.float64)
    profile = np.clip(np.asarray(profile, dtype=np.float64), 0.0, None)
    if gamma.size < 2:
        return math.pi
    # Energy of each interval: 2 pi int p(g) sin(g) dg, trapezoid on p sin g.
    density = profile * np.sin(gamma)
    pieces = 0.5 * (density[1:] + density[:-1]) * np.diff(gamma)
    cumulative = np.concatenate([[0.0], np.cumsum(pieces)])
    total = cumulative[-1]
    if not total > 0:
        return math.pi
    return float(np.interp(0.25 * total, cumulative, gamma))


def effective_half_width(half_width, probe_shape, probe_layout) -> float:
    """Width (rad) of the lobe convolved with the probe's reconstruction: widths add in
    quadrature, the probe contributing half its coarsest texel (pi / 2 / detail rows)."""
    probe = 0.5 * math.pi / latlong_detail_rows(probe_shape, probe_layout)
    return math.hypot(half_width, probe)


def rows_for_half_width(half_width: float) -> int:
    """Lat-long rows at which a lobe of this HWHM (rad) spans TEXELS_PER_HALF_WIDTH texels."""
    if not half_width > 0:
        raise BakeError(f"a lobe half width must be > 0 rad, not {half_width!r}")
    return int(math.ceil(TEXELS_PER_HALF_WIDTH * math.pi / half_width))


def _round_rows(rows):
    """Up to a multiple of 8 (FFT-friendly widths 2N), at least MIN_ROWS."""
    return max(MIN_ROWS, int(math.ceil(rows / 8.0)) * 8)


class Choice:
    """A chosen size and the reason for it, in words for the panel and the log."""

    def __init__(self, value: int, reason: str, limited_by: str):
        self.value = int(value)
        self.reason = reason
        #: "lobe", "probe", "maximum" or "minimum": what set the value.
        self.limited_by = limited_by

    def __repr__(self):
        return f"Choice({self.value}, {self.reason!r})"


def choose_map_rows(half_widths, probe_shape, probe_layout, maximum=None) -> Choice:
    """Auto lat-long rows of a baked map.

    half_widths: HWHM (rad) of every lobe the map holds (the narrowest rules);
    probe_shape / probe_layout: the probe filtered; maximum: the user's upper
    bound (None: none).
    """
    narrowest = float(min(half_widths))
    lobe_rows = rows_for_half_width(narrowest)
    probe_rows = int(math.ceil(PROBE_OVERSAMPLING * latlong_detail_rows(probe_shape,
                                                                        probe_layout)))
    degrees = math.degrees(narrowest)
    if lobe_rows <= probe_rows:
        rows, limited_by = _round_rows(lobe_rows), "lobe"
        reason = (f"{rows} rows: the narrowest lobe (half width {degrees:.2f} deg) spans "
                  f"{TEXELS_PER_HALF_WIDTH:g} texels")
        if rows == MIN_ROWS and lobe_rows < MIN_ROWS:
            limited_by = "minimum"
    else:
        rows, limited_by = _round_rows(probe_rows), "probe"
        reason = (f"{rows} rows: capped by the probe's detail ({probe_shape[0]} px "
                  f"{probe_layout}); the lobe (half width {degrees:.2f} deg) would use "
                  f"{_round_rows(lobe_rows)}")
    if maximum is not None and rows > int(maximum):
        rows, limited_by = int(maximum), "maximum"
        reason = f"{rows} rows: the Max Map Size set on the material (Auto wanted more)"
    return Choice(rows, reason, limited_by)


def choose_probe_face(half_widths, maximum, world_rows=None) -> Choice:
    """Auto cube face size of a probe for lobes of these HWHMs (rad).

    The face whose detail rows times PROBE_OVERSAMPLING reach the narrowest
    lobe's map rows; capped by ``maximum`` (the user's field) and, for a
    world-only probe, by the world image's own detail ``world_rows``
    (lat-long rows of the environment image).
    """
    narrowest = float(min(half_widths)) if len(half_widths) else math.pi / 8
    wanted_rows = rows_for_half_width(narrowest) / PROBE_OVERSAMPLING
    face = max(8, int(math.ceil(2.0 * wanted_rows / math.pi)))
    face = int(math.ceil(face / 8.0)) * 8
    reason = (f"{face} px faces: the narrowest lobe (half width "
              f"{math.degrees(narrowest):.2f} deg) needs them")
    limited_by = "lobe"
    if world_rows is not None:
        world_face = int(math.ceil(2.0 * world_rows / math.pi / 8.0)) * 8
        if face > world_face:
            face, limited_by = world_face, "world"
            reason = (f"{face} px faces: the world image's own detail "
                      f"({world_rows} rows); finer faces would add nothing")
    if face > int(maximum):
        face, limited_by = int(maximum), "maximum"
        reason = f"{face} px faces: the object's Max Probe Resolution (Auto wanted more)"
    return Choice(face, reason, limited_by)
