"""glossy.export_environment: the world's environment image as a cube/paraboloid/sphere EXR.

The image is exported as the world renders it (its Mapping node and Background
Strength applied, as a World Only probe is: glossy_addon.world.world_environment);
a world whose shader Glossy cannot reproduce exports the image as stored, and
the operator says so.
"""

import bpy
import numpy as np

from ..bake import envmap, exr
from ..bake.envmap import mip
from ..bake.errors import BakeError
from ..glossy_addon.paths import check_may_write, output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.world import (
    WorldNotReadable,
    find_environment_image,
    world_environment,
    world_pixels,
)


class GLOSSY_OT_export_environment(bpy.types.Operator):
    """Export the world's image as the world shows it (Mapping, Strength) to EXR files"""

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
            written, note = self._export(context, settings, image)
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        settings.last_export = str(written[0])
        if note:
            self.report({"WARNING"}, note)
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
        pixels = world_pixels(image)
        envmap.get_layout("latlong").check_image(pixels)
        try:  # the world as it renders: its Mapping node and Strength (as World Only)
            mapping = world_environment(context.scene.world)[1]
            note = None
        except WorldNotReadable as error:
            mapping = None
            note = f"Glossy exported the image as stored, not as the world shows it ({error})"
        levels = []
        with BlenderProgress(context, "export environment") as progress:
            transform = mapping.texture_directions if mapping and mapping.moves_directions \
                else None
            converted = envmap.convert(pixels, "latlong", layout, size, progress=progress,
                                       transform=transform)
            if mapping is not None and mapping.strength != 1.0:
                converted *= np.float32(mapping.strength)
            if pyramid != "none":
                levels = mip.pyramid(converted, layout, pyramid)[1:]
        meta = {
            "generator": "glossy-blender",
            "layout": layout,
            "size": size,
            "source": image.filepath or image.name,
        }
        if mapping is not None:
            meta["world_mapping"] = mapping.to_meta()
        outputs = [(path, converted, meta)]
        for index, level in enumerate(levels, start=1):
            level_path = path.with_name(f"{path.stem}.mip{index}.exr")
            outputs.append((level_path, level, {**meta, "mip_level": index, "mip_filter": pyramid}))
        for target_path, _, _ in outputs:
            check_may_write(target_path)
        for target_path, data, data_meta in outputs:
            exr.write(target_path, data, data_meta)
        return [p for p, _, _ in outputs], note


classes = (GLOSSY_OT_export_environment,)
