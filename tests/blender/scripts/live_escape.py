"""Esc in a live Blender window: the modal capture and bake stop, write no
half files, and Blender keeps working.

    xvfb-run blender --enable-event-simulate --python live_escape.py -- WORKDIR RESULT.json

Runs in a real window (Xvfb, Mesa's software OpenGL) with the Glossy extension
installed in the user directory. The operators are invoked as a click would
(INVOKE_DEFAULT in the 3D viewport), and Esc is a real window event
(Window.event_simulate, which --enable-event-simulate allows). Progress is
watched through Blender itself: render_post counts the capture's face
renders, and the materials' bake paths show the bake's finished steps.
"""

import sys
import time
import traceback
from pathlib import Path

import bpy

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _live import run, viewport_override, wait_until  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
workdir, result_path = Path(args[0]), Path(args[1])
report = {"phases": []}
faces_rendered = []


def count_face(*_):
    faces_rendered.append(time.monotonic())




def files():
    folder = workdir / "glossy"
    return sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []




def scenario():
    window, override = viewport_override()
    report["background"] = bpy.app.background
    report["version"] = bpy.app.version_string
    cube = bpy.data.objects["Cube"]
    cube.glossy.probe_resolution = 48
    cube.glossy.capture_samples = 16
    bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
    bpy.app.handlers.render_post.append(count_face)

    # 1. Esc while the six faces render: after the second face.
    with bpy.context.temp_override(**override):
        report["capture_invoke"] = sorted(bpy.ops.glossy.capture_probes("INVOKE_DEFAULT"))
    yield from wait_until(lambda: len(faces_rendered) >= 2)
    window.event_simulate(type="ESC", value="PRESS")
    yield 1.0  # the modal loop would have rendered more faces by now
    report["capture_cancel"] = {"faces_rendered": len(faces_rendered),
                                "probe_path": cube.glossy.probe_path, "files": files()}

    # 2. Blender keeps working: the same operator, invoked again, runs to the end.
    faces_rendered.clear()
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.capture_probes("INVOKE_DEFAULT")
    yield from wait_until(lambda: bool(cube.glossy.probe_path))
    report["capture_done"] = {"faces_rendered": len(faces_rendered),
                              "probe_path": cube.glossy.probe_path, "files": files()}

    # 3. Esc during a bake of three materials, after the first one.
    cube.data.materials.clear()
    for index, roughness in enumerate((0.2, 0.35, 0.5)):
        material = bpy.data.materials.new(f"M{index}")
        material.glossy.model = "ggx"
        material.glossy.roughness = roughness
        material.glossy.map_size = 64
        material.glossy.slices = 16
        material.glossy.method = "3d"  # the 3D map's parts: the same files in Blender 4.x
        material.glossy.lamps = False  # the environment bake's Esc (the startup scene has a lamp)
        cube.data.materials.append(material)
    materials = list(cube.data.materials)
    bpy.context.view_layer.objects.active = cube
    with bpy.context.temp_override(**override):
        report["bake_invoke"] = sorted(bpy.ops.glossy.bake_materials("INVOKE_DEFAULT"))
    yield from wait_until(lambda: bool(materials[0].glossy.bake_path))
    window.event_simulate(type="ESC", value="PRESS")
    yield 2.0
    report["bake_cancel"] = {"baked": [bool(m.glossy.bake_path) for m in materials],
                             "bake_paths": [m.glossy.bake_path for m in materials],
                             "files": files()}

    # 4. ... and a second bake finishes the rest.
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.bake_materials("INVOKE_DEFAULT")
    yield from wait_until(lambda: all(m.glossy.bake_path for m in materials))
    report["bake_done"] = {"bake_paths": [m.glossy.bake_path for m in materials],
                           "files": files()}
    # 4b. Esc inside one material's bake (between two parts, a pair of slices each):
    # the bake stops there and writes nothing, though it would need seconds more.
    big = bpy.data.materials.new("Big")
    big.glossy.model, big.glossy.method = "ggx", "3d"
    big.glossy.roughness = 0.1
    big.glossy.size_mode = "FIXED"
    big.glossy.map_size = 256
    big.glossy.slices = 32  # about 10 parts of a few tenths of a second each
    big.glossy.lamps = False
    cube.data.materials.clear()
    cube.data.materials.append(big)
    started = time.monotonic()
    with bpy.context.temp_override(**override):
        bpy.ops.glossy.bake_materials("INVOKE_DEFAULT")
    yield 0.6  # the fit and the first parts have run
    window.event_simulate(type="ESC", value="PRESS")
    yield 8.0  # longer than the whole bake would take, had it gone on
    report["bake_mid_cancel"] = {"bake_path": big.glossy.bake_path, "files": files(),
                                 "seconds": time.monotonic() - started}

    # What the status bar showed: the Info editor's reports, copied as a user would.
    area = override["area"]
    area.type = "INFO"
    yield 0.2
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.info.select_all(action="SELECT")
        bpy.ops.info.report_copy()
    report["reports"] = bpy.context.window_manager.clipboard.splitlines()

    # 5. The panels as a user sees them: the Glossy sidebar tab in the 3D
    # viewport and Glossy in Material properties, drawn by the window (each
    # panel class is re-registered with its draw wrapped to record that it ran
    # and what it raised).
    drawn, failed = set(), []

    def recording(name, original):
        def draw(self, context):
            try:
                original(self, context)
                drawn.add(name)
            except Exception:
                failed.append(traceback.format_exc())
                raise
        return draw

    for name in ("GLOSSY_PT_environment", "GLOSSY_PT_probe", "GLOSSY_PT_material"):
        cls = getattr(bpy.types, name)
        bpy.utils.unregister_class(cls)
        cls.draw = recording(name, cls.draw)
        bpy.utils.register_class(cls)
    area.type = "VIEW_3D"
    properties = next(a for a in window.screen.areas if a.type == "PROPERTIES")
    properties.spaces.active.context = "MATERIAL"
    area.spaces.active.show_region_ui = True
    yield 0.2
    next(r for r in area.regions if r.type == "UI").active_panel_category = "Glossy"
    for _ in range(3):
        for each in (area, properties):
            each.tag_redraw()
        yield 0.3
    report["panels_drawn"] = sorted(drawn)
    report["panel_errors"] = failed


run(scenario(), report, result_path)
