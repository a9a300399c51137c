"""Settings saved in the .blend: ``Scene.glossy``."""

import bpy

LAYOUT_ITEMS = [
    ("cube", "Cube", "OpenGL cube strip (N x 6N) in glTF's Y-up frame"),
    ("latlong", "Lat-Long", "Blender's Environment Texture layout (N x 2N)"),
    ("paraboloid", "Dual Paraboloid", "Front +Z, back -Z, extended [-1, 1]^2 domain (N x 2N)"),
    ("sphere", "Sphere Map", "Mirror ball seen from -Y, +Z up (N x N)"),
]

MIP_ITEMS = [
    ("none", "None", "Only the converted map"),
    ("box", "Box 2x2", "Solid-angle-weighted 2x2 box pyramid"),
    ("gauss4", "Gaussian 4x4", "Binomial 4x4 pyramid with cross-face borders"),
    ("gauss6", "Gaussian 6x6", "Binomial 6x6 pyramid with cross-face borders"),
]


class GlossySceneSettings(bpy.types.PropertyGroup):
    export_layout: bpy.props.EnumProperty(
        name="Layout", description="Parameterization of the exported map", items=LAYOUT_ITEMS
    )
    export_size: bpy.props.IntProperty(
        name="Size",
        description="Map size N: cube faces N x N, lat-long N x 2N, paraboloid halves N x N",
        default=256,
        min=2,
        soft_max=2048,
        max=8192,
    )
    export_mip: bpy.props.EnumProperty(
        name="MIP Pyramid", description="Also write a MIP pyramid (cube and lat-long)",
        items=MIP_ITEMS, default="none",
    )
    last_export: bpy.props.StringProperty(
        name="Last Export", description="File written by the last export", subtype="FILE_PATH"
    )

    @classmethod
    def register(cls):
        bpy.types.Scene.glossy = bpy.props.PointerProperty(type=cls)

    @classmethod
    def unregister(cls):
        del bpy.types.Scene.glossy


classes = (GlossySceneSettings,)
register, unregister = bpy.utils.register_classes_factory(classes)
