"""bake.probe_detail: how fine a world-image probe must be, measured on the world itself."""

import math

import numpy as np
import pytest

from bake import envmap, lobes, probe_detail, resolution
from bake.errors import BakeError


@pytest.mark.parametrize("width", [0.01, 0.0558, 0.3])
def test_the_lobe_is_ggx_reflected_at_normal_incidence(width):
    """The half vector of D(h) (h.n) holds t^2 / (alpha^2 + t^2) of the energy within
    slope t = tan(gamma / 2) (closed form); cut at the horizon (t = 1) the lobe's
    share within gamma is that over 1 / (1 + alpha^2). Unit integral; its
    resolution.lobe_half_width (25% of the cut lobe's energy) is where that share
    is 1/4: t = alpha sqrt(1 / (3 + 4 alpha^2)), the width asked for when narrow."""
    alpha = math.sqrt(3.0) * math.tan(0.5 * width)
    gamma = np.linspace(0.0, math.pi, 400001)
    profile = probe_detail.ggx_kernel_profile(width, gamma)
    density = 2.0 * math.pi * profile * np.sin(gamma)
    cumulative = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1])
                                                  * np.diff(gamma))])
    assert cumulative[-1] == pytest.approx(1.0, abs=1e-4)
    for angle in (0.5 * width, width, 3.0 * width, 1.0):
        t2 = math.tan(0.5 * angle) ** 2
        expected = t2 / (alpha**2 + t2) * (1.0 + alpha**2)
        assert np.interp(angle, gamma, cumulative) == pytest.approx(expected, rel=2e-3)
    nodes = probe_detail.ggx_kernel_profile(width, lobes.GAMMA)
    quarter = 2.0 * math.atan(alpha * math.sqrt(1.0 / (3.0 + 4.0 * alpha**2)))
    assert resolution.lobe_half_width(lobes.GAMMA, nodes) == pytest.approx(quarter, rel=0.01)
    assert quarter == pytest.approx(width, rel=0.05)
    with pytest.raises(BakeError, match="lobe width"):
        probe_detail.ggx_kernel_profile(2.0, gamma)


def _world(rows, lamp=None):
    """(rows, 2 rows, 3) lat-long sky: 1 + z/2 (smooth), plus ``lamp`` (radiance) in the
    texel at elevation 40 deg, longitude 0.3 rad."""
    theta = (np.arange(rows) + 0.5) / rows * math.pi
    world = np.repeat((1.0 + 0.5 * np.cos(theta))[:, None, None], 2 * rows, axis=1)
    world = np.repeat(world, 3, axis=2).astype(np.float32)
    if lamp:
        world[int(rows * 50 / 180), int(2 * rows * 0.3 / (2 * math.pi))] = lamp
    return world


def test_a_constant_world_gives_a_constant_probe():
    """Any probe of a constant world is that constant: no error at any face."""
    world = np.full((128, 256, 3), 2.5, np.float32)
    detail = probe_detail.WorldDetail(world, 0.0558)
    for face in (16, 40, 72):
        assert detail.error(face) < 1e-4


def test_a_one_texel_lamp_raises_the_face_a_smooth_sky_does_not():
    """GGX 0.3's lobe (width 0.0558 rad) with the lobe rule's 72 px face
    (resolution.choose_probe_face): a smooth sky needs no more; a lamp one world
    texel wide (2e4 against a sky of 1-1.5) is moved and smeared by 72 px texels
    (3.1% here, above the tolerance; 0.7% for a lamp of 2e3), and the face
    chosen brings it within probe_detail.TOLERANCE, at most the world's own
    detail (168 px faces for 256 rows)."""
    width, lobe_face = 0.0558, 72
    assert resolution.choose_probe_face([width], 4096).value == lobe_face
    cap = resolution.world_detail_face(256)
    assert cap == 168
    face, error, tried = probe_detail.choose_world_face(_world(256), width, lobe_face, cap)
    assert face == lobe_face and error < 0.25 * probe_detail.TOLERANCE and len(tried) == 1
    face, error, tried = probe_detail.choose_world_face(_world(256, 2e4), width, lobe_face, cap)
    assert tried[0][1] > 1.25 * probe_detail.TOLERANCE
    assert lobe_face < face <= cap
    assert error <= probe_detail.TOLERANCE
    assert [f for f, _ in tried] == probe_detail.face_ladder(lobe_face, cap)[:len(tried)]
    assert all(e > probe_detail.TOLERANCE for _, e in tried[:-1])


