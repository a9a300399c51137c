"""Glossy's modal loop: one step per timer tick, Esc and errors stop it cleanly."""

import pytest

from tests.blender.conftest import run_script

pytestmark = pytest.mark.blender


def test_timer_steps_run_cancel_and_fail_cleanly(tmp_path):
    r = run_script("modal_steps.py", tmp_path / "r.json")
    complete = r["complete"]
    assert complete["ran"] == [1, 2, 3]
    assert complete["results"] == [["RUNNING_MODAL"], ["RUNNING_MODAL"], ["PASS_THROUGH"],
                                   ["RUNNING_MODAL"], ["FINISHED"]]
    assert complete["reports"][-1][0] == "INFO"
    assert complete["timers_added"] == complete["timers_removed"] == 1
    escape = r["escape"]
    assert escape["ran"] == [1] and escape["results"][-1] == ["CANCELLED"]
    assert escape["reports"] == [["WARNING", "Cancelled after 1 of 3 step(s)"]]
    assert escape["timers_removed"] == 1
    failure = r["failure"]
    assert failure["ran"] == [1] and failure["results"][-1] == ["CANCELLED"]
    assert failure["reports"] == [["ERROR", "step 2 failed"]] and failure["timers_removed"] == 1
    bad = r["bad_input"]
    assert bad["results"] == [["CANCELLED"]] and bad["timers_added"] == 0
    assert bad["reports"] == [["ERROR", "nothing to do: select a mesh"]]
    assert r["background"]["executed"] is True and r["background"]["timers_added"] == 0
