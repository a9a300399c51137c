"""glossy.export_environment: the world's environment image as a cube/paraboloid/sphere EXR."""

import bpy

from ..bake import envmap, exr
from ..bake.envmap import mip
from ..bake.errors import BakeError
from ..glossy_addon.paths import check_may_write, output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.world import find_environment_image, image_pixels


class GLOSSY_OT_export_environment(bpy.types.Operator):
    """Convert the world's environment image to the chosen layout (and MIP pyramid) as EXR files"""

    bl_idname = "glossy.export_environment"
    bl_label = "Export Environment Map"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        if context.scene is None or context.scene.world is None:
            cls.poll_message_set("The scene has no world")
            return False
        if find_environment_image(context.scene.world) is None:
            cls.poll_message_set("The world has no Environment Texture with an image")
            return False
        return True

    def execute(self, context):
        settings = context.scene.glossy
        image = find_environment_image(context.scene.world)
        try:
            written = self._export(context, settings, image)
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        settings.last_export = str(written[0])
        self.report({"INFO"}, f"Glossy wrote {len(written)} file(s) to {written[0].parent}")
        return {"FINISHED"}

    @staticmethod
    def _export(context, settings, image):
        layout, size, pyramid = settings.export_layout, settings.export_size, settings.export_mip
        target = envmap.get_layout(layout)
        target.shape(size)
        if pyramid != "none" and layout not in ("cube", "latlong"):
            raise BakeError("MIP pyramids are built for cube and lat-long maps only")
        folder = output_folder()
        stem = bpy.path.clean_name(image.name.rsplit(".", 1)[0])
        path = folder / f"{stem}_{layout}{size}.exr"
        pixels = image_pixels(image)
        envmap.get_layout("latlong").check_image(pixels)
        levels = []
        with BlenderProgress(context, "export environment") as progress:
            converted = envmap.convert(pixels, "latlong", layout, size, progress=progress)
            if pyramid != "none":
                levels = mip.pyramid(converted, layout, pyramid)[1:]
        meta = {
            "generator": "glossy-blender",
            "layout": layout,
            "size": size,
            "source": image.filepath or image.name,
        }
        outputs = [(path, converted, meta)]
        for index, level in enumerate(levels, start=1):
            level_path = path.with_name(f"{path.stem}.mip{index}.exr")
            outputs.append((level_path, level, {**meta, "mip_level": index, "mip_filter": pyramid}))
        for target_path, _, _ in outputs:
            check_may_write(target_path)
        for target_path, data, data_meta in outputs:
            exr.write(target_path, data, data_meta)
        return [p for p, _, _ in outputs]


classes = (GLOSSY_OT_export_environment,)
