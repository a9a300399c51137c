"""Bake bookkeeping (up to date / stale / missing) and attaching lookups, as a script does."""

import pytest

from tests.blender.conftest import run_script
from tests.conftest import ROOT

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def test_bake_is_skipped_when_unchanged_and_redone_when_stale_or_missing(tmp_path, hdri_dir):
    r = run_script("bake_attach.py", ROOT, tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["poll_no_material"] is False
    assert "has no probe yet" in r["bake_without_probe"]
    assert r["capture"] == ["FINISHED"] and r["bake1"] == ["FINISHED"]
    assert r["before"] == "missing" and r["after_bake"] == "up to date"
    assert r["rebake_did_no_work"] is True
    assert r["after_reload"] == "up to date" and r["reload_rebake_did_no_work"] is True
    assert r["after_change"] == "stale" and r["after_rebake"] == "up to date"
    assert r["after_delete"] == "missing" and r["restored"] is True
    assert r["attach"] == ["FINISHED"]
    assert {"EMISSION", "TEX_IMAGE", "NEW_GEOMETRY"} <= set(r["node_types"])
    assert r["image_taps"] == 10  # 2 slices x (4 taps + 1 offset)
    # Auto within Map Size 8; a half-float atlas is uploaded as half floats.
    assert r["chosen_size"] == 8 and r["size_reason"].startswith("8 rows: limited by Max Map")
    assert r["atlas_precision"] == "half" and r["atlas_use_half_precision"] is True
    assert "the map size's upper bound must be in [4, 1024], not 0" in r["size_zero"]
    assert r["reload_missing_status"] == "missing"
    assert r["image_has_data_missing"] is False
    assert r["rebake"] == ["FINISHED"] and r["reattach"] == ["FINISHED"]
    assert r["image_size_after"] == [8 * 2 + 3, 3 * (8 + 2)]  # (W + 3) x K (H + 2), K = 3
    assert "save the .blend first" in r["unsaved"] and r["unsaved_probe_path"] == ""
    assert r["split_sum_status_before"] == "stale"
    assert r["split_sum"] == ["FINISHED", "FINISHED"]
    assert r["split_sum_file"].endswith("_split-sum.exr")
