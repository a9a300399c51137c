"""Auto resolution (bake.resolution): lobe widths, the map and probe rules, and the
measured claim behind them: at Auto rows the resolution no longer limits the map."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from bake import envmap, exr, lobes, prefilter, resolution
from bake.errors import BakeError

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from benchmarks.resolution_curve import (  # noqa: E402
    pixel_relative_rms,
    sphere_subpixels,
    truth_of,
)


def test_width_of_a_narrow_gaussian_is_its_25_percent_energy_radius():
    """exp(-g^2 / 2 s^2) holds 1 - exp(-r^2 / 2 s^2) of its energy within r (flat limit):
    25% at r = s sqrt(2 ln 4/3)."""
    sigma = 0.01
    profile = np.exp(-0.5 * (lobes.GAMMA / sigma) ** 2)
    expected = sigma * math.sqrt(2.0 * math.log(4.0 / 3.0))
    assert resolution.lobe_half_width(lobes.GAMMA, profile) == pytest.approx(expected, rel=2e-3)


def test_ggx_width_at_normal_incidence_matches_the_slope_distribution():
    """For small alpha the reflected GGX lobe at normal incidence holds r^2 / (alpha^2 + r^2)
    of its energy within slope r = tan(gamma / 2): 25% at gamma = 2 alpha / sqrt(3).
    The fitted profile carries the cosine and the shadowing too: within 3%."""
    alpha = 0.1**2
    fit = lobes.fit("ggx:roughness=0.1", slices=4)
    width = resolution.lobe_half_width(lobes.GAMMA, fit.slices[-1].lobes[0].profile)
    assert width == pytest.approx(2.0 * alpha / math.sqrt(3.0), rel=0.03)


def test_a_spike_without_energy_does_not_make_a_lobe_narrow():
    """A grazing slice's mean profile drops to half its peak at once (half its profiles
    go below the horizon): its half maximum is tiny, its energy width is not."""
    wide = np.exp(-0.5 * (lobes.GAMMA / 0.3) ** 2)
    spiked = wide.copy()
    spiked[0] = 2.0  # a peak at the centre holding no energy
    assert resolution.lobe_half_width(lobes.GAMMA, spiked) == pytest.approx(
        resolution.lobe_half_width(lobes.GAMMA, wide), rel=1e-3)


def test_map_rows_follow_the_lobe_seen_through_the_probe():
    probe = (128, 6 * 128)
    half_texel = 0.5 * math.pi / resolution.latlong_detail_rows(probe, "cube")
    width = 0.02
    choice = resolution.choose_map_rows([0.05, width], probe, "cube", maximum=2048)
    expected = resolution.TEXELS_PER_HALF_WIDTH * math.pi / math.hypot(width, half_texel)
    assert choice.limited_by == "lobe" and choice.value % 8 == 0
    assert expected <= choice.value < expected + 8
    # A much sharper lobe gains little: the probe's texels set the rows.
    sharp = resolution.choose_map_rows([1e-4], probe, "cube", maximum=2048)
    assert sharp.value <= resolution.TEXELS_PER_HALF_WIDTH * math.pi / half_texel + 8
    # Bounds: the user's maximum, the GPU's texture height for the stacked slices, the minimum.
    capped = resolution.choose_map_rows([1e-4], probe, "cube", maximum=200)
    assert capped.value == 200 and capped.limited_by == "maximum" and "Auto wanted" in \
        capped.reason
    stacked = resolution.choose_map_rows([1e-4], probe, "cube", maximum=2048, layers=64)
    assert stacked.value == 16384 // 64 - 2 and stacked.limited_by == "texture limit"
    wide = resolution.choose_map_rows([2.0], probe, "cube", maximum=2048)
    assert wide.value == resolution.MIN_ROWS and wide.limited_by == "minimum"


def test_probe_face_follows_the_lobe_within_the_world_detail_and_the_maximum():
    choice = resolution.choose_probe_face([0.0066], maximum=4096)
    # 16 / sqrt(0.0066) = 197 > 1 / 0.0066 = 152: up to a multiple of 8.
    assert choice.limited_by == "lobe" and choice.value == 200
    narrow = resolution.choose_probe_face([0.001], maximum=4096)
    assert narrow.value == 1000  # 1 / w = 1000 > 16 / sqrt(w) = 506
    assert resolution.choose_probe_face([0.2671], maximum=4096).value == 32  # GGX 0.6
    world = resolution.choose_probe_face([0.001], maximum=4096, world_rows=512)
    assert world.limited_by == "world" and world.value == 328  # 2 * 512 / pi, up to 8
    capped = resolution.choose_probe_face([0.001], maximum=128, world_rows=512)
    assert capped.value == 128 and capped.limited_by == "maximum"
    assert resolution.choose_probe_face([], maximum=256).value == 8  # no lobe: the minimum
    with pytest.raises(BakeError, match="half width"):
        resolution.rows_for_half_width(0.0)


def test_a_face_set_by_hand_names_the_face_auto_would_capture_when_finer():
    # The same rule as Auto (above): 16 / sqrt(0.0066) = 197 -> 200 px, within a
    # World Only probe's 512-row world (328 px) and the maximum.
    coarse = resolution.fixed_face_reason(64, [0.0066, 0.05], 4096, world_rows=512)
    assert coarse == ("64 px faces: set by hand; Auto would capture 200 px for the narrowest "
                      "lobe (width 0.38 deg), which this probe's texels blur")
    # Past the world's own detail a finer face adds nothing: 328 px, not 1000.
    assert "Auto would capture 328 px" in resolution.fixed_face_reason(64, [0.001], 4096, 512)
    # Faces as fine as Auto's, or no Glossy lobe: nothing more to say.
    assert resolution.fixed_face_reason(256, [0.0066], 4096) == "256 px faces: set by hand"
    assert resolution.fixed_face_reason(16, [], 4096) == "16 px faces: set by hand"


def test_at_the_auto_face_the_probe_stops_limiting_a_wide_lobe(hdri_dir):
    """GGX 0.6 on a 24 px isolated sphere in studio.exr (softboxes: sharp edges):
    the brute-force integral over the probe at the Auto face (32 px for this
    lobe's narrowest slice) against the same over a 128 px probe, the finer
    truth. Measured: 0.7% at 32 px, where the earlier half-texel rule's 8 px
    faces gave 12%; allowed 2% (the rule's target, resolution's module doc),
    and the 8 px face must be off by more than 5%, so the check can fail."""
    from bake import brdf, envmap, exr, lobes, reference

    spec = "ggx:roughness=0.6"
    fit = lobes.fit(spec, slices=16)
    narrowest = min(resolution.lobe_half_width(lobes.GAMMA, lobe.profile)
                    for s in fit.slices for lobe in s.lobes)
    face = resolution.choose_probe_face([narrowest], maximum=256).value
    assert face == 32
    image, _ = exr.read(hdri_dir / "studio.exr")
    normals, views, mask = reference.sphere_buffers(24)
    normals, views = normals[mask], views[mask]
    luminance = np.array([0.2126, 0.7152, 0.0722])

    def render(size):
        probe = envmap.convert(image[..., :3], "latlong", "cube", size)
        return reference.render(brdf.parse(spec), probe, "cube", normals, views) @ luminance

    truth = render(128)
    errors = {size: float(np.sqrt(np.mean((render(size) - truth) ** 2) / np.mean(truth ** 2)))
              for size in (8, face)}
    assert errors[face] < 0.02 and errors[8] > 0.05, errors


@pytest.fixture(scope="module")
def sunset_ggx01_maps(hdri_dir):
    """GGX 0.1 from a 32-px cube probe of sunset.exr: (probe, model, {rows: BakedMap}) at
    Auto rows, twice and half those rows."""
    source, _ = exr.read(hdri_dir / "sunset.exr")
    probe = envmap.convert(source, "latlong", "cube", 32)
    spec = "ggx:roughness=0.1"
    fit = lobes.fit(spec, slices=16)
    auto = prefilter.prefilter(probe, fit, "3d", "auto", layout="cube", max_size=2048)
    rows = auto.meta["size"]
    assert auto.meta["size_reason"].startswith(f"{rows} rows: the lobe")
    maps = {rows: auto}
    for size in (2 * rows, rows // 2):
        maps[size] = prefilter.prefilter(probe, fit, "3d", size, layout="cube")
    return probe, prefilter.parse(spec), rows, maps


@pytest.mark.slow
@pytest.mark.parametrize("pixels", [16, 28])
def test_auto_rows_are_where_resolution_stops_limiting_the_map(sunset_ggx01_maps, pixels):
    """The issue's acceptance: GGX 0.1 on an isolated sphere (orthographic, 16 and 28 px,
    anti-aliased over 4 x 4 sub-pixels) in sunset.exr from a 32-px cube probe. The
    error of the map's lookup against the brute-force integral of the true BRDF over
    the probe's bilinear reconstruction at Auto rows (400) is within 1.2x of the error
    at twice those rows, and half the Auto rows is clearly worse (the rule gives the
    map no fewer texels than it needs). Measured: 0.235 / 0.271 / 0.947% at Auto /
    twice / half on 16 px (ratios 0.87, 4.0), 0.345 / 0.319 / 0.458% on 28 px (1.08,
    1.33).

    The pixels are averaged over sub-pixels as a render's are
    (benchmarks.resolution_curve.sphere_subpixels): over pixel centres alone the sun,
    one or two pixels wide at these sizes, is point-sampled and the ratio Auto /
    twice measured 1.73 and 2.53 on these two spheres (0.66-1.20 on 20-64 px);
    anti-aliased it is 0.87-1.14 on all six sizes, across three sun positions and
    on 64- and 128-px probes (docs/HISTORY.md, stop 59). 28 px is the size where
    the centre rays gave the worst figure.

    The truth is benchmarks.resolution_curve.truth_of (bake.reference.render over
    the bilinear reconstruction, within 0.3% of an importance-sampled integral:
    tests/bake/test_reference.py)."""
    probe, model, rows, maps = sunset_ggx01_maps
    normals, views, average = sphere_subpixels(pixels, 4)
    truth = truth_of(model, probe, normals, views)
    error = {size: pixel_relative_rms(baked.shade(normals, views), truth, average)
             for size, baked in maps.items()}
    at_auto, at_double, at_half = error[rows], error[2 * rows], error[rows // 2]
    assert at_auto <= 1.2 * at_double, (rows, at_auto, at_double)
    assert at_half > 1.2 * at_auto, (rows, at_half, at_auto)


@pytest.mark.parametrize("alpha", [0.018, 0.09, 0.25])
def test_ggx_half_width_is_lobe_half_width_of_the_ggx_profile(alpha):
    """The closed form against lobe_half_width of the reflected GGX lobe at normal
    incidence, integrated numerically: per solid angle of the reflected direction
    it is D(h) / 4 (the Jacobian 1 / (4 cos theta_h) cancels D's cos theta_h), at
    theta_h = gamma / 2, over every half vector of the hemisphere (gamma up to
    pi: the closed form keeps the tail that a horizon would cut, 4% of the width
    at alpha 0.25). A fine grid (400k angles) leaves the trapezoid error far
    below the 1e-3 allowed."""
    gamma = np.linspace(0.0, np.pi * (1 - 1e-9), 400001)
    t2 = np.tan(gamma / 2) ** 2
    ggx = 1.0 / (np.pi * alpha ** 2 * np.cos(gamma / 2) ** 4 * (1.0 + t2 / alpha ** 2) ** 2)
    numeric = resolution.lobe_half_width(gamma, ggx / 4.0)
    assert resolution.ggx_half_width(alpha) == pytest.approx(numeric, rel=1e-3)
    with pytest.raises(BakeError, match="alpha"):
        resolution.ggx_half_width(0.0)
