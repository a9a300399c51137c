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
    # The lobe is 25 times narrower across than along, about a texel of the 64 px
    # probe across: the reference integrates the probe's bilinear reconstruction
    # on a finer grid (bake.reference.reconstruction_factor), and the report says so.
    assert any("bilinear reconstruction" in note and "finer" in note
               for note in brushed["notes"]), brushed["notes"]


def test_bad_input_is_refused_or_falls_back_with_a_note(brushed):
    outcome, report = brushed["no_sampler"]["bake"], brushed["reports"][0]
    assert outcome == ["CANCELLED"] and "no sampler" in report and "ward" in report, report
    assert brushed["no_sampler"]["bake_path"] == ""
    assert not [name for name in brushed["no_sampler"]["files"] if "Ward" in name]
    no_uv = brushed["no_uv"]
    assert no_uv["bake"] == no_uv["attach"] == ["FINISHED"]
    assert no_uv["tangents"] == [["RADIAL", "Z"]]
    assert "no UV map 'UVMap'" in no_uv["note"] and "radial about Z" in no_uv["note"]


def test_auto_chooses_the_hybrid_only_for_an_isotropic_sampled_lobe(brushed):
    """glossy_addon.method_choice's rule, on each kind of BRDF: the Hybrid for an
    isotropic GGX or Beckmann lobe (a GGX BSDF, the default Principled BSDF, a
    Beckmann BSDF), Runtime Sampling for an anisotropic one, the 3D map for
    lobes the nodes cannot sample (Ward, a Principled BSDF with a coat), for a
    roughness texture and for a fixed map size too small for the runtime
    texture; a method set by hand is kept, with no reason shown; Runtime Sampling
    for a near-mirror GGX or Beckmann lobe."""
    choices = brushed["choices"]
    assert choices["ggx"][0] == choices["principled"][0] == choices["beckmann"][0] == "hybrid"
    assert "Beckmann" in choices["beckmann"][1]
    assert choices["ggx_anisotropic"][0] == "runtime"
    for label in ("ward", "principled_coat", "textured", "ggx_fixed_8"):
        assert choices[label][0] == "3d", (label, choices[label])
        assert choices[label][1].startswith("3D Map: "), choices[label]
    assert "roughness texture" in choices["textured"][1]
    assert "ward" in choices["ward"][1]
    for label in ("ggx", "ggx_anisotropic", "beckmann", "principled"):
        assert choices[f"{label}_set"] == ["3d", ""]
    # Near-mirror GGX and Beckmann (below 0.1, where the Hybrid's tables have no
    # row and Runtime Sampling measured below it: method_choice's module doc) get
    # Runtime Sampling, a GGX BSDF, a Principled metal and a Beckmann BSDF alike;
    # 0.1 itself and a colour texture that splits the map keep the Hybrid.
    assert choices["ggx_0.05"][0] == choices["metal_0.05"][0] == "runtime", choices
    assert choices["beckmann_0.05"][0] == "runtime", choices
    assert "near-mirror GGX" in choices["ggx_0.05"][1]
    assert "near-mirror Beckmann" in choices["beckmann_0.05"][1]
    for label in ("ggx_0.1", "metal_0.05_checker"):
        assert choices[label][0] == "hybrid", (label, choices[label])


@pytest.fixture(scope="module")
def auto_and_map(tmp_path_factory, hdri_dir):
    """One isolated sphere of GGX 0.3 in night.exr (small bright lamps, where the 3D
    map's grazing floor shows), through the camera that makes it fill the frame:
    once on the default method (Auto), once on the 3D map; each captured, baked,
    attached and validated at 64 px (Cycles 2 x 64 spp, EEVEE 4 samples), so
    both are measured on the same pixels against the same Cycles render."""
    results = {}
    for method in ("auto", "3d"):
        work = tmp_path_factory.mktemp(f"auto_method_{method}")
        results[method] = run_script(
            "runtime_validate.py", hdri_dir / "night.exr", work, 64, 64, 4,
            f'[["S", "{method}", 0.3, 0.0, 0.0]]', 0, 1, work / "result.json",
            timeout=900)["S"]
    return results


