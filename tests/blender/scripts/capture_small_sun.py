"""glossy.capture_probes (Render Scene, Cycles) of a world with a sun far smaller than
a probe texel: the probe must hold the world's energy.

    python capture_small_sun.py REPO WORKDIR [SEED [ENGINE]] RESULT.json

The world is a lat-long image made here: a constant sky of 0.05 and a disc of 0.5
degrees (Blender's Sky Texture draws a 0.545 degree sun) holding three times the
sky's energy, read with Closest interpolation so that its energy is exactly the sum
over its texels. Captures at 16 and 32 px faces with the default Samples (32)
record the probe's energy, the sum over its texels of radiance times solid angle,
against the image's.

ENGINE BLENDER_EEVEE captures with EEVEE at 2 samples (software GL is slow) and
adds an emitting cube of radiance 7 (edge 1) at (4, 1.2, 0.8), so the probe must
keep the scene in front of the world it composites: the script also records the
World Only cube of the same world (glossy_addon.world.world_cube) and the probe's
texels (red channel), then captures once more at 16 px with a Gamma of 1 between
the image and the Background, a world World Only cannot read, and once more with
that world hidden from glossy rays; between the two, it drives the operator's
modal loop (its world step one Cycles face per timer tick, then the six faces)
with a stand-in window manager, once cut by Esc and once to the end.
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

repo, workdir, result_path = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[-1]
options = sys.argv[3:-1]  # [SEED [ENGINE]]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.bake import envmap, exr  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

workdir.mkdir(parents=True, exist_ok=True)
latlong = envmap.get_layout("latlong")
shape = (512, 1024)
directions = latlong.texel_directions(shape)
solid = latlong.solid_angles(shape)
elevation, azimuth = math.radians(30.0), math.radians(40.0)
sun = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                math.sin(elevation)])
inside = directions @ sun > math.cos(math.radians(0.25))
sky = 0.05
image = np.full((*shape, 3), sky, np.float32)
sky_energy = float(sky * solid.sum())
image[inside] = sky + 3.0 * sky_energy / float(solid[inside].sum())
exr.write(workdir / "small_sun.exr", image)
energy = float((image[..., 0] * solid).sum())

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.seed = int(options[0]) if options else 0
node = environment_world(scene, workdir / "small_sun.exr")
node.interpolation = "Closest"
bpy.ops.mesh.primitive_uv_sphere_add(location=(0.0, 0.0, 0.0))
ball = bpy.context.object
ball.glossy.probe_source = "RENDER"
ball.glossy.probe_size_mode = "FIXED"
engine = options[1] if len(options) > 1 else "CYCLES"
GLOW_CENTRE = (4.0, 1.2, 0.8)  # off the +X face's centre: a turned or mirrored face shows
ball.glossy.capture_engine = engine
if engine != "CYCLES":
    ball.glossy.capture_samples = 2
    # No sun extracted from the world (a careful user's setting): nothing here is lit
    # by it (the cube emits, the ball is hidden from its own capture), and with no
    # light casting a shadow the capture renders without EEVEE's shadow maps
    # (glossy_addon.scenes.casts_shadows), most of a small face's time in software GL.
    scene.world.sun_threshold = 0.0
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=GLOW_CENTRE)
    lamp_cube = bpy.context.object
    glow = bpy.data.materials.new("glow")
    glow.use_nodes = True
    emission = glow.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 7.0
    glow.node_tree.links.new(emission.outputs[0],
                             glow.node_tree.nodes["Material Output"].inputs["Surface"])
    lamp_cube.data.materials.append(glow)
bpy.ops.object.select_all(action="DESELECT")
ball.select_set(True)
bpy.context.view_layer.objects.active = ball
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))


def modal_capture(events):
    """Drive glossy.capture_probes' modal loop (TimerSteps.invoke / modal and the
    operator's own _begin and _run_step) with TIMER / ESC events: its steps,
    results, reports, whether the scene and the probe file were left as found,
    and what its world cache holds."""
    from types import SimpleNamespace

    from glossy.glossy_addon.modal import TimerSteps
    from glossy.operators.capture_probes import GLOSSY_OT_capture_probes

    class WindowManager:
        def event_timer_add(self, interval, window=None):
            return "timer"

        def event_timer_remove(self, timer):
            pass

        def modal_handler_add(self, operator):
            pass

        def progress_begin(self, *args):
            pass

        progress_update = progress_end = progress_begin

    class Context:
        window, window_manager = None, WindowManager()
        workspace = SimpleNamespace(status_text_set=lambda text: None)

        def __getattr__(self, name):
            return getattr(bpy.context, name)

    class Driver(TimerSteps):
        progress_title = GLOSSY_OT_capture_probes.progress_title

        def __init__(self):
            self.reports = []

        def _interactive(self):
            return True

        def report(self, kind, message):
            self.reports.append([sorted(kind)[0], message])

    for name in ("_plan", "_measure_detail", "_claim_paths", "_finish", "_world_cube",
                 "_capture", "_begin", "_run_step", "_done_message", "_cancel_message"):
        setattr(Driver, name, GLOSSY_OT_capture_probes.__dict__[name])

    def scene_state():
        return (str(scene.camera), scene.render.engine, scene.render.resolution_x,
                scene.render.film_transparent, [o.hide_render for o in scene.objects],
                scene.cycles.samples)

    path = Path(bpy.path.abspath(ball.glossy.probe_path))
    stamp, before = path.stat().st_mtime_ns, scene_state()
    driver, context = Driver(), Context()
    results = [sorted(driver.invoke(context, None))]
    for kind in events:
        if results[-1] != ["RUNNING_MODAL"]:
            break
        results.append(sorted(driver.modal(context, SimpleNamespace(type=kind))))
    return {"steps": [list(map(str, step)) for step in driver._steps],
            "results": results, "reports": driver.reports,
            "scene_unchanged": scene_state() == before,
            "probe_unchanged": path.stat().st_mtime_ns == stamp,
            "cached": len(driver._world_renders)}

cube = envmap.get_layout("cube")
report = {"sun_texels": int(inside.sum()), "image_energy": energy,
          "sun_share": 1.0 - sky_energy / energy, "samples": ball.glossy.capture_samples,
          "filter_before": [scene.cycles.pixel_filter_type, scene.cycles.filter_width,
                            scene.cycles.samples]}
for face in (16, 32):
    ball.glossy.probe_resolution = face
    report[f"status_{face}"] = sorted(bpy.ops.glossy.capture_probes())
    probe, _ = exr.read(ball.glossy.probe_path)
    report[f"energy_{face}"] = float((probe[..., 0] * cube.solid_angles(probe.shape[:2])).sum())
    report[f"meta_world_{face}"] = exr.read_meta(ball.glossy.probe_path).get("world")
    if engine != "CYCLES":
        from glossy.glossy_addon.world import world_cube

        world = world_cube(scene.world, face)
        report[f"probe_{face}"] = probe[..., 0].tolist()
        report[f"world_{face}"] = world[..., 0].tolist()
if engine != "CYCLES":
    # A world World Only cannot read (a Gamma of 1 between the image and the
    # Background): Cycles renders it alone behind EEVEE's scene.
    tree = scene.world.node_tree
    background = next(n for n in tree.nodes if n.type == "BACKGROUND")
    gamma = tree.nodes.new("ShaderNodeGamma")
    gamma.inputs["Gamma"].default_value = 1.0
    tree.links.new(node.outputs["Color"], gamma.inputs["Color"])
    tree.links.new(gamma.outputs["Color"], background.inputs["Color"])
    ball.glossy.probe_resolution = 16
    report["status_unreadable"] = sorted(bpy.ops.glossy.capture_probes())
    probe, meta = exr.read(ball.glossy.probe_path)
    report["meta_world_unreadable"] = meta.get("world")
    report["probe_unreadable"] = probe[..., 0].tolist()
    # The UI's modal loop of the operator itself (a stand-in window manager, as
    # modal_steps.py; Blender runs modal operators only with an event loop): an
    # (object, "world") step renders that world one Cycles face per timer tick
    # before EEVEE's six faces. Esc during it leaves the scene, the probe and the
    # cache as they were; run to the end it writes the probe the capture wrote.
    report["modal_escape"] = modal_capture(["TIMER", "ESC"])
    report["modal"] = modal_capture(["TIMER"] * 20)
    probe, meta = exr.read(ball.glossy.probe_path)
    report["modal"]["meta_world"] = meta.get("world")
    report["modal"]["probe"] = probe[..., 0].tolist()
    # A world hidden from glossy rays: not in the probe (as Cycles leaves it out).
    scene.world.cycles_visibility.glossy = False
    report["status_hidden"] = sorted(bpy.ops.glossy.capture_probes())
    probe, meta = exr.read(ball.glossy.probe_path)
    report["meta_world_hidden"] = meta.get("world")
    report["probe_hidden"] = probe[..., 0].tolist()
report["filter_after"] = [scene.cycles.pixel_filter_type, scene.cycles.filter_width,
                          scene.cycles.samples]
with open(result_path, "w") as handle:
    json.dump(report, handle)