def test_the_face_ladder_steps_by_a_quarter_in_multiples_of_8():
    assert probe_detail.face_ladder(72, 168) == [72, 96, 120, 152, 168]
    assert probe_detail.face_ladder(8, 16) == [8, 16]
    assert probe_detail.choose_world_face(_world(64), 0.05, 72, 72)[0] == 72


def test_a_world_measured_before_in_the_session_is_not_measured_again():
    """The second capture of the same world for the same lobe returns the first's
    result after one step; one changed texel is a new world, measured again (and
    its result is what the measurement itself gives, not the cached one)."""
    width, lobe_face = 0.0558, 72
    cap = resolution.world_detail_face(256)
    world = _world(256, 1.7e4)  # a world no other test measures

    def run(image):
        steps = probe_detail.world_face_steps(image, width, lobe_face, cap)
        messages = []
        while True:
            try:
                messages.append(next(steps)[1])
            except StopIteration as done:
                return done.value, messages

    first, measured = run(world)
    second, remembered = run(world.copy())
    assert second == first and len(measured) > 1
    assert remembered == ["the world's detail for this lobe, measured before in this session"]
    changed = world.copy()
    changed[200, 100] = 7.0  # a smooth-sky texel, far from the lamp
    third, again = run(changed)
    assert len(again) > 1
    detail = probe_detail.WorldDetail(changed, width)
    assert [e for _, e in third[2]] == [detail.error(f) for f, _ in third[2]]


def test_the_probe_each_face_was_measured_on_is_kept_for_the_capture():
    """The World Only capture after a measure takes the chosen face's probe from the
    measure (bake.envmap.convert of the world, the capture's own conversion) rather
    than converting the world again: it must be that conversion to the bit, for
    every face tried, and nothing for a face not tried or another world."""
    width, lobe_face = 0.0558, 72
    cap = resolution.world_detail_face(256)
    world = _world(256, 2.3e4)  # a world no other test measures
    face, _, tried = probe_detail.choose_world_face(world, width, lobe_face, cap)
    assert len(tried) > 1
    for tried_face, _ in tried:
        kept = probe_detail.measured_probe(world.copy(), tried_face)
        expected = envmap.convert(world, "latlong", "cube", tried_face)
        assert kept is not None and np.array_equal(kept, expected), tried_face
        kept[:] = 0.0  # the caller's copy: the kept probe is unchanged
        assert np.array_equal(probe_detail.measured_probe(world, tried_face), expected)
    assert probe_detail.measured_probe(world, face + 8) is None
    other = world.copy()
    other[10, 10] = 3.0
    assert probe_detail.measured_probe(other, face) is None


def test_the_ladder_stops_at_the_finest_face_the_measure_resolves():
    """A world of 1024 rows is compared at MAX_REFERENCE_ROWS (512) rows, whose texels
    match 328 px faces: finer faces only change how a lamp aliases on the two grids
    (the error bounces, e.g. 2.6-4.9% from 320 to 792 px on a 4096 x 2048 night.exr
    at GGX 0.1). So the ladder stops at 328 px, and when no face up to there passes,
    the cap (the world's own detail, 656 px) stands, as it did when every rung up to
    it failed (a 0.3 degree sun in a 4096 x 2048 world measured 2.7% from Cycles at
    its 1024 px cap, 4.5% at 256 px: docs/HISTORY.md, stop 40). Where the lobe's
    own face is past 328 px, nothing is measured. Measured here: 11.1% / 13.6% at
    304 / 328 px (a one-texel lamp of 5e4 in a smooth sky)."""
    world = _world(1024, 5e4)
    cap = resolution.world_detail_face(1024)
    assert cap == 656 and probe_detail.measurable_face(1024) == 328
    assert probe_detail.measurable_face(512) == resolution.world_detail_face(512) == 328
    face, error, tried = probe_detail.choose_world_face(world, 0.0067, 304, cap)
    assert [f for f, _ in tried] == [304, 328]
    assert all(e > probe_detail.TOLERANCE for _, e in tried)
    assert face == cap and error == tried[-1][1]
    assert probe_detail.choose_world_face(world, 0.0067, 336, cap) == (cap, None, [])
