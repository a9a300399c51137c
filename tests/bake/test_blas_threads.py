"""bake.blas_threads: the bake's worker holds NumPy's OpenBLAS to one thread and gives
back the count it found."""

import sys
import threading

import pytest

from bake import blas_threads
from bake.progress import background_steps, blas_limited_steps, run_steps


@pytest.fixture
def two_threads():
    """OpenBLAS set to two threads for the test (make test starts it at one), then
    back to what it was."""
    if not blas_threads.available():
        # The pinned NumPy 1.26 wheels bundle OpenBLAS on every platform the tests run on.
        pytest.fail(f"NumPy's OpenBLAS was not found ({sys.platform})")
    _, set_threads = blas_threads._controls()
    before = blas_threads.current()
    set_threads(2)
    assert blas_threads.current() == 2
    yield
    set_threads(before)


def test_limited_holds_one_thread_and_restores_the_count_it_found(two_threads):
    with blas_threads.limited():
        assert blas_threads.current() == 1
        with blas_threads.limited():  # nested: still one, and the outer block restores
            assert blas_threads.current() == 1
        assert blas_threads.current() == 1
    assert blas_threads.current() == 2
    with pytest.raises(RuntimeError):
        with blas_threads.limited():
            raise RuntimeError("a failing step")
    assert blas_threads.current() == 2


def test_overlapping_blocks_on_two_threads_restore_once_both_end(two_threads):
    entered, release = threading.Event(), threading.Event()

    def other():
        with blas_threads.limited():
            entered.set()
            release.wait(5)

    worker = threading.Thread(target=other)
    worker.start()
    entered.wait(5)
    with blas_threads.limited():
        assert blas_threads.current() == 1
    assert blas_threads.current() == 1  # the other thread's block is still open
    release.set()
    worker.join(5)
    assert blas_threads.current() == 2


def test_a_background_step_runs_with_one_blas_thread(two_threads):
    def steps():
        yield 0.5, f"threads {blas_threads.current()}"
        return blas_threads.current()

    seen = []
    assert run_steps(background_steps(steps()), lambda f, m: seen.append(m)) == 1
    assert "threads 1" in seen
    assert blas_threads.current() == 2


def test_limited_steps_hold_one_thread_within_each_part_only(two_threads):
    def steps():
        yield 0.5, blas_threads.current()
        yield 1.0, blas_threads.current()
        return blas_threads.current()

    limited = blas_limited_steps(steps())
    assert next(limited) == (0.5, 1)
    assert blas_threads.current() == 2  # between parts (a modal operator's ticks)
    assert run_steps(limited) == 1
    assert blas_threads.current() == 2
    closed = blas_limited_steps(steps())
    next(closed)
    closed.close()  # a cancelled bake
    assert blas_threads.current() == 2
