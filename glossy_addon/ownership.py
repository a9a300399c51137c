"""Whose file is it: probes and bakes that belong to one object or material.

Blender copies custom properties with the data: Shift+D / Alt+D copy an
object's ``probe_path``, a duplicated material (and the copy Glossy keeps of
the original) copies ``bake_path``. So a recorded path alone does not say
whose file it is. The rule:

- Capture and bake record the owner's name (``probe_owner``, ``bake_owner``)
  next to the path. An object or material *owns* its recorded file when its
  name is that owner, or when no other object or material records the file
  (a rename keeps ownership; a copy never takes it).
- A file name is *claimed* only if no other owner records it: Glossy never
  writes over a file another object or material owns (``Ball.1`` and
  ``Ball_1`` both clean to ``Ball_1``; the second gets ``Ball_1-2``).
- Every file an owner wrote is remembered (``*_history``), so Clear deletes
  exactly what that object's and material's bakes wrote, including files an
  earlier bake replaced, and a file still recorded by another owner never.
- A file's stamp (size and modification time at writing) tells a damaged or
  replaced file from the one Glossy wrote.
"""

import json
import os
from pathlib import Path

import bpy

from ..bake import exr, outputs
from ..bake.errors import BakeError
from .bookkeeping import stamp, stamps  # noqa: F401  (re-exported)

#: Files remembered per owner (older ones are forgotten, never deleted blindly).
HISTORY_LIMIT = 32


def resolved(path_text: str) -> Path | None:
    """The absolute Path of a recorded (possibly ``//``-relative) path, or None."""
    if not path_text:
        return None
    return Path(os.path.normpath(bpy.path.abspath(path_text)))


def damaged(path, recorded_stamp: str) -> bool:
    """True when the file at ``path`` is not the one Glossy recorded (truncated,
    rewritten or replaced), judged by its stamp; False without a stamp."""
    return bool(recorded_stamp) and stamp(path) != recorded_stamp


def is_glossy_file(path, recorded_stamp: str = "") -> bool:
    """True for a file Glossy wrote: its metadata says so (even a truncated EXR,
    see bake.outputs.written_by_glossy), or it is a damaged remnant of the file
    recorded with ``recorded_stamp`` (smaller than written, EXR magic or empty)."""
    if outputs.written_by_glossy(path):
        return True
    if not recorded_stamp:
        return False
    try:
        size = Path(path).stat().st_size
        with open(path, "rb") as handle:
            head = handle.read(4)
    except OSError:
        return False
    written_size = int(recorded_stamp.split(":", 1)[0] or 0)
    return size < written_size and exr.EXR_MAGIC.startswith(head)  # b"" too


# --- who records a file -----------------------------------------------------------
def _object_records(obj):
    settings = obj.glossy
    return [settings.probe_path] + history(settings, "probe_history")


def _material_records(material):
    settings = material.glossy
    return [settings.bake_path, settings.diffuse_path, settings.lamp_path,
            settings.runtime_path] + \
        [p for _, p, _ in settings.roughness_map_list()] + history(settings, "bake_history")


def holders(path) -> list:
    """Objects and materials whose *current* probe or bake paths name ``path``."""
    path = Path(path)
    found = []
    for obj in bpy.data.objects:
        if resolved(obj.glossy.probe_path) == path:
            found.append(obj)
    for material in bpy.data.materials:
        if path in _current(material):
            found.append(material)
    return found


def _owner_name(data) -> str:
    settings = data.glossy
    return settings.probe_owner if isinstance(data, bpy.types.Object) else settings.bake_owner


def owns(data, path) -> bool:
    """True if object or material ``data`` owns the file at ``path`` (see module doc)."""
    path = Path(path)
    others = [h for h in holders(path) if h != data]
    if _owner_name(data) == data.name:
        return True
    if any(_owner_name(h) == h.name for h in others):
        return False
    return not others


def owns_probe(obj) -> bool:
    path = resolved(obj.glossy.probe_path)
    return path is not None and owns(obj, path)


def read_only_problem(data) -> str | None:
    """Why Glossy cannot keep its state on ``data`` (an object or material), or None:
    data linked from a library, or a library override, is reloaded from its
    library when the file opens, so a probe, bake or lookup recorded on it (and
    the lookup's nodes) would be lost on the next open while the files stayed on
    disk. Make it local first."""
    library = data.library
    override = getattr(data, "override_library", None)
    if library is None and override is None and getattr(data, "is_editable", True):
        return None
    kind = "object" if isinstance(data, bpy.types.Object) else "material"
    if library is None and override is not None and override.reference is not None:
        library = override.reference.library
    where = f" from {bpy.path.basename(library.filepath)}" if library is not None else ""
    how = "a library override" if override is not None else "linked"
    return (f"{data.name} is {how}{where}: Blender reloads a linked {kind} from its library "
            f"when the file opens, so what Glossy records on it would be lost; make it local "
            f"first (Object > Relations > Make Local)")


def probe_problem(obj) -> str | None:
    """Why ``obj``'s recorded probe is not its own (a copy's), or None."""
    path = resolved(obj.glossy.probe_path)
    if path is None or owns(obj, path):
        return None
    owners = [h.name for h in holders(path) if h != obj and isinstance(h, bpy.types.Object)]
    whose = f"{owners[0]}'s" if owners else "another object's"
    return (f"{obj.name} holds {whose} probe ({path.name}), copied with the object: "
            f"capture a probe for {obj.name} first")


