"""The operators under hostile but realistic use (issue 15), driven as a script would.

    python hostile_operators.py WORKDIR HDRI RESULT.json

Each case records the operator's result, its report (ERROR reports raise
RuntimeError in background mode; warnings and info go to stdout, captured
here), the Glossy state and the folder's files, for the test to check.
"""

import hashlib
import json
import os
import sys
import tempfile
import traceback
from pathlib import Path

import _checkout  # noqa: F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))
from tests.conftest import read_only_folder  # noqa: E402

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
folder = workdir / "glossy"
report = {}


def call(operator, **kwargs):
    """(sorted result, report text) of one operator call; stdout captured."""
    sys.stdout.flush()
    with tempfile.TemporaryFile(mode="w+") as capture:
        saved = os.dup(1)
        os.dup2(capture.fileno(), 1)
        try:
            result, error = sorted(operator(**kwargs)), ""
        except RuntimeError as failure:
            result, error = ["CANCELLED"], str(failure).strip()
        finally:
            sys.stdout.flush()
            os.dup2(saved, 1)
            os.close(saved)
        capture.seek(0)
        text = capture.read()
    return result, (error + "\n" + text).strip()


def files():
    return sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def select_only(*objects):
    bpy.ops.object.select_all(action="DESELECT")
    for obj in objects:
        obj.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]


def ball(name, x, material):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=16, ring_count=8, location=(x, 0.0, 0.0))
    obj = bpy.context.object
    obj.name = name
    obj.data.materials.append(material)
    obj.glossy.probe_source = "WORLD"
    obj.glossy.probe_size_mode = "FIXED"
    obj.glossy.probe_resolution = 16
    return obj


def shiny(name, **settings):
    material = bpy.data.materials.new(name)
    material.use_nodes = True
    glossy_settings = material.glossy
    glossy_settings.model = "ggx"
    glossy_settings.roughness = 0.4
    glossy_settings.slices = 3
    glossy_settings.size_mode = "FIXED"
    glossy_settings.map_size = 8
    for key, value in settings.items():
        setattr(glossy_settings, key, value)
    return material


def captured(object_name, material_name, **settings):
    """(material, object): a new ball with a new Glossy material, selected alone,
    its World probe captured."""
    material = shiny(material_name, **settings)
    obj = ball(object_name, 0.0, material)
    select_only(obj)
    call(bpy.ops.glossy.capture_probes)
    return material, obj


def case(function):
    try:
        report[function.__name__] = function()
    except Exception:  # noqa: BLE001 - recorded for the test to show
        report[function.__name__] = {"crashed": traceback.format_exc()}
    return function


bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
environment_world(bpy.context.scene, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))


@case
def duplicates():
    """Shift+D and Alt+D after capture: the copies hold the original's probe path."""
    original = ball("Ball", 0.0, shiny("Shiny"))
    select_only(original)
    out = {"capture": call(bpy.ops.glossy.capture_probes),
           "bake": call(bpy.ops.glossy.bake_materials)}
    probe, bake = original.glossy.probe_path, bpy.data.materials["Shiny"].glossy.bake_path
    hashes = (digest(probe), digest(bake))
    bpy.ops.object.duplicate()  # Shift+D
    copy = bpy.context.object
    bpy.ops.object.duplicate(linked=True)  # Alt+D of the copy
    linked = bpy.context.object
    out["copy_holds_path"] = copy.glossy.probe_path == probe == linked.glossy.probe_path
    select_only(copy)
    out["bake_copy"] = call(bpy.ops.glossy.bake_materials)
    select_only(linked)
    out["bake_linked"] = call(bpy.ops.glossy.bake_materials)
    out["material_bake_unchanged"] = bpy.data.materials["Shiny"].glossy.bake_path == bake
    select_only(copy)
    out["clear_copy"] = call(bpy.ops.glossy.clear)
    out["after_clear"] = {
        "original_files": [Path(probe).exists(), Path(bake).exists()],
        "original_unchanged": (digest(probe), digest(bake)) == hashes,
        "original_probe_path": original.glossy.probe_path == probe,
        "material_bake_path": bpy.data.materials["Shiny"].glossy.bake_path == bake,
        "copy_probe_path": copy.glossy.probe_path}
    out["capture_copy"] = call(bpy.ops.glossy.capture_probes)
    out["copy_own_probe"] = Path(copy.glossy.probe_path).name
    out["original_probe_unchanged"] = digest(probe) == hashes[0]
    select_only(copy)
    out["bake_copy_after_capture"] = call(bpy.ops.glossy.bake_materials)
    for obj in (original, copy, linked):
        select_only(obj)
        bpy.ops.glossy.clear()
    return out


