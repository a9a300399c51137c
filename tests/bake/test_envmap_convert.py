"""Bilinear sampling continuity, conversion accuracy, power and anti-aliasing."""

import numpy as np
import pytest

from bake.envmap import LAYOUTS, convert, get_layout, radiant_power, sample
from bake.errors import BakeError


def smooth_environment(d):
    """A smooth test radiance (..., 3): low-order terms plus a broad lobe."""
    lobe = np.exp(3.0 * (d @ np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8]) - 1.0))
    base = 1.0 + 0.5 * d[..., 0] - 0.3 * d[..., 1] ** 2 + 0.2 * d[..., 2] + lobe
    return np.stack([base, 0.5 * base + 0.1, 2.0 - 0.5 * d[..., 2]], -1)


def baked(name, size, function=smooth_environment):
    layout = get_layout(name)
    shape = layout.shape(size)
    return function(layout.texel_directions(shape)).astype(np.float32)


def random_map(name, size, seed=0):
    layout = get_layout(name)
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, 1.0, size=(*layout.shape(size), 3)).astype(np.float32)


def unit(v):
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _pairs_across(points, normals, eps=1e-9):
    """Directions just either side of boundary points, stepping along ``normals``."""
    return unit(points - eps * normals), unit(points + eps * normals)


def _check_continuous(name, points, normals):
    image = random_map(name, 8)  # texel values are independent: any seam shows
    a, b = _pairs_across(points, normals)
    jump = np.abs(sample(image, name, a) - sample(image, name, b)).max()
    # A bilinear surface over O(1) values changes by O(eps * size) across 1e-9 rad.
    assert jump < 1e-5, (name, jump)


def test_cube_lookups_are_continuous_across_edges_and_vertices():
    rng = np.random.default_rng(4)
    t = rng.uniform(-1, 1, 200)
    edges, normals = [], []
    for i, j in [(0, 1), (0, 2), (1, 2)]:
        for si in (-1, 1):
            for sj in (-1, 1):
                p = np.zeros((t.size, 3))
                p[:, i], p[:, j] = si, sj
                k = 3 - i - j
                p[:, k] = t
                nrm = np.zeros_like(p)
                nrm[:, i], nrm[:, j] = si, -sj  # crosses from face i to face j
                edges.append(p)
                normals.append(nrm)
    _check_continuous("cube", np.concatenate(edges), np.concatenate(normals))
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    image = random_map("cube", 8)
    values = [sample(image, "cube", unit(corners + 1e-9 * rng.normal(size=corners.shape)))
              for _ in range(6)]
    assert np.ptp(np.stack(values), axis=0).max() < 1e-5


def test_latlong_lookups_are_continuous_at_seam_and_poles():
    rng = np.random.default_rng(5)
    z = rng.uniform(-0.99, 0.99, 300)
    r = np.sqrt(1 - z**2)
    seam = np.stack([-r, np.zeros_like(z), z], -1)  # u = 0 / 1 is -X
    across = np.stack([np.zeros_like(z), np.ones_like(z), np.zeros_like(z)], -1)
    _check_continuous("latlong", seam, across)
    image = random_map("latlong", 8)
    for pole in (1.0, -1.0):
        phi = rng.uniform(0, 2 * np.pi, 50)
        near = unit(np.stack([1e-9 * np.cos(phi), 1e-9 * np.sin(phi), np.full(50, pole)], -1))
        values = sample(image, "latlong", near)
        assert np.ptp(values, axis=0).max() < 1e-5


def test_paraboloid_lookups_are_continuous_at_the_rim():
    rng = np.random.default_rng(6)
    phi = rng.uniform(0, 2 * np.pi, 300)
    rim = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1)
    up = np.tile([0.0, 0.0, 1.0], (phi.size, 1))
    image = baked("paraboloid", 32)  # halves agree only where both hold the same function
    a, b = _pairs_across(rim, up)
    jump = np.abs(sample(image, "paraboloid", a) - sample(image, "paraboloid", b)).max()
    # Each half interpolates the same smooth function at different texels:
    # the difference is bilinear interpolation error, O(h^2 |f''|) with h = 2/32.
    assert jump < 1e-2


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_lookup_at_texel_centres_returns_the_texel(name):
    layout = get_layout(name)
    image = random_map(name, 16)
    shape = image.shape[:2]
    d = layout.texel_directions(shape)
    omega = layout.solid_angles(shape)
    inside = omega > 0.5 * np.median(omega[omega > 0])  # skip texels cut by a rim
    np.testing.assert_allclose(sample(image, name, d)[inside], image[inside], atol=2e-6)


