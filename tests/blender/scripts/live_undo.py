"""Undo after capture, bake and attach, and Esc within a second of a large bake,
in a live Blender window (undo does not run headless).

    xvfb-run blender --enable-event-simulate --python live_undo.py -- WORKDIR RESULT.json HDRI

Runs with the Glossy extension installed in the user directory. The
operators run as a click would (INVOKE_DEFAULT in the 3D viewport); undo and
redo are Blender's own operators in the same window. After each undo the
object's and the material's Glossy state and the material's nodes are
compared with the state recorded before the undone step.
"""

import sys
import time
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _live import run, viewport_override, wait_until  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
workdir, result_path, hdri = Path(args[0]), Path(args[1]), args[2]
report = {}

OBJECT_KEYS = ("probe_path", "probe_owner", "probe_stamp", "probe_reason")
MATERIAL_KEYS = ("bake_path", "bake_hash", "bake_owner", "bake_object", "chosen_size")


def state():
    """The Glossy state a user sees (read afresh: undo replaces the data)."""
    cube = bpy.data.objects["Cube"]
    slot = cube.material_slots[0].material
    return {
        "object": {key: getattr(cube.glossy, key) for key in OBJECT_KEYS},
        "material": slot.name,
        "settings": {key: getattr(slot.glossy, key) for key in MATERIAL_KEYS},
        "original": slot.glossy.original.name if slot.glossy.original else None,
        "nodes": sorted(node.bl_idname for node in slot.node_tree.nodes),
        "materials": sorted(m.name for m in bpy.data.materials),
    }




def running(window):
    return [op.bl_idname for op in window.modal_operators]




def scenario():
    window, override = viewport_override()
    report["background"] = bpy.app.background
    world = bpy.context.scene.world
    world.use_nodes = True
    texture = world.node_tree.nodes.new("ShaderNodeTexEnvironment")
    texture.image = bpy.data.images.load(hdri)
    world.node_tree.links.new(texture.outputs["Color"],
                              world.node_tree.nodes["Background"].inputs["Color"])
    cube = bpy.data.objects["Cube"]
    cube.glossy.probe_source = "WORLD"
    cube.glossy.probe_size_mode = "FIXED"
    cube.glossy.probe_resolution = 16
    material = cube.material_slots[0].material
    material.glossy.model, material.glossy.method = "ggx", "3d"  # the same in Blender 4.x
    material.glossy.slices = 3
    material.glossy.size_mode = "FIXED"
    material.glossy.map_size = 8
    bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
    with bpy.context.temp_override(**override):
        bpy.ops.ed.undo_push(message="Glossy settings")
    states = [state()]

    # Capture, bake and attach as a click would; each is one undo step.
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.capture_probes("INVOKE_DEFAULT")
    yield from wait_until(lambda: not running(window) and
                          bpy.data.objects["Cube"].glossy.probe_path)
    states.append(state())
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.bake_materials("INVOKE_DEFAULT")
    yield from wait_until(lambda: not running(window) and
                          bpy.data.objects["Cube"].material_slots[0].material.glossy.bake_path)
    states.append(state())
    with bpy.context.temp_override(**override):
        # A click pushes an undo step; from Python that is the call's undo=True.
        bpy.ops.glossy.attach_materials("INVOKE_DEFAULT", True)
    yield 0.2
    states.append(state())
    report["states"] = states

    for key, operator in (("undone", bpy.ops.ed.undo), ("redone", bpy.ops.ed.redo)):
        report[key] = []
        for _ in range(3):
            with bpy.context.temp_override(**override):
                operator()
            yield 0.3
            report[key].append(state())

    # Esc during a bake whose every part takes seconds (1024 rows, GGX 0.1): the
    # operator ends within a second, writes nothing, and Blender keeps working.
    big = bpy.data.materials.new("Big")
    big.glossy.model, big.glossy.method = "ggx", "3d"
    big.glossy.roughness = 0.1
    big.glossy.size_mode = "FIXED"
    big.glossy.map_size = 1024
    big.glossy.slices = 2
    cube = bpy.data.objects["Cube"]
    cube.data.materials.clear()
    cube.data.materials.append(big)
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.bake_materials("INVOKE_DEFAULT")
    yield 2.0  # the fit is done and the first slice is being filtered
    report["big_running"] = running(window)
    window.event_simulate(type="ESC", value="PRESS")
    pressed = time.monotonic()
    yield from wait_until(lambda: "GLOSSY_OT_bake_materials" not in running(window), 30.0)
    report["big_stop_seconds"] = time.monotonic() - pressed
    yield 0.5
    report["big_after"] = {"bake_path": big.glossy.bake_path,
                           "files": sorted(p.name for p in (workdir / "glossy").iterdir())}


run(scenario(), report, result_path)
