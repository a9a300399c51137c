"""Glossy materials under Blender's lamps (issue 12): separable BRDF factors lit
by point, sun, spot and area lamps in EEVEE, against Cycles rendering the true
BSDF (the independent reference) and against EEVEE's own BSDF (native)."""

import numpy as np
import pytest

from bake import exr, metrics
from tests.blender.conftest import run_script
from tests.conftest import ROOT  # noqa: F401  (the repository on sys.path)

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def _image(path):
    image, _ = exr.read(path)
    return np.asarray(image, dtype=np.float64)


def test_every_lamp_kind_lights_the_factored_brdf_as_cycles_does(tmp_path):
    r = run_script("lamps_scene.py", tmp_path, "ggx:roughness=0.3", "point,sun,spot,area,textured",
                   256, 2, "half-difference", tmp_path / "r.json")
    assert r["truth"] is None
    assert r["lamp_set"] == [["area", "AREA SQUARE 4"], ["point", "POINT"], ["spot", "SPOT"],
                             ["sun", "SUN"]]
    assert [name for name, _ in r["skipped"]] == ["textured"]
    assert "node tree" in r["skipped"][0][1]
    assert {"Glossy Point Lamp v2", "Glossy Spot Lamp v2", "Glossy Sun Lamp v2",
            "Glossy Area Lamp v2", "Glossy Separable Half-Difference v1",
            "Glossy Spread Level v1", "Glossy Spread Texel v1"} <= set(r["groups"])
    first, second = (_image(p) for p in r["cycles"])
    mask = first[..., 3] > 0.999  # the sphere's pixels (film transparent)
    assert mask.sum() > 2000
    reference = (first[..., :3] + second[..., :3]) / 2
    noise = metrics.relative_rms(first[..., :3], second[..., :3], mask) / 2
    glossy = _image(r["glossy"])[..., :3]
    native = _image(r["native"])[..., :3]
    glossy_error = metrics.relative_rms(glossy, reference, mask)
    native_error = metrics.relative_rms(native, reference, mask)
    print(f"lamps: Glossy {glossy_error:.4f}, native EEVEE {native_error:.4f}, "
          f"Cycles noise {noise:.4f}, factor error {r['lamp_error']:.3f}")
    # Isotropic GGX: EEVEE renders it itself; the factored lamps must be within
    # 2 percentage points of that (the bound), the reference's noise
    # entering both errors.
    assert glossy_error <= native_error + 0.02 + noise
    # Wrong conversions (a missing 4 pi, a spot cone's cosine, an area lamp's
    # pi) change the image by 30% or more; the highlights sit where Cycles has them.
    assert abs(metrics.bias(glossy, reference, mask) - 1.0) < 0.05
    brightest = np.unravel_index(np.argmax(metrics.luminance(glossy) * mask), mask.shape)
    truth_brightest = np.unravel_index(np.argmax(metrics.luminance(reference) * mask),
                                       mask.shape)
    assert np.abs(np.subtract(brightest, truth_brightest)).max() <= 1
    # The point lamp moved after attach: the drivers follow it (no re-attach), in the
    # private node group this lookup's lamp terms went to (glossy_addon.nodes.PART_NODES).
    assert "point" in r["lamps_in_groups"]
    moved = metrics.relative_rms(_image(r["glossy_moved"])[..., :3],
                                 _image(r["truth_moved"])[..., :3], mask)
    assert moved <= glossy_error + 0.03 + 2 * noise
    # Lamp set changes: flagged, picked up by re-attach.
    assert r["changed_before"] is False and r["changed_after_adding"] is True
    assert r["changed_after_reattach"] is False and "late" in r["lamp_nodes"]
    assert "lamp factors: terms must be a whole number in [1, 16], not 0" in r["zero_terms"]
    assert r["files_unchanged"] is True
    # The NumPy reference the Ward case uses (BRDF library, the lamp conversions
    # written out in the script) agrees with Cycles here, where Cycles has the BSDF.
    truth = _image(r["numpy_truth"])[..., :3]
    assert metrics.relative_rms(truth, reference, mask) <= 0.02 + 2 * noise


