"""How many texels a lobe needs: the Auto map size and probe resolution.

A filtered map is looked up bilinearly, so its texels must be small against
what it shows: the lobe that blurred it, applied to the probe it was
filtered from. The rules are in units of the lobe's width (rad,
:func:`lobe_half_width`) and of the probe's angular spacing
(:func:`bake.probe_maps.latlong_detail_rows`):

    w_eff     = hypot(w_lobe, w_probe)      w_probe = half the probe's coarsest texel
    map rows  = ceil(TEXELS_PER_HALF_WIDTH * pi / w_eff), rounded up to a multiple of 8,
                at least MIN_ROWS, at most the user's maximum and the GPU's texture limit

w_lobe is the narrowest slice's width (the angle holding 25% of its energy,
which for GGX is within 11% of the half width at half maximum). The probe term is
there because the truth a map converges to is the lobe applied to the
probe's (bilinear) reconstruction, whose sharpest features (a sun one texel
wide) are a texel across: a lobe far narrower than the probe's texels needs
no more rows than the texels themselves.

The constant comes from the curve `benchmarks/resolution_curve.py` measures:
the relative RMS error of a 3D map's lookup against the brute-force
integral of the true BRDF over the probe's bilinear reconstruction, on
isolated-sphere pixels in sunset.exr (its sun is the hardest case), as the
rows grow. GGX 0.1 from a 32-px cube probe: 0.071 / 0.042 / 0.048 / 0.038 /
0.034 / 0.036 / 0.033 at 200 / 304 / 352 / 400 / 608 / 704 / 800 rows. With
the filter's earlier sub-sampling settings: GGX 0.1 from a 64-px probe 0.064 /
0.040 / 0.027 at 256 / 384 / 512; GGX 0.2 from a 64-px probe 0.028 / 0.015 /
0.017 / 0.014 at 152 / 192 / 256 / 384 (the probe term's support). The error
falls steeply until w_eff spans about 3 texels and then wanders within
about 15% (the sun's alignment with the texel grid), so
TEXELS_PER_HALF_WIDTH = 4 (400 rows for the 32-px case): at Auto, doubling
the rows changes the error by less than 1.2x (1.14x there;
tests/bake/test_resolution.py asserts it at GGX 0.1). Measured since against
the converged integral over anti-aliased pixels (4 x 4 sub-pixels, as a
render averages them; pixel centres alone point-sample a sun one or two pixels
wide): Auto over twice the rows 0.87-1.14 on 16-64 px spheres, three sun
positions, 32-128 px probes (benchmarks/resolution_curve.py prints both).
Where the lobe is far narrower than half a probe texel (GGX 0.05 from a 32- to
128-px probe; Auto's probe for it is 600 px), the bilinear reconstruction's
kink at a one-texel sun stays in the map and twice the rows can still gain:
Auto over twice 7.1 / 4.5 (32 px probe, 16 / 28 px spheres, errors 0.40 /
0.83%), 0.59 / 1.73 (64 px, 0.22 / 0.15%), 1.48 / 0.73 (128 px, where the
atlas's texture limit caps Auto at 1022 rows; 1.08 / 0.82%).

The probe term is the probe's texels unless its *content* is smoother
(bake.probe_content): when a coarser level of the probe's box MIP pyramid
reconstructs the probe to 0.1% of its mean (RMS), w_probe is half that
level's texel (``content_shape`` of :func:`choose_map_rows`). That bound
keeps the map's extra error at about 0.1%; a constant world then bakes at
MIN_ROWS, and every bundled HDRI keeps its texels (`benchmarks/
resolution_curve.py --smooth`).

The probe face a lobe needs (:func:`choose_probe_face`): the larger of the
face whose half texel is no wider than the lobe (then the lobe, not the
probe, sets the map) and PROBE_FACE_PER_ROOT_WIDTH / sqrt(w_lobe), the face
at which the probe itself stops limiting the reflection; a world-only probe
is further capped by the world image's own detail. Where the world has lamps
only a few of its texels wide, the lobe rule's face is not enough:
bake.probe_detail measures the probe's error on the world image itself and
raises the face until it is under 2% (glossy.capture_probes does this for
Auto faces whenever the world has an environment image).

The second term comes from the probe's own error: the brute-force integral
of the true BRDF over the probe against the same over a 256 px probe of the
HDRI (a 48 px isolated sphere, every bundled HDRI: benchmarks/probe_face.py).
It falls under about 2% at faces of 96 (GGX 0.2, w_lobe 0.026
rad; studio.exr 11.5 / 4.1 / 3.7 / 0.5% at 40 / 48 / 64 / 96), 48 (GGX 0.3,
w 0.056; studio 5.2 / 2.0% at 40 / 48), 40-48 (GGX 0.45, w 0.139; interior
2.5%, studio 1.4% at 40) and 32 (GGX 0.6, w 0.267; studio 12.0 / 2.9 / 0.7%
at 8 / 16 / 32, interior 2.7% at 32): about 16 / sqrt(w), not 1 / w. The
half-texel rule alone gave 40 / 24 / 8 / 8 px faces there, where the probe
was 4-12% off on sharp-edged lights (studio's softboxes, interior's window).
Lamps a texel or two wide (night.exr, interior.exr) alias differently at
every face size (night at GGX 0.2: 11-24% from 48 to 128 px, not falling):
there the probe lights (bake.probe_lights), not the face, carry them.
"""

