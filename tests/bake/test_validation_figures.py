"""bake.validation's per-seed figures and ordering verdict, against the sums
written out on synthetic images."""

import numpy as np
import pytest

from bake import validation

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def _images(seed=0, shape=(24, 32)):
    rng = np.random.default_rng(seed)
    truth = rng.uniform(0.5, 2.0, (*shape, 3))
    noise = 0.05
    a = truth * (1.0 + noise * rng.standard_normal((*shape, 3)))
    b = truth * (1.0 + noise * rng.standard_normal((*shape, 3)))
    mask = np.zeros(shape, bool)
    mask[2:-2, 3:-3] = True
    return truth, a, b, mask


def _relative_rms(test, reference, mask):
    t, r = test[mask] @ LUMINANCE, reference[mask] @ LUMINANCE
    return np.sqrt(np.sum((t - r) ** 2) / np.sum(r ** 2))


def test_per_seed_figures_are_the_relative_rms_against_each_seed():
    truth, a, b, mask = _images()
    glossy = truth * 1.03
    figures = validation.evaluate_object({"eevee_glossy": glossy, "reference": truth}, mask,
                                         (a, b))
    per_seed = figures["methods"]["eevee_glossy"]["relative_rms_per_seed"]
    assert per_seed == [_relative_rms(glossy, a, mask), _relative_rms(glossy, b, mask)]
    # Without Cycles the reference is the truth and there is no per-seed figure.
    alone = validation.evaluate_object({"eevee_glossy": glossy, "reference": truth}, mask)
    assert "relative_rms_per_seed" not in alone["methods"]["eevee_glossy"]


def test_ordering_holds_on_both_seeds_when_the_gap_is_above_the_noise():
    truth, a, b, mask = _images(1)
    close = validation.evaluate_object({"eevee_glossy": truth * 1.01, "reference": truth},
                                       mask, (a, b))
    far = validation.evaluate_object({"eevee_glossy": truth * 1.2, "reference": truth},
                                     mask, (a, b))
    verdict = validation.ordering(close, far)
    assert verdict == {"mean": True, "per_seed": [True, True], "reference": True,
                       "decided_by_noise": False}
    assert validation.ordering(far, close)["mean"] is False


def test_ordering_is_decided_by_noise_when_each_method_sits_on_one_seed():
    # Each "method" equals one seed's render: against that seed it is exact, against
    # the other it carries both seeds' noise, so the order flips with the seed; the
    # noise-free reference (the truth itself) cannot tell them apart by more than
    # their own noise, and the mean of the seeds sees them equally far.
    truth, a, b, mask = _images(2)
    first = validation.evaluate_object({"eevee_glossy": a, "reference": truth}, mask, (a, b))
    second = validation.evaluate_object({"eevee_glossy": b, "reference": truth}, mask, (a, b))
    verdict = validation.ordering(first, second)
    assert verdict["per_seed"] == [True, False]
    assert verdict["decided_by_noise"] is True
    expected = _relative_rms(a, truth, mask) < _relative_rms(b, truth, mask)
    assert verdict["reference"] is bool(expected)


def test_the_pixels_that_decide_an_order_are_counted():
    # Grey images (luminance = the value). ``first`` is 0.01 off on all 1000 pixels
    # (squared error 0.1 in all); ``second`` is exact but for three pixels 0.1**0.5
    # off (0.3 in all): ``first`` is closer by 0.2. Leaving out two of the three
    # still leaves ``first`` closer (0.0998 against 0.1); leaving out all three
    # reverses the order: three pixels decide it. Either way round the count is the same.
    truth = np.ones((20, 50, 3))
    mask = np.ones((20, 50), bool)
    first = truth + 0.01
    second = truth.copy()
    second[3, [4, 17, 30]] += np.sqrt(0.1)
    assert validation.deciding_pixels(first, second, truth, mask) == (3, 1000)
    assert validation.deciding_pixels(second, first, truth, mask) == (3, 1000)
    # A gap spread over the whole surface takes most of the pixels to reverse.
    assert validation.deciding_pixels(truth * 1.01, truth * 1.02, truth, mask)[0] > 700
    # Pixels outside the mask do not count: without the three, ``second`` is exact
    # and closer on every pixel left, so all of them decide it. Equal renders are level.
    inside = mask.copy()
    inside[3, [4, 17, 30]] = False
    assert validation.deciding_pixels(first, second, truth, inside) == (997, 997)
    assert validation.deciding_pixels(first, first, truth, mask) == (0, 1000)


