"""The timer-driven modal loop of Glossy's long operators, with a stand-in window manager.

Blender runs modal operators only with an interactive event loop, which a
headless session lacks; this drives TimerSteps.invoke/modal with recorded
events instead.    python modal_steps.py RESULT.json
"""

import json
import sys
from types import SimpleNamespace

import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
from glossy.bake.errors import BakeError
from glossy.glossy_addon.modal import TimerSteps


class WindowManager:
    def __init__(self):
        self.timers, self.removed, self.handlers = [], [], []

    def event_timer_add(self, interval, window=None):
        self.timers.append(interval)
        return "timer"

    def event_timer_remove(self, timer):
        self.removed.append(timer)

    def modal_handler_add(self, operator):
        self.handlers.append(operator)

    def progress_begin(self, *args):
        pass

    progress_update = progress_end = progress_begin


class Operator(TimerSteps):
    progress_title = "test"

    def __init__(self, steps, fail_at=None, interactive=True):
        self.steps_in, self.fail_at, self.interactive = steps, fail_at, interactive
        self.ran, self.reports, self.executed = [], [], False

    def _interactive(self):
        return self.interactive

    def execute(self, context):
        self.executed = True
        return {"FINISHED"}

    def _begin(self, context):
        if self.steps_in is None:
            raise BakeError("nothing to do: select a mesh")
        return self.steps_in

    def _run_step(self, context, step):
        if step == self.fail_at:
            raise BakeError(f"step {step} failed")
        self.ran.append(step)
        return f"step {step}"

    def report(self, kind, message):
        self.reports.append([sorted(kind)[0], message])


class PartsOperator(Operator):
    """Each step is a generator of three parts that 'writes' only after its last part."""

    def __init__(self, steps):
        super().__init__(steps)
        self.parts, self.written, self.closed = [], [], []

    def _run_step(self, context, step):
        def parts():
            try:
                for part in range(3):
                    self.parts.append([step, part])
                    yield (part + 1) / 3, f"step {step} part {part}"
                self.written.append(step)
                return f"step {step} done"
            except GeneratorExit:
                self.closed.append(step)
                raise

        return parts()


def context():
    workspace = SimpleNamespace(status_text_set=lambda text: None)
    return SimpleNamespace(window_manager=WindowManager(), window=None, workspace=workspace)


TIMER, ESC, MOUSE = (SimpleNamespace(type=t) for t in ("TIMER", "ESC", "MOUSEMOVE"))


def run(operator, events):
    ctx = context()
    results = [sorted(operator.invoke(ctx, None))]
    for event in events:
        if results[-1] != ["RUNNING_MODAL"] and results[-1] != ["PASS_THROUGH"]:
            break
        results.append(sorted(operator.modal(ctx, event)))
    return {"results": results, "ran": operator.ran, "reports": operator.reports,
            "timers_added": len(ctx.window_manager.timers),
            "timers_removed": len(ctx.window_manager.removed),
            "executed": operator.executed}


report = {
    "complete": run(Operator([1, 2, 3]), [TIMER, MOUSE, TIMER, TIMER, TIMER]),
    "escape": run(Operator([1, 2, 3]), [TIMER, ESC, TIMER]),
    "failure": run(Operator([1, 2, 3], fail_at=2), [TIMER, TIMER, TIMER]),
    "bad_input": run(Operator(None), [TIMER]),
    "background": run(Operator([1], interactive=False), []),
}
for name, events in (("parts_complete", [TIMER] * 8), ("parts_escape", [TIMER] * 5 + [ESC])):
    operator = PartsOperator([1, 2])
    report[name] = run(operator, events)
    report[name].update(parts=operator.parts, written=operator.written, closed=operator.closed)
with open(sys.argv[1], "w") as handle:
    json.dump(report, handle, indent=1)
