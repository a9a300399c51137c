"""The one exception type that user-facing code turns into a one-line message."""

__all__ = ["BakeError"]


class BakeError(ValueError):
    """Bad input or a failed operation, with a message meant for a person.

    The command line prints ``str(error)`` on one stderr line and exits non-zero;
    Blender operators pass it to ``self.report({'ERROR'}, ...)``.
    """
