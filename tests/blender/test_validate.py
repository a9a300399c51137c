"""glossy.validate end to end: bad input, Esc, the report's figures recomputed from its
EXRs, the NumPy reference against Cycles, Glossy against native EEVEE, staleness."""

import json
from pathlib import Path

import numpy as np
import pytest

from bake import exr
from tests.blender.conftest import run_script
from tools.bpy_wheel import studio_lights

pytestmark = [pytest.mark.blender, pytest.mark.slow]

LUM = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module", params=["sunset.exr", "forest.exr"])
def validated(request, tmp_path_factory):
    work = tmp_path_factory.mktemp("validate")
    checks = request.param == "sunset.exr"
    # forest.exr through a close orthographic scene camera, sunset.exr through the
    # perspective one validation frames.
    camera = [] if checks else ["ortho"]
    result = run_script("validate_scene.py", studio_lights() / request.param,
                        int(checks), work, *camera, work / "r.json", timeout=900)
    folder = Path(result["folder"])
    report = json.loads((folder / "report.json").read_text())
    return request.param, result, folder, report


def _luminance(path):
    return exr.read(path)[0][..., :3].astype(np.float64) @ LUM


def test_bad_input_is_reported_and_esc_leaves_nothing(validated):
    hdri, result, _, _ = validated
    if hdri != "sunset.exr":
        pytest.skip("checked once")
    messages = set()
    for case in ("no_material", "not_baked", "not_attached"):
        outcome, message = result[case]
        assert outcome == ["CANCELLED"] and message.startswith("Error:"), (case, message)
        assert "Traceback" not in message
        messages.add(message)
    assert len(messages) == 3  # each case says what is wrong
    assert result["esc"] == {"restored": True, "report": False, "work_left": False}
    assert result["validate"] == [["FINISHED"], ""]
    assert result["restored"], (result["before"], result["after"])
    assert result["stored"]["fresh"] and result["stale_after_rebake"]
    assert result["stored"]["cause"] in ("bake", "probe", "noise", "mixed")  # the panel's line


def test_report_figures_recompute_from_the_written_exrs(validated):
    _, _, folder, report = validated
    masks, _ = exr.read(folder / "masks.exr", layers=True)
    seeds = [_luminance(folder / "cycles_seed1.exr"), _luminance(folder / "cycles_seed2.exr")]
    truth = 0.5 * (seeds[0] + seeds[1])
    glossy = _luminance(folder / "eevee_glossy.exr")
    checked = 0
    for entry in report["objects"]:
        mask = masks[entry["mask_layer"]][..., 0] > 0.5
        figures = entry["figures"]
        assert figures["pixels"] == int(mask.sum()) > 300
        if figures["truth"] != "cycles":
            continue
        t, r = glossy[mask], truth[mask]
        rms = np.sqrt(np.sum((t - r) ** 2) / np.sum(r**2))
        noise = np.sqrt(np.sum((seeds[0][mask] - seeds[1][mask]) ** 2) / 4 / np.sum(r**2))
        # Same sums in float64 over the same float32 pixels: agreement to rounding.
        assert figures["methods"]["eevee_glossy"]["relative_rms"] == pytest.approx(rms, rel=1e-9)
        assert figures["methods"]["eevee_glossy"]["bias"] == pytest.approx(t.mean() / r.mean(),
                                                                           rel=1e-9)
        assert figures["cycles_noise"] == pytest.approx(noise, rel=1e-9)
        # Where the error is: per band of n.v (the layer masks.exr keeps), the same sums.
        cos_view = masks["cos_view"][..., 0][mask].astype(np.float64)
        # A sphere: its centre faces the camera; a pixel inside its eroded silhouette at
        # 0.8 of its radius has n.v 0.6 (the spheres here are about 15 px across).
        assert cos_view.max() > 0.99 and cos_view.min() < 0.6
        bands = figures["methods"]["eevee_glossy"]["by_view"]
        assert sum(band["pixels"] for band in bands) == figures["pixels"]
        total = np.sum((t - r) ** 2)
        for band in bands:
            inside = (cos_view >= band["from"]) & (
                (cos_view < band["to"]) | (band["to"] == 1.0))
            assert band["pixels"] == int(inside.sum())
            assert band["error_share"] == pytest.approx(np.sum((t - r)[inside] ** 2) / total,
                                                        rel=1e-6, abs=1e-12)
        assert f"{entry['object']} by view elevation" in (folder / "report.md").read_text()
        # Where the error comes from: the bake against the reference, the reference
        # against Cycles less the noise in quadrature (bake.validation.diagnosis).
        # reference.exr holds the float64 reference as float32: agreement to 1e-6.
        reference = _luminance(folder / "reference.exr")[mask]
        found = figures["diagnosis"]
        bake = np.sqrt(np.sum((t - reference) ** 2) / np.sum(reference**2))
        probe = np.sqrt(max(np.sum((reference - r) ** 2) / np.sum(r**2) - noise**2, 0.0))
        assert found["bake"] == pytest.approx(bake, rel=1e-6)
        assert found["probe"] == pytest.approx(probe, rel=1e-6, abs=1e-12)
        parts = {"bake": bake, "probe": probe, "noise": noise}
        leaders = [k for k, v in parts.items()
                   if all(v >= 2 * o for key, o in parts.items() if key != k)]
        assert found["cause"] == (leaders[0] if leaders else "mixed")
        assert f"- {entry['object']}: {found['text']}" in (folder / "report.md").read_text()
        checked += 1
    assert checked == 1


def test_ward_is_measured_against_the_reference_only(validated):
    _, _, _, report = validated
    ward = next(e for e in report["objects"] if e["object"] == "Ward")
    assert ward["figures"]["truth"] == "reference"
    assert "eevee_native" not in ward["figures"]["methods"]
    assert any("Ward" in note and "NumPy reference only" in note for note in report["notes"])
    # Glossy's 3D map of a Ward lobe against the brute-force sum: a method error of a few %.
    assert ward["figures"]["methods"]["eevee_glossy"]["relative_rms"] < 0.1


def test_reference_agrees_with_cycles_and_glossy_beats_native(validated):
    hdri, _, _, report = validated
    shiny = next(e for e in report["objects"] if e["object"] == "Shiny")["figures"]
    noise = shiny["cycles_noise"]
    methods = shiny["methods"]
    native = min(methods[m]["relative_rms"] for m in ("eevee_native", "eevee_native_careful")
                 if m in methods)
    assert methods["eevee_glossy"]["relative_rms"] < native, (hdri, methods)
    # The acceptance bound: the reference's distance from the 2-seed Cycles mean
    # is its noise (the reference is noise-free) plus at most 1%. Measured on this
    # scene (/tmp experiments, stop 28): sunset 0.33% at 2 x 2048 spp (noise 0.20%),
    # 0.33% at 2 x 1024 (noise 0.54%), 1.9% at 2 x 256 (noise 1.1%).
    assert methods["reference"]["relative_rms"] < noise + 0.01, (hdri, noise, methods)
