"""Prefiltered maps: every mode against brute force, energy, offsets, grazing views, files."""

import numpy as np
import pytest

from bake import brdf, envmap, lobes, prefilter
from bake.errors import BakeError
from bake.reference import reflected_radiance
from bake.zonal import brute_force_convolve

CUBE = envmap.get_layout("cube")
LATLONG = envmap.get_layout("latlong")


@pytest.fixture(scope="module")
def probe(forest):
    return envmap.convert(forest, "latlong", "cube", 32)


@pytest.fixture(scope="module")
def reconstruction(probe):
    """The probe's bilinear reconstruction, sampled 3x finer: (directions, values, omega)."""
    shape = CUBE.shape(96)
    directions = CUBE.texel_directions(shape)
    values = CUBE.sampler(probe)(directions).reshape(-1, 3)
    return directions.reshape(-1, 3), values, CUBE.solid_angles(shape).reshape(-1)


def relative_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def some_texels(shape, count=800, seed=1):
    """A fixed random subset of texel indices (rows, cols) and their centre directions."""
    rng = np.random.default_rng(seed)
    flat = rng.choice(shape[0] * shape[1], size=min(count, shape[0] * shape[1]), replace=False)
    rows, cols = np.unravel_index(flat, shape)
    return rows, cols


def check(layer, layout, reconstruction, kernel, weight=1.0):
    """Relative RMS of a map against the brute-force convolution at sampled texels."""
    rows, cols = some_texels(layer.shape[:2])
    targets = layout.texel_directions(layer.shape[:2])[rows, cols]
    reference = brute_force_convolve(*reconstruction, kernel, targets) * np.asarray(weight)
    return relative_rms(layer[rows, cols], reference)


def test_3d_and_2d_maps_match_brute_force(probe, reconstruction):
    """Each map against the brute-force all-pairs convolution of the probe's
    bilinear reconstruction (3x finer than the probe), at 800 texels: < 1%."""
    fit = lobes.fit("ggx:roughness=0.5", slices=4)
    baked = prefilter.prefilter(probe, fit, "3d", 64)
    for k, s in enumerate(fit.slices):
        lobe = s.lobes[0]
        error = check(baked.layers[f"slice.{k}"], LATLONG, reconstruction,
                      prefilter._profile_kernel(lobe.profile), lobe.weight)
        assert error < 0.01, (k, error)
    fit2 = lobes.fit("ggx:roughness=0.5", slices=4, mode="2d")
    baked2 = prefilter.prefilter(probe, fit2, "2d", 64)
    kernel = prefilter._profile_kernel(fit2.slices[0].lobes[0].profile)
    assert check(baked2.layers[""], LATLONG, reconstruction, kernel) < 0.01


def test_phong_and_irradiance_match_brute_force(probe, reconstruction):
    phong = prefilter.prefilter(probe, "phong:n=20", "phong", 64)
    assert check(phong.layers[""], LATLONG, reconstruction,
                 lambda c: 21 / (2 * np.pi) * np.clip(c, 0, None) ** 20) < 0.01

    def cosine(c):
        return np.clip(c, 0, None) / np.pi

    direct = prefilter.prefilter(probe, "lambert", "irradiance", 64)
    assert check(direct.layers["irradiance"], LATLONG, reconstruction, cosine) < 0.01
    # Nine SH coefficients: Ramamoorthi & Hanrahan bound the irradiance error
    # by a few percent for natural lighting (here about 2.4%).
    sh9 = prefilter.prefilter(probe, "lambert", "irradiance", 64, method="sh")
    assert check(sh9.layers["irradiance"], LATLONG, reconstruction, cosine) < 0.04


