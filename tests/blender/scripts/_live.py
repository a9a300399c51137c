"""Shared by the live-window scripts (live_escape.py, live_undo.py): the 3D
viewport's context, waiting inside a scenario, and running the scenario as a
generator from Blender's timer until it ends, then writing the report and
quitting. Scenarios yield the seconds to wait before their next step."""

import json
import time
import traceback
from pathlib import Path

import bpy


def viewport_override():
    """(window, context override of the 3D viewport's main region)."""
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    return window, {"window": window, "area": area, "region": region}


def wait_until(condition, timeout=120.0):
    """Yield short waits until ``condition()`` holds; TimeoutError after ``timeout`` s."""
    start = time.monotonic()
    while not condition():
        if time.monotonic() - start > timeout:
            raise TimeoutError("timed out waiting in the live window")
        yield 0.02


def run(scenario, report: dict, result_path: Path):
    """Drive ``scenario`` (a generator) from a timer; report ``ok`` or the
    traceback in ``report``, write it as JSON and quit Blender."""

    def tick():
        try:
            return next(scenario)
        except StopIteration:
            report["ok"] = True
        except Exception:
            report["error"] = traceback.format_exc()
        Path(result_path).write_text(json.dumps(report, indent=1))
        bpy.ops.wm.quit_blender()
        return None

    bpy.app.timers.register(tick, first_interval=1.0)
