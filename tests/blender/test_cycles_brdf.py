"""bake.brdf's GGX, Beckmann and Ashikhmin-Shirley against Cycles renders of the Glossy BSDF."""

import numpy as np
import pytest

from bake import brdf
from tests.blender.conftest import run_script

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def local_frame(normal, tangent):
    """Cycles' shading frame: Y = normalize(n x T), X = Y x n."""
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    y = np.cross(n, tangent)
    y /= np.linalg.norm(y)
    return np.stack([np.cross(y, n), y, n])


def model_of(config):
    common = (f"roughness={config['roughness']},anisotropy={config['anisotropy']},"
              f"rotation={config['rotation']}")
    if config["distribution"] == "principled_metallic":
        colors = "base_color={},specular_tint={}".format(
            *("/".join(map(str, config[key])) for key in ("base_color", "specular_tint")))
        return brdf.parse(f"principled_metallic:{common},{colors}")
    return brdf.parse(f"{config['distribution']}:{common}")


def tolerance(config):
    """Relative tolerance of a prediction (see the tests' comments)."""
    # Multiscatter GGX divides by E(cos theta_o): Cycles reads E from its own
    # 32 x 32 table, which differs from the exact integral by up to ~6e-4
    # (CYCLES.md), i.e. ~1e-3 relative where E ~ 0.6.
    return 2e-3 if config["distribution"] == "ggx_multiscatter" else 1e-4


@pytest.fixture(scope="module")
def renders(tmp_path_factory):
    work = tmp_path_factory.mktemp("cycles_glossy")
    return run_script("cycles_glossy.py", work, work / "r.json")


def test_sun_lamp_pixels_equal_f_times_cosine(renders):
    checked = 0
    for sun in renders["suns"]:
        for config, pixel, spread in zip(renders["configs"], sun["mean"], sun["spread"],
                                         strict=True):
            frame = local_frame(config["normal_blender"], config["tangent"])
            wi = frame @ np.asarray(sun["direction"])
            wo = frame @ np.array([0.0, 0.0, 1.0])
            predicted = model_of(config).f(wi, wo) * max(wi[2], 0.0)
            # A delta sun has no sampling noise: the pixels of a plane agree to
            # float32 rounding (spread), and the BRDF to the same relative
            # precision; 1e-4 covers float32 accumulation in Cycles' kernel.
            assert max(spread) < 1e-4 * max(1.0, max(pixel))
            np.testing.assert_allclose(pixel, predicted, rtol=tolerance(config), atol=1e-6,
                                       err_msg=str(config))
            checked += predicted[0] > 1e-3
    assert checked >= 25  # most planes sit in a visible highlight


def test_white_furnace_pixels_equal_directional_albedo(renders):
    furnace = renders["furnace"]
    for config, mean, stderr, between in zip(renders["configs"], furnace["mean"],
                                             furnace["stderr"], furnace["seed_difference"],
                                             strict=True):
        frame = local_frame(config["normal_blender"], config["tangent"])
        wo = frame @ np.array([0.0, 0.0, 1.0])
        albedo = model_of(config).albedo(wo, 1 << 14)
        # Render noise measured per plane: standard error of 72 pixel means
        # over two seeds; 5 sigma, plus 1e-3 for our albedo's own quadrature
        # (and Cycles' E table for multiscatter, whose white albedo is ~1).
        noise = np.maximum(stderr, np.asarray(between) / np.sqrt(2) / np.sqrt(36))
        slack = 1e-3 + (2e-3 if config["distribution"] == "ggx_multiscatter" else 0.0)
        assert np.all(np.abs(np.asarray(mean) - albedo) <= 5 * noise + slack), \
            (config, mean, albedo, noise)
