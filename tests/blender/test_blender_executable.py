"""The README's headless pipeline in a real ``blender`` executable, with the
extension installed from its zip into a temporary user directory.

The executable is Debian trixie's Blender 4.3 (Python 3.13, NumPy 2) unless
GLOSSY_BLENDER names another (conftest.blender_executable). Everything the
pytest side checks is computed here, with this process's NumPy: the EEVEE
render against bake.atlas.shade, and each baked atlas against a bake of the
same probe by bake.prefilter.
"""

import json
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from bake import atlas, exr, prefilter
from tests.blender.conftest import SCRIPTS, run_blender
from tests.blender.lookup_check import assert_matches_shade
from tests.blender.readme import pipeline_block

pytestmark = [pytest.mark.blender, pytest.mark.slow]


def run_readme(blender, folder, user, text):
    """Run README shell text in ``folder`` with ``blender`` on PATH."""
    bin_dir = folder / "bin"
    bin_dir.mkdir(exist_ok=True)
    link = bin_dir / "blender"
    if not link.exists():
        link.symlink_to(blender)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user),
               PATH=f"{bin_dir}{os.pathsep}{os.environ['PATH']}")
    return subprocess.run(["sh", "-ec", text], cwd=folder, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True, timeout=900)


def test_readme_pipeline_captures_bakes_attaches_and_eevee_matches(
        blender_executable, installed, tmp_path):
    run_blender(blender_executable, "--background", "--python", SCRIPTS / "binary_scene.py",
                "--", tmp_path, user_dir=installed)
    process = run_readme(blender_executable, tmp_path, installed, pipeline_block())
    out = process.stdout
    assert process.returncode == 0, out[-4000:]
    assert "Traceback" not in out and "Error:" not in out, out[-4000:]
    # Background mode prints progress lines, ending at 100%.
    assert re.search(r"Glossy: capture probes: \[100%\]", out), out[-2000:]
    assert re.search(r"Glossy: bake materials: \[100%\]", out), out[-2000:]
    written = sorted(p.name for p in (tmp_path / "glossy").iterdir())
    assert "forest_cube256.exr" in written
    assert {"Sphere_probe.exr", "Torus_probe.exr", "Sphere_Sphere_glossy_3d.exr",
            "Sphere_Sphere_glossy_diffuse.exr", "Torus_Torus_glossy_2d.exr"} <= set(written)
    assert not [name for name in written if "tmp" in name], written

    # The saved, attached scene opened again, rendered by EEVEE in the executable.
    run_blender(blender_executable, "--background", tmp_path / "scene.blend", "--python",
                SCRIPTS / "binary_views.py", "--", tmp_path, user_dir=installed)
    views = json.loads((tmp_path / "views.json").read_text())
    assert views["node_groups"] == {"Glossy Slice Blend v1": 3, "Glossy Atlas Taps v1": 7}
    for name, maps in views["atlases"].items():
        # Symmetric meshes: the volume centroid is the origin (float32 mesh data).
        np.testing.assert_allclose(maps["centre"], maps["origin"], atol=1e-5, err_msg=name)
    assert_matches_shade(tmp_path)

    # The executable's bake (NumPy 2, Python 3.13) equals this process's bake of
    # the same probe: same algorithm and the same Auto size (chosen there, within
    # the material's Max Map Size); FFT and summation order differ between NumPy
    # versions at ~1e-6 of the peak, and the atlas is stored as half floats
    # (relative rounding up to 2^-11 = 4.9e-4).
    for name, maps in views["atlases"].items():
        probe, meta = exr.read(maps["probe"])
        settings = maps["bake"]
        assert settings["size_mode"] == "AUTO" and settings["size"] <= settings["max_size"]
        auto = prefilter.prefilter(probe, settings["spec"], settings["method"], "auto",
                                   slices=settings["slices"], lobes_count=settings["lobes"],
                                   layout=meta["layout"], max_size=settings["max_size"])
        assert auto.meta["size"] == settings["size"], name
        assert auto.meta["size_reason"] == settings["size_reason"], name
        expected, _ = atlas.pack(auto)
        got, got_meta = exr.read(maps["glossy"])
        assert got_meta["precision"] == "half", name
        assert got.shape == expected.shape, name
        assert np.all(np.abs(got - expected) <= 4.9e-4 * np.abs(expected)
                      + 1e-4 * np.abs(expected).max()), name


