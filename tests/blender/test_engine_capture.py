"""Probes captured with Cycles and with EEVEE agree with a resample of the world
image, in the bpy module (Blender 5.0) and in a blender executable (4.3, whose
EEVEE is called BLENDER_EEVEE_NEXT)."""

import json

import numpy as np
import pytest

from bake import exr
from tests.blender.conftest import SCRIPTS, run_blender, run_script

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def _box(image, k=4):
    h, w, c = image.shape
    return image.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))


def assert_captures_match_the_world(result):
    assert result["capture"] == ["FINISHED"]
    world, _ = exr.read(result["probes"]["world"])
    for engine in ("cycles", "eevee"):
        image, meta = exr.read(result["probes"][engine])
        assert image.shape == world.shape == (32, 192, 3)
        # The world resample averages each texel's solid angle exactly; a Cycles
        # render filters with its pixel filter (1.5 px Blackman-Harris, 16 spp).
        # On 4 x 4 texel blocks those differences fall to ~1-2 % (median) in
        # forest.exr's foliage; a face turned or mirrored gives ~85 %. An EEVEE
        # capture composites this same resample behind the scene (here empty),
        # so its faces' orientation is tested with an object in front
        # (test_capture_probes: an EEVEE capture composites the world).
        relative = np.abs(_box(image) - _box(world)) / np.maximum(_box(world), 1e-3)
        assert np.median(relative) < 0.04, (engine, np.median(relative))
        assert abs(image.mean() / world.mean() - 1.0) < 0.03, engine
        mirrored = np.abs(_box(image[:, ::-1]) - _box(world)) / np.maximum(_box(world), 1e-3)
        assert np.median(mirrored) > 0.3


def test_engines_in_the_bpy_module(extension_zip, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    r = run_script("engine_capture.py", extension_zip, tmp_path, tmp_path / "r.json",
                   user_dir=user)
    assert_captures_match_the_world(r)


def test_engines_in_a_blender_executable(blender_executable, installed, tmp_path):
    run_blender(blender_executable, "--background", "--python", SCRIPTS / "engine_capture.py",
                "--", tmp_path, tmp_path / "r.json", user_dir=installed)
    assert_captures_match_the_world(json.loads((tmp_path / "r.json").read_text()))
