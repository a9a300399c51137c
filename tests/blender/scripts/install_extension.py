"""Install the built extension zip into a fresh Blender user directory, as a user would.

Run as ``python install_extension.py ZIP RESULT.json`` with BLENDER_USER_RESOURCES
set to an empty temporary folder *before* bpy is imported. Writes what it
observed as JSON; the pytest side asserts on it.
"""

import importlib
import json
import sys
import traceback

from _installed import MODULE, install  # first: hides the venv's OpenEXR

# isort: split
import bpy

OPERATORS = ("GLOSSY_OT_export_environment", "GLOSSY_OT_capture_probes",
             "GLOSSY_OT_bake_materials", "GLOSSY_OT_attach_materials", "GLOSSY_OT_clear")
PANELS = ("GLOSSY_PT_environment", "GLOSSY_PT_probe", "GLOSSY_PT_material")


def registered():
    return {
        "operators": all(hasattr(bpy.types, name) for name in OPERATORS),
        "panels": all(hasattr(bpy.types, name) for name in PANELS),
        "scene_settings": all(hasattr(owner, "glossy")
                              for owner in (bpy.types.Scene, bpy.types.Object,
                                            bpy.types.Material)),
        "enabled": MODULE in bpy.context.preferences.addons,
    }


def main(zip_path, result_path):
    result = {"user_resources": bpy.utils.resource_path("USER")}
    result["install"] = install(zip_path)
    result["after_install"] = registered()
    result["addon_path"] = bpy.utils.extension_path_user(MODULE, create=False)
    module = importlib.import_module(MODULE)
    result["module_file"] = module.__file__
    # The bundled OpenEXR wheel must be importable from the installed extension.
    exr = importlib.import_module(MODULE + ".bake.exr")
    result["openexr"] = exr._import_openexr().__file__
    result["poll_without_image"] = bpy.ops.glossy.export_environment.poll()

    bpy.ops.preferences.addon_disable(module=MODULE)
    result["after_disable"] = registered()
    bpy.ops.preferences.addon_enable(module=MODULE)
    result["after_reenable"] = registered()
    bpy.ops.preferences.addon_disable(module=MODULE)
    bpy.ops.preferences.addon_enable(module=MODULE)
    result["after_second_cycle"] = registered()
    with open(result_path, "w") as handle:
        json.dump(result, handle, indent=1)


if __name__ == "__main__":
    try:
        main(sys.argv[1], sys.argv[2])
    except Exception:
        traceback.print_exc()
        sys.exit(1)
