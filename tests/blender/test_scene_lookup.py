"""#5's acceptance scene: sphere (GGX) and torus (Ward) over a plane, EEVEE against shade."""

import numpy as np
import pytest

from tests.blender.conftest import run_script

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_eevee_renders_what_the_numpy_lookup_predicts(tmp_path, hdri_dir):
    r = run_script("scene_lookup.py", tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["capture"] == ["FINISHED"]
    for name, (centre, origin) in r["centres"].items():
        # A UV sphere and a torus are symmetric about their origins: the volume
        # centroid is the origin (float32 mesh data).
        np.testing.assert_allclose(centre, origin, atol=1e-5, err_msg=name)
    # One copy of each versioned group, shared by both materials (the taps group
    # twice per material, once more for the sphere's diffuse part).
    # (sphere: 2 lobes x 2 slices + diffuse; torus: 2 slices).
    assert r["node_groups"] == {"Glossy Slice Blend v1": 3, "Glossy Atlas Taps v1": 7}
    assert r["Sphere_maps"] == 2 and r["Torus_maps"] == 1  # the sphere has a diffuse part
    for name in ("Sphere", "Torus"):
        result = r[name]
        assert result["pixels"] > 500, name
        # EEVEE writes half floats (relative rounding <= 4.9e-4) for both the
        # radiance and the normal it is compared at; normals off by that much
        # move the lookup by ~1e-3 rad: a few 1e-3 on these maps.
        assert result["median"] < 3e-3, (name, result)
        assert result["p95"] < 2e-2, (name, result)
        assert result["max"] < 5e-2, (name, result)
