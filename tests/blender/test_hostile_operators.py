"""Capture, bake, attach and clear under hostile but realistic use (issue 15):
copies of captured objects, names that clean alike, shared materials, a
read-only folder, a user's file where a map would go, damaged bakes,
settings that cannot work, and data linked from a library. Each case: the
operator's report checked, no file Glossy did not write changed, no partial
file, Clear removing exactly the
files the object's own captures and bakes wrote."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


@pytest.fixture(scope="module")
def result(tmp_path_factory, hdri_dir):
    workdir = tmp_path_factory.mktemp("hostile")
    r = run_script("hostile_operators.py", workdir, hdri_dir / "forest.exr",
                   workdir / "r.json")
    crashed = {k: v["crashed"] for k, v in r.items() if isinstance(v, dict) and "crashed" in v}
    assert not crashed, crashed
    return r


def _error(call):
    status, text = call
    assert status == ["CANCELLED"], text
    assert "Traceback" not in text
    return text


def test_copies_of_a_captured_object_never_use_or_delete_the_original_s_files(result):
    r = result["duplicates"]
    assert r["copy_holds_path"]  # Blender copied the path with the object
    for key, name in (("bake_copy", "Ball.001"), ("bake_linked", "Ball.002")):
        assert f"capture a probe for {name} first" in _error(r[key])
    assert r["material_bake_unchanged"]
    assert r["clear_copy"][0] == ["FINISHED"] and "left alone" in r["clear_copy"][1]
    after = r["after_clear"]
    assert after["original_files"] == [True, True] and after["original_unchanged"]
    assert after["original_probe_path"] and after["material_bake_path"]
    assert after["copy_probe_path"] == ""
    # Once it has its own probe, the copy bakes, and says the material is shared.
    assert r["capture_copy"][0] == ["FINISHED"] and r["copy_own_probe"] == "Ball_001_probe.exr"
    assert r["original_probe_unchanged"]
    assert r["bake_copy_after_capture"][0] == ["FINISHED"]
    assert "Shiny is shared with Ball, whose probe differs: Ball.001 now has its own copy " \
        "'Shiny (Ball.001)'" in r["bake_copy_after_capture"][1]


def test_names_that_clean_alike_get_files_of_their_own(result):
    r = result["similar_names"]
    assert "captured 2 probe(s)" in r["capture"][1]
    assert r["distinct"] and r["objects_in_files"] == ["Ball.1", "Ball_1"]
    assert r["names"] == ["Ball_1_probe.exr", "Ball_1-2_probe.exr"]
    assert r["again"][0] == ["FINISHED"] and r["again_path_same"] and r["other_unchanged"]
    assert "2 file(s) deleted" in r["clear"][1] and r["left"] == [False, False]


def test_a_material_shared_by_objects_with_their_own_probes_gets_a_copy_per_object(result):
    r = result["shared_material"]
    assert "Shared is shared with B, whose probe differs: A now has its own copy " \
        "'Shared (A)'" in r["bake_a"][1]
    assert "own copy" not in r["bake_b"][1]  # B is the material's only user by then
    assert r["materials"] == {"A": "Shared (A)", "B": "Shared"}
    assert r["baked_for"] == {"Shared (A)": "A", "Shared": "B"}
    assert r["copy_of"] == {"Shared (A)": "Shared", "Shared": ""}
    assert r["bakes_exist"] == [True, True, True]
    # Clearing A removes its probe and its copy's bake, and leaves B's alone...
    assert "2 file(s) deleted" in r["clear_a"][1]
    assert r["after_a"] == {"a_bake": False, "b_bake": True, "b_path": True, "b_probe": True}
    # ...and clearing B removes the rest: no orphan.
    assert "2 file(s) deleted" in r["clear_b"][1]
    assert r["after_b"] == [False, ""] and r["files"] == []


def test_clear_in_a_read_only_folder_changes_nothing(result):
    r = result["read_only_clear"]
    if "skipped" in r:
        pytest.skip(r["skipped"])
    assert "nothing was cleared" in _error(r["clear"])
    assert r["unchanged"] == {"paths": True, "lookup_kept": True, "files": True}
    assert r["clear_writable"][0] == ["FINISHED"] and r["files_after"] == []


def test_a_user_file_at_the_diffuse_map_s_path_refuses_the_bake_before_any_write(result):
    r = result["user_file_at_diffuse_path"]
    assert "was not written by Glossy" in _error(r["bake"])
    assert r["user_file"] and r["bake_path"] == ""
    assert r["files"] == ["Dif_DifMat_diffuse.exr"]  # the glossy map was not written either


def test_a_damaged_bake_is_recognised_rebaked_and_cleared(result):
    r = result["truncated_bake"]
    assert r["status"] == "damaged"
    assert "damaged" in _error(r["attach"])
    assert r["rebake"][0] == ["FINISHED"] and r["status_after"] == "up to date"
    assert r["readable_after"]
    # Cut inside its header, it is still Glossy's file: Clear deletes it.
    assert r["clear"][0] == ["FINISHED"] and "not written by Glossy" not in r["clear"][1]
    assert not r["exists_after_clear"]


def test_settings_that_cannot_work_are_refused_at_once(result):
    r = result["refused_settings"]
    assert "16896-row texture, past the GPU's 16384-row limit" in _error(r["atlas"])
    assert "at most 62" in r["atlas"][1]
    assert "32896-row texture" in _error(r["atlas_lobes"])
    assert "do not fit the GPU's 16384-row texture limit at any map size" in \
        _error(r["atlas_auto"])
    assert "Fresnel IOR 0.5" in _error(r["fresnel"])
    assert "too deep" in _error(r["nested"])
    assert r["map_size_max"] == 1024
    assert r["files"] == []


def test_linked_library_data_is_refused_before_any_change(result):
    """Linked objects and materials: Blender reloads them from their library on open,
    so a probe or a lookup recorded on them would vanish with the next open while
    the files stayed behind (measured before stop 55: a linked material baked and
    attached, its 227 nodes back to 2 and its bake record empty after a reload)."""
    r = result["linked_library"]
    assert "LibBall is linked from library.blend" in _error(r["capture_linked"])
    assert "make it local first" in r["capture_linked"][1]
    assert r["capture_local"][0] == ["FINISHED"]
    assert "LibMetal is linked from library.blend" in _error(r["bake"])
    assert "LibMetal is linked from library.blend" in _error(r["attach"])
    assert r["files"] == ["Local_probe.exr"]  # the local object's probe alone
    assert r["bake_path"] == "" and r["nodes"] == 2  # the material untouched
    assert r["clear"][0] == ["FINISHED"]


def test_no_partial_or_stray_file_is_left(result):
    assert result["leftovers"] == []
    assert result["all_files"] == []
