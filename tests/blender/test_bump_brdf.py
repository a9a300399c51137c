"""The Bump-Map BRDF through Blender: computed, plotted, baked, attached; its baked
lookup against the brute-force integral of the same table; bad input."""

import math

import numpy as np
import pytest

from bake import atlas, brdf, exr, reference
from tests.blender.conftest import run_script

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_a_bump_material_is_computed_plotted_baked_and_attached(tmp_path, hdri_dir,
                                                                monkeypatch):
    r = run_script("bump_brdf.py", tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["spec"].startswith("bump:preset=gaussian,size=64,slope=0.25")
    assert r["compute"] == ["FINISHED"] and r["plot_image"]
    assert r["plot"].endswith("Sand.png") and "table 24x24x25" in r["status"]
    # The material panel draws every Bump-Map field, the button and the plot.
    assert r["panel_missing"] == []
    assert {"bump_source", "bump_file", "bump_texel", "bump_height", "bump_period",
            "bump_depth", "bump_slope", "bump_seed", "bump_ior", "bump_k"} <= set(r["panel_props"])
    assert {"operator", "template_icon", "icon"} <= set(r["panel_calls"])
    assert r["capture"] == r["bake"] == r["attach"] == ["FINISHED"]
    assert r["cache_files"] == 1  # the table the bake used is the one computed
    # Validated against the NumPy reference (no Cycles BSDF for a table), in EEVEE:
    # the node lookup's error on a 48 px render, measured 13% (the 3D map's own error
    # for this wide lobe is about 15% in NumPy, below); bound 20%.
    assert r["validate"] == ["FINISHED"] and r["validation_truth"] == "reference"
    assert any("NumPy reference only" in note for note in r["validation_notes"])
    assert r["validation_error"] < 0.2, r["validation_error"]
    # The baked 3D map's NumPy twin (what the nodes compute) against the brute-force
    # integral of the same table over the probe, beside the same 3D map pipeline on
    # the closed form the surface follows (Beckmann, alpha = sqrt(2) x 0.25, F = 1):
    # the Kautz-McCool method's own error for so wide a lobe (measured 14.7% and
    # 14.2%). The bump table must be baked as well as its closed form (bound 1.25x).
    from bake import prefilter

    monkeypatch.setenv("GLOSSY_CACHE_DIR", str(tmp_path / "cache"))
    probe = exr.read(r["probe_path"])[0][..., :3]
    normals, views, mask = reference.sphere_buffers(32)
    normals, views = normals[mask], views[mask]
    lum = np.array([0.2126, 0.7152, 0.0722])

    def error(values, truth):
        return np.sqrt(np.sum(((values - truth) @ lum) ** 2) / np.sum((truth @ lum) ** 2))

    truth = reference.render(brdf.parse(r["spec"]), probe, "cube", normals, views)
    bump_error = error(atlas.shade(*exr.read(r["bake_path"]), normals, views), truth)
    beckmann = brdf.parse(f"beckmann:alpha={math.sqrt(2) * 0.25}")
    closed = reference.render(beckmann, probe, "cube", normals, views)
    closed_error = error(prefilter.prefilter(probe, beckmann, "3d", "auto")
                         .shade(normals, views), closed)
    assert bump_error < 1.25 * closed_error, (bump_error, closed_error)
    outcome, message = r["bad"]
    assert outcome == ["CANCELLED"] and "cannot read it as an image" in message
    assert "Traceback" not in message and not r["bad_plot"]
