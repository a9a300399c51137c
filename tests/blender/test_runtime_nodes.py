"""The runtime-sampling node tree renders what bake.sampling_runtime.shade computes (EEVEE)."""

import pytest

from tests.blender.conftest import run_script
from tests.conftest import ROOT

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_runtime_nodes_match_the_numpy_twin_for_an_anisotropic_lobe(tmp_path, hdri_dir):
    """Anisotropic GGX (Cycles' roughness 0.3, anisotropy 0.8, rotation 0.1) with
    Blender's radial tangent. EEVEE writes half floats (relative rounding up to
    4.9e-4) for the radiance and for the normal and tangent the twin is evaluated
    at; a frame off by ~1e-3 rad moves the 14 samples' lookups by as much, a few
    1e-3 on this map at most (measured: median 9e-4, p99 7.8e-3, max 1.4e-2)."""
    result = run_script("runtime_render.py", ROOT, tmp_path, hdri_dir / "forest.exr",
                        "ggx:roughness=0.3,anisotropy=0.8,rotation=0.1", tmp_path / "r.json")
    assert result["pixels"] > 1000
    assert result["mean_value"] > 0.1  # the sphere is lit: the comparison means something
    assert result["median"] < 3e-3
    assert result["p99"] < 2e-2
    assert result["max"] < 5e-2
    # The samples are a loop (two repeat zones), not unrolled: the graph and so the
    # shader's compile time do not grow with the sample count.
    small, large = result["graphs"]["budget"], result["graphs"]["large"]
    assert large["samples"] > 2 * small["samples"]
    assert large["nodes"] == small["nodes"] < 150
    for graph in (small, large):
        assert graph["iterations"] == [graph["samples"]] * 2


def test_runtime_nodes_match_the_numpy_twin_with_probe_lights(tmp_path, hdri_dir):
    """Isotropic GGX 0.3 in sunrise.exr with its sun taken out of the probe
    (bake.probe_lights) and four more lights added, of several extents (their
    widened alphas differ): the loop over the lights' atlas texels (the exact
    GGX term per light, scaled by rho / A_ss) renders what
    bake.sampling_runtime.light_radiance computes, to the half-float tolerances
    of the test above (the light term is smooth: a frame off by 1e-3 rad moves
    it by about as much)."""
    result = run_script("runtime_render.py", ROOT, tmp_path, hdri_dir / "sunrise.exr",
                        "ggx:roughness=0.3", "lights", tmp_path / "r.json")
    assert result["lights"] >= 5  # the sun and the added lights
    assert result["light_share"] > 0.1  # the lights are a visible part of the image
    assert result["light_peak"] > 1.0
    assert result["median"] < 3e-3
    assert result["p99"] < 2e-2
    assert result["max"] < 5e-2



@pytest.mark.parametrize("hdri, spec, lights", [
    ("forest.exr", "beckmann:roughness=0.3,anisotropy=0.8,rotation=0.1", False),
    ("sunrise.exr", "beckmann:roughness=0.3", True)])
def test_beckmann_nodes_match_the_numpy_twin(tmp_path, hdri_dir, hdri, spec, lights):
    """Cycles' Beckmann through GGX's visible normals, each sample weighed by
    Beckmann's D over GGX's and Cycles' rational Beckmann Lambda (anisotropic,
    as the first test above), and the lights' exact Beckmann term (isotropic,
    as the second): the nodes render what bake.sampling_runtime's twin computes,
    to the same half-float tolerances (measured: median 9e-4 / 1.1e-3, p99 9.4e-3
    / 1.6e-2, max 1.6e-2 / 3.1e-2). Not both at once: the anisotropic lobe's
    narrow axis (alpha about 0.03) makes its lights' highlight so sharp that the
    half-float normal the twin is evaluated at moves it by up to 10%."""
    result = run_script("runtime_render.py", ROOT, tmp_path, hdri_dir / hdri, spec,
                        *(["lights"] if lights else []), tmp_path / "r.json")
    assert result["mean_value"] > 0.1
    if lights:
        assert result["lights"] >= 5 and result["light_share"] > 0.1
    assert result["median"] < 3e-3
    assert result["p99"] < 2e-2
    assert result["max"] < 5e-2


def test_knot_lights_nodes_match_the_numpy_twin_at_every_pixel_s_roughness(tmp_path, hdri_dir):
    """Maps of a coloured metal at roughness knots 0.3 and 0.5 with the probe lights
    beside them (bake.knot_lights: sunrise.exr's sun and tiles taken out at the
    narrower knot, four more lights of several extents), the user's roughness 0.2-0.6
    across the sphere through a node chain: the lookup (each knot's map plus the
    lights' loop at the pixel's own alpha, scaled by that knot's rho / A_ss, then the
    geometric roughness blend) renders what bake.atlas.shade and
    bake.knot_lights.shade compute, to the half-float tolerances of the tests above
    (measured: median 1.0e-3, p99 6.1e-3, max 1.1e-2; the lights 80% of the image)."""
    result = run_script("knot_lights_render.py", tmp_path, hdri_dir / "sunrise.exr",
                        tmp_path / "r.json")
    assert result["pixels"] > 1000
    assert result["lights"] >= 5
    low, high = result["roughness"]
    assert low < 0.25 and high > 0.55  # below, between and above the knots
    assert result["light_share"] > 0.1 and result["light_peak"] > 1.0
    # This lookup (185 nodes) is split: the second knot's map and the lights' scale
    # went on in a private node group (glossy_addon.nodes.PART_NODES), its sockets
    # carried through the group's interface, and the pixels are the NumPy twin's all
    # the same (the figures below are those measured before the split).
    assert result["parts"] and result["root"] + sum(result["parts"]) > 150
    assert result["median"] < 3e-3
    assert result["p99"] < 2e-2
    assert result["max"] < 5e-2


def test_runtime_nodes_match_the_numpy_twin_on_a_stack_without_its_finest_levels(
        tmp_path, hdri_dir):
    """GGX 1 reads no level finer than 1 of the 32-row stack of a 16 px probe
    (bake.sampling_runtime.finest_level): its texture holds the stack from
    there, 16 rows, and the nodes, which take the texel's solid angle from the
    stored rows, read the same levels the twin does, to the half-float
    tolerances of the tests above."""
    result = run_script("runtime_render.py", ROOT, tmp_path, hdri_dir / "forest.exr",
                        "ggx:roughness=1", tmp_path / "r.json")
    assert (result["first_level"], result["slice_height"]) == (1, 16)
    assert result["mean_value"] > 0.1
    assert result["median"] < 3e-3
    assert result["p99"] < 2e-2
    assert result["max"] < 5e-2
