"""glossy.clear: undo Glossy on the selected objects (probes, bakes, lookups)."""

import os

import bpy

from ..glossy_addon import ownership
from ..glossy_addon.materials import restore_original


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

    def _plan(self, objects):
        """(files to delete {path: stamp}, changes to apply [callables], kept [notes]).

        Nothing is changed here. A copy's probe (Shift+D, Alt+D) and a shared
        material showing the bake of an object outside the selection are left
        alone and said so; files another owner still records are never listed."""
        files, changes, kept, seen = {}, [], [], set()
        names = {obj.name for obj in objects}
        for obj in objects:
            settings = obj.glossy
            if self.probes and settings.probe_path:
                if ownership.owns_probe(obj):
                    written = ownership.stamps(settings.probe_stamp)
                    for path in ownership.object_files(obj):
                        files[path] = written.get(str(path), "")
                else:
                    kept.append(ownership.probe_problem(obj).split(",")[0] + " (a copy's)")
                changes.append(lambda obj=obj: _forget_probe(obj))
            for slot in obj.material_slots:
                material = slot.material
                if material is None or material.name in seen:
                    continue
                seen.add(material.name)
                glossy = material.glossy
                baked_for = glossy.bake_object
                baked = glossy.bake_path or glossy.lamp_path
                if baked and baked_for and baked_for not in names and \
                        baked_for in bpy.data.objects:
                    kept.append(f"{material.name} (it shows {baked_for}'s bake; clear "
                                f"{baked_for} to remove it)")
                    continue
                if self.bakes:
                    written = ownership.stamps(glossy.bake_stamp)
                    for path in ownership.material_files(material):
                        files[path] = written.get(str(path), "")
                changes.append(lambda name=material.name: self._clear_material(name))
        return files, changes, kept

    def _clear_material(self, name):
        material = bpy.data.materials[name]
        if self.lookups:
            restored = restore_original(material)
            if restored is not None:
                material = restored
                self._counts["restored"] += 1
        if self.bakes:
            glossy = material.glossy
            glossy.bake_path = glossy.diffuse_path = glossy.lamp_path = glossy.bake_hash = ""
            glossy.roughness_maps = glossy.runtime_path = ""
            glossy.lamp_set = glossy.lamp_skipped = glossy.emission_set = ""
            glossy.lamp_error = -1.0
            glossy.bake_owner = glossy.bake_probe = glossy.bake_object = ""
            glossy.bake_stamp = glossy.bake_history = ""
            glossy.bake_time = 0.0

    def execute(self, context):
        objects = _meshes(context)
        self._counts = {"restored": 0}
        files, changes, kept = self._plan(objects)
        doomed, foreign = [], []
        if self.delete_files:
            for path, written in files.items():
                if not path.exists():
                    continue
                if ownership.is_glossy_file(path, written):
                    doomed.append(path)
                else:
                    foreign.append(path.name)
        try:
            trash = _move_aside(doomed)  # all or none: nothing is changed if one fails
        except OSError as error:
            self.report({"ERROR"}, f"Glossy cannot delete {error.filename} "
                        f"({error.strerror}); nothing was cleared")
            return {"CANCELLED"}
        for change in changes:
            change()
        for moved in trash:
            try:
                moved.unlink()
            except OSError:  # pragma: no cover - the folder changed meanwhile
                pass
        _drop_unused_images(files)
        message = (f"Glossy cleared {len(objects)} object(s): {len(doomed)} file(s) deleted, "
                   f"{self._counts['restored']} material(s) restored")
        notes = []
        if foreign:
            notes.append("not written by Glossy, kept: " + ", ".join(foreign))
        if kept:
            notes.append("left alone: " + "; ".join(kept))
        if notes:
            self.report({"WARNING"}, message + "; " + "; ".join(notes))
        else:
            self.report({"INFO"}, message)
        return {"FINISHED"}


def _forget_probe(obj):
    settings = obj.glossy
    settings.probe_path = settings.probe_owner = settings.probe_stamp = ""
    settings.probe_history = ""


def _move_aside(paths):
    """Rename each file to a hidden name beside it; on the first failure put the
    moved ones back and raise the OSError (so a read-only folder changes nothing)."""
    moved = []
    try:
        for path in paths:
            aside = path.with_name(f".{path.name}.glossy-clear")
            os.replace(path, aside)
            moved.append((aside, path))
    except OSError:
        for aside, path in reversed(moved):
            os.replace(aside, path)
        raise
    return [aside for aside, _ in moved]


def _drop_unused_images(paths):
    """Remove Blender images loaded from deleted files that nothing uses any more."""
    paths = set(paths)
    for image in list(bpy.data.images):
        if image.filepath and image.users == 0 and \
                ownership.resolved(image.filepath) in paths:
            bpy.data.images.remove(image)


classes = (GLOSSY_OT_clear,)