def texel_means(function, layout, shape, m=16):
    """Reference: Jacobian-weighted m x m midpoint mean of ``function`` over each texel."""
    sub = (np.arange(m) + 0.5) / m
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    x, y = np.broadcast_arrays(cols[..., None, None] + sub[None, None, None, :],
                               rows[..., None, None] + sub[None, None, :, None])
    weights = np.broadcast_to(layout.jacobian(x, y, shape), x.shape)[..., None]
    values = function(layout.directions(x, y, shape))
    return (weights * values).sum(axis=(2, 3)) / weights.sum(axis=(2, 3))


@pytest.mark.parametrize("src", list(LAYOUTS))
@pytest.mark.parametrize("dst", list(LAYOUTS))
def test_conversion_of_a_smooth_environment_is_accurate(src, dst):
    """Against the exact texel means of the analytic radiance."""
    source = baked(src, 96)
    result = convert(source, src, dst, 48)
    layout = get_layout(dst)
    expected = texel_means(smooth_environment, layout, result.shape[:2])
    error = np.abs(result - expected).max(axis=-1)
    # A sphere map squeezes the back hemisphere into its rim, where one texel
    # spans tens of degrees and no bilinear lookup is accurate: compare only
    # directions within 2 asin(0.9) = 128 degrees of its centre (texels at most
    # 4.6x the angular size of the central ones).
    if "sphere" in (src, dst):
        sphere = get_layout("sphere")
        d = layout.texel_directions(result.shape[:2])
        x, y = sphere.coords(d, (48, 48))
        rho = np.hypot(x / 24 - 1, 1 - y / 24)
        error = error[rho < 0.9]
    # What remains is the source's bilinear interpolation error, about
    # h^2 |f''| / 8 with h = pi / 96 and |f''| <= 10 here: 1.3e-3; the
    # sphere map's texels grow 4.6x in angle by rho = 0.9 (4.6^2 in error).
    tolerance = 2.5e-3 if "sphere" not in (src, dst) else 2.5e-3 * 4.6**2
    assert error.max() < tolerance


@pytest.mark.parametrize("src", list(LAYOUTS))
@pytest.mark.parametrize("dst", list(LAYOUTS))
def test_constant_maps_stay_constant(src, dst):
    source = np.full((*get_layout(src).shape(24), 3), 2.5, np.float32)
    np.testing.assert_allclose(convert(source, src, dst, 10), 2.5, rtol=1e-6)


@pytest.mark.parametrize("dst", list(LAYOUTS))
@pytest.mark.parametrize("size", [8, 16, 64])
def test_downsampling_does_not_alias(dst, size):
    """A per-texel checkerboard of 0 and 2 averages to 1 under every smaller texel."""
    rows, cols = np.mgrid[0:512, 0:1024]
    checker = np.repeat((((rows + cols) % 2) * 2.0)[..., None], 3, -1).astype(np.float32)
    result = convert(checker, "latlong", dst, size)
    omega = get_layout(dst).solid_angles(result.shape[:2])
    # Exact 2x2 box steps plus >= 2 sub-samples per source texel: the
    # remaining error is float32 rounding of the texel sums.
    assert np.abs(result[omega > 0] - 1.0).max() < 1e-3


def _mean_relative_error(a, b):
    return float(np.mean(np.abs(a - b).sum(-1) / np.maximum(np.abs(b).sum(-1), 1e-3)))


@pytest.mark.parametrize("hdri", ["forest.exr", "courtyard.exr"])
@pytest.mark.parametrize(("via", "size"), [("cube", 256), ("paraboloid", 256)])
def test_round_trip_of_a_real_hdri(hdri_dir, hdri, via, size):
    from bake import exr

    image, _ = exr.read(hdri_dir / hdri)
    height = image.shape[0]
    there = convert(image, "latlong", via, size)
    back = convert(there, via, "latlong", height)
    power = radiant_power(image, "latlong")
    # Power is conserved by construction (area means of a bilinear surface).
    np.testing.assert_allclose(radiant_power(there, via), power, rtol=5e-3)
    np.testing.assert_allclose(radiant_power(back, "latlong"), power, rtol=5e-3)
    # The detail a map of T texels cannot hold is lost whatever its layout:
    # the reference is the same round trip through a lat-long map of the
    # same texel count over the sphere. Glossy's layouts may lose 15% more.
    texels = get_layout(via).covered_texels(there.shape[:2])
    equal = int(round(np.sqrt(texels / 2)))
    reference = convert(convert(image, "latlong", "latlong", equal), "latlong", "latlong", height)
    error = _mean_relative_error(back, image)
    assert error <= 1.15 * _mean_relative_error(reference, image)


