"""bake.sampling_atlas: the pre-blurred level atlas the runtime-sampling nodes will read,
against the lat-long map it comes from, the sphere's solid angle, power conservation,
an EXR round trip and the cube-pyramid estimator."""

import numpy as np
import pytest

from bake import brdf, exr, reference, sampling, sampling_atlas
from bake.envmap import convert, get_layout
from bake.errors import BakeError


def _sky(face=16):
    cube = get_layout("cube")
    directions = cube.texel_directions(cube.shape(face))
    return (0.3 + np.clip(directions[..., 2], 0, None)[..., None] * np.array([1.0, 2.0, 3.0])
            + 0.5 * directions[..., :1] ** 2).astype(np.float32)


def test_level_zero_reads_back_the_lat_long_map_at_texel_centres():
    env = _sky()
    atlas, meta = sampling_atlas.pack_levels(env, height=32)
    probe = sampling_atlas.AtlasProbe(atlas, meta)
    base = convert(env, "cube", "latlong", 32)
    directions = get_layout("latlong").texel_directions(base.shape[:2])
    got = probe.lookup(directions, np.zeros(directions.shape[:2]))
    np.testing.assert_allclose(got, base, rtol=1e-5, atol=1e-6)


def test_the_level_texel_solid_angle_sums_to_the_sphere():
    atlas, meta = sampling_atlas.pack_levels(_sky(), height=64)
    probe = sampling_atlas.AtlasProbe(atlas, meta)
    latlong = get_layout("latlong")
    directions = latlong.texel_directions(latlong.shape(64))
    assert probe.texel_solid_angle(directions).sum() == pytest.approx(4 * np.pi, rel=2e-3)


def _level_powers(atlas, meta):
    """sum(L omega) (3,) of each stored level, read from its own block of the atlas
    (bake.sampling_atlas's "mip" layout) with its own lat-long solid angles."""
    latlong = get_layout("latlong")
    top, powers = int(meta["slice_height"]), []
    for k in range(int(meta["slices"])):
        rows = top >> k
        first = int(sampling_atlas.level_row(top, k)) + 1
        texels = atlas[first:first + rows, 1:1 + 2 * rows]
        omega = latlong.solid_angles((rows, 2 * rows))[..., None]
        powers.append(np.sum(texels.astype(np.float64) * omega, axis=(0, 1)))
    return powers


def test_every_level_keeps_the_radiant_power():
    """Each level is stored at its own size (no resampling to the base's texels), so
    it keeps the pyramid's exact conservation of sum(L omega): to float32 rounding
    (1e-5 allowed). Until stop 75 the levels were sampled back at the base's
    texels, which kept it only to 0.7-1.8%."""
    atlas, meta = sampling_atlas.pack_levels(sampling.spots_environment(16, 5), height=32)
    assert meta["level_layout"] == "mip" and atlas.shape[0] == meta["atlas_rows"]
    assert atlas.shape[0] == sum((32 >> k) + 2 for k in range(meta["slices"]))
    powers = _level_powers(atlas, meta)
    for power in powers[1:]:
        np.testing.assert_allclose(power, powers[0], rtol=1e-5)


@pytest.mark.parametrize("spec", ["ggx:roughness=0.3,anisotropy=0.8",
                                  "kurt:ks=1,mx=0.2,my=0.075,f0=0.5"])
def test_a_constant_environment_stays_constant_through_the_atlas(spec):
    model = brdf.parse(spec)
    env = np.full(get_layout("cube").shape(8) + (3,), 1.5, np.float32)
    probe = sampling_atlas.AtlasProbe(*sampling_atlas.pack_levels(env))
    normals, views, mask = reference.sphere_buffers(16)
    normals, views = normals[mask], views[mask]
    out = sampling.render_regular(model, None, normals, views, budget=19, mip=probe)
    frames = sampling._frames(normals, None, (0.3, 0.5, 0.8))
    wo = np.einsum("bij,bj->bi", frames, views)
    np.testing.assert_allclose(out, 1.5 * model.albedo(wo, samples=1024), rtol=1e-5, atol=1e-9)


