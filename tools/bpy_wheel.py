"""Files that ship inside the installed ``bpy`` wheel, found without importing bpy."""

import importlib.util
from pathlib import Path

__all__ = ["bpy_package_dir", "studio_lights", "blender_ext_script"]


class BpyWheelMissing(RuntimeError):
    """The bpy wheel (or a file expected in it) is not installed."""


def bpy_package_dir() -> Path:
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise BpyWheelMissing("the bpy wheel is not installed (run make, which installs it)")
    return Path(list(spec.submodule_search_locations)[0])


def _data_path(pattern: str) -> Path:
    base = bpy_package_dir()
    matches = sorted(base.glob(pattern))
    if not matches:
        raise BpyWheelMissing(f"no {pattern} in {base}")
    return matches[-1]


def studio_lights() -> Path:
    """Folder of the HDRIs bundled with Blender (forest.exr, courtyard.exr, ...)."""
    return _data_path("*/datafiles/studiolights/world")


def blender_ext_script() -> Path:
    """Blender's extension builder/validator, which runs under plain Python."""
    return _data_path("*/scripts/addons_core/bl_pkg/cli/blender_ext.py")
