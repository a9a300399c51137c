"""Specs read from users' node trees (glossy_addon.node_reader) against Cycles renders of
those same trees: Principled metals, plastics, coats, brushed anisotropy, Mix and Add,
and Metallic BSDFs (F82 Tint and Physical Conductor)."""

import numpy as np
import pytest

from bake import brdf
from tests.blender.conftest import run_script
from tests.blender.test_cycles_brdf import local_frame

pytestmark = [pytest.mark.blender, pytest.mark.slow]

#: Kinds whose value uses no table: single-scatter GGX / Beckmann with analytic
#: Fresnel, Lambert and the Fresnel node. Cycles agrees with these to float32
#: precision (CYCLES.md), so 1e-4 relative.
EXACT = {"rough_metal", "brushed", "mix_constant", "mix_fresnel", "metallic_f82", "conductor"}
#: The rest read Cycles' tabulated E(rough, mu) (32 x 32) or Fresnel blend s
#: (16^3, trilinear), which our integrals match to ~6e-4 (measured: at most
#: 5.8e-4 relative on these planes): 1.5e-3.
TABLED = 1.5e-3


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    work = tmp_path_factory.mktemp("cycles_principled")
    return run_script("cycles_principled.py", work, work / "r.json")


def test_the_reader_covers_the_kinds_a_user_builds(renders):
    kinds = {c["kind"]: c for c in renders["configs"]}
    assert len(kinds) == 16
    assert kinds["rough_metal"]["spec"].startswith("principled:")
    assert "metallic=1" in kinds["rough_metal"]["spec"]
    assert "multiscatter=1" in kinds["plastic"]["spec"]  # the node's distribution is read
    assert "multiscatter=0" in kinds["rough_metal"]["spec"]
    assert "roughness=0.3" in kinds["value_roughness"]["spec"]  # through the Value node
    assert kinds["mix_fresnel"]["spec"].startswith("fresnel_mix(ior=1.45;")
    assert kinds["mix_constant"]["spec"].startswith("sum(scale(k=0.6;")
    assert kinds["add"]["spec"].startswith("sum(")
    assert any("Tangent" in line for line in kinds["brushed"]["ignored"])
    assert all(not c["ignored"] for c in renders["configs"]
               if c["kind"] not in ("brushed", "metallic_brushed"))
    # The Metallic BSDF: F82 Tint is the Principled metal (Edge Tint as Specular
    # Tint); Physical Conductor carries n and k.
    assert "specular_tint=0.6/0.8/1" in kinds["metallic_f82"]["spec"]
    assert "multiscatter=0" in kinds["metallic_f82"]["spec"]
    assert "anisotropy=0.6" in kinds["metallic_brushed"]["spec"]
    assert "conductor_ior=2.757/2.513/2.231" in kinds["conductor"]["spec"]
    assert "conductor_extinction=3.983/2.385/1.603" in kinds["conductor_multi"]["spec"]


def test_sun_lamp_pixels_equal_the_derived_brdf(renders):
    checked = 0
    for sun in renders["suns"]:
        for config, pixel, spread in zip(renders["configs"], sun["mean"], sun["spread"],
                                         strict=True):
            frame = local_frame(config["normal_blender"], config["tangent"])
            wi = frame @ np.asarray(sun["direction"])
            wo = frame @ np.array([0.0, 0.0, 1.0])
            predicted = brdf.parse(config["spec"]).f(wi, wo) * max(wi[2], 0.0)
            assert max(spread) < 1e-4 * max(1.0, max(pixel))
            rtol = 1e-4 if config["kind"] in EXACT else TABLED
            np.testing.assert_allclose(pixel, predicted, rtol=rtol, atol=1e-6,
                                       err_msg=str(config))
            checked += predicted[0] > 1e-3
    assert checked >= 40


def test_white_furnace_equals_the_derived_albedo(renders):
    furnace = renders["furnace"]
    for config, mean, stderr, between in zip(renders["configs"], furnace["mean"],
                                             furnace["stderr"], furnace["seed_difference"],
                                             strict=True):
        frame = local_frame(config["normal_blender"], config["tangent"])
        wo = frame @ np.array([0.0, 0.0, 1.0])
        albedo = brdf.parse(config["spec"]).albedo(wo, 1 << 15)
        # 5 standard errors of 72 pixel means over two seeds, plus 1e-3 for the
        # quadratures and Cycles' tables (the layering weights read them).
        noise = np.maximum(stderr, np.asarray(between) / np.sqrt(2) / np.sqrt(36))
        assert np.all(np.abs(np.asarray(mean) - albedo) <= 5 * noise + 1e-3), \
            (config["kind"], mean, albedo, noise)