import math

import numpy as np

from .errors import BakeError
from .probe_maps import latlong_detail_rows

__all__ = ["TEXELS_PER_HALF_WIDTH", "MIN_ROWS", "PROBE_FACE_PER_ROOT_WIDTH", "lobe_half_width",
           "ggx_half_width",
           "effective_half_width",
           "latlong_detail_rows",
           "rows_for_half_width", "Choice", "choose_map_rows", "world_detail_face",
           "choose_probe_face"]

TEXELS_PER_HALF_WIDTH = 4.0
MIN_ROWS = 16
#: Auto probe faces are at least this over the root of the narrowest lobe's half
#: width (rad): where the probe stops limiting the reflection (module doc).
PROBE_FACE_PER_ROOT_WIDTH = 16.0


def lobe_half_width(gamma, profile) -> float:
    """A zonal profile's width (rad): the angle from its centre holding 25% of its energy.

    For a GGX lobe it is 2 alpha / sqrt(3) at normal incidence (the slope
    distribution holds r^2 / (alpha^2 + r^2) of its energy within slope r),
    within 11% of its half width at half maximum (1.29 alpha); unlike the
    HWHM it ignores narrow spikes that carry no energy (the mean profile of
    a grazing slice, cut by the horizon, drops to half its peak at once).
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


def ggx_half_width(alpha: float) -> float:
    """:func:`lobe_half_width` of a GGX lobe of roughness ``alpha`` at normal
    incidence, in closed form: 2 atan(alpha / sqrt(3)) rad (the half vector holds
    tan^2 / (alpha^2 + tan^2) of the energy within angle theta_h, and the
    reflected direction turns by 2 theta_h). For an anisotropic lobe pass the
    narrow axis's alpha: its sharpest direction is what the probe must resolve."""
    if not alpha > 0:
        raise BakeError(f"a GGX alpha must be > 0, not {alpha!r}")
    return 2.0 * math.atan(float(alpha) / math.sqrt(3.0))


def effective_half_width(half_width, probe_shape, probe_layout) -> float:
    """Width (rad) of the lobe convolved with the probe's reconstruction: widths add in
    quadrature, the probe contributing half its coarsest texel (pi / 2 / detail rows)."""
    probe = 0.5 * math.pi / latlong_detail_rows(probe_shape, probe_layout)
    return math.hypot(half_width, probe)


def rows_for_half_width(half_width: float) -> int:
    """Lat-long rows at which a lobe of this width (rad) spans TEXELS_PER_HALF_WIDTH texels."""
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
        #: "lobe", "content", "probe", "maximum" or "minimum": what set the value.
        self.limited_by = limited_by

    def __repr__(self):
        return f"Choice({self.value}, {self.reason!r})"