def test_lamps_of_any_size_light_the_material_as_cycles_does(tmp_path):
    # A point lamp of radius 0.5, a sphere lamp of radius 0.4 (Soft Falloff off),
    # a 10-degree sun and a 1.2 x 0.6 rectangle (Size 1.2 x 0.4, the object
    # scaled 1.5 along Y) on a GGX 0.3 sphere.
    r = run_script("lamps_scene.py", tmp_path, "ggx:roughness=0.3",
                   "wide_point,wide_sphere,wide_sun,wide_area", 256, 2, "half-difference",
                   tmp_path / "r.json")
    assert r["lamp_set"] == [["wide_area", "AREA RECTANGLE 2"], ["wide_point", "POINT"],
                             ["wide_sphere", "POINT"], ["wide_sun", "SUN"]]
    first, second = (_image(p) for p in r["cycles"])
    mask = first[..., 3] > 0.999
    reference = (first[..., :3] + second[..., :3]) / 2
    noise = metrics.relative_rms(first[..., :3], second[..., :3], mask) / 2
    glossy = _image(r["glossy"])[..., :3]
    errors = {name: metrics.relative_rms(image, reference, mask) for name, image in (
        ("glossy", glossy), ("native", _image(r["native"])[..., :3]),
        ("twin", _image(r["twin"])[..., :3]), ("points", _image(r["twin_points"])[..., :3]))}
    print("wide lamps against Cycles:", {k: round(v, 4) for k, v in errors.items()},
          f"noise {noise:.4f}")
    # The material's nodes compute bake.lamp_term's arithmetic: EEVEE against
    # the NumPy twin at the pixels' hits differs by the mesh's interpolated
    # normals and single precision (measured 0.93%; 1.0-1.3% for the point
    # lamps' scene); the twin with every lamp as a point (the lamp term before
    # lamps had a size) is 36.2% away from it. Bound 2%.
    twin_error = metrics.relative_rms(glossy, _image(r["twin"])[..., :3], mask)
    assert twin_error <= 0.02
    # Against Cycles: within 2 points of native EEVEE (which integrates these
    # lamps itself) plus noise, as the point lamps' test (measured: Glossy
    # 4.9%, native 2.7%, noise 2.2%; without the sphere lamp 4.7%, 2.3%, 1.7%);
    # the point approximation is 35.1% away, asserted at least 4x worse.
    assert errors["glossy"] <= errors["native"] + 0.02 + noise
    assert errors["points"] >= 4 * errors["glossy"]
    # Resizing the area lamp is followed by the drivers; a new aspect that
    # needs another cell layout (3.0 x 0.63: 5 cells, not 2) asks for an attach.
    assert r["changed_before"] is False and r["changed_after_resizing"] is False
    assert r["changed_after_reshaping"] is True


def test_a_lamps_exposure_and_temperature_light_the_material_as_in_cycles(tmp_path):
    """Exposure 1 (twice the power) and a 3200 K Temperature (Color times an orange):
    before stop 53 the lamp term read Color and Power alone, a bias of about 0.5
    in luminance and a white highlight. Bounds of the first test: within 2 points
    of native EEVEE's error plus the noise, bias within 5%, and the highlight's
    colour (red over blue of the summed image) within 5% of Cycles'."""
    r = run_script("lamps_scene.py", tmp_path, "ggx:roughness=0.3", "warm", 128, 2,
                   "half-difference", tmp_path / "r.json")
    first, second = (_image(p) for p in r["cycles"])
    mask = first[..., 3] > 0.999
    reference = (first[..., :3] + second[..., :3]) / 2
    noise = metrics.relative_rms(first[..., :3], second[..., :3], mask) / 2
    glossy = _image(r["glossy"])[..., :3]
    glossy_error = metrics.relative_rms(glossy, reference, mask)
    native_error = metrics.relative_rms(_image(r["native"])[..., :3], reference, mask)
    print(f"warm lamp: Glossy {glossy_error:.4f}, native {native_error:.4f}, noise {noise:.4f}")
    assert glossy_error <= native_error + 0.02 + noise
    assert abs(metrics.bias(glossy, reference, mask) - 1.0) < 0.05
    tint = glossy[mask].sum(axis=0)
    truth_tint = reference[mask].sum(axis=0)
    assert truth_tint[0] > 3 * truth_tint[2]  # the Temperature's orange
    assert abs((tint[0] / tint[2]) / (truth_tint[0] / truth_tint[2]) - 1.0) < 0.05


