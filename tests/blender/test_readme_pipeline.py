"""The README's headless pipeline, run through the bpy module with the
extension installed from its zip (test_blender_executable.py runs the same
block in a ``blender`` executable)."""

import json

import numpy as np
import pytest

from tests.blender.conftest import run_script
from tests.blender.lookup_check import assert_matches_shade
from tests.blender.readme import pipeline_expressions

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_readme_lines_in_the_bpy_module(extension_zip, tmp_path):
    user = tmp_path / "user"
    user.mkdir()
    expressions = tmp_path / "expressions.json"
    expressions.write_text(json.dumps(pipeline_expressions()))
    r = run_script("readme_in_bpy.py", extension_zip, tmp_path, expressions,
                   tmp_path / "r.json", user_dir=user)
    assert r["install"] == ["FINISHED"]
    written = sorted(p.name for p in (tmp_path / "glossy").iterdir())
    assert "forest_cube256.exr" in written
    assert {"Sphere_probe.exr", "Torus_probe.exr", "Sphere_Sphere_glossy_3d.exr",
            "Torus_Torus_glossy_2d.exr"} <= set(written)
    views = r["views"]
    assert views["node_groups"] == {"Glossy Slice Blend v1": 3, "Glossy Atlas Taps v1": 7}
    for name, maps in views["atlases"].items():
        np.testing.assert_allclose(maps["centre"], maps["origin"], atol=1e-5, err_msg=name)
    assert_matches_shade(tmp_path)
