"""Shared set-up of the scripts that use the extension as installed from its zip.

Importing this module (before bpy) hides the test environment's own OpenEXR,
so the installed extension can only load the wheel bundled in its zip.
BLENDER_USER_RESOURCES must point at an empty temporary folder.
"""

import importlib.abc
import importlib.machinery
import sys

MODULE = "bl_ext.user_default.glossy"


class BundledOpenEXROnly(importlib.abc.MetaPathFinder):
    """``import OpenEXR`` finds only the copy installed in the Blender user folder."""

    def find_spec(self, name, path=None, target=None):
        if name != "OpenEXR":
            return None
        allowed = [entry for entry in sys.path if "/extensions/" in entry.replace("\\", "/")]
        spec = importlib.machinery.PathFinder.find_spec(name, allowed)
        if spec is None:
            raise ImportError("OpenEXR is not installed in the Blender user directory")
        return spec


sys.meta_path.insert(0, BundledOpenEXROnly())


def install(zip_path):
    """Install and enable the zip as Preferences > Get Extensions > Install from Disk does."""
    import bpy

    result = bpy.ops.extensions.package_install_files(
        filepath=str(zip_path), repo="user_default", enable_on_install=True
    )
    # The operator reports FINISHED even for a missing zip: check the add-on itself.
    if MODULE not in bpy.context.preferences.addons:
        raise RuntimeError(f"{zip_path} did not install as {MODULE}")
    return sorted(result)