def test_split_sum_levels_match_brute_force(probe, reconstruction):
    baked = prefilter.prefilter(probe, "ggx:roughness=0.5", "split-sum", 32)
    assert baked.meta["roughness_levels"] == pytest.approx([0, 0.2, 0.4, 0.6, 0.8, 1.0])
    np.testing.assert_array_equal(baked.layers["level0"], probe)
    for level, roughness in enumerate(baked.meta["roughness_levels"][1:], start=1):
        error = check(baked.layers[f"level{level}"], CUBE, reconstruction,
                      prefilter.split_sum_kernel(roughness))
        assert error < 0.01, (level, error)
    # The DFG table's A + B is the directional albedo of Cycles' GGX.
    dfg = baked.layers["dfg"]
    row, col = 8, 15
    mu, rough = 1 - 8.5 / 32, 15.5 / 32
    model = brdf.parse(f"ggx:roughness={rough}")
    wo = np.array([np.sqrt(1 - mu**2), 0, mu])
    assert abs(dfg[row, col, 2] - model.albedo(wo)[0]) < 5e-3


@pytest.mark.parametrize(("mode", "spec"), [("3d", "ggx:roughness=0.3"),
                                            ("3d", "sum(lambert:color=0.2; ggx:roughness=0.2)"),
                                            ("2d", "ward:alpha=0.1"), ("phong", "phong:n=80"),
                                            ("irradiance", "lambert:color=0.7/0.5/0.3"),
                                            ("split-sum", "ggx:roughness=0.4")])
def test_constant_environment_gives_albedo_times_the_constant(mode, spec):
    constant = np.full((*CUBE.shape(16), 3), 2.0, np.float32)
    baked = prefilter.prefilter(constant, spec, mode, 32, slices=5,
                                lobes_count=2 if "sum" in spec else 1)
    model = brdf.parse(spec)
    if mode in ("3d", "2d", "phong"):
        for k, mu in enumerate(baked.meta["mu"]):
            expected = 2.0 * model.albedo(lobes._view(mu))
            names = [n for n in baked.layers if n.endswith(f"slice.{k}")] or [""]
            total = sum(baked.layers[n] for n in names)
            if mode != "3d":
                total = total * np.asarray(baked.meta["k"][k])
            np.testing.assert_allclose(total, np.broadcast_to(expected, total.shape), rtol=1e-3)
    elif mode == "irradiance":
        np.testing.assert_allclose(baked.layers["irradiance"], 2.0, rtol=1e-3)
    else:
        for name, layer in baked.layers.items():
            if name != "dfg":
                np.testing.assert_allclose(layer, 2.0, rtol=1e-3)
    # shade() at random normals and views reproduces albedo x constant too.
    rng = np.random.default_rng(0)
    n = rng.normal(size=(50, 3))
    v = n + rng.normal(scale=0.5, size=(50, 3))
    mu = np.clip(np.sum(n / np.linalg.norm(n, axis=1, keepdims=True)
                        * v / np.linalg.norm(v, axis=1, keepdims=True), 1), 0.0, 1.0)
    shaded = baked.shade(n, v)
    if mode == "irradiance":
        np.testing.assert_allclose(shaded, 2.0 * np.asarray([0.7, 0.5, 0.3]) + 0 * shaded,
                                   rtol=1e-3)
    else:
        wo = np.stack([np.sqrt(1 - mu**2), 0 * mu, mu], -1)
        albedo = model.albedo(wo)
        # Between slice nodes the tent interpolation of albedo is linear in mu;
        # the split-sum DFG table is 32 x 32: both within 3% of the exact curve.
        np.testing.assert_allclose(shaded, 2.0 * albedo, rtol=0.03, atol=0.01)


