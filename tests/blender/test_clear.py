"""glossy.clear puts the user's material back and deletes only Glossy's files."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


def test_clear_restores_the_material_and_deletes_only_glossy_files(tmp_path, hdri_dir):
    r = run_script("clear.py", tmp_path, hdri_dir / "forest.exr", tmp_path / "r.json")
    assert r["poll_nothing_selected"] is False
    # The lookup sits beside the user's nodes (its output active), and a copy of
    # the material as it was is kept (the validation truth).
    assert r["attached_nodes_have_mine"] is True and r["attached_lookup_active"] is True
    assert r["stash"] == "Paint (before Glossy)"
    assert r["stashes_after_reattach"] == ["Paint", "Paint (before Glossy)"]
    assert r["clear"] == ["FINISHED"]
    after = r["after"]
    assert after["materials"] == ["Paint"]  # the kept copy is gone, the name kept
    assert after["slots_are_paint"] == [True, True]  # both objects use it still
    assert after["has_mine"] is True and after["lookup_nodes"] == 0
    assert after["user_output_active"] == "Material Output"
    assert after["base_color"] == pytest.approx([0.7, 0.2, 0.1, 1.0])  # the user's edit kept
    assert after["settings_kept"] == [pytest.approx(0.4), pytest.approx([0.2, 0.2, 0.2])]
    assert after["status"] == "missing" and after["paths"] == ["", "", "", ""]
    assert after["written_exist"] == [False, False, False]
    assert after["foreign_exists"] and after["foreign_readable"]  # never deleted
    assert after["images"] == ["forest.exr"]  # the atlases went with the lookup; the world stays
    assert after["original"] is False
    assert r["again"] == [["FINISHED"]] * 3
    assert r["again_stash"] == "Paint (before Glossy)"
