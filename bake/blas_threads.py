"""One BLAS thread while the baker's own threads work.

NumPy's bundled OpenBLAS starts a thread per core and, between calls, keeps
them spinning (sched_yield) for a while. The bake runs its own workers
(bake.progress.background_steps, the prefilter's row pool, zlib in
bake.exr_codec) on every core, so each matrix product of a bake step (the
slice mixes of bake.prefilter, the direction products of bake.probe_lights
and bake.world_lights) woke threads that then spun against those workers:
eight materials baked by one glossy.bake_materials call spent 5.9 s of
system time in a 10 s process, 1.3 s with OpenBLAS held to one thread, and
the operator's wall time fell from 7.1 s to 6.2 s (benchmarks/operator_bake.py's
eight materials, 128 px probe of sunset.exr, this 2-core machine).

:func:`limited` sets OpenBLAS's thread count to one for the duration of a
``with`` block and restores the count it found; blocks may nest and overlap
across threads (the count is restored when the last one ends). The library
is found among the shared objects this process has loaded (Linux:
/proc/self/maps), else in NumPy's wheel folders (``numpy.libs``,
``numpy/.libs``, ``numpy/.dylibs``); a NumPy linked against another BLAS
(Accelerate, MKL) or none found leaves everything as it is: :func:`limited`
then changes nothing and :func:`available` is False.
"""

import contextlib
import ctypes
import threading
from pathlib import Path

__all__ = ["limited", "available", "current"]

#: OpenBLAS symbol prefixes and suffixes, NumPy 1.x wheels (openblas_*64_) and
#: 2.x (scipy_openblas_*64_), and plain 32-bit-integer builds.
_NAMES = [(f"{prefix}get_num_threads{suffix}", f"{prefix}set_num_threads{suffix}")
          for prefix in ("openblas_", "scipy_openblas_") for suffix in ("64_", "")]

_lock = threading.Lock()
_state = {"controls": None, "searched": False, "depth": 0, "saved": None}


def _candidate_paths():
    """Paths of OpenBLAS libraries: those this process mapped, then NumPy's own."""
    paths = []
    maps = Path("/proc/self/maps")
    if maps.is_file():
        try:
            for line in maps.read_text().splitlines():
                path = line.split()[-1] if line.split() else ""
                if "openblas" in Path(path).name.lower() and path not in paths:
                    paths.append(path)
        except OSError:
            pass
    try:
        import numpy
    except ImportError:
        return paths
    root = Path(numpy.__file__).resolve().parent
    for folder in (root.parent / "numpy.libs", root / ".libs", root / ".dylibs"):
        if folder.is_dir():
            paths += [str(p) for p in sorted(folder.iterdir())
                      if "openblas" in p.name.lower() and str(p) not in paths]
    return paths


def _find_controls():
    """(get, set) ctypes functions of the loaded OpenBLAS, or None."""
    import numpy  # noqa: F401  (NumPy loads its BLAS: search after it)

    for path in _candidate_paths():
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for get_name, set_name in _NAMES:
            get = getattr(library, get_name, None)
            set_ = getattr(library, set_name, None)
            if get is not None and set_ is not None:
                get.restype, get.argtypes = ctypes.c_int, []
                set_.restype, set_.argtypes = None, [ctypes.c_int]
                return get, set_
    return None


def _controls():
    with _lock:
        if not _state["searched"]:
            _state["controls"] = _find_controls()
            _state["searched"] = True
        return _state["controls"]


def available() -> bool:
    """Whether NumPy's OpenBLAS was found (its thread count can be set)."""
    return _controls() is not None


def current() -> int | None:
    """OpenBLAS's thread count now, or None where it was not found."""
    controls = _controls()
    return None if controls is None else int(controls[0]())


@contextlib.contextmanager
def limited():
    """Hold OpenBLAS to one thread inside the block (nothing where it was not found)."""
    controls = _controls()
    if controls is None:
        yield
        return
    get, set_ = controls
    with _lock:
        if _state["depth"] == 0:
            _state["saved"] = int(get())
            set_(1)
        _state["depth"] += 1
    try:
        yield
    finally:
        with _lock:
            _state["depth"] -= 1
            if _state["depth"] == 0:
                set_(max(int(_state["saved"]), 1))
