"""The Runtime Sampling method through the add-on's operators, judged by glossy.validate
against Cycles (issue 11, item 4)."""

import pytest

from tests.blender.conftest import run_script

pytestmark = [pytest.mark.blender, pytest.mark.slow]


@pytest.fixture(scope="module")
def brushed(tmp_path_factory, hdri_dir):
    """One brushed sphere (GGX roughness 0.3, anisotropy 0.8, radial tangent about Z)
    in sunset.exr, captured, baked with Runtime Sampling (14 samples), attached and
    validated at 64 px (Cycles 2 x 64 spp, EEVEE 4 samples), after the bad-input
    checks."""
    work = tmp_path_factory.mktemp("runtime_method")
    return run_script("runtime_validate.py", hdri_dir / "sunset.exr", work, 64, 64, 4,
                      '[["Brushed", "runtime", 0.3, 0.8, 0.0]]', 1, work / "result.json",
                      timeout=900)


def test_a_brushed_sphere_is_at_most_half_native_eevees_error(brushed):
    """The acceptance's ordering on one small case. EEVEE renders the anisotropic lobe
    as isotropic GGX (measured 59% here, both with the scene's settings and with
    sun_threshold 0 and no clamp); the runtime estimate measured 20% (its 14-sample
    quadrature, 15% against the NumPy brute-force integral, plus Cycles' 64 spp
    noise, 4.9%). Half of native's error is the acceptance's bound."""
    assert brushed["Brushed"]["capture"] == brushed["Brushed"]["bake"] == \
        brushed["Brushed"]["attach"] == ["FINISHED"]
    assert brushed["Brushed"]["bake_path"].endswith("_runtime.exr")
    figures = brushed["Brushed"]["figures"]
    assert figures["truth"] == "cycles"
    methods = figures["methods"]
    native = min(methods[m]["relative_rms"] for m in ("eevee_native", "eevee_native_careful")
                 if m in methods)
    glossy = methods["eevee_glossy"]["relative_rms"]
    assert glossy <= 0.5 * native, methods
    # The NumPy brute-force reference (the radial tangent given to it) sits within
    # Cycles' own noise plus a few % of the Cycles mean: the validation measures the
    # lobe Cycles renders, not a differently oriented one (measured 9.2%, noise 4.9%).
    assert methods["reference"]["relative_rms"] < figures["cycles_noise"] + 0.06, methods


def test_bad_input_is_refused_or_falls_back_with_a_note(brushed):
    outcome, report = brushed["beckmann"]["bake"], brushed["reports"][0]
    assert outcome == ["CANCELLED"] and "GGX" in report and "Beckmann" in report, report
    assert brushed["beckmann"]["bake_path"] == ""
    assert not [name for name in brushed["beckmann"]["files"] if "Beckmann" in name]
    no_uv = brushed["no_uv"]
    assert no_uv["bake"] == no_uv["attach"] == ["FINISHED"]
    assert no_uv["tangents"] == [["RADIAL", "Z"]]
    assert "no UV map 'UVMap'" in no_uv["note"] and "radial about Z" in no_uv["note"]
