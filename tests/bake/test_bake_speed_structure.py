"""What makes bakes fast, checked for correctness: shared probe transforms, slices mixed
from a few filtered ones, steps per slice, the multi-scale filter, and the refusals
(memory, float16) that keep a fast bake from being a wrong one."""

import numpy as np
import pytest

from bake import atlas, envmap, lobes, prefilter, probe_maps, slice_basis
from bake.errors import BakeError
from bake.zonal import brute_force_convolve, zonal_convolve

LATLONG = envmap.get_layout("latlong")


@pytest.fixture(scope="module")
def probe(forest):
    return envmap.convert(forest, "latlong", "cube", 32)


def relative_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


def test_materials_of_one_probe_share_its_conversions_and_transforms(probe):
    """Three materials, then the same three again: the probe's lat-long maps and row
    spectra are made once per row count, and a second bake of the same probe content
    (another array with equal values) makes none."""
    probe_maps.clear_cache()
    specs = ["ggx:roughness=0.3", "ggx:roughness=0.5", "beckmann:roughness=0.4"]
    for spec in specs:
        prefilter.prefilter(probe, spec, "3d", "auto", slices=4)
    maps = probe_maps.probe_maps(probe, "cube")
    first = dict(maps.computed)
    assert first["maps"] == first["spectra"] == len(maps._maps)
    for spec in specs:
        prefilter.prefilter(probe.copy(), spec, "3d", "auto", slices=4)
    assert probe_maps.probe_maps(probe.copy(), "cube") is maps
    for kind in ("maps", "spectra", "filtered"):  # nothing made twice
        assert maps.computed[kind] == first[kind], kind