@case
def similar_names():
    """Ball.1 and Ball_1 clean to the same file name."""
    material = shiny("Names")
    first, second = ball("Ball.1", 0.0, material), ball("Ball_1", 3.0, material)
    select_only(first, second)
    out = {"capture": call(bpy.ops.glossy.capture_probes)}
    paths = [first.glossy.probe_path, second.glossy.probe_path]
    out["distinct"] = len(set(paths)) == 2
    out["objects_in_files"] = [exr.read(p)[1]["object"] for p in paths]
    out["names"] = [Path(p).name for p in paths]
    select_only(second)  # captured again alone: keeps its own file, not the other's
    before = digest(paths[0])
    out["again"] = call(bpy.ops.glossy.capture_probes)
    out["again_path_same"] = second.glossy.probe_path == paths[1]
    out["other_unchanged"] = digest(paths[0]) == before
    select_only(first, second)
    out["clear"] = call(bpy.ops.glossy.clear)
    out["left"] = [Path(p).exists() for p in paths]
    return out


@case
def shared_material():
    """One material on two objects with probes of their own: each object that bakes
    gets its own copy, so each reflects its own probe."""
    material = shiny("Shared")
    a, b = ball("A", 0.0, material), ball("B", 3.0, material)
    select_only(a, b)
    call(bpy.ops.glossy.capture_probes)
    select_only(a)
    out = {"bake_a": call(bpy.ops.glossy.bake_materials)}
    select_only(b)
    out["bake_b"] = call(bpy.ops.glossy.bake_materials)
    mats = {obj.name: obj.material_slots[0].material for obj in (a, b)}
    out["materials"] = {name: m.name for name, m in mats.items()}
    out["baked_for"] = {m.name: m.glossy.bake_object for m in mats.values()}
    out["copy_of"] = {m.name: m.glossy.copy_of for m in mats.values()}
    a_bake, b_bake = mats["A"].glossy.bake_path, mats["B"].glossy.bake_path
    out["bakes_exist"] = [Path(a_bake).exists(), Path(b_bake).exists(), a_bake != b_bake]
    select_only(a)
    out["clear_a"] = call(bpy.ops.glossy.clear)
    out["after_a"] = {"a_bake": Path(a_bake).exists(), "b_bake": Path(b_bake).exists(),
                      "b_path": mats["B"].glossy.bake_path == b_bake,
                      "b_probe": Path(b.glossy.probe_path).exists()}
    select_only(b)
    out["clear_b"] = call(bpy.ops.glossy.clear)
    out["after_b"] = [Path(b_bake).exists(), mats["B"].glossy.bake_path]
    out["files"] = [f for f in files() if f.startswith(("A_", "B_"))]
    return out


@case
def read_only_clear():
    """Clear when //glossy/ cannot be written: nothing changes, one error."""
    material, obj = captured("Locked", "Locked")
    call(bpy.ops.glossy.bake_materials)
    call(bpy.ops.glossy.attach_materials)
    state = (obj.glossy.probe_path, bpy.data.materials["Locked"].glossy.bake_path)
    listing = files()
    try:
        with read_only_folder(folder):
            out = {"clear": call(bpy.ops.glossy.clear)}
    except BaseException as skip:  # pytest.skip: no way to make a folder read-only
        if type(skip).__name__ != "Skipped":
            raise
        return {"skipped": str(skip)}
    material = bpy.data.materials["Locked"]
    out["unchanged"] = {
        "paths": (obj.glossy.probe_path, material.glossy.bake_path) == state,
        "lookup_kept": material.glossy.original is not None,
        "files": files() == listing}
    out["clear_writable"] = call(bpy.ops.glossy.clear)
    out["files_after"] = [f for f in files() if f.startswith("Locked")]
    return out