def _current(data) -> list:
    settings = data.glossy
    if isinstance(data, bpy.types.Object):
        return [resolved(settings.probe_path)]
    return [resolved(settings.bake_path), resolved(settings.diffuse_path),
            resolved(settings.lamp_path), resolved(settings.runtime_path)] + \
        [resolved(p) for _, p, _ in settings.roughness_map_list()]


def used_by_other_owner(path, data) -> str | None:
    """Name of an object or material other than ``data`` that owns ``path``: as
    its current probe or bake, or in the history of files it wrote (only an
    owner under its own name counts there: a copy's history is inherited)."""
    path = Path(path)
    for other in list(bpy.data.objects) + list(bpy.data.materials):
        if other == data:
            continue
        if path in _current(other):
            if owns(other, path):
                return other.name
        elif _owner_name(other) == other.name:
            records = _object_records(other) if isinstance(other, bpy.types.Object) \
                else _material_records(other)
            if any(resolved(text) == path for text in records if text):
                return other.name
    return None


# --- naming -----------------------------------------------------------------------
def claim(folder: Path, stem: str, suffix: str, data, taken=()) -> Path:
    """A path ``folder/stem[-n]suffix`` (``suffix`` such as ``_probe.exr``) that
    ``data`` may write: not recorded by
    another owner, not in ``taken`` (paths planned in the same run), and either
    absent or a file Glossy wrote. Raises BakeError for a user's file."""
    for index in range(1, 1000):
        name = stem if index == 1 else f"{stem}-{index}"
        path = Path(os.path.normpath(folder / f"{name}{suffix}"))
        if path in taken or used_by_other_owner(path, data):
            continue
        if path.is_dir():
            raise BakeError(f"{path} is a directory; Glossy's file would go there")
        if path.exists() and not outputs.written_by_glossy(path):
            raise BakeError(f"{path} exists and was not written by Glossy; not overwriting it")
        return path
    raise BakeError(f"{folder}: no free file name for {stem}{suffix}")


# --- history ----------------------------------------------------------------------
def history(settings, attribute: str) -> list:
    """Paths an owner wrote before (JSON list in a string property)."""
    try:
        values = json.loads(getattr(settings, attribute) or "[]")
    except ValueError:
        return []
    return [v for v in values if isinstance(v, str)]


def remember(settings, attribute: str, *paths) -> None:
    """Add written paths to an owner's history (most recent last)."""
    values = [v for v in history(settings, attribute) if v not in paths]
    values += [str(p) for p in paths if p]
    setattr(settings, attribute, json.dumps(values[-HISTORY_LIMIT:]))


def object_files(obj) -> list:
    """Files ``obj``'s captures wrote that it still owns (current first)."""
    return _owned_files(obj, _object_records(obj))


def material_files(material) -> list:
    """Files ``material``'s bakes wrote that it still owns (current first)."""
    return _owned_files(material, _material_records(material))


def _owned_files(data, records) -> list:
    files = []
    current = resolved(records[0]) if records else None
    if current is not None and not owns(data, current):
        return []  # a copy: its records are another owner's files
    for text in records:
        path = resolved(text)
        if path is None or path in files or used_by_other_owner(path, data):
            continue
        files.append(path)
    return files


def material_users(material) -> list:
    """Mesh objects with ``material`` in one of their slots."""
    return [obj for obj in bpy.data.objects if obj.type == "MESH" and
            any(slot.material == material for slot in obj.material_slots)]


def object_copy(material, obj):
    """Give ``obj`` its own copy of ``material`` (``<material> (<obj>)``, Glossy
    settings and user nodes copied, ``copy_of`` naming the source) in every slot
    of ``obj`` that holds ``material``; a slot linked to mesh data that other
    objects share is switched to an object link, so their slots stay as they
    were. Returns the copy."""
    copy = material.copy()
    copy.name = f"{material.name} ({obj.name})"
    copy.use_fake_user = False
    copy.glossy.copy_of = material.glossy.copy_of or material.name
    shared_mesh = obj.data.users > 1
    for slot in obj.material_slots:
        if slot.material != material:
            continue
        if slot.link == "DATA" and shared_mesh:
            slot.link = "OBJECT"
        slot.material = copy
    return copy


def needs_own_copy(material, obj) -> bool:
    """True when baking ``obj``'s probe into ``material`` would change the look of
    another object: the material is also used by objects with probes of their
    own that differ from ``obj``'s, and its current bake is not ``obj``'s (a
    bake made for ``obj`` stays; the others take copies when they bake)."""
    return bool(shared_probe_users(material, obj)) and \
        material.glossy.bake_object != obj.name


def shared_probe_users(material, obj) -> list:
    """Other objects using ``material`` that have a probe of their own, different
    from ``obj``'s: they will all show ``obj``'s bake (one material, one map)."""
    mine = resolved(obj.glossy.probe_path)
    return [other.name for other in material_users(material) if other != obj
            and owns_probe(other) and resolved(other.glossy.probe_path) != mine]
