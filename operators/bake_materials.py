"""glossy.bake_materials and glossy.attach_materials: the active object's Glossy materials."""

import time

import bpy

from ..bake import atlas, exr, prefilter
from ..bake.errors import BakeError
from ..glossy_addon.bookkeeping import bake_inputs_hash, bake_status
from ..glossy_addon.nodes import build_lookup, load_atlas
from ..glossy_addon.paths import check_may_write, output_folder
from ..glossy_addon.progress import BlenderProgress


def _object_with_probe(context):
    obj = context.object
    if obj is None or obj.type != "MESH":
        return None, "Select a mesh object"
    if not obj.material_slots or not any(slot.material for slot in obj.material_slots):
        return None, "The object has no material"
    return obj, None


def _materials(obj):
    seen, out = set(), []
    for slot in obj.material_slots:
        if slot.material is not None and slot.material.name not in seen:
            seen.add(slot.material.name)
            out.append(slot.material)
    return out


class _MaterialsOperator:
    """poll() shared by the operators that work on the active object's materials."""

    @classmethod
    def poll(cls, context):
        obj, message = _object_with_probe(context)
        if obj is None:
            cls.poll_message_set(message)
            return False
        return True


class GLOSSY_OT_bake_materials(_MaterialsOperator, bpy.types.Operator):
    """Prefilter the object's probe for each of its materials' BRDFs (skips up-to-date bakes)"""

    bl_idname = "glossy.bake_materials"
    bl_label = "Bake Materials"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj, _ = _object_with_probe(context)
        probe_path = obj.glossy.probe_path
        try:
            if not probe_path:
                raise BakeError(f"{obj.name} has no probe yet: capture one first")
            probe, meta = exr.read(bpy.path.abspath(probe_path))
            folder = output_folder()
            baked_count = 0
            with BlenderProgress(context, "bake materials") as progress:
                materials = _materials(obj)
                for index, material in enumerate(materials):
                    settings = material.glossy
                    if not 4 <= settings.map_size <= 2048:
                        raise BakeError(f"{material.name}: map size must be in [4, 2048], "
                                        f"not {settings.map_size}")
                    if bake_status(settings, probe_path) == "up to date":
                        continue
                    path = folder / f"{bpy.path.clean_name(obj.name)}_" \
                                    f"{bpy.path.clean_name(material.name)}_3d.exr"
                    check_may_write(path)
                    baked = prefilter.prefilter(probe, settings.brdf_spec(), "3d",
                                                settings.map_size, slices=settings.slices,
                                                layout=meta.get("layout", "cube"))
                    image, atlas_meta = atlas.pack(baked)
                    atlas_meta.update({"generator": "glossy-blender", "probe": probe_path,
                                       "material": material.name})
                    exr.write(path, image, atlas_meta)
                    settings.bake_path = str(path)
                    settings.bake_hash = bake_inputs_hash(settings, probe_path)
                    settings.bake_time = time.time()
                    baked_count += 1
                    progress((index + 1) / len(materials), f"baked {material.name}")
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Glossy baked {baked_count} material(s)")
        return {"FINISHED"}


class GLOSSY_OT_attach_materials(_MaterialsOperator, bpy.types.Operator):
    """Rebuild each baked material's nodes as the Glossy 3D-map lookup (EEVEE and Cycles)"""

    bl_idname = "glossy.attach_materials"
    bl_label = "Attach Lookups"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        obj, _ = _object_with_probe(context)
        attached = 0
        try:
            for material in _materials(obj):
                path = material.glossy.bake_path
                if not path:
                    continue
                image_data, meta = exr.read(path)
                build_lookup(material, load_atlas(path), meta)
                attached += 1
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        if not attached:
            self.report({"ERROR"}, "No baked material to attach: bake first")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Glossy attached {attached} material(s)")
        return {"FINISHED"}


classes = (GLOSSY_OT_bake_materials, GLOSSY_OT_attach_materials)