def _errors(r, against_cycles):
    glossy = _image(r["glossy"])
    mask = glossy[..., 3] > 0.999
    if against_cycles:
        first, second = (_image(p)[..., :3] for p in r["cycles"])
        reference = (first + second) / 2
    else:
        reference = _image(r["numpy_truth"])[..., :3]
    return (metrics.relative_rms(glossy[..., :3], reference, mask),
            metrics.relative_rms(_image(r["native"])[..., :3], reference, mask))


@pytest.mark.parametrize("spec, against_cycles", [
    ("ggx:roughness=0.3,anisotropy=0.8", True),  # Cycles renders it; EEVEE as isotropic
    ("ward:ax=0.21,ay=0.048,ks=0.3,kd=1/0/0", False),  # the paper's Figure 10: no Cycles BSDF
])
def test_anisotropic_brdfs_under_lamps_beat_native_eevee_by_half(tmp_path, spec,
                                                                 against_cycles):
    """The issue's bound: at most half of native EEVEE's error, which renders
    anisotropic GGX as isotropic (native Ward: Blender's nearest anisotropic GGX
    with a diffuse part). Measured: 7.5% vs 110% (GGX), 8.7% vs 65% (Ward)."""
    r = run_script("lamps_scene.py", tmp_path, spec, "point,sun", 256, 2, "half-difference",
                   tmp_path / "r.json")
    glossy, native = _errors(r, against_cycles)
    print(f"{spec}: Glossy {glossy:.4f}, native {native:.4f}")
    assert glossy <= native / 2


def test_the_acceptance_scene_with_a_sun_has_its_highlight_where_cycles_has_it(tmp_path,
                                                                             hdri_dir):
    """#5's scene (GGX sphere with a Fresnel-blended diffuse part, Ward torus,
    forest.exr) with a sun added after nothing else changed: the sphere's
    brightest pixel in EEVEE with Glossy is where Cycles (true BSDF) has it."""
    r = run_script("sun_scene.py", tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["capture"] == ["FINISHED"] and r["truth_problem"] is None
    assert r["Sphere_lamps"] == [["sun", "SUN"]] and r["Torus_lamps"] == [["sun", "SUN"]]
    ids = _image(r["ids"])[..., 0]
    sphere = ids == 1
    cycles = sum(_image(p)[..., :3] for p in r["cycles"]) / 2
    glossy = _image(r["glossy"])[..., :3]

    def brightest(image):
        return np.unravel_index(np.argmax(metrics.luminance(image) * sphere), sphere.shape)

    peak = brightest(cycles)
    ratio = metrics.luminance(glossy)[peak] / metrics.luminance(cycles)[peak]
    print(f"sphere's brightest pixel: Glossy {brightest(glossy)}, Cycles {peak}, "
          f"Glossy/Cycles there {ratio:.3f}")
    # The sun's highlight outshines the sky's reflection; 1 px of the 96 px view
    # is the peak's jitter between two Cycles seeds here. Without the lamp term
    # the peak would be the sky's reflection, far dimmer (the ratio's bound).
    assert np.abs(np.subtract(brightest(glossy), peak)).max() <= 1
    assert 0.8 <= ratio <= 1.25