def choose_map_rows(half_widths, probe_shape, probe_layout, maximum=None, layers=1,
                    texture_limit=16384, content_shape=None) -> Choice:
    """Auto lat-long rows of a baked map.

    half_widths: widths (rad, :func:`lobe_half_width`) of every lobe the map
    holds (the narrowest rules); probe_shape / probe_layout: the probe
    filtered; maximum: the user's upper bound (None: none); layers: slices
    stacked in the atlas, which must stay within ``texture_limit`` rows.
    content_shape: the (H, W) of the coarsest level of the probe's box MIP
    pyramid that stands for its content (bake.probe_content.content_detail;
    None or the probe's own shape: its texels): the rule then sees the probe
    through that level's texels, since the probe holds no finer detail.
    """
    narrowest = float(min(half_widths))
    smoother = content_shape is not None and int(content_shape[0]) < int(probe_shape[0])
    width = effective_half_width(narrowest, content_shape if smoother else probe_shape,
                                 probe_layout)
    wanted = _round_rows(rows_for_half_width(width))
    rows, limited_by = wanted, "lobe"
    if smoother:
        limited_by = "content"
        reason = (f"{rows} rows: the lobe (width {math.degrees(narrowest):.2f} deg) seen "
                  f"through the probe's content, no more detailed than a "
                  f"{int(content_shape[0])} px {probe_layout} (the {probe_shape[0]} px "
                  f"probe holds nothing finer), spans {TEXELS_PER_HALF_WIDTH:g} texels")
    else:
        reason = (f"{rows} rows: the lobe (width {math.degrees(narrowest):.2f} deg) seen "
                  f"through the probe's texels ({probe_shape[0]} px {probe_layout}) spans "
                  f"{TEXELS_PER_HALF_WIDTH:g} texels")
    if rows == MIN_ROWS:
        limited_by = "minimum"
    gpu = texture_limit // max(int(layers), 1) - 2
    if maximum is not None and rows > int(maximum):
        rows, limited_by = int(maximum), "maximum"
        reason = (f"{rows} rows: limited by Max Map Size (Auto wanted {wanted}: sharper "
                  f"highlights, bake time grows with rows squared)")
    if rows > gpu:
        rows, limited_by = gpu, "texture limit"
        reason = (f"{rows} rows: {layers} slices x {rows + 2} rows is the GPU's {texture_limit}-"
                  f"row texture limit (Auto wanted {wanted})")
    return Choice(rows, reason, limited_by)


def world_detail_face(world_rows) -> int:
    """The cube face (px, a multiple of 8) whose texels match a lat-long world image of
    ``world_rows`` rows at the face centre (2 rows / pi): finer faces only interpolate it."""
    return max(8, int(math.ceil(2.0 * int(world_rows) / math.pi / 8.0)) * 8)


def choose_probe_face(half_widths, maximum, world_rows=None) -> Choice:
    """Auto cube face size of a probe for lobes of these widths (rad).

    For the narrowest lobe w: the larger of 1 / w (its half texel at the face
    centre no wider than the lobe, so the map's rows follow the lobe rather
    than the probe) and PROBE_FACE_PER_ROOT_WIDTH / sqrt(w) (the probe's own
    error under about 2%: module doc); a multiple of 8, at least 8. Capped by ``maximum`` (the
    user's field) and, for a world-only probe, by the world image's own
    detail ``world_rows`` (lat-long rows of the environment image: finer
    faces would only interpolate it).
    """
    if len(half_widths):
        narrowest = float(min(half_widths))
        wanted = max(1.0 / narrowest, PROBE_FACE_PER_ROOT_WIDTH / math.sqrt(narrowest))
        face = max(8, int(math.ceil(wanted / 8.0)) * 8)
        reason = (f"{face} px faces: where the probe stops limiting the narrowest lobe "
                  f"(width {math.degrees(narrowest):.2f} deg)")
    else:
        face, reason = 8, "8 px faces: no Glossy lobe needs more"
    limited_by = "lobe"
    if world_rows is not None:
        world_face = world_detail_face(world_rows)
        if face > world_face:
            face, limited_by = world_face, "world"
            reason = (f"{face} px faces: the world image's own detail ({world_rows} rows); "
                      f"finer faces would add nothing")
    if face > int(maximum):
        wanted = face
        face, limited_by = int(maximum), "maximum"
        reason = f"{face} px faces: limited by Max Probe Resolution (Auto wanted {wanted})"
    return Choice(face, reason, limited_by)


def fixed_face_reason(size, half_widths, maximum, world_rows=None) -> str:
    """The reason shown for a probe face of ``size`` px set by hand.

    When the lobes of widths ``half_widths`` (rad) would get finer faces under
    Auto (:func:`choose_probe_face`, up to ``maximum`` px and, for a world-only
    probe, the world image's own detail ``world_rows``), the reason names that
    face: such a probe limits the reflection however many rows its maps have
    (a near-mirror coat from a 64 px probe: 13.6% from Cycles, 2.1% from Auto's
    256 px; docs/HISTORY.md, stop 65).
    """
    reason = f"{int(size)} px faces: set by hand"
    if len(half_widths):
        wanted = choose_probe_face(half_widths, maximum, world_rows).value
        if wanted > int(size):
            reason += (f"; Auto would capture {wanted} px for the narrowest lobe (width "
                       f"{math.degrees(float(min(half_widths))):.2f} deg), which this "
                       f"probe's texels blur")
    return reason
