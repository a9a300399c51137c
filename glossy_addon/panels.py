"""The Glossy tab of the 3D viewport sidebar."""

import bpy

from .world import find_environment_image


class GLOSSY_PT_environment(bpy.types.Panel):
    bl_label = "Environment"
    bl_idname = "GLOSSY_PT_environment"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Glossy"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.glossy
        image = find_environment_image(context.scene.world)
        if image is None:
            layout.label(text="World has no Environment Texture image", icon="INFO")
        else:
            layout.label(text=f"{image.name} ({image.size[0]}x{image.size[1]})", icon="WORLD")
        column = layout.column(align=True)
        column.prop(settings, "export_layout")
        column.prop(settings, "export_size")
        column.prop(settings, "export_mip")
        layout.operator("glossy.export_environment", icon="EXPORT")
        if settings.last_export:
            layout.label(text=bpy.path.basename(settings.last_export), icon="FILE_IMAGE")


classes = (GLOSSY_PT_environment,)
register, unregister = bpy.utils.register_classes_factory(classes)