def test_the_atlas_estimate_agrees_with_the_cube_pyramid_s():
    """Two independent MIP layouts (lat-long levels, cube levels) under the same
    estimator, on a smooth sky: within 2% relative RMS
    (their filters differ by a texel or so at each level)."""
    env = _sky(32)
    model = brdf.parse("ggx:roughness=0.3,anisotropy=0.6")
    normals, views, mask = reference.sphere_buffers(24)
    normals, views = normals[mask], views[mask]
    atlas_probe = sampling_atlas.AtlasProbe(*sampling_atlas.pack_levels(env))
    a = sampling.render_regular(model, None, normals, views, mip=atlas_probe)
    c = sampling.render_regular(model, None, normals, views,
                                mip=sampling.MipProbe(env, filter="gauss4"))
    assert np.sqrt(np.mean((a - c) ** 2) / np.mean(c ** 2)) < 0.02


def test_the_atlas_survives_an_exr_round_trip(tmp_path):
    atlas, meta = sampling_atlas.pack_levels(_sky(), height=16)
    exr.write(tmp_path / "levels.exr", atlas, meta)
    again, again_meta = exr.read(tmp_path / "levels.exr")
    probe = sampling_atlas.AtlasProbe(again[..., :3], again_meta)
    directions = get_layout("latlong").texel_directions((16, 32))
    np.testing.assert_array_equal(probe.lookup(directions, np.full((16, 32), 1.5)),
                                  sampling_atlas.AtlasProbe(atlas, meta).lookup(
                                      directions, np.full((16, 32), 1.5)))


def test_bad_input_is_refused():
    with pytest.raises(BakeError, match="power of two"):
        sampling_atlas.pack_levels(_sky(), height=40)
    with pytest.raises(BakeError, match="levels"):
        sampling_atlas.pack_levels(_sky(), height=16, levels=9)
    with pytest.raises(BakeError, match="not a level atlas"):
        sampling_atlas.AtlasProbe(np.zeros((4, 4, 3)), {"mode": "atlas3d"})


@pytest.mark.parametrize("rows_in, rows_out", [(2, 64), (4, 32), (8, 8), (16, 64), (3, 8)])
def test_separable_upsampling_equals_the_bilinear_sampler_at_texel_centres(rows_in, rows_out):
    """LatLong.upsampled (what pack_levels stores for each level) against the
    sampler looked up at every target texel's direction: the same pole rows,
    seam wrap and bilinear weights, so equal to float32 rounding (1e-6 of the
    peak: the lookups' coordinates come from atan2 and acos of directions)."""
    latlong = get_layout("latlong")
    rng = np.random.default_rng(rows_in * 100 + rows_out)
    image = (rng.random((rows_in, 2 * rows_in, 3)) ** 4 * 50).astype(np.float32)
    directions = latlong.texel_directions((rows_out, 2 * rows_out))
    expected = latlong.sampler(image)(directions)
    got = latlong.upsampled(image, rows_out)
    assert got.shape == (rows_out, 2 * rows_out, 3) and got.dtype == np.float32
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-6 * float(expected.max()))


@pytest.mark.parametrize("height", [12, 24, 48])
def test_a_stack_three_times_a_power_of_two_halves_down_to_three_rows(height):
    """384 = 3 x 2^7 (the default Max Map Size) is a stack height: each level halves
    exactly down to 3 rows, level 0 reads back the lat-long map, and every level
    keeps the radiant power as a power-of-two stack's do
    (:func:`test_every_level_keeps_the_radiant_power`)."""
    env = sampling.spots_environment(16, 5)
    atlas, meta = sampling_atlas.pack_levels(env, height=height)
    assert meta["slices"] == sampling_atlas.level_count(height) == 1 + int(np.log2(height // 3))
    latlong = get_layout("latlong")
    base = convert(env, "cube", "latlong", height)
    got = sampling_atlas.AtlasProbe(atlas, meta).lookup(
        latlong.texel_directions(base.shape[:2]), np.zeros(base.shape[:2]))
    np.testing.assert_allclose(got, base, rtol=1e-5, atol=1e-6)
    powers = _level_powers(atlas, meta)
    for power in powers[1:]:
        np.testing.assert_allclose(power, powers[0], rtol=1e-5)


def test_the_stack_heights_are_powers_of_two_and_three_times_them():
    allowed = [rows for rows in range(1, 800) if sampling_atlas.is_stack_height(rows)]
    expected = sorted({1 << k for k in range(2, 10)} | {3 << k for k in range(1, 9)})
    assert allowed == [rows for rows in expected if rows < 800]
    for wanted in range(4, 800):  # the most allowed rows at most wanted
        assert sampling_atlas.stack_rows_below(wanted) == max(
            rows for rows in allowed if rows <= wanted)
