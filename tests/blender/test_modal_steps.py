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


def test_steps_in_parts_advance_one_part_per_tick_and_escape_writes_nothing(tmp_path):
    """A long step (a material's bake) yields after each part (the fit, a pair of
    slices): one part per timer tick, so Esc stops it within a part; the unfinished
    step is closed before its writes."""
    r = run_script("modal_steps.py", tmp_path / "r.json")
    complete = r["parts_complete"]
    assert complete["parts"] == [[1, 0], [1, 1], [1, 2], [2, 0], [2, 1], [2, 2]]
    assert complete["written"] == [1, 2] and complete["results"][-1] == ["FINISHED"]
    # 3 parts + the tick that finishes each step: 8 ticks for 2 steps.
    assert len(complete["results"]) == 9
    escape = r["parts_escape"]
    # Five ticks: step 1 finished (4 ticks) and step 2's first part ran; then Esc.
    assert escape["parts"] == [[1, 0], [1, 1], [1, 2], [2, 0]]
    assert escape["written"] == [1] and escape["closed"] == [2]
    assert escape["results"][-1] == ["CANCELLED"] and escape["timers_removed"] == 1
