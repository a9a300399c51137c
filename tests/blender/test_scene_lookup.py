"""#5's acceptance scene: sphere (GGX) and torus (Ward) over a plane, EEVEE against shade."""

import numpy as np
import pytest

from tests.blender.conftest import run_script
from tests.blender.lookup_check import assert_matches_shade

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_eevee_renders_what_the_numpy_lookup_predicts(tmp_path, hdri_dir):
    r = run_script("scene_lookup.py", tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["capture"] == ["FINISHED"]
    assert r["Sphere"] == r["Torus"] == [["FINISHED"], ["FINISHED"]]
    for name, maps in r["views"]["atlases"].items():
        # A UV sphere and a torus are symmetric about their origins: the volume
        # centroid is the origin (float32 mesh data).
        np.testing.assert_allclose(maps["centre"], maps["origin"], atol=1e-5, err_msg=name)
    # One copy of each versioned group, shared by both materials (sphere: 2 lobes
    # x 2 slices + diffuse; torus: 2 slices).
    groups = r["views"]["node_groups"]
    assert groups == {"Glossy Slice Blend v1": 3, "Glossy Atlas Taps v1": 7}
    assert_matches_shade(tmp_path)
