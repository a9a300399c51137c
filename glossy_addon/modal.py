"""Long operators in the UI: one step per timer tick, progress, Esc cancels.

An operator mixes in :class:`TimerSteps` and provides ``execute`` (scripts
and background mode run everything at once), ``_begin(context) -> steps``
(raise BakeError/ValueError for bad input), ``_run_step(context, step) ->
message`` and the report texts. Each step writes whole files only, so a
cancel between steps leaves nothing half-written.

A step may instead return a generator (a long step cut into parts): it
yields ``(fraction, message)`` after each part and returns the step's
message. The loop advances it by one part per timer tick, so Esc stops a
long bake within one part (a fraction of a second), and closes it: a
generator writes its files only after its last part, so nothing is left.
"""

import types

import bpy

from ..bake.errors import BakeError
from .progress import BlenderProgress

STEP_ERRORS = (BakeError, ValueError, RuntimeError, KeyError)


class TimerSteps:
    progress_title = ""
    timer_interval = 0.05

    def _interactive(self):
        return not bpy.app.background

    def _done_message(self):
        return f"Glossy finished {self._done} step(s)"

    def _cancel_message(self):
        return f"Cancelled after {self._done} of {len(self._steps)} step(s)"

    def invoke(self, context, event):
        if not self._interactive():
            return self.execute(context)
        try:
            self._steps = list(self._begin(context))
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._done = 0
        self._current = None  # the running step's generator, if it has parts
        self._progress = BlenderProgress(context, self.progress_title).__enter__()
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(self.timer_interval, window=context.window)
        window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        if getattr(self, "_current", None) is not None:
            self._current.close()  # an unfinished step writes nothing
            self._current = None
        context.window_manager.event_timer_remove(self._timer)
        self._progress.__exit__(None, None, None)

    def _advance(self, context):
        """Run the current step, or its next part: (finished, fraction of it, message)."""
        if self._current is None:
            result = self._run_step(context, self._steps[self._done])
            if not isinstance(result, types.GeneratorType):
                return True, 1.0, result
            self._current = result
        try:
            fraction, message = next(self._current)
        except StopIteration as stop:
            self._current = None
            return True, 1.0, stop.value
        return False, fraction, message

    def modal(self, context, event):
        if event.type == "ESC":
            self._stop(context)
            self.report({"WARNING"}, self._cancel_message())
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._done < len(self._steps):
            try:
                finished, fraction, message = self._advance(context)
            except STEP_ERRORS as error:
                self._current = None
                self._stop(context)
                self.report({"ERROR"}, str(error))
                return {"CANCELLED"}
            if finished:
                self._done += 1
                fraction = 0.0
            self._progress((self._done + fraction) / len(self._steps), message)
        if self._done >= len(self._steps):
            self._stop(context)
            self.report({"INFO"}, self._done_message())
            return {"FINISHED"}
        return {"RUNNING_MODAL"}
