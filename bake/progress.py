"""Progress reporting shared by the baker, the command line and Blender.

Long functions in ``bake`` take ``progress: Callable[[float, str], None] | None``
and call it with a fraction in [0, 1] and a short message. The command line
passes :class:`LinePrinter`; Blender operators forward to
``window_manager.progress_update`` and the status bar.
"""

import queue
import sys
import threading
import time
from collections.abc import Callable

from .blas_threads import limited as limited_blas

__all__ = ["Progress", "LinePrinter", "report", "scaled", "scaled_steps", "run_steps",
           "prefixed_steps", "background_steps", "blas_limited_steps"]

Progress = Callable[[float, str], None]


def report(progress: Progress | None, fraction: float, message: str) -> None:
    """Call ``progress`` if given; fraction is clipped to [0, 1]."""
    if progress is not None:
        progress(min(max(float(fraction), 0.0), 1.0), message)


def scaled(progress: Progress | None, start: float, stop: float) -> Progress | None:
    """A callback mapping [0, 1] of a sub-task onto [start, stop] of ``progress``."""
    if progress is None:
        return None

    def inner(fraction: float, message: str) -> None:
        progress(start + (stop - start) * fraction, message)

    return inner


def run_steps(steps, progress: Progress | None = None, start: float = 0.0, stop: float = 1.0):
    """Drive a generator of (fraction, message) steps to its end; returns its value.

    Each step's fraction is mapped onto [start, stop] of ``progress``.
    """
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            return done.value
        report(progress, start + (stop - start) * fraction, message)


class LinePrinter:
    """Prints ``[ 42%] message`` lines on stderr, at most every ``interval`` seconds.

    On a terminal the line is rewritten in place; otherwise one line per update.
    """

    def __init__(self, stream=None, interval: float = 0.5):
        self.stream = stream if stream is not None else sys.stderr
        self.interval = interval
        self._last = -1e9
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())

    def __call__(self, fraction: float, message: str) -> None:
        now = time.monotonic()
        if fraction < 1.0 and now - self._last < self.interval:
            return
        self._last = now
        line = f"[{100.0 * fraction:5.1f}%] {message}"
        if self._tty:
            end = "\n" if fraction >= 1.0 else ""
            self.stream.write("\r\033[K" + line + end)
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def scaled_steps(steps, start: float, stop: float):
    """Re-yield a step generator's fractions mapped onto [start, stop]; returns its value."""
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            return done.value
        yield start + (stop - start) * fraction, message


def prefixed_steps(prefix: str, steps):
    """Re-yield a step generator's (fraction, message) with ``prefix`` before each
    message; returns the generator's value."""
    while True:
        try:
            fraction, message = next(steps)
        except StopIteration as done:
            return done.value
        yield fraction, prefix + message


def background_steps(steps, poll: float = 0.1):
    """Run a step generator on a worker thread; re-yield its (fraction, message)
    steps, and between them the last one again at least every ``poll`` seconds.

    A caller that advances one step per UI tick (Blender's modal operators)
    thus never waits more than ``poll`` for control, even while one step of
    the work takes seconds (a large map's slice): Esc is seen at once. Closing
    this generator (the caller cancelled) tells the worker to stop at its next
    step boundary and drops its result; the work writes nothing itself (the
    caller writes files after the last step). Exceptions of the work are
    raised here. Returns the work's return value.
    """
    events = queue.Queue()
    stop = threading.Event()

    def work():
        try:
            # The work's own threads use every core: BLAS's spinning ones would
            # only contend with them (bake.blas_threads).
            with limited_blas():
                while not stop.is_set():
                    try:
                        events.put(("step", next(steps)))
                    except StopIteration as done:
                        events.put(("done", done.value))
                        return
        except BaseException as error:  # re-raised on the caller's thread
            events.put(("error", error))
        finally:
            if stop.is_set():
                steps.close()

    worker = threading.Thread(target=work, name="glossy-steps", daemon=True)
    worker.start()
    last = (0.0, "working")
    try:
        while True:
            try:
                kind, value = events.get(timeout=poll)
            except queue.Empty:
                yield last
                continue
            if kind == "done":
                return value
            if kind == "error":
                raise value
            last = value
            yield value
    finally:
        stop.set()


def blas_limited_steps(steps):
    """Re-yield a step generator's steps, running each part with NumPy's OpenBLAS held
    to one thread (bake.blas_threads) and giving the count back between parts, so
    that a modal operator changes nothing for the rest of Blender between its timer
    ticks. Returns the generator's value; closing this one closes it."""
    try:
        while True:
            with limited_blas():
                try:
                    value = next(steps)
                except StopIteration as done:
                    return done.value
            yield value
    finally:
        steps.close()
