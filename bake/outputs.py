"""Output files: checked before the work starts, written whole or not at all.

Rules every writer in ``bake`` (and the Blender operators through it) keeps:

- A target is checked before any work: the right suffix, an existing and
  writable folder, not a directory, not one of the command's inputs
  (:func:`check_target`).
- A file the user did not name (a map's ``.json`` sidecar, a pyramid's
  ``.mip<k>.exr`` levels) may replace only a file Glossy wrote
  (:func:`check_implicit`): a user's ``notes.json`` is never overwritten.
- Each file is written under a temporary name beside its target and renamed
  over it (:func:`atomic_write`); several files of one result are staged first
  and renamed together (:class:`Staged`), so a failure in the second file
  leaves the first untouched.
- Every temporary lives in :data:`_LIVE` while it exists, so an interrupt that
  ends the process at once (the command line's Ctrl-C) removes them
  (:func:`remove_temporaries`).
"""

import json
import os
import threading
from pathlib import Path

from .errors import BakeError

__all__ = ["check_target", "check_implicit", "same_file", "atomic_write", "Staged",
           "remove_temporaries", "written_by_glossy", "GENERATOR_PREFIX"]

#: Every file Glossy writes carries ``"generator": "glossy..."`` in its metadata
#: (EXR header attribute or JSON field).
GENERATOR_PREFIX = "glossy"

_LIVE: set = set()
_LOCK = threading.Lock()


def same_file(a, b) -> bool:
    """True if paths ``a`` and ``b`` name the same file (links and ``..`` resolved)."""
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return os.path.samefile(a, b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def check_target(path, suffix: str | None = None, inputs=(), what: str = "output") -> Path:
    """``path`` as a Path, or BakeError if it cannot be written as an output file.

    ``suffix``: the required extension (``".exr"``); ``inputs``: paths the
    command reads, which it must never replace.
    """
    path = Path(path)
    if suffix is not None and path.suffix.lower() != suffix:
        raise BakeError(f"{path}: {what} file name must end in {suffix}")
    if path.is_dir():
        raise BakeError(f"{path}: is a directory, not a file")
    folder = path.parent
    if not folder.is_dir():
        raise BakeError(f"{folder}: {what} folder does not exist")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise BakeError(f"{folder}: {what} folder is not writable")
    if path.exists() and not os.access(path, os.W_OK) and not os.access(folder, os.W_OK):
        raise BakeError(f"{path}: is read-only")
    for source in inputs:
        if source and same_file(path, source):
            raise BakeError(f"{path}: is also the input; choose another {what} name")
    return path


def written_by_glossy(path) -> bool:
    """True if ``path`` is a file Glossy wrote, even a damaged one.

    JSON: an object whose ``generator`` starts with ``glossy``. EXR (and any
    other file): the header's metadata says so; a truncated or corrupt EXR is
    still recognised from the ``"generator": "glossy`` text its header holds
    (Glossy writes the metadata as JSON into the header's first kilobytes).
    """
    path = Path(path)
    if not path.is_file():
        return False
    try:
        with open(path, "rb") as handle:
            head = handle.read(1 << 16)
    except OSError:
        return False
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(path.read_text())
        except (OSError, ValueError, UnicodeDecodeError):
            return b'"generator": "glossy' in head
        return isinstance(data, dict) and \
            str(data.get("generator", "")).startswith(GENERATOR_PREFIX)
    return b'\\"generator\\": \\"glossy' in head or b'"generator": "glossy' in head


def check_implicit(path, what: str = "file") -> Path:
    """``path`` (a file the user did not name) as a Path, or BakeError if
    writing it would replace something that is not Glossy's own file."""
    path = Path(path)
    if path.is_dir():
        raise BakeError(f"{path}: the {what} would go there, but it is a directory")
    if path.exists() and not written_by_glossy(path):
        raise BakeError(f"{path}: the {what} would replace this file, which Glossy did not "
                        f"write; move it or choose another output name")
    if not os.access(path.parent, os.W_OK | os.X_OK):
        raise BakeError(f"{path.parent}: folder is not writable")
    return path


def _temporary(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.{threading.get_ident()}.partial"
                          f"{path.suffix}")


def _register(temporary: Path) -> None:
    with _LOCK:
        _LIVE.add(temporary)


def _forget(temporary: Path) -> None:
    with _LOCK:
        _LIVE.discard(temporary)
    try:
        temporary.unlink()
    except FileNotFoundError:
        pass
    except OSError:  # pragma: no cover - a folder that turned read-only meanwhile
        pass


def remove_temporaries() -> None:
    """Delete every temporary still being written (for an immediate exit)."""
    with _LOCK:
        live = list(_LIVE)
        _LIVE.clear()
    for temporary in live:
        try:
            temporary.unlink()
        except OSError:
            pass


def _write_temporary(path: Path, write) -> Path:
    temporary = _temporary(path)
    _register(temporary)
    try:
        write(str(temporary))
    except BaseException as error:
        _forget(temporary)
        if isinstance(error, (OSError, RuntimeError)):
            raise BakeError(f"{path}: cannot write ({error})") from error
        raise
    return temporary


def atomic_write(path, write) -> Path:
    """Call ``write(temporary path)`` beside ``path``, then rename it over ``path``.

    On any failure (or interrupt) the temporary is removed and ``path`` is
    untouched; an OSError or RuntimeError becomes a BakeError naming ``path``.
    """
    path = Path(path)
    temporary = _write_temporary(path, write)
    try:
        os.replace(temporary, path)
    except OSError as error:
        raise BakeError(f"{path}: cannot write ({error.strerror})") from error
    finally:
        _forget(temporary)
    return path


class Staged:
    """Several files of one result, renamed into place together::

        with Staged() as staged:
            staged.add(path_a, writer_a)   # written to a temporary now
            staged.add(path_b, writer_b)
        # both renamed here; on an error in the block neither target changes
    """

    def __init__(self):
        self._staged = []

    def __enter__(self):
        return self

    def add(self, path, write) -> Path:
        path = Path(path)
        self._staged.append((_write_temporary(path, write), path))
        return path

    def __exit__(self, kind, error, trace):
        try:
            if kind is None:
                for temporary, path in self._staged:
                    try:
                        os.replace(temporary, path)
                    except OSError as failure:
                        raise BakeError(f"{path}: cannot write ({failure.strerror})") \
                            from failure
        finally:
            for temporary, _ in self._staged:
                _forget(temporary)
        return False
