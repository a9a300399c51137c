"""Where Glossy writes files, and the rule that it never overwrites a file it did not write."""

import os
from pathlib import Path

import bpy

from ..bake import outputs
from ..bake.errors import BakeError
from . import ADDON_PACKAGE


def output_folder() -> Path:
    """``//glossy/`` beside a saved .blend, else the extension's user folder.

    Raises BakeError when neither can be created or written.
    """
    if bpy.data.filepath:
        folder = Path(bpy.path.abspath("//glossy"))
    else:
        try:
            folder = Path(bpy.utils.extension_path_user(ADDON_PACKAGE, path="glossy", create=True))
        except (ValueError, OSError) as error:
            raise BakeError(
                f"save the .blend first: no user folder for '{ADDON_PACKAGE}' ({error})"
            ) from error
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise BakeError(f"{folder}: cannot create the output folder ({error.strerror})") from error
    if not os.access(folder, os.W_OK):
        raise BakeError(f"{folder}: output folder is not writable")
    return folder


def written_by_glossy(path: Path) -> bool:
    """True if ``path`` is a file whose metadata says Glossy wrote it, even a
    truncated one (bake.outputs.written_by_glossy)."""
    return outputs.written_by_glossy(path)


def check_may_write(path: Path) -> None:
    """Raise BakeError if ``path`` exists and is not a file Glossy wrote."""
    if path.exists() and not written_by_glossy(path):
        raise BakeError(f"{path} exists and was not written by Glossy; not overwriting it")