def test_single_bright_texel_appears_where_the_peak_offset_says():
    """A bright texel lights the view whose lobe peak, turned by the slice's offset
    from the mirror direction, falls on it, as the true BRDF says it must."""
    spec = "ggx:roughness=0.8"
    fit = lobes.fit(spec, slices=6, centre="peak")  # lobes about the slices' peaks
    model = brdf.parse(spec)
    normal = np.array([0.0, 0.0, 1.0])
    for k in (1, 2, 3):  # offsets of -0.31, -0.25, -0.18 rad: several texels
        s = fit.slices[k]
        theta_o = np.arccos(s.mu)
        view = np.array([np.sin(theta_o), 0.0, np.cos(theta_o)])  # mirror at -x
        offset = s.lobes[0].offset
        responses, truths = [], []
        for polar in (theta_o, theta_o + offset, theta_o + 2 * offset):
            d = np.array([-np.sin(polar), 0.0, np.cos(polar)])
            probe = np.zeros((*LATLONG.shape(64), 3), np.float32)
            row, col = LATLONG.direction_to_texel(d, (64, 128))
            # Same power whatever the row: radiance / solid angle of the texel.
            probe[row, col] = 1.0 / LATLONG.solid_angles((64, 128))[row, col]
            baked = prefilter.prefilter(probe, fit, "3d", 64, layout="latlong")
            responses.append(baked.shade(normal, view)[0])
            texel = LATLONG.texel_directions((64, 128))[row, col]
            truths.append(model.f(texel, view)[0] * texel[2])
        assert np.argmax(responses) == 1, (k, responses)
        assert np.argmax(truths) == 1, (k, truths)


def test_3d_map_beats_2d_and_split_sum_at_grazing_views(forest):
    """Kautz & McCool's claim: per-elevation lobes help most at grazing angles."""
    probe = envmap.convert(forest, "latlong", "cube", 24)
    spec = "ggx:roughness=0.5"
    model = brdf.parse(spec)
    rng = np.random.default_rng(3)
    normals = rng.normal(size=(120, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    tangent = np.cross(normals, rng.normal(size=(120, 3)))
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    cos_o = rng.uniform(0.08, 0.3, 120)  # grazing
    views = cos_o[:, None] * normals + np.sqrt(1 - cos_o**2)[:, None] * tangent
    truth = reflected_radiance(model, probe, "cube", normals, views)

    def median_error(mode):
        baked = prefilter.prefilter(probe, spec, mode, 48, slices=16)
        lum = np.array([0.2126, 0.7152, 0.0722])
        approx, exact = baked.shade(normals, views) @ lum, truth @ lum
        return float(np.median(np.abs(approx - exact) / exact))

    three_d = median_error("3d")
    assert three_d < median_error("2d")
    assert three_d < median_error("split-sum")


def test_write_and_load_round_trip(tmp_path, probe):
    for mode, spec in [("3d", "ggx:roughness=0.4"), ("split-sum", "ggx:roughness=0.4"),
                       ("irradiance", "lambert")]:
        baked = prefilter.prefilter(probe, spec, mode, 16, slices=4)
        path = baked.write(tmp_path / f"{mode}.exr")
        assert path.with_suffix(".json").exists()
        loaded = prefilter.load(path)
        assert loaded.mode == mode and loaded.meta["spec"] == baked.meta["spec"]
        n = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]])
        v = np.array([[0.3, 0.1, 0.95], [0.0, 0.6, 0.8]])
        np.testing.assert_allclose(loaded.shade(n, v), baked.shade(n, v), rtol=1e-6)


@pytest.mark.parametrize(("args", "kwargs", "message"), [
    (("lambert:color=0", "3d", 16), {}, "reflects nothing"),
    (("ggx:roughness=0.3", "3d", 16), {"slices": 1}, "slices must be"),
    (("ggx:roughness=0.3", "3d", 10**6), {}, "size must be"),
    (("ggx:roughness=0.3", "3d", 2), {}, "size must be"),
    (("ggx:roughness=0.3", "5d", 16), {}, "unknown mode"),
    (("ggx:roughness=0.3,anisotropy=0.5", "3d", 16), {}, "isotropic"),
    (("ward:alpha=0.1", "split-sum", 16), {}, "split-sum mode is for"),
    (("ggx:roughness=0.3", "phong", 16), {}, "phong mode"),
    (("ggx:roughness=0.3", "irradiance", 16), {}, "irradiance mode"),
])
def test_bad_requests_are_refused(probe, args, kwargs, message):
    with pytest.raises(BakeError, match=message):
        prefilter.prefilter(probe, *args, **kwargs)


