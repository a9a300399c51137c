"""bake.metrics on images whose errors are known in closed form."""

import numpy as np
import pytest

from bake import metrics


def _scene(shape=(64, 96)):
    rng = np.random.default_rng(1)
    reference = rng.uniform(0.5, 2.0, (*shape, 3))
    mask = np.zeros(shape, dtype=bool)
    mask[8:-8, 10:-10] = True
    return reference, mask


def test_relative_rms_bias_and_psnr_of_known_distortions():
    reference, mask = _scene()
    grey = np.repeat(reference[..., :1], 3, axis=-1)  # luminance = the channel value
    # +-10% alternating: every pixel is off by 10%, the mean is not.
    sign = np.where(np.indices(mask.shape).sum(axis=0) % 2 == 0, 1.0, -1.0)[..., None]
    test = grey * (1.0 + 0.1 * sign)
    assert metrics.relative_rms(test, grey, mask) == pytest.approx(0.1, rel=1e-12)
    np.testing.assert_allclose(metrics.relative_rms(test, grey, mask, "rgb"), 0.1, rtol=1e-12)
    # A uniform 10% gain: RMS 0.1, bias 1.1.
    assert metrics.bias(1.1 * grey, grey, mask) == pytest.approx(1.1, rel=1e-12)
    assert metrics.relative_rms(1.1 * grey, grey, mask) == pytest.approx(0.1, rel=1e-12)
    # PSNR: an offset of 0.01 everywhere, peak = the reference's maximum.
    peak = grey[mask][:, 0].max()
    expected = 10 * np.log10(peak**2 / 0.01**2)
    assert metrics.psnr(grey + 0.01, grey, mask) == pytest.approx(expected, rel=1e-9)
    assert metrics.psnr(grey, grey, mask) == float("inf")


def test_only_masked_pixels_count_and_bad_input_is_refused():
    reference, mask = _scene()
    test = reference.copy()
    test[~mask] *= 100.0  # outside the mask: no effect
    assert metrics.relative_rms(test, reference, mask) == 0.0
    with pytest.raises(ValueError, match="no pixel"):
        metrics.relative_rms(test, reference, np.zeros_like(mask))
    with pytest.raises(ValueError, match="shape"):
        metrics.relative_rms(test[:-1], reference, mask)


def test_percentiles_of_a_known_error_distribution():
    reference, mask = _scene()
    grey = np.repeat(reference[..., :1], 3, axis=-1)
    count = int(mask.sum())
    errors = np.linspace(0.0, 0.5, count)  # uniform on [0, 0.5]
    test = grey.copy()
    test[mask] *= (1.0 + errors)[:, None]
    found = metrics.percentiles(test, grey, mask)
    for q in (50, 90, 99):
        assert found[f"p{q}"] == pytest.approx(np.percentile(errors, q), rel=1e-9)


def test_noise_of_mean_predicts_the_error_of_two_seeds():
    reference, mask = _scene((256, 256))
    rng = np.random.default_rng(7)
    a = reference + 0.2 * rng.standard_normal(reference.shape)
    b = reference + 0.2 * rng.standard_normal(reference.shape)
    predicted = metrics.noise_of_mean(a, b, mask)
    actual = metrics.relative_rms(0.5 * (a + b), reference, mask)
    # ~45000 pixels: the two estimates of one variance agree to about 1%.
    assert predicted == pytest.approx(actual, rel=0.03)


@pytest.mark.skipif(not metrics.flip_available(), reason="flip-evaluator not installed")
def test_flip_is_zero_for_identical_images_and_grows_with_distortion():
    reference, mask = _scene((96, 96))
    assert metrics.flip(reference, reference, mask) == pytest.approx(0.0, abs=1e-7)
    rng = np.random.default_rng(3)
    noise = rng.standard_normal(reference.shape)
    values = [metrics.flip(reference * (1 + s * noise).clip(0), reference, mask)
              for s in (0.02, 0.1, 0.4)]
    assert 0 < values[0] < values[1] < values[2] <= 1.0


def test_erode_drops_exactly_the_boundary():
    y, x = np.mgrid[0:41, 0:41]
    disc = (x - 20) ** 2 + (y - 20) ** 2 <= 15**2
    inner = metrics.erode(disc, 1)
    padded = np.pad(disc, 1)
    boundary = disc & ~(padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2]
                        & padded[1:-1, 2:])
    np.testing.assert_array_equal(inner, disc & ~boundary)
    assert metrics.erode(disc, 2).sum() < inner.sum()


def test_heatmaps_show_sign_and_size():
    reference, mask = _scene()
    test = reference.copy()
    test[:, :48] *= 1.3  # too bright on the left
    test[:, 48:] *= 0.7  # too dark on the right
    signed = metrics.signed_heatmap(test, reference, mask).astype(int)
    assert signed.dtype == np.int64 and signed.shape == (*mask.shape, 3)
    left, right = signed[32, 20], signed[32, 70]
    assert left[0] > left[2] and right[2] > right[0]
    absolute = metrics.absolute_heatmap(test, reference, mask)
    assert absolute[32, 20].sum() > 0 and np.all(absolute[~mask] == 64)
    figures = metrics.compare(test, reference, mask)
    assert 0.25 < figures["relative_rms"] < 0.35


def test_the_error_by_view_elevation_sits_in_the_band_that_holds_it():
    # A sphere's n.v seen head-on, orthographically: sqrt(1 - x^2 - y^2).
    reference, _ = _scene((64, 64))
    grey = np.repeat(reference[..., :1], 3, axis=-1)
    y, x = (np.indices((64, 64)) + 0.5) / 32.0 - 1.0
    cos_view = np.sqrt(np.clip(1.0 - x * x - y * y, 0.0, 1.0))
    mask = x * x + y * y < 1.0
    # A 20% error on the grazing ring only (n.v < 0.35), 5% where n.v >= 0.85.
    test = grey * np.where(cos_view < 0.35, 1.2, np.where(cos_view >= 0.85, 1.05, 1.0))[..., None]
    bands = metrics.by_view(test, grey, mask, cos_view)
    assert [(b["from"], b["to"]) for b in bands] == list(zip(metrics.VIEW_BANDS[:-1],
                                                              metrics.VIEW_BANDS[1:], strict=True))
    assert sum(b["pixels"] for b in bands) == mask.sum()
    t, r = test[mask][:, 0], grey[mask][:, 0]
    mu = cos_view[mask]
    for band in bands:
        inside = (mu >= band["from"]) & ((mu < band["to"]) | (band["to"] == 1.0))
        assert band["pixels"] == inside.sum() > 0
        expected = 0.2 if band["to"] <= 0.35 else 0.05 if band["from"] >= 0.85 else 0.0
        assert band["relative_rms"] == pytest.approx(expected, rel=1e-12, abs=1e-15)
        assert band["error_share"] == pytest.approx(
            np.sum((t - r)[inside] ** 2) / np.sum((t - r) ** 2), rel=1e-12, abs=1e-15)
    assert sum(b["error_share"] for b in bands) == pytest.approx(1.0, rel=1e-12)
    # n.v exactly 1 falls in the last band; a perfect match has no share anywhere.
    flat = np.ones((4, 4, 3))
    ones = metrics.by_view(flat, flat, np.ones((4, 4), bool), np.ones((4, 4)))
    assert ones[-1]["pixels"] == 16 and all(b["error_share"] == 0.0 for b in ones)
    with pytest.raises(ValueError, match="cos_view"):
        metrics.by_view(test, grey, mask, cos_view[:10])
