"""bake.lamp_spread and bake.lamp_term: the cap levels of the lamp factors against
closed forms and brute-force cap means, their interpolation's exact cases, the
atlas's lookups, area cells, and the sized lamp term against the integral over
the emitter (bake.lamp_reference)."""

import math

import numpy as np
import pytest

from bake import brdf, lamp_reference, lamp_spread, lamp_term, metrics, separable
from bake.separable import _bilinear, hemisphere_coords, hemisphere_directions

SIZE = 128


@pytest.fixture(scope="module")
def narrow():
    """GGX 0.2 factored on 128^2 g maps (its half-vector peak about 6 texels wide)."""
    return separable.factorize("ggx:roughness=0.2", "half-difference", "sampled", 2, SIZE,
                               "xy", size_h=16)


def _cap_points(count):
    i = np.arange(count) + 0.5
    return i / count, i * math.pi * (3.0 - math.sqrt(5.0))


def _brute_cap_mean(texture, centre, rho, count=8192):
    """The mean over a cap of the bilinear reconstruction of a hemisphere map, by
    ``count`` area-uniform points; points below the horizon are left out."""
    fraction, azimuth = _cap_points(count)
    cos_t = 1.0 - fraction * (1.0 - math.cos(rho))
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    helper = np.array([0.0, 0.0, 1.0]) if abs(centre[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, centre)
    x /= np.linalg.norm(x)
    y = np.cross(centre, x)
    d = centre * cos_t[:, None] + x * (sin_t * np.cos(azimuth))[:, None] + \
        y * (sin_t * np.sin(azimuth))[:, None]
    d = d[d[:, 2] > 0.0]
    n = texture.shape[0]
    col, row = hemisphere_coords(d, n)
    return _bilinear(texture, np.clip(col, -0.5, n - 0.5), np.clip(row, -0.5, n - 0.5)).mean(0)


def test_a_cap_mean_of_a_linear_function_is_its_closed_form():
    # mean of z over a cap of radius rho around c: c_z (1 + cos rho) / 2. The
    # texel sum with its one-texel edge ramp is a quadrature of the cap: its
    # error is about the edge's texel share squared (measured 2e-4 to 6e-4 at
    # 128^2); 2e-3 catches a missing solid-angle weight (several percent).
    n, side = 128, 32
    source = hemisphere_directions(n)[..., 2:3].astype(np.float64)
    centres = hemisphere_directions(side)
    for rho in (0.05, 0.2, 0.5):
        means = lamp_spread.cap_means(source, "xy", side, rho)[..., 0]
        inside = np.arccos(np.clip(centres[..., 2], -1, 1)) + rho < math.radians(75)
        expected = centres[..., 2] * (1.0 + math.cos(rho)) / 2.0
        assert inside.sum() > 50
        assert np.abs(means - expected)[inside].max() < 2e-3


def test_levels_match_a_brute_force_cap_mean_of_the_factor(narrow):
    # Against 8192 points on the factor's own reconstruction (error about
    # 1 / sqrt(8192) of the local spread, well under 1e-3 of the peak here), at
    # the texels around the peak and at random ones whose caps stay within 70
    # degrees of the pole. The texel sum differs from the bilinear
    # reconstruction's integral at the cap's edge: measured at most 0.93% of
    # the level's peak here (0.7% at the default 256^2); bound 1.25%.
    levels = lamp_spread.blur_levels(narrow)
    assert levels.count == lamp_spread.level_count(SIZE) == 12
    rng = np.random.default_rng(3)
    for j, (rho, level) in enumerate(zip(levels.radii, levels.maps, strict=True), start=1):
        side = level.shape[1]
        assert side == lamp_spread.level_side(SIZE, j)
        assert rho == pytest.approx(lamp_spread.level_radius(4.0 / SIZE, j))
        centres = hemisphere_directions(side)
        peak = np.unravel_index(np.argmax(level[0, ..., 1]), (side, side))
        picks = [(peak[0] + a, peak[1] + b) for a in (-2, 0, 2) for b in (-2, 0, 2)]
        picks += [tuple(p) for p in rng.integers(0, side, (12, 2))]
        for r, c in picks:
            r, c = min(max(r, 0), side - 1), min(max(c, 0), side - 1)
            if np.arccos(centres[r, c, 2]) + rho > math.radians(70):
                continue
            truth = _brute_cap_mean(narrow.g[0].astype(np.float64), centres[r, c], rho)
            assert np.abs(level[0, r, c] - truth).max() <= 0.0125 * np.abs(level[0]).max()


def test_the_interpolation_is_exact_for_narrow_and_for_flat_features():
    # Between two levels the cap integral is interpolated linearly in the cap's
    # area: a feature narrower than both caps (level means I / A_j) gives I / A
    # exactly, a flat one (every level the same) the same value: weights sum to 1.
    first, count = 4.0 / 256, 14
    radii = lamp_spread.level_radius(first, np.arange(1, count + 1))
    spread = np.geomspace(first, radii[-1], 97)
    a, b, wa, wb = lamp_spread.level_weights(spread, first, count)
    area = 1.0 - np.cos(spread)
    level_area = 1.0 - np.cos(np.concatenate([[0.0], radii]))
    narrow = wa / level_area[a.astype(int)] + wb / level_area[b.astype(int)]
    np.testing.assert_allclose(narrow, 1.0 / area, rtol=1e-9)
    np.testing.assert_allclose(wa + wb, 1.0, rtol=1e-12)
    # at a level's own radius it is that level alone; continuous across them
    a, b, wa, wb = lamp_spread.level_weights(radii, first, count)
    picked = np.where(wa > 0.5, a, b)
    np.testing.assert_array_equal(picked, np.arange(1, count + 1))
    np.testing.assert_allclose(np.maximum(wa, wb), 1.0, atol=1e-9)
    # below rho_1: a linear mix in area from the factor itself (level 0)
    a, b, wa, wb = lamp_spread.level_weights(np.array([0.0, first / 2]), first, count)
    assert (a == 0).all() and (b == 1).all() and wa[0] == 1.0
    assert wb[1] == pytest.approx((1 - math.cos(first / 2)) / (1 - math.cos(first)))


def test_the_atlas_reads_each_level_at_its_radius_and_the_factor_without_spread(narrow):
    levels = lamp_spread.blur_levels(narrow)
    image, meta = separable.pack(narrow, levels)
    assert meta["levels"] == levels.count and meta["h_row"] == 2 * (SIZE + 2)
    rng = np.random.default_rng(5)
    wi = rng.normal(size=(400, 3))
    wo = rng.normal(size=(400, 3))
    for v in (wi, wo):
        v[:, 2] = np.abs(v[:, 2]) + 0.05
        v /= np.linalg.norm(v, axis=1, keepdims=True)
    plain = narrow.evaluate(wi, wo)
    np.testing.assert_allclose(separable.atlas_lookup(image, meta, wi, wo), plain, atol=1e-6)
    np.testing.assert_allclose(separable.atlas_lookup(image, meta, wi, wo, spread=0.0), plain,
                               atol=1e-6)
    # at rho_j (the lamp's radius 2 rho_j) g is level j's bilinear value
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    d = separable._rotate_to_pole(wi, h)
    for j in (1, 4, 7):
        level = levels.maps[j - 1]
        side = level.shape[1]
        col, row = hemisphere_coords(h, SIZE)
        col = np.clip((np.clip(col, -0.5, SIZE - 0.5) + 0.5) * side / SIZE - 0.5, -0.5, side - .5)
        row = np.clip((np.clip(row, -0.5, SIZE - 0.5) + 0.5) * side / SIZE - 0.5, -0.5, side - .5)
        hc, hr = hemisphere_coords(d, 16)
        expected = sum(_bilinear(level[k], col, row) * _bilinear(
            narrow.h[k], np.clip(hc, -0.5, 15.5), np.clip(hr, -0.5, 15.5)) *
            narrow.scale_g[k] * narrow.scale_h[k] for k in range(narrow.terms))
        got = separable.atlas_lookup(image, meta, wi, wo, spread=2.0 * levels.radii[j - 1])
        np.testing.assert_allclose(got, expected, atol=1e-5 * np.abs(expected).max())


def test_elevation_azimuth_factors_get_no_levels():
    factors = separable.factorize("ggx:roughness=0.5", "elevation-azimuth", "svd", 1, 8, "xy")
    levels = lamp_spread.blur_levels(factors)
    image, meta = separable.pack(factors, levels)
    assert levels.count == 0 and meta["levels"] == 0 and meta["h_row"] == 10


@pytest.mark.parametrize("shape, size, count", [("SQUARE", (1.0, 1.0), 4),
                                                ("RECTANGLE", (1.5, 0.5), 3),
                                                ("RECTANGLE", (0.3, 2.0), 7),
                                                ("DISK", (1.0, 1.0), 1),
                                                ("ELLIPSE", (2.0, 0.6), 3)])
def test_area_cells_partition_the_lamp(shape, size, count):
    cells = np.array(lamp_spread.area_cells(shape, *size))
    assert len(cells) == count
    assert cells[:, 2].sum() == pytest.approx(1.0, abs=1e-12)
    # the area-weighted mean of the cells' centroids is the lamp's centre
    np.testing.assert_allclose((cells[:, :2] * cells[:, 2:]).sum(0), 0.0, atol=1e-12)
    if shape == "ELLIPSE":  # each slice's share and centroid, by 1D quadrature of its chords
        edges = np.linspace(-0.5, 0.5, count + 1)
        for (cu, _, share), lo, hi in zip(cells, edges[:-1], edges[1:], strict=True):
            step = (hi - lo) / 200000
            u = lo + (np.arange(200000) + 0.5) * step  # midpoints
            chord = 2.0 * np.sqrt(np.maximum(0.25 - u * u, 0.0))
            part = chord.sum() * step
            assert share == pytest.approx(part / (math.pi / 4.0), abs=1e-6)
            assert cu == pytest.approx((u * chord).sum() * step / part, abs=1e-6)


def test_bad_area_sizes_are_refused():
    with pytest.raises(Exception, match="positive"):
        lamp_spread.area_cells("SQUARE", 0.0, 1.0)


def test_sized_lamps_follow_the_integral_over_the_emitter():
    # A GGX 0.3 sphere (40^2 px) under three large lamps, against the MIS
    # integral over each emitter (bake.lamp_reference, itself within 2.5% of
    # one with 64x the samples per pixel and 1.35% of Cycles). Measured: the
    # point approximation 25-68%, the sized term 1.6% (area), 2.7% (sun), 5.8%
    # (point: the factor's own error at 128^2, the round cap for an elongated
    # region of half vectors, and the levels' interpolation); bound 8%, and
    # at least 8x better than points (measured 9.2-32x).
    factors = separable.factorize("ggx:roughness=0.3", "half-difference", "sampled", 2, 128,
                                  "xy", size_h=16)
    image, meta = separable.pack(factors, lamp_spread.blur_levels(factors))
    width = 40
    xs = (np.arange(width) + 0.5) / width * 2.4 - 1.2
    x, z = np.meshgrid(xs, -xs)
    inside = x * x + z * z < 0.98
    normals = np.stack([x[inside], -np.sqrt(1 - x[inside] ** 2 - z[inside] ** 2), z[inside]], -1)
    views = np.array([0.0, -6.0, 0.0]) - normals
    views /= np.linalg.norm(views, axis=1, keepdims=True)
    tangents = np.stack([-normals[:, 1], normals[:, 0], np.zeros(len(normals))], -1)
    point, low, high = (2.0, -3.0, 2.5), (2.4, -3.0, -0.4), (3.0, -3.0, 4.0)
    Lamp, aim = lamp_reference.Lamp, lamp_reference.aimed_axes
    model = brdf.parse("ggx:roughness=0.3")
    mask = np.ones((len(normals), 1), bool)
    for lamp in (Lamp("POINT", (300.0,) * 3, point, aim(point), radius=0.8),
                 Lamp("SUN", (1.5,) * 3, high, aim(high), angle=math.radians(15)),
                 Lamp("AREA", (250.0,) * 3, low, aim(low), shape="RECTANGLE",
                      size=(1.5, 0.5))):
        truth = lamp_reference.radiance(model, [lamp], normals, normals, views,
                                        tangents=tangents)[:, None]
        errors = [metrics.relative_rms(lamp_term.radiance(
            image, meta, [lamp], normals, normals, views, tangents, sized=sized)[:, None],
            truth, mask) for sized in (False, True)]
        assert errors[1] <= 0.08, (lamp.kind, errors)
        assert errors[0] >= 8 * errors[1], (lamp.kind, errors)


def test_an_isotropic_factor_gathers_a_quadrant_and_mirrors_it(narrow):
    """GGX's g is its own mirror image across both axes (bake.separable fits one
    row per radius), so blur_levels gathers the top-left quadrant of each level
    and mirrors it: every level equals the gather over all of its texels to
    float32 summation order (1e-5 of the level's peak)."""
    stacked = np.concatenate(list(narrow.g), axis=-1).astype(np.float64)
    assert lamp_spread.map_symmetry(stacked) == "mirror"
    levels = lamp_spread.blur_levels(narrow)
    assert levels.count > 4
    for j, level in enumerate(levels.maps, 1):
        side = lamp_spread.level_side(SIZE, j)
        source = lamp_spread._box_reduce(
            stacked, max(1, SIZE // (lamp_spread.SOURCE_TEXELS * side)))
        full = lamp_spread.cap_means(source, "xy", side, levels.radii[j - 1])
        full = np.moveaxis(full.reshape(side, side, 2, 3), 2, 0)
        np.testing.assert_allclose(level, full, rtol=0, atol=1e-5 * np.abs(full).max())


@pytest.mark.parametrize("side", [35, 36])
def test_a_mirrored_gather_of_odd_and_even_sides_matches_the_full_one(side):
    """A symmetric source (a Gaussian bump about the pole): the quadrant gather,
    mirrored, equals the full gather, the middle row and column of an odd side
    included."""
    directions = hemisphere_directions(side, "xy")
    source = np.exp(-((1.0 - directions[..., 2]) / 0.05))[..., None] * [1.0, 0.5, 0.25]
    for rho in (0.05, 0.3):
        full = lamp_spread.cap_means(source, "xy", side, rho)
        mirrored = lamp_spread.cap_means(source, "xy", side, rho, symmetry="mirror")
        np.testing.assert_allclose(mirrored, full, rtol=0, atol=1e-5 * np.abs(full).max())


@pytest.mark.parametrize("side", [35, 36])
def test_a_half_turn_gather_matches_the_full_one(side):
    """A source symmetric only under a half turn about the pole (an elliptical bump
    whose axes are turned 30 degrees from the map's, as an anisotropic lobe with
    a rotation): the top half gathered and turned equals the full gather."""
    directions = hemisphere_directions(side, "xy")
    angle = math.radians(30.0)
    u = directions[..., 0] * math.cos(angle) + directions[..., 1] * math.sin(angle)
    v = -directions[..., 0] * math.sin(angle) + directions[..., 1] * math.cos(angle)
    source = np.exp(-(u / 0.3) ** 2 - (v / 0.1) ** 2)[..., None] * [1.0, 0.5, 0.25]
    assert lamp_spread.map_symmetry(source) in ("half-turn", None)  # exact only to rounding
    for rho in (0.05, 0.3):
        full = lamp_spread.cap_means(source, "xy", side, rho)
        turned = lamp_spread.cap_means(source, "xy", side, rho, symmetry="half-turn")
        np.testing.assert_allclose(turned, full, rtol=0, atol=1e-5 * np.abs(full).max())
    assert not np.allclose(full, full[::-1], atol=1e-3 * np.abs(full).max())  # not mirrored


def test_an_anisotropic_factor_is_gathered_by_half_turns():
    """Principled anisotropic metal turned 0.1 (36 degrees): its g repeats under a
    half turn (bake.separable) but not under mirrors; every level equals the
    full gather to float32 summation order."""
    factors = separable.factorize("principled:metallic=1,roughness=0.3,anisotropy=0.8,"
                                  "rotation=0.1", "half-difference", "sampled", 2, 64, "xy",
                                  size_h=16)
    stacked = np.concatenate(list(factors.g), axis=-1).astype(np.float64)
    assert lamp_spread.map_symmetry(stacked) == "half-turn"
    levels = lamp_spread.blur_levels(factors)
    for j, level in enumerate(levels.maps, 1):
        side = lamp_spread.level_side(64, j)
        source = lamp_spread._box_reduce(
            stacked, max(1, 64 // (lamp_spread.SOURCE_TEXELS * side)))
        full = lamp_spread.cap_means(source, "xy", side, levels.radii[j - 1])
        full = np.moveaxis(full.reshape(side, side, 2, 3), 2, 0)
        np.testing.assert_allclose(level, full, rtol=0, atol=1e-5 * np.abs(full).max())