def test_nan_probe_is_refused(probe):
    bad = probe.copy()
    bad[3, 4, 1] = np.nan
    with pytest.raises(BakeError, match="NaN"):
        prefilter.prefilter(bad, "ggx:roughness=0.3", "3d", 16)


@pytest.mark.parametrize("share", [0.0, 0.5])
def test_a_split_s_low_map_takes_the_high_map_s_lobes_within_its_bound(probe, share):
    """A metal split at base colours 0 and 1 (bake.colour_response): the low map takes the
    high map's filtered unit lobe where prefilter.Companion's bound allows (the slice's
    weight times its shape error at most slice_basis.TOLERANCE of the slice's weight at
    the mean colour ``share``). Each such layer differs from the low map filtered on
    its own by at most that bound times the brightest radiance (the filtered
    difference of two unit lobes is at most their L1 distance times the largest
    value; 1.25x for the two lobes' own discretisation on a 32 px probe); the slices
    left to filter stay within slice_basis's own bound of theirs (twice: each map's
    basis mixes). With share 0 the bound is slice_basis's alone."""
    from bake import slice_basis
    from bake.probe_maps import resample_rows

    low_spec = "principled:base_color=0,metallic=1,roughness=0.3"
    high = prefilter.run_steps(prefilter.prefilter_steps(
        probe, "principled:base_color=1,metallic=1,roughness=0.3", "3d", 32,
        layout="cube", keep_unit_layers=True))
    alone = prefilter.prefilter(probe, low_spec, "3d", 32, layout="cube")
    companion = prefilter.Companion(high.unit_fit, high.unit_layers, 32, share)
    low = prefilter.run_steps(prefilter.prefilter_steps(probe, low_spec, "3d", 32,
                                                        layout="cube", companion=companion))
    reused = low.meta["reused_slices"]
    fit = lobes.fit(brdf.parse(low_spec), slices=16, lobes=1, mode="3d")
    brightest = float(np.max(probe))
    tolerance = slice_basis.TOLERANCE
    for k in range(16):
        w_low = float(np.mean(fit.slices[k].lobes[0].weight))
        w_high = float(np.mean(high.unit_fit.slices[k].lobes[0].weight))
        error = slice_basis.energy_error(high.unit_fit.slices[k].lobes[0].profile,
                                         fit.slices[k].lobes[0].profile, lobes.GAMMA)
        allowed = w_low * error <= tolerance * ((1 - share) * w_low + share * w_high)
        assert (f"{k}.0" in reused) == allowed, k
        difference = np.abs(low.layers[f"slice.{k}"] - alone.layers[f"slice.{k}"]).max()
        if allowed:  # the high map's unit lobe times the low slice's own weight
            weight = np.asarray(fit.slices[k].lobes[0].weight, dtype=np.float32)
            assert np.array_equal(low.layers[f"slice.{k}"], high.unit_layers[(k, 0)] * weight)
            # Measured on forest.exr: 0.01-0.07 of the bound.
            assert difference <= 1.25 * w_low * error * brightest + 1e-6, k
        else:
            assert difference <= 2.5 * tolerance * w_low * brightest + 1e-6, k
    expected = {0.0: (0, 4), 0.5: (5, 14)}[share]
    assert expected[0] <= len(reused) <= expected[1], reused
    # A map of another size takes the companion's lobes resampled to its rows.
    other = prefilter.run_steps(prefilter.prefilter_steps(
        probe, low_spec, "3d", 24, layout="cube", companion=companion))
    assert other.meta["reused_slices"] == reused
    for name in reused:
        k = int(name.split(".")[0])
        weight = np.asarray(fit.slices[k].lobes[0].weight, dtype=np.float32)
        assert np.array_equal(other.layers[f"slice.{k}"],
                              resample_rows(high.unit_layers[(k, 0)], 24) * weight)
