"""Add-on preferences (bl_idname is the extension's own package name)."""

import bpy

from . import ADDON_PACKAGE


class GlossyPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_PACKAGE

    default_layout: bpy.props.EnumProperty(
        name="Default Layout",
        description="Layout used when exporting environment maps",
        items=[
            ("cube", "Cube", "OpenGL cube strip (N x 6N), glTF Y-up frame"),
            ("latlong", "Lat-Long", "Blender's Environment Texture layout (N x 2N)"),
            ("paraboloid", "Dual Paraboloid", "Front +Z, back -Z, extended domain (N x 2N)"),
            ("sphere", "Sphere Map", "Mirror ball seen from -Y (N x N)"),
        ],
        default="cube",
    )

    def draw(self, context):
        self.layout.prop(self, "default_layout")


classes = (GlossyPreferences,)
register, unregister = bpy.utils.register_classes_factory(classes)
