"""glossy.clear: undo Glossy on the selected objects (probes, bakes, lookups)."""

from pathlib import Path

import bpy

from ..glossy_addon.materials import restore_original
from ..glossy_addon.paths import written_by_glossy


def _meshes(context):
    objects = [obj for obj in context.selected_objects if obj.type == "MESH"]
    active = context.object
    if active is not None and active.type == "MESH" and active not in objects:
        objects.append(active)
    return objects


class GLOSSY_OT_clear(bpy.types.Operator):
    """Remove Glossy's probes, bakes and lookups from the selected objects (files Glossy did
    not write are never deleted)"""

    bl_idname = "glossy.clear"
    bl_label = "Clear"
    bl_options = {"REGISTER", "UNDO"}

    probes: bpy.props.BoolProperty(name="Probes", default=True,
                                   description="Forget the objects' captured probes")
    bakes: bpy.props.BoolProperty(name="Bakes", default=True,
                                  description="Forget the materials' baked maps")
    lookups: bpy.props.BoolProperty(
        name="Lookups", default=True,
        description="Put back each material as it was before Glossy attached its lookup")
    delete_files: bpy.props.BoolProperty(
        name="Delete Files", default=True,
        description="Delete the forgotten files, if Glossy wrote them")

    @classmethod
    def poll(cls, context):
        if not _meshes(context):
            cls.poll_message_set("Select mesh objects")
            return False
        return True

    def _forget(self, path_text, counts):
        """Delete one forgotten file if it is Glossy's; drop images loaded from it."""
        if not path_text:
            return
        path = Path(bpy.path.abspath(path_text))
        for image in list(bpy.data.images):
            if image.filepath and Path(bpy.path.abspath(image.filepath)) == path \
                    and image.users == 0:
                bpy.data.images.remove(image)
        if not self.delete_files or not path.exists():
            return
        if written_by_glossy(path):
            path.unlink()
            counts["deleted"] += 1
        else:
            counts["kept"].append(path.name)

    def execute(self, context):
        counts = {"deleted": 0, "kept": [], "restored": 0, "objects": 0}
        seen = set()
        for obj in _meshes(context):
            counts["objects"] += 1
            if self.probes and obj.glossy.probe_path:
                probe = obj.glossy.probe_path
                obj.glossy.probe_path = ""
                self._forget(probe, counts)
            for slot in obj.material_slots:
                material = slot.material
                if material is None or material.name in seen:
                    continue
                if self.lookups and material.glossy.original is not None:
                    material = restore_original(material)
                    counts["restored"] += 1
                seen.add(material.name)
                if self.bakes:
                    settings = material.glossy
                    paths = [settings.bake_path, settings.diffuse_path]
                    settings.bake_path = settings.diffuse_path = settings.bake_hash = ""
                    settings.bake_time = 0.0
                    for path in paths:
                        self._forget(path, counts)
        message = (f"Glossy cleared {counts['objects']} object(s): {counts['deleted']} file(s) "
                   f"deleted, {counts['restored']} material(s) restored")
        if counts["kept"]:
            self.report({"WARNING"}, message + "; not written by Glossy, kept: "
                        + ", ".join(counts["kept"]))
        else:
            self.report({"INFO"}, message)
        return {"FINISHED"}


classes = (GLOSSY_OT_clear,)
