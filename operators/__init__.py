"""One module per user action; each exports ``classes``."""

import importlib

_MODULE_NAMES = ("export_environment", "capture_probes", "bake_materials", "clear", "validate",
                 "bump_brdf")


def _classes():
    classes = []
    for name in _MODULE_NAMES:
        classes.extend(importlib.import_module(f"{__package__}.{name}").classes)
    return classes


def register():
    import bpy

    for cls in _classes():
        bpy.utils.register_class(cls)


def unregister():
    import bpy

    for cls in reversed(_classes()):
        bpy.utils.unregister_class(cls)
