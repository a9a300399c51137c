"""Long operators in the UI: one step per timer tick, progress, Esc cancels.

An operator mixes in :class:`TimerSteps` and provides ``execute`` (scripts
and background mode run everything at once), ``_begin(context) -> steps``
(raise BakeError/ValueError for bad input), ``_run_step(context, step) ->
message`` and the report texts. Each step writes whole files only, so a
cancel between steps leaves nothing half-written.
"""

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
        self._progress = BlenderProgress(context, self.progress_title).__enter__()
        window_manager = context.window_manager
        self._timer = window_manager.event_timer_add(self.timer_interval, window=context.window)
        window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        context.window_manager.event_timer_remove(self._timer)
        self._progress.__exit__(None, None, None)

    def modal(self, context, event):
        if event.type == "ESC":
            self._stop(context)
            self.report({"WARNING"}, self._cancel_message())
            return {"CANCELLED"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if self._done < len(self._steps):
            try:
                message = self._run_step(context, self._steps[self._done])
            except STEP_ERRORS as error:
                self._stop(context)
                self.report({"ERROR"}, str(error))
                return {"CANCELLED"}
            self._done += 1
            self._progress(self._done / len(self._steps), message)
        if self._done >= len(self._steps):
            self._stop(context)
            self.report({"INFO"}, self._done_message())
            return {"FINISHED"}
        return {"RUNNING_MODAL"}