@case
def user_file_at_diffuse_path():
    material, obj = captured("Dif", "DifMat", diffuse=(0.2, 0.2, 0.2))
    user = folder / "Dif_DifMat_diffuse.exr"
    user.write_bytes(b"the user's own file")
    out = {"bake": call(bpy.ops.glossy.bake_materials),
           "user_file": user.read_bytes() == b"the user's own file",
           "bake_path": material.glossy.bake_path,
           "files": [f for f in files() if f.startswith("Dif_DifMat")]}
    user.unlink()
    bpy.ops.glossy.clear()
    return out


@case
def truncated_bake():
    material, obj = captured("Cut", "CutMat")
    call(bpy.ops.glossy.bake_materials)
    path = Path(material.glossy.bake_path)
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])
    out = {"status": bake_status(material.glossy, obj.glossy.probe_path),
           "attach": call(bpy.ops.glossy.attach_materials),
           "rebake": call(bpy.ops.glossy.bake_materials)}
    out["status_after"] = bake_status(material.glossy, obj.glossy.probe_path)
    out["readable_after"] = exr.read(path)[0].shape[0] > 0
    path.write_bytes(path.read_bytes()[:40])  # cut inside the header
    out["clear"] = call(bpy.ops.glossy.clear)
    out["exists_after_clear"] = path.exists()
    return out


@case
def refused_settings():
    """Settings refused before any file is written."""
    out = {}
    material, _ = captured("Refused", "Refused")
    settings = material.glossy
    settings.slices, settings.map_size = 256, 64  # 256 x 66 rows = 16,896 > 16,384
    out["atlas"] = call(bpy.ops.glossy.bake_materials)
    settings.slices, settings.lobes, settings.map_size = 16, 4, 512
    out["atlas_lobes"] = call(bpy.ops.glossy.bake_materials)
    settings.slices, settings.size_mode = 256, "AUTO"  # 256 x 4 lobes: too tall at any size
    out["atlas_auto"] = call(bpy.ops.glossy.bake_materials)
    settings.size_mode = "FIXED"
    settings.slices, settings.lobes, settings.map_size = 3, 1, 8
    settings.fresnel_ior = 0.5
    out["fresnel"] = call(bpy.ops.glossy.bake_materials)
    settings.fresnel_ior = 0.0
    settings.model, settings.spec = "CUSTOM", "sum(" * 400 + "lambert" + ")" * 400
    out["nested"] = call(bpy.ops.glossy.bake_materials)
    settings.model = "ggx"
    settings.map_size = 2048
    out["map_size_max"] = settings.map_size
    out["files"] = [f for f in files() if f.startswith("Refused_Refused")]
    bpy.ops.glossy.clear()
    return out


@case
def linked_library():
    """An object and a material linked from a library .blend (read-only: Blender
    reloads them from the library on open, so Glossy's records would be lost)."""
    out = {}
    material = shiny("LibMetal")
    obj = ball("LibBall", 3.0, material)
    library = workdir / "library.blend"
    bpy.data.libraries.write(str(library), {obj, material}, fake_user=True)
    bpy.data.objects.remove(obj)
    bpy.data.materials.remove(material)
    with bpy.data.libraries.load(str(library), link=True) as (_, linked):
        linked.objects, linked.materials = ["LibBall"], ["LibMetal"]
    obj, material = bpy.data.objects["LibBall"], bpy.data.materials["LibMetal"]
    bpy.context.scene.collection.objects.link(obj)
    select_only(obj)
    out["capture_linked"] = call(bpy.ops.glossy.capture_probes)
    local = ball("Local", -3.0, material)  # a local object with the linked material
    select_only(local)
    out["capture_local"] = call(bpy.ops.glossy.capture_probes)
    out["bake"] = call(bpy.ops.glossy.bake_materials)
    out["attach"] = call(bpy.ops.glossy.attach_materials)
    out["files"] = files()
    out["bake_path"] = material.glossy.bake_path
    out["nodes"] = len(material.node_tree.nodes)
    out["clear"] = call(bpy.ops.glossy.clear)
    for each in (obj, local):
        bpy.data.objects.remove(each)
    return out


report["leftovers"] = [f for f in files() if ".partial" in f or "glossy-clear" in f]
report["all_files"] = files()
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