def test_round_trip_of_band_limited_content_is_nearly_lossless(forest):
    """Content the intermediate map can hold survives the round trip."""
    smooth = convert(convert(forest, "latlong", "latlong", 16), "latlong", "latlong", 256)
    # Cube 128 and paraboloid 256 hold about the same number of texels (1e5).
    for via, size in (("cube", 128), ("paraboloid", 256)):
        back = convert(convert(smooth, "latlong", via, size), via, "latlong", 256)
        # Features of the 16-row map are ~0.2 rad wide, >= 12 intermediate
        # texels: bilinear error ~ (1/12)^2 / 8 of the local contrast, <1%.
        assert _mean_relative_error(back, smooth) < 0.01, via


def test_convert_rejects_bad_input():
    good = np.ones((8, 16, 3), np.float32)
    with pytest.raises(BakeError, match="strip of six"):
        convert(good, "cube", "latlong", 8)
    with pytest.raises(BakeError, match="unknown"):
        convert(good, "latlong", "octahedral", 8)
    bad = good.copy()
    bad[0, 0, 0] = np.nan
    with pytest.raises(BakeError, match="NaN"):
        convert(bad, "latlong", "cube", 8)
    with pytest.raises(BakeError, match="too large"):
        convert(good, "latlong", "cube", 10**6)


@pytest.mark.parametrize(("src", "src_size", "dst", "size", "turned"), [
    ("latlong", 96, "cube", 16, True),     # a World Only capture: turned by a Mapping
    ("latlong", 256, "cube", 12, False),   # the source prereduced first
    ("cube", 24, "latlong", 40, False),
    ("cube", 16, "paraboloid", 20, True),
])
def test_converting_some_texels_gives_what_the_whole_conversion_gives(src, src_size, dst, size,
                                                                       turned):
    """bake.envmap.convert.convert_texels evaluates chosen target texels alone with
    convert's own prereduction, sub-samples, weights and lookups: equal to the
    whole conversion at those texels to float32 rounding (1e-6 relative; the sums
    run in another order), for texels anywhere, seams and poles included."""
    from bake.envmap.convert import convert_texels

    image = random_map(src, src_size, seed=3) * 10.0
    turn = None
    if turned:
        angle = 0.7
        rotation = np.array([[np.cos(angle), -np.sin(angle), 0.0],
                             [np.sin(angle), np.cos(angle), 0.0], [0.0, 0.0, 1.0]])

        def turn(directions):
            return directions @ rotation.T

    whole = convert(image, src, dst, size, transform=turn)
    rng = np.random.default_rng(4)
    ys = np.concatenate([rng.integers(0, whole.shape[0], 300), [0, whole.shape[0] - 1]])
    xs = np.concatenate([rng.integers(0, whole.shape[1], 300), [0, whole.shape[1] - 1]])
    some = convert_texels(image, src, dst, size, ys, xs, transform=turn)
    assert some.shape == (len(ys), 3) and some.dtype == np.float32
    np.testing.assert_allclose(some, whole[ys, xs], rtol=1e-6, atol=1e-6)


def _changed(name, size, picks, seed):
    """(image, changed image, mask): a random map with the texels ``picks`` scaled by
    0.01, as a probe's lights are lowered."""
    from bake.envmap import get_layout as layout_of

    shape = layout_of(name).shape(size)
    rng = np.random.default_rng(seed)
    image = (rng.random((*shape, 3)) ** 6 * 20.0 + 0.1).astype(np.float32)
    mask = np.zeros(shape, dtype=bool)
    for y, x in picks:
        mask[y % shape[0], x % shape[1]] = True
    changed = image.copy()
    changed[mask] *= np.float32(0.01)
    return image, changed, mask


@pytest.mark.parametrize("src, src_size, size, samples, picks", [
    # cube corners, a pole-facing face centre and a seam
    ("cube", 32, 64, None, [(0, 0), (31, 191), (16, 16), (16, 69), (0, 144), (31, 96)]),
    ("cube", 32, 96, 1, [(5, 7), (20, 100), (31, 160)]),  # one sub-sample (ProbeMaps' rule)
    ("cube", 64, 16, None, [(3, 5), (60, 300)]),  # reduced twice before resampling
    ("cube", 32, 64, None, [(y, x) for y in range(8, 14) for x in range(70, 82)]),  # a block
    ("latlong", 32, 64, None, [(0, 3), (31, 40), (16, 0), (16, 63)]),  # poles, the u seam
    ("latlong", 64, 16, None, [(0, 3), (1, 70), (40, 127)]),
])
def test_a_conversion_updated_near_changed_texels_is_the_whole_conversion(
        monkeypatch, src, src_size, size, samples, picks):
    """convert_changed against convert of the changed image: equal to float32 rounding
    (1e-6 of the peak), recomputing only near the changes (the whole conversion is
    not called)."""
    import importlib

    convert_module = importlib.import_module("bake.envmap.convert")
    image, changed, mask = _changed(src, src_size, picks, seed=len(picks) + size)
    before = convert(image, src, "latlong", size, samples=samples)
    expected = convert(changed, src, "latlong", size, samples=samples)

    def whole(*args, **kwargs):
        raise AssertionError("converted the whole image")

    monkeypatch.setattr(convert_module, "convert", whole)
    got = convert_module.convert_changed(before, changed, mask, src, size, samples=samples)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6 * float(expected.max()))