def test_by_view_figures_are_reported_per_method_and_tabulated():
    truth, a, b, mask = _images()
    cos_view = np.linspace(0.0, 1.0, mask.size).reshape(mask.shape)
    glossy = truth * np.where(cos_view < 0.1, 1.5, 1.0)[..., None]  # wrong at the rim only
    figures = validation.evaluate_object({"eevee_glossy": glossy, "reference": truth}, mask,
                                         (a, b), cos_view)
    bands = figures["methods"]["eevee_glossy"]["by_view"]
    # Against Cycles' noisy mean (5% per seed) the other bands hold the noise's share.
    assert bands[0]["error_share"] > 0.5
    assert bands[0]["error_share"] == max(band["error_share"] for band in bands)
    # Against the noise-free reference the rim holds all of Glossy's error.
    reference_bands = figures["glossy_vs_reference"]["by_view"]
    assert reference_bands[0]["error_share"] == pytest.approx(1.0, rel=1e-12)
    assert reference_bands[0]["relative_rms"] > 0.49
    assert all(band["relative_rms"] == 0.0 for band in reference_bands[1:])
    report = {"date": "today", "resolution": [32, 24], "cycles_samples": 4, "eevee_samples": 1,
              "objects": [{"object": "Sphere", "material": "M", "brdf": "ggx:roughness=0.3",
                           "figures": figures}]}
    text = validation.markdown(report)
    assert "Sphere by view elevation" in text
    assert "| 0.00-0.10 |" in text and "(100%)" in text
    # Without n.v there is no such table.
    plain = validation.evaluate_object({"eevee_glossy": glossy, "reference": truth}, mask,
                                       (a, b))
    assert "by_view" not in plain["methods"]["eevee_glossy"]
    assert "by view" not in validation.markdown({**report, "objects": [
        {**report["objects"][0], "figures": plain}]})


def test_the_cause_of_glossy_s_error_is_named_from_the_reference_and_the_noise():
    """diagnosis against figures computed here: each synthetic case makes one part
    ten times the others (Cycles' noise 5% per seed, so 3.5% in the mean), and the
    part named must be that one; where two parts are alike it says so."""
    truth, a, b, mask = _images(3)
    rng = np.random.default_rng(4)
    wave = 1.0 + 0.5 * np.sin(np.arange(truth.shape[1]) / 3.0)[None, :, None]
    scene = truth * wave  # a structured departure: what one probe cannot hold
    noise = validation.evaluate_object({"eevee_glossy": truth, "reference": truth}, mask,
                                       (a, b))["cycles_noise"]

    def figures(glossy, reference):
        return validation.evaluate_object({"eevee_glossy": glossy, "reference": reference},
                                          mask, (a, b))

    # The reference far from Cycles, Glossy on the reference: the probe.
    found = figures(scene * 1.001, scene)["diagnosis"]
    assert found["cause"] == "probe"
    assert found["bake"] == pytest.approx(_relative_rms(scene * 1.001, scene, mask))
    assert found["probe"] == pytest.approx(np.sqrt(
        _relative_rms(scene, 0.5 * (a + b), mask) ** 2 - noise**2))
    assert found["noise"] == noise
    assert "what one probe cannot hold" in found["text"]
    # Glossy far from a reference that sits on the truth: the bake.
    bake = figures(scene, truth)["diagnosis"]
    assert bake["cause"] == "bake" and "the bake's own error" in bake["text"]
    assert bake["probe"] < 0.5 * noise  # the reference's figure is Cycles' noise alone
    # Both on the truth (the reference exactly, Glossy within 0.2%): the noise.
    glossy = truth * (1.0 + 0.002 * rng.standard_normal(truth.shape))
    assert figures(glossy, truth)["diagnosis"]["cause"] == "noise"
    # The bake and the probe alike: no single cause.
    mixed = figures(scene * wave, scene)["diagnosis"]
    assert mixed["cause"] == "mixed"
    assert 0.5 < mixed["bake"] / mixed["probe"] < 2.0
    # Reported: one line per object in report.md, one on the sheet.
    report = {"date": "today", "resolution": [32, 24], "cycles_samples": 4, "eevee_samples": 1,
              "objects": [{"object": "Suzanne", "material": "M", "brdf": "ggx:roughness=0.3",
                           "figures": figures(scene * 1.001, scene)}]}
    assert f"- Suzanne: {found['text']}" in validation.markdown(report)
    assert any(line.startswith("Cause: probe (bake 0.1%")
               for line in validation._figure_lines(report["objects"][0]["figures"], "S"))
    # Without a Cycles truth there is nothing to split.
    assert validation.diagnosis(validation.evaluate_object(
        {"eevee_glossy": scene, "reference": truth}, mask)) is None