def test_a_bake_steps_after_the_fit_and_each_pair_of_slices(probe):
    steps = prefilter.prefilter_steps(probe, "ggx:roughness=0.4", "3d", 32, slices=6,
                                      threads=2)
    messages = []
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            baked = done.value
            break
        messages.append((fraction, message))
    filtered = len(baked.meta["filtered_slices"])
    assert messages[0][1] == "fitted the lobes"
    assert sum(m.startswith("filtered slice") for _, m in messages) == -(-filtered // 2)
    fractions = [f for f, _ in messages]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert len(baked.layers) == 6


def test_mixed_slices_match_filtering_every_slice(probe):
    """Slices made as mixes of filtered slices against each slice filtered on its own:
    within the mix tolerance (0.5% of the lobe's energy misplaced, a bound on the
    relative error for a non-negative environment)."""
    spec = "ggx:roughness=0.2"
    fit = lobes.fit(spec, slices=16)
    profiles = [s.lobes[0].profile for s in fit.slices]
    chosen, mixes, errors = slice_basis.choose(profiles, lobes.GAMMA)
    assert len(chosen) < len(profiles) and errors.max() <= slice_basis.TOLERANCE
    np.testing.assert_allclose(mixes.sum(axis=1), 1.0, atol=1e-12)  # energy kept
    baked = prefilter.prefilter(probe, fit, "3d", 48)
    maps = probe_maps.probe_maps(probe, "cube")
    for k in range(0, 16, 3):
        lobe = fit.slices[k].lobes[0]
        direct = prefilter._filter(maps, prefilter._profile_kernel(lobe.profile), 48)
        direct = direct * np.asarray(lobe.weight, dtype=np.float32)
        assert relative_rms(baked.layers[f"slice.{k}"], direct) < slice_basis.TOLERANCE, k


def test_multiscale_filter_matches_the_brute_force_sum_for_a_heavy_tailed_lobe(probe):
    """GGX 0.1's lobe (narrow core, tail across the sphere) on a 64-row map: tiers of
    annuli on grids halving in rows against the all-pairs sum over the same working
    map's texels (integrated 4 x 4 per texel): < 1% relative RMS."""
    fit = lobes.fit("ggx:roughness=0.1", slices=2)
    kernel = prefilter._profile_kernel(fit.slices[-1].lobes[0].profile)
    maps = probe_maps.probe_maps(probe, "cube")
    rows = 64
    ours = prefilter._filter(maps, kernel, rows)
    work = maps.latlong(rows)
    fine_shape = (4 * rows, 8 * rows)
    fine = LATLONG.sampler(work, spacing=None)(LATLONG.texel_directions(fine_shape))
    # The working map as texel boxes: each texel's value over its 4 x 4 sub-texels.
    boxes = np.repeat(np.repeat(work, 4, axis=0), 4, axis=1)
    del fine
    rng = np.random.default_rng(3)
    picks = rng.choice(rows * 2 * rows, 300, replace=False)
    r, c = np.unravel_index(picks, (rows, 2 * rows))
    targets = LATLONG.texel_directions((rows, 2 * rows))[r, c]
    reference = brute_force_convolve(LATLONG.texel_directions(fine_shape).reshape(-1, 3),
                                     boxes.reshape(-1, 3).astype(np.float64),
                                     LATLONG.solid_angles(fine_shape).reshape(-1), kernel,
                                     targets)
    assert relative_rms(ours[r, c], reference) < 0.01


def test_sub_sampling_near_the_centre_only_matches_sub_sampling_everywhere(probe):
    maps = probe_maps.probe_maps(probe, "cube")
    fit = lobes.fit("ggx:roughness=0.15", slices=2)
    kernel = prefilter._profile_kernel(fit.slices[-1].lobes[0].profile)
    work = maps.latlong(48)
    everywhere = zonal_convolve(work, kernel, supersample=3)
    near = zonal_convolve(work, kernel, supersample=3, supersample_radius=0.15)
    assert relative_rms(near, everywhere) < 2e-3


def test_a_map_beyond_memory_is_refused_before_anything_is_allocated(probe, monkeypatch):
    monkeypatch.setattr(prefilter, "available_memory", lambda: 2**30)
    with pytest.raises(BakeError, match=r"needs about [0-9.]+ GiB; 1\.0 GiB is available"):
        prefilter.prefilter(probe, "ggx:roughness=0.3", "3d", 2048, slices=16)
    assert prefilter.bake_memory(2048, 16) > 2**30


def test_a_probe_brighter_than_half_floats_keeps_a_32_bit_map(probe):
    """A sun of 1e6 (sunset-like HDRIs reach 1e5): the atlas holds values beyond 65504,
    so it is stored as 32-bit float, and the value survives; an ordinary one is half."""
    bright = probe.copy()
    bright[16, 16] = 1e6
    baked = prefilter.prefilter(bright, "ggx:roughness=0.05", "3d", 32, slices=3)
    image, _ = atlas.pack(baked)
    assert np.abs(image).max() > atlas.HALF_MAX and np.all(np.isfinite(image))
    assert atlas.storage_precision(image) == "float32"
    ordinary, _ = atlas.pack(prefilter.prefilter(probe, "ggx:roughness=0.3", "3d", 32,
                                                 slices=3))
    assert atlas.storage_precision(ordinary) == "half"


def test_auto_refuses_split_sum_and_reports_its_choice(probe):
    with pytest.raises(BakeError, match="needs a face size"):
        prefilter.prefilter(probe, "ggx:roughness=0.3", "split-sum", "auto")
    baked = prefilter.prefilter(probe, "ggx:roughness=0.3", "3d", "auto", slices=4,
                                max_size=24)
    assert baked.meta["size"] == 24 and "Max Map Size" in baked.meta["size_reason"]


@pytest.mark.parametrize("count", [1, 2, 7, 64, 1024])
def test_gauss_legendre_nodes_equal_numpys(count):
    from bake.zonal import gauss_legendre

    nodes, weights = gauss_legendre(count)
    expected_nodes, expected_weights = np.polynomial.legendre.leggauss(count)
    np.testing.assert_allclose(nodes, expected_nodes, atol=1e-14)
    # End weights are ~1e-6 for 1024 nodes: both rules agree there to ~1e-14 absolute.
    np.testing.assert_allclose(weights, expected_weights, rtol=1e-12, atol=5e-14)
    # The defining property: exact for polynomials of degree < 2n (even powers shown).
    for k in range(0, min(2 * count, 40), 2):
        assert weights @ nodes**k == pytest.approx(2.0 / (k + 1), rel=1e-12, abs=1e-14)


def test_a_lobe_filtered_once_serves_every_material_and_bake_with_its_shape(probe):
    """Two tints of one GGX roughness, and a diffuse part in two colours: the lobes'
    shapes are equal, so each is filtered once and the second material only reuses
    the maps (scaled by its own weights); the results equal separate bakes."""
    probe_maps.clear_cache()
    red = prefilter.prefilter(probe, "ggx:roughness=0.3,color=1/0.2/0.2", "3d", 32, slices=4)
    maps = probe_maps.probe_maps(probe, "cube")
    first = dict(maps.computed)
    blue = prefilter.prefilter(probe, "ggx:roughness=0.3,color=0.1/0.3/1", "3d", 32, slices=4)
    assert maps.computed["filtered"] == first["filtered"]
    assert maps.computed["reused"] - first["reused"] == len(blue.meta["filtered_slices"])
    probe_maps.clear_cache()
    alone = prefilter.prefilter(probe, "ggx:roughness=0.3,color=0.1/0.3/1", "3d", 32, slices=4)
    for name, layer in alone.layers.items():
        np.testing.assert_allclose(blue.layers[name], layer, rtol=1e-6, atol=1e-7)
    assert red.layers["slice.0"][..., 0].mean() > red.layers["slice.0"][..., 2].mean()
    grey = prefilter.prefilter(probe, "lambert:color=0.5", "irradiance", 16)
    before = maps_of(probe).computed["filtered"]
    green = prefilter.prefilter(probe, "lambert:color=0.1/0.9/0.1", "irradiance", 16)
    assert maps_of(probe).computed["filtered"] == before
    np.testing.assert_array_equal(grey.layers["irradiance"], green.layers["irradiance"])
    assert grey.meta["color"] != green.meta["color"]


def maps_of(image):
    return probe_maps.probe_maps(image, "cube")


@pytest.mark.parametrize(("width", "cols"), [(512, 12), (64, 33), (63, 9), (200, 60)])
def test_row_kernels_equal_the_direct_circular_sum(width, cols):
    """zonal.apply_row_kernels (a narrow kernel's real spectrum from the cosine table,
    a wide one's from an FFT) against the circular convolution written out: output
    row a at column j = sum over input rows b and offsets k of the kernel mirrored
    about k = 0 times input row b at column j - k. Float64 inputs; the result is
    float32, so agreement to 1e-6 of the largest value."""
    from bake.zonal import apply_row_kernels

    rng = np.random.default_rng(width + cols)
    rows, band, channels = 3, 5, 2
    half = rng.random((rows, band, cols))
    image = rng.random((band, width, channels))
    offsets = np.arange(width)
    kernel = np.zeros((rows, band, width))  # the whole even kernel over offsets 0..W-1
    for k in range(cols):
        kernel[:, :, k] = half[:, :, k]
        kernel[:, :, (width - k) % width] = half[:, :, k]
    direct = np.zeros((rows, width, channels))
    for j in range(width):
        shifted = image[:, (j - offsets) % width, :]  # (band, W, C): input at j - k
        direct[:, j, :] = np.einsum("abk,bkc->ac", kernel, shifted)
    spectrum = np.fft.rfft(image, axis=1).transpose(1, 0, 2)  # (F, B, C)
    narrow = apply_row_kernels(half, spectrum, width)
    padded = np.concatenate([half, np.zeros((rows, band, width // 2 + 1 - cols))], axis=2)
    wide = apply_row_kernels(padded, spectrum, width)  # all offsets: the FFT branch
    scale = np.abs(direct).max()
    assert np.abs(narrow - direct).max() < 1e-6 * scale
    assert np.abs(wide - direct).max() < 1e-6 * scale
    # normalized to a target integral: every output row's weights sum to it
    target = 2.5
    totals = kernel.sum(axis=(1, 2))
    rescaled = apply_row_kernels(half, spectrum, width, target)
    expected = direct * (target / totals)[:, None, None]
    assert np.abs(rescaled - expected).max() < 1e-6 * np.abs(expected).max()


@pytest.mark.parametrize("out_rows", [9, 17, 24])
@pytest.mark.parametrize("width", [0.15, 0.6])
def test_rows_filtered_as_the_mirror_of_the_north_match_the_direct_sum(out_rows, width):
    """zonal_convolve computes each chunk's kernel for the northern rows and applies it,
    reversed, to their mirror about the equator (odd row counts overlap at the
    middle row). On an image whose two hemispheres differ (a random field times a
    ramp from pole to pole), point-sampled (one sample per texel), every output
    row equals the direct sum over the input texels' centres of the same tabulated
    kernel, to float32 rounding: measured at most 9e-8 of the largest value (6e-7
    with 1 - cos gamma taken from a float32 cos before the haversine form, at
    width 0.15); bound 1e-5."""
    from bake.zonal import _Table

    rng = np.random.default_rng(11)
    shape = (24, 48)
    image = (rng.random((*shape, 3)) * np.linspace(0.1, 4.0, shape[0])[:, None, None])
    table = _Table(lambda c: np.exp((np.asarray(c) - 1.0) / width**2))
    ours = zonal_convolve(image.astype(np.float32), table, out_rows, normalize=False)
    targets = LATLONG.texel_directions((out_rows, shape[1]))  # the input's columns
    direct = brute_force_convolve(LATLONG.texel_directions(shape).reshape(-1, 3),
                                  image.reshape(-1, 3), LATLONG.solid_angles(shape).reshape(-1),
                                  table, targets, normalize=False)
    assert np.abs(ours - direct).max() < 1e-5 * np.abs(direct).max()


@pytest.mark.parametrize(("height", "rows"), [(48, 384), (24, 96), (24, 37), (40, 24)])
def test_resampling_rows_is_bilinear_in_latitude_and_periodic_longitude(height, rows):
    """probe_maps.resample_rows (integer upsampling in longitude by shifted slices,
    any other ratio by gathers) against np.interp, column by column in latitude
    (nodes: the row centres plus each pole holding the mean of its ring) and
    then row by row in longitude with period 2 pi: equal to float32 rounding."""
    rng = np.random.default_rng(height + rows)
    image = rng.random((height, 2 * height, 3)).astype(np.float32)
    ours = probe_maps.resample_rows(image, rows)
    assert ours.shape == (rows, 2 * rows, 3) and ours.dtype == np.float32
    nodes = np.concatenate([[0.0], np.pi * (np.arange(height) + 0.5) / height, [np.pi]])
    values = np.concatenate([image[:1].mean(axis=1, keepdims=True).repeat(2 * height, 1),
                             image, image[-1:].mean(axis=1, keepdims=True).repeat(2 * height, 1)])
    theta = np.pi * (np.arange(rows) + 0.5) / rows
    by_rows = np.stack([[np.interp(theta, nodes, values[:, j, c]) for c in range(3)]
                        for j in range(2 * height)], axis=1).transpose(2, 1, 0)  # (rows, W, 3)
    phi_in = 2 * np.pi * (np.arange(2 * height) + 0.5) / (2 * height)
    phi_out = 2 * np.pi * (np.arange(2 * rows) + 0.5) / (2 * rows)
    expected = np.stack([[np.interp(phi_out, phi_in, by_rows[i, :, c], period=2 * np.pi)
                          for c in range(3)] for i in range(rows)]).transpose(0, 2, 1)
    np.testing.assert_allclose(ours, expected, atol=1e-6)


def test_a_principled_brdf_solves_no_quadrature_per_evaluation(monkeypatch):
    """The Principled BSDF's Fresnel averages come from a cached 64-node Gauss-Legendre
    rule: evaluating it again (another material of the same IOR included) calls
    numpy's leggauss, an eigenvalue problem, not once (it did on every f(), 3.6 s of
    a From Material bake of eight materials); its values are the rule's own."""
    from bake import brdf
    from bake.brdf import fresnel
    from bake.brdf.principled import dielectric_hemispherical_average

    spec = "principled:metallic=0.5,roughness=0.3,coat_weight=0.5,coat_ior=1.7,ior=1.45"
    wi = np.array([[0.3, 0.1, 0.9]]) / np.linalg.norm([0.3, 0.1, 0.9])
    wo = np.array([[-0.2, 0.4, 0.8]]) / np.linalg.norm([-0.2, 0.4, 0.8])
    first = brdf.parse(spec).f(wi, wo)  # warms the caches
    calls = []
    original = np.polynomial.legendre.leggauss
    monkeypatch.setattr(np.polynomial.legendre, "leggauss",
                        lambda n: calls.append(n) or original(n))
    again = brdf.parse(spec).f(wi, wo)
    assert calls == []
    np.testing.assert_array_equal(again, first)
    nodes, weights = original(64)
    mu = 0.5 * (nodes + 1.0)
    assert dielectric_hemispherical_average(1.45) == pytest.approx(
        float(np.sum(weights * fresnel.dielectric(mu, 1.45) * mu)), rel=1e-13)


def test_a_residual_s_maps_are_its_probe_s_updated_near_its_lights(probe):
    """bake.probe_maps.residual_maps (what bake.world_lights.split_for makes for each
    lobe's residual): its lat-long maps, for the 3D map's filtering and for the
    runtime level stack, equal those of the same residual made on its own (1e-6 of
    the peak: float32 sums in another order), and are computed from the probe's."""
    from bake import probe_lights

    probe_maps.clear_cache()
    bright = probe.copy()
    bright[5, 40] = bright[20, 130] = 400.0  # two small lights, above the ladder's rungs
    residual, lights = probe_lights.extract_kept(bright, "cube", 0.09)
    assert lights and np.any(residual != bright)
    derived = probe_maps.residual_maps(residual, "cube", bright)
    assert derived.parent is probe_maps.probe_maps(bright, "cube")
    assert probe_maps.probe_maps(residual.copy(), "cube") is derived
    alone = probe_maps.ProbeMaps(residual, "cube")
    for rows in (16, 48, 64):
        expected = alone.latlong(rows)
        np.testing.assert_allclose(derived.latlong(rows), expected, rtol=0,
                                   atol=1e-6 * float(expected.max()))
        np.testing.assert_allclose(derived.plain(rows), envmap.convert(residual, "cube",
                                                                       "latlong", rows),
                                   rtol=0, atol=1e-6 * float(expected.max()))
    # At 48 and 64 rows the lights' neighbourhoods are small and the probe's
    # conversions are updated; at 16 rows they cover over half the map, which is
    # then converted on its own (the probe's conversion is not made for it).
    assert set(derived.parent._maps) == set(derived.parent._plain) == {48, 64}


def test_lobes_of_one_probe_share_its_bright_regions(probe, monkeypatch):
    """extract_kept for three lobes of one probe clusters each rung's bright texels
    once (bake.probe_lights._bright_regions), and gives what extract_for gives
    alone."""
    from bake import probe_lights

    probe_maps.clear_cache()
    bright = probe.copy()
    bright[5, 40] = bright[20, 130] = 400.0
    bright[10:14, 100:106] = 60.0  # a wide region: tiled, per lobe
    calls = []
    clusters = probe_lights._clusters

    def counted(ordered, directions, radius):
        calls.append(np.ndim(radius) == 0)  # one radius: the rung's clusters, not tiles
        return clusters(ordered, directions, radius)

    monkeypatch.setattr(probe_lights, "_clusters", counted)
    alphas = (0.04, 0.09, 0.25)
    kept = [probe_lights.extract_kept(bright, "cube", alpha) for alpha in alphas]
    rungs = sum(calls)
    monkeypatch.setattr(probe_lights, "_clusters", clusters)
    for alpha, (residual, lights) in zip(alphas, kept, strict=True):
        alone_residual, alone_lights = probe_lights.extract_for(bright, "cube", alpha)
        np.testing.assert_array_equal(residual, alone_residual)
        assert [light.to_json() for light in lights] == \
            [light.to_json() for light in alone_lights]
    calls.clear()
    monkeypatch.setattr(probe_lights, "_clusters", counted)
    for alpha in alphas:
        probe_lights.extract_for(bright, "cube", alpha)
    assert rungs < sum(calls)  # unshared, each lobe clusters its rungs again


def test_sub_sampled_weights_integrate_the_kernel_over_texels_up_to_the_poles():
    """zonal_convolve's sub-sampled weights (s in latitude, fewer in longitude where
    texels are thin: bake.zonal._SubGrid) against the kernel integrated over every
    input texel with 32 x 32 sub-samples, for a 3-degree Gaussian on 11.25-degree
    texels, at output rows next to both poles and in between. The midpoint rule's
    relative error is about (spacing / sigma)^2 / 24: 0.9% at s = 8 (1.4-degree
    spacing), 0.06% for the reference; the error must shrink with s and stay
    under 1%, the polar rows no worse than the rest."""
    height, width, n = 16, 32, 32
    image = np.random.default_rng(5).random((height, width, 1)).astype(np.float32) ** 3
    kappa = 1.0 / np.radians(3.0) ** 2

    def kernel(cos_gamma):
        return np.exp(kappa * (np.asarray(cos_gamma) - 1.0))

    y, x = np.mgrid[0:height * n, 0:width * n]
    sub = LATLONG.directions((x + 0.5) / n, (y + 0.5) / n, (height, width)).reshape(-1, 3)
    edges = np.cos(np.pi * np.arange(height * n + 1) / (height * n))
    omega = np.repeat((edges[:-1] - edges[1:]) * 2 * np.pi / (width * n), width * n)
    values = np.repeat(np.repeat(image[..., 0], n, 0), n, 1).reshape(-1) * omega
    rows = [0, 1, 2, 5, 8, 13, 14, 15]
    yy, xx = np.meshgrid(np.array(rows) + 0.5, np.arange(width) + 0.5, indexing="ij")
    centres = LATLONG.directions(xx, yy, (height, width)).reshape(-1, 3)
    truth = np.concatenate([kernel(centres[i:i + 16] @ sub.T) @ values
                            for i in range(0, len(centres), 16)]).reshape(len(rows), width)
    errors = {}
    for s in (2, 4, 8):
        got = zonal_convolve(image, kernel, supersample=s, normalize=False)[rows, :, 0]
        errors[s] = np.abs(got - truth) / np.abs(truth).max()
    assert errors[8].max() < errors[4].max() < errors[2].max()
    assert errors[8].max() < 0.01
    # Rows 0, 1, 14, 15 (thin texels, one longitude sub-step) against rows 5 and 8.
    assert errors[8][[0, 1, 6, 7]].max() <= errors[8][[3, 4]].max()
