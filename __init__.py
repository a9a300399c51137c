"""Glossy Blender extension: registration only.

No bpy import at module level: pytest imports this file while collecting
tests, and the baker in ``bake/`` must stay usable without Blender.
"""


def register():
    from . import glossy_addon, operators

    glossy_addon.register()
    operators.register()


def unregister():
    from . import glossy_addon, operators

    operators.unregister()
    glossy_addon.unregister()