def test_pipeline_error_exits_non_zero_and_saves_nothing(blender_executable, installed,
                                                         tmp_path):
    # Blender's default scene: the Cube, selected and active, with its material removed.
    run_blender(blender_executable, "--background", "--python-expr",
                "import bpy; cube = bpy.data.objects['Cube']; cube.data.materials.clear(); "
                "cube.glossy.probe_resolution = 8; cube.glossy.capture_samples = 1; "
                f"bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / 'scene.blend')!r})",
                user_dir=installed)
    before = (tmp_path / "scene.blend").read_bytes()
    commands = pipeline_block().split("blender --background")
    process = run_readme(blender_executable, tmp_path, installed,
                         "blender --background" + commands[-1])
    assert process.returncode != 0
    # The operator's poll message reaches the script's error, and Blender
    # stops the script with a non-zero exit (--python-exit-code 1).
    assert "poll() The object has no material" in process.stdout, process.stdout[-3000:]
    assert "Error: script failed" in process.stdout
    assert (tmp_path / "scene.blend").read_bytes() == before  # not saved
    assert [p.name for p in (tmp_path / "glossy").iterdir()] == ["Cube_probe.exr"]


@pytest.mark.serial  # Esc between faces and materials: event timing, run alone
def test_escape_in_a_live_window_cancels_and_keeps_blender_working(live_blender, installed,
                                                                   tmp_path):
    run_blender(live_blender, "--enable-event-simulate", "--python",
                SCRIPTS / "live_escape.py", "--", tmp_path, tmp_path / "r.json",
                user_dir=installed)
    r = json.loads((tmp_path / "r.json").read_text())
    assert r.get("ok"), r.get("error")
    assert r["background"] is False  # a real window, not background mode
    assert r["capture_invoke"] == r["bake_invoke"] == ["RUNNING_MODAL"]
    # Esc after the second face: no more faces, no probe, no file.
    cancel = r["capture_cancel"]
    assert 2 <= cancel["faces_rendered"] < 6, cancel
    assert cancel["probe_path"] == "" and cancel["files"] == []
    assert r["capture_done"]["faces_rendered"] == 6
    assert r["capture_done"]["files"] == ["Cube_probe.exr"]
    # Esc after the first of three materials: that one whole, the rest untouched.
    cancel = r["bake_cancel"]
    assert cancel["baked"][0] and not all(cancel["baked"]), cancel
    baked = [Path(p).name for p in cancel["bake_paths"] if p]
    assert cancel["files"] == sorted(["Cube_probe.exr", *baked])  # no partial files
    for path in cancel["bake_paths"]:
        if path:
            image, meta = exr.read(path)  # complete and readable
            assert image.shape[0] > 0 and meta["material"].startswith("M")
    assert r["bake_done"]["files"] == ["Cube_M0_3d.exr", "Cube_M1_3d.exr", "Cube_M2_3d.exr",
                                       "Cube_probe.exr"]
    # Esc inside one material's bake (a 256-row, 32-slice GGX 0.1 map): stopped
    # between two parts, nothing written for it.
    mid = r["bake_mid_cancel"]
    assert mid["bake_path"] == "" and not [f for f in mid["files"] if "Big" in f], mid
    # The status bar's reports, as the Info editor lists them.
    reports = r["reports"]
    assert "Probe capture cancelled; no unfinished probe was written" in reports
    assert any(line.startswith("Bake cancelled after") for line in reports)
    assert "Glossy captured 1 probe(s)" in reports
    # The three panels drew in the window (sidebar tab and Material properties).
    assert r["panels_drawn"] == ["GLOSSY_PT_environment", "GLOSSY_PT_material",
                                 "GLOSSY_PT_probe"]
    assert r["panel_errors"] == []


@pytest.mark.serial  # times the stop after Esc: run alone
def test_undo_restores_glossy_state_and_esc_stops_a_large_bake_at_once(live_blender, installed,
                                                                       tmp_path, hdri_dir):
    """Issue 15: undo after capture, bake and attach gives back the object's and
    the material's Glossy state (and the material's own nodes); a bake whose
    parts take seconds each stops within a second of Esc and writes nothing."""
    run_blender(live_blender, "--enable-event-simulate", "--python",
                SCRIPTS / "live_undo.py", "--", tmp_path, tmp_path / "r.json",
                hdri_dir / "forest.exr", user_dir=installed)
    r = json.loads((tmp_path / "r.json").read_text())
    assert r.get("ok"), r.get("error")
    assert r["background"] is False
    before, captured, baked, attached = r["states"]
    assert before["object"]["probe_path"] == "" and captured["object"]["probe_path"]
    assert captured["settings"]["bake_path"] == "" and baked["settings"]["bake_path"]
    assert attached["original"] and attached["nodes"] != baked["nodes"]
    # Each undo gives back the state before the step it undoes; redo the one after.
    assert r["undone"] == [baked, captured, before]
    assert r["redone"] == [captured, baked, attached]
    # Esc during a 1024-row bake: the operator ended within a second (the
    # issue's target; each of its parts takes several seconds), nothing written.
    assert r["big_running"] == ["GLOSSY_OT_bake_materials"]
    assert r["big_stop_seconds"] < 1.0, r["big_stop_seconds"]
    assert r["big_after"]["bake_path"] == ""
    assert not [f for f in r["big_after"]["files"] if "Big" in f]
