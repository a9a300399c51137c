"""Forward ``bake`` progress callbacks to Blender's UI or to stdout in background mode."""

import bpy


class BlenderProgress:
    """A ``progress(fraction, message)`` callable for the bake functions.

    In the UI it drives ``window_manager.progress_*`` and the status bar; in
    background mode (``blender -b`` or the bpy module) it prints lines.
    """

    def __init__(self, context, title: str):
        self.window_manager = context.window_manager
        self.workspace = getattr(context, "workspace", None)
        self.title = title
        self.background = bpy.app.background
        self._last_percent = -1

    def __enter__(self):
        if not self.background:
            self.window_manager.progress_begin(0, 100)
        return self

    def __call__(self, fraction: float, message: str) -> None:
        percent = int(round(100 * fraction))
        if percent == self._last_percent:
            return
        self._last_percent = percent
        if self.background:
            print(f"Glossy: {self.title}: [{percent:3d}%] {message}", flush=True)
            return
        self.window_manager.progress_update(percent)
        if self.workspace is not None:
            self.workspace.status_text_set(f"Glossy: {self.title}: {message}")

    def __exit__(self, *exc):
        if not self.background:
            self.window_manager.progress_end()
            if self.workspace is not None:
                self.workspace.status_text_set(None)
        return False