def test_a_conversion_updated_from_the_wrong_image_is_converted_whole():
    """When ``converted`` is not the original's conversion (the check texels differ),
    the result is still the changed image's whole conversion."""
    from bake.envmap.convert import convert_changed

    image, changed, mask = _changed("cube", 32, [(4, 4)], seed=1)
    wrong = convert(image * np.float32(1.5), "cube", "latlong", 64)
    got = convert_changed(wrong, changed, mask, "cube", 64)
    np.testing.assert_allclose(got, convert(changed, "cube", "latlong", 64), rtol=1e-6)
    with pytest.raises(BakeError):
        convert_changed(wrong, changed, mask[:, :10], "cube", 64)


def test_a_change_over_most_of_the_map_converts_it_whole_without_the_original():
    """When most of the target is near changed texels, convert_changed converts the
    changed image itself and never asks for the original's conversion (a function
    that would compute it for nothing)."""
    from bake.envmap.convert import convert_changed

    picks = [(y, x) for y in range(0, 16, 2) for x in range(0, 96, 3)]
    image, changed, mask = _changed("cube", 16, picks, seed=3)

    def original():
        raise AssertionError("the original's conversion was asked for")

    got = convert_changed(original, changed, mask, "cube", 16)
    np.testing.assert_allclose(got, convert(changed, "cube", "latlong", 16), rtol=1e-6)


@pytest.mark.parametrize(("source_rows", "rows", "samples"),
                         [(64, 16, 8), (64, 200, None), (128, 37, 3), (128, 128, 4)])
def test_latlong_to_latlong_is_the_per_sub_sample_resampling_computed_separably(
        source_rows, rows, samples):
    """convert between lat-long maps (LatLong.resampled: rows and columns apart) against
    the per-sub-sample resampling every other pair of layouts takes (convert.resample
    over the same sampler, with the same prereduction, sub-samples, polar row
    prefilter and Jacobian weights): equal to float32 rounding (measured: at most
    4e-7 of the largest value, the sums running in another order), downsampling
    with the polar prefilter on (16 rows from 64 with 8 x 8 sub-samples),
    upsampling, odd sizes and the same size. A lamp a texel wide makes a texel
    missed or weighted wrongly show."""
    import importlib

    convert_module = importlib.import_module("bake.envmap.convert")
    rng = np.random.default_rng(source_rows + rows)
    image = rng.random((source_rows, 2 * source_rows, 3), dtype=np.float32)
    image[source_rows // 3, source_rows // 2] = 500.0
    separable = convert(image, "latlong", "latlong", rows, samples=samples)
    sample, target, shape, k, channels = convert_module._plan(
        image, "latlong", "latlong", rows, samples, None)
    generic = convert_module.resample(sample, target, shape, k, channels)
    assert separable.shape == generic.shape == (rows, 2 * rows, 3)
    assert np.abs(separable - generic).max() <= 2e-6 * np.abs(generic).max()


def test_cube_directions_from_column_and_row_coordinates_are_the_broadcast_ones():
    """convert.resample passes a cube target its sub-samples' x as columns and y as
    rows (the face table gathered per column, not per sub-sample): the directions
    and Jacobian weights must be those of the broadcast grid, to the bit."""
    cube = get_layout("cube")
    shape = cube.shape(24)
    offsets = (np.arange(3) + 0.5) / 3
    x = (np.arange(shape[1])[:, None] + offsets[None, :])[None, None, :, :]
    y = (np.arange(5, 11)[:, None] + offsets[None, :])[:, :, None, None]
    xs, ys = np.broadcast_arrays(x, y)
    assert np.array_equal(cube.directions(x, y, shape), cube.directions(xs, ys, shape))
    weights = np.broadcast_to(cube.jacobian(x, y, shape), xs.shape)
    assert np.array_equal(weights, cube.jacobian(xs, ys, shape))