def test_the_default_method_bakes_the_hybrid_and_beats_the_3d_map(auto_and_map):
    """The default method of a GGX material is Auto, which bakes the Hybrid (its 3D
    map and runtime texture), and against Cycles it is below the 3D map alone.
    Measured at 128 px, Cycles 2 x 256 spp (README): 22.6% against 34.1%; here
    (64 px, 2 x 64 spp) 30.0% against 37.9%, with Cycles' noise at 9.6% in both
    (the same render). The bound asks for a tenth less than the 3D map's error:
    the measured gap is twice that, and every render involved is deterministic
    (fixed seeds), so only platform rounding moves it."""
    auto, plain = auto_and_map["auto"], auto_and_map["3d"]
    for entry in (auto, plain):
        assert entry["capture"] == entry["bake"] == entry["attach"] == ["FINISHED"], entry
    assert auto["method_used"] == "hybrid" and plain["method_used"] == "3d"
    assert auto["bake_path"].endswith("_hybrid.exr")
    assert auto["runtime_path"].endswith("_hybrid_runtime.exr")
    # A World Only probe of a world that has not changed since the capture: its
    # lights are measured on night.exr's own texels (bake.world_lights).
    assert "re-measured on the world's 512-row image" in auto["size_reason"], auto["size_reason"]
    errors = {name: entry["figures"]["methods"]["eevee_glossy"]["relative_rms"]
              for name, entry in auto_and_map.items()}
    assert errors["auto"] < 0.9 * errors["3d"], errors


@pytest.fixture(scope="module")
def beckmann(tmp_path_factory, hdri_dir):
    """Three isolated spheres of Cycles' Beckmann in sunset.exr: roughness 0.3 on the
    default method (Auto: the Hybrid) and on the 3D map (what Auto chose for
    Beckmann before runtime sampling took its lobe), and brushed (roughness 0.3,
    anisotropy 0.8, radial tangent about Z) on Runtime Sampling with 14 samples;
    captured, baked, attached and validated together at 64 px (Cycles 2 x 64 spp,
    EEVEE 4 samples)."""
    work = tmp_path_factory.mktemp("beckmann_method")
    return run_script("runtime_validate.py", hdri_dir / "sunset.exr", work, 64, 64, 4,
                      '[["Plain", "beckmann/auto", 0.3, 0.0, 0.0], '
                      '["Map", "beckmann/3d", 0.3, 0.0, 0.0], '
                      '["Brushed", "beckmann/runtime", 0.3, 0.8, 0.0, 14]]', 0,
                      work / "result.json", timeout=900)


def test_a_beckmann_material_is_sampled_at_runtime_and_beats_native_eevee(beckmann):
    """EEVEE renders Beckmann as GGX and an anisotropic lobe as an isotropic one;
    Glossy samples Beckmann's lobe through GGX's visible normals
    (bake.sampling_runtime). Auto bakes the Hybrid for the isotropic sphere (with
    its own table, bake/hybrid_errors_beckmann.json), which is below the 3D map
    Auto chose for Beckmann before; the brushed sphere is at most half of native
    EEVEE's error (the acceptance's bound for an anisotropic material).
    Measured in this three-sphere frame: Hybrid 3.7% against the 3D map's 4.7%,
    brushed 4.0% against native's 50.1%. (Against native on the isotropic
    sphere there is no margin to assert here: EEVEE's sun extraction shades
    sunset's sun as a lamp, 3.8%, and Cycles' 64 spp noise is most of both;
    at 128 px and 2 x 256 spp see docs/HISTORY.md "Stop 37".)"""
    for name in ("Plain", "Map", "Brushed"):
        entry = beckmann[name]
        assert entry["capture"] == entry["bake"] == entry["attach"] == ["FINISHED"], entry
    errors, natives = {}, {}
    for name in ("Plain", "Map", "Brushed"):
        methods = beckmann[name]["figures"]["methods"]
        errors[name] = methods["eevee_glossy"]["relative_rms"]
        natives[name] = min(methods[m]["relative_rms"] for m in ("eevee_native",
                                                                 "eevee_native_careful")
                            if m in methods)
    assert beckmann["Plain"]["method_used"] == "hybrid"
    assert beckmann["Plain"]["runtime_path"].endswith("_hybrid_runtime.exr")
    assert beckmann["Brushed"]["method_used"] == "runtime"
    assert errors["Plain"] < errors["Map"], (errors, natives)
    assert errors["Brushed"] <= 0.5 * natives["Brushed"], (errors, natives)
