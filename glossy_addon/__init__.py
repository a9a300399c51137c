"""Blender-facing package: preferences, properties, panels and glue.

Submodules register in order and unregister in reverse (Blender's
bl_operators model); registration errors are never swallowed.
"""

import importlib

#: The extension's root package (``bl_ext.<repo>.glossy`` once installed).
ADDON_PACKAGE = __package__.rpartition(".")[0]

_MODULE_NAMES = ("preferences", "properties", "panels")


def _modules():
    return [importlib.import_module(f"{__package__}.{name}") for name in _MODULE_NAMES]


def register():
    for module in _modules():
        module.register()


def unregister():
    for module in reversed(_modules()):
        module.unregister()
