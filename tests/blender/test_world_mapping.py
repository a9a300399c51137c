"""World Only probes follow the world's Mapping node and Background Strength, as
Cycles renders them (tests/blender/scripts/world_mapping.py), decode 8-bit sRGB
images, see through the
"camera sees a plain colour" Mix Shader (a Cycles capture too), and a world they cannot reproduce is
refused with one message and no file."""

import numpy as np
import pytest

from bake import exr
from tests.blender.conftest import run_script
from tests.blender.test_engine_capture import _box

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def _median_relative(image, truth):
    return float(np.median(np.abs(_box(image) - _box(truth)) / np.maximum(_box(truth), 1e-3)))


def test_world_only_probes_match_cycles_for_turned_and_brightened_worlds(extension_zip,
                                                                         tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    r = run_script("world_mapping.py", extension_zip, tmp_path, tmp_path / "r.json",
                   user_dir=user)
    plain_world, _ = exr.read(r["variants"]["plain"]["probes"]["world"])
    for variant, found in r["variants"].items():
        assert found["capture"] == ["FINISHED"], variant
        cycles, _ = exr.read(found["probes"]["cycles"])
        world, meta = exr.read(found["probes"]["world"])
        assert meta["world_mapping"]["vector_type"] in ("POINT", "TEXTURE"), variant
        # Same tolerances as test_engine_capture (4 x 4 texel blocks: a render's
        # pixel filter against the resample's exact texel mean, ~1-2% in sunset's
        # sky; a face turned or the strength wrong gives 30-150%). The mean is
        # looser than there (5%): sunset's sun, a few texels of 16 spp, carries a
        # large share of it.
        assert _median_relative(world, cycles) < 0.04, variant
        assert abs(world.mean() / cycles.mean() - 1.0) < 0.05, variant
        if variant in ("plain", "muted", "hidden"):  # the image as loaded (a muted
            np.testing.assert_array_equal(world, plain_world)  # Mapping passes it on)
        else:  # the image as it is (what World Only made before) is wrong
            assert _median_relative(plain_world, cycles) > 0.2, variant
    # Export Environment writes the world as it renders: the tilted world's export
    # is its World Only probe, texel for texel, and records the mapping.
    exported, meta = exr.read(r["export"]["path"])
    assert r["export"]["status"] == ["FINISHED"]
    np.testing.assert_array_equal(exported, exr.read(r["variants"]["tilted"]["probes"]["world"])[0])
    assert meta["world_mapping"]["strength"] == pytest.approx(2.5)
    # A Hybrid's lights are measured on the world's own texels while the world is
    # the one captured (the digest and Mapping in the probe's header), on the
    # probe's once it is turned, and the bake says so.
    lit = r["world_lights"]
    assert lit["capture"] == lit["bake"] == lit["turned_bake"] == ["FINISHED"], lit
    assert "re-measured on the world's 512-row image" in lit["reason"], lit["reason"]
    assert "the world changed since the capture" in lit["turned_reason"], lit["turned_reason"]
    # The Mapping turned back: the world is the captured one again; then its image's
    # pixels edited in Blender: changed, though its file and name are not.
    assert lit["restored_bake"] == lit["edited_bake"] == ["FINISHED"], lit
    assert "re-measured on the world's 512-row image" in lit["restored_reason"], \
        lit["restored_reason"]
    assert "the world changed since the capture" in lit["edited_reason"], lit["edited_reason"]
    # An 8-bit sRGB image is decoded as Cycles decodes it: its blue channel is
    # 128/255 everywhere, 0.2158 in linear light (0.502 as stored).
    png = r["png"]
    assert png["capture"] == ["FINISHED"]
    cycles, _ = exr.read(png["probes"]["cycles"])
    world, _ = exr.read(png["probes"]["world"])
    np.testing.assert_allclose(world[..., 2], 0.2158, atol=2e-3)
    np.testing.assert_allclose(world.mean(axis=(0, 1)), cycles.mean(axis=(0, 1)), rtol=0.03)
    # Behind a Mix Shader driven by Is Camera Ray, the rays a probe stands for see
    # the turned HDRI: both captures give the turned world's probes (the Cycles
    # one showed the camera's grey, 0.2, before), and the world is left as it was.
    trick = r["camera_trick"]
    assert trick["capture"] == ["FINISHED"]
    turned = {kind: exr.read(path)[0]
              for kind, path in r["variants"]["turned"]["probes"].items()}
    np.testing.assert_array_equal(exr.read(trick["probes"]["world"])[0], turned["world"])
    trick_cycles, _ = exr.read(trick["probes"]["cycles"])
    assert _median_relative(trick_cycles, turned["cycles"]) < 0.01
    assert trick["fac_still_linked"] and trick["fac_default"] == pytest.approx(0.5)
    # The probe shows what reflections see: the world hidden from the camera is
    # in it (the assertions above: a black probe before), and of two emitting
    # cubes (strength 100) the one only reflections see is in it, the one only
    # the camera sees is not; both keep their own visibility after.
    visibility = r["visibility"]
    assert visibility["capture"] == ["FINISHED"]
    seen, _ = exr.read(visibility["probes"]["cycles"])
    plain_cycles, _ = exr.read(r["variants"]["plain"]["probes"]["cycles"])
    n = seen.shape[0]
    faces = {name: seen[:, k * n:(k + 1) * n]
             for k, name in enumerate(("+x", "-x", "+z", "-z", "-y", "+y"))}
    # The glossy-only cube (emission strength 100, white) covers the middle ninth of
    # the +X face: the texels there are its radiance (texel averages since stop 59;
    # the world's sun may be brighter than 100 in a texel, so no maximum is compared).
    middle = faces["+x"][n // 2 - 2:n // 2 + 2, n // 2 - 2:n // 2 + 2]
    np.testing.assert_allclose(middle, 100.0, rtol=0.02)
    # The point lamp at +Y (1000 W, radius 0.25) stays out: lamps are shaded by
    # the lamp path (glossy_addon.lamps), so in the probe they would count twice.
    np.testing.assert_allclose(faces["+y"].max(), plain_cycles[:, 5 * n:].max(), rtol=0.1)
    assert faces["+x"].mean() > 10 * plain_cycles[:, :n].mean()  # the glossy-only cube
    assert _median_relative(faces["-x"], plain_cycles[:, n:2 * n]) < 0.04  # camera-only
    assert visibility["restored"] == [[False, True], [True, False]]
    refused = r["refused"]
    assert refused["outcome"] == ["ERROR"]
    assert "Hue/Saturation/Value" in refused["message"]
    assert "Render Scene" in refused["message"]
    assert refused["probe_path"] == ""
    assert not (tmp_path / "glossy" / "refused_probe.exr").exists()
