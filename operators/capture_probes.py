"""glossy.capture_probes: a cube probe at the centre of each selected mesh object."""

import time

import bpy
import numpy as np

from ..bake import envmap, exr
from ..bake.errors import BakeError
from ..glossy_addon.capture import CubeCapture
from ..glossy_addon.centres import probe_centre
from ..glossy_addon.modal import TimerSteps
from ..glossy_addon.paths import check_may_write, output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.world import find_environment_image, image_pixels

MIN_RESOLUTION, MAX_RESOLUTION = 8, 4096


def _targets(context):
    return [obj for obj in context.selected_objects if obj.type == "MESH"]


class GLOSSY_OT_capture_probes(TimerSteps, bpy.types.Operator):
    """Capture a cube probe at the centre of each selected mesh (six renders, or the world image)"""

    bl_idname = "glossy.capture_probes"
    bl_label = "Capture Probes"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if context.scene is None:
            cls.poll_message_set("No scene")
            return False
        if not _targets(context):
            cls.poll_message_set("Select one or more mesh objects")
            return False
        return True

    # --- planning ----------------------------------------------------------
    def _plan(self, context):
        """(object name, centre, settings) per target; raises BakeError on bad settings."""
        depsgraph = context.evaluated_depsgraph_get()
        plan = []
        for obj in _targets(context):
            settings = obj.glossy
            size = settings.probe_resolution
            if not MIN_RESOLUTION <= size <= MAX_RESOLUTION:
                raise BakeError(f"{obj.name}: probe resolution must be between {MIN_RESOLUTION} "
                                f"and {MAX_RESOLUTION}, not {size}")
            if settings.clip_end <= settings.clip_start:
                raise BakeError(f"{obj.name}: clip end must be beyond clip start")
            if settings.probe_source == "WORLD" and \
                    find_environment_image(context.scene.world) is None:
                raise BakeError(f"{obj.name}: 'World Only' needs an Environment Texture image "
                                "in the world")
            centre, used = probe_centre(obj, settings.centre_mode, depsgraph)
            plan.append((obj.name, centre, used))
        return plan

    def _path(self, folder, name):
        path = folder / f"{bpy.path.clean_name(name)}_probe.exr"
        check_may_write(path)
        return path

    def _finish(self, context, name, centre, used, faces_or_cube, folder):
        obj = bpy.data.objects[name]
        settings = obj.glossy
        cube = faces_or_cube if isinstance(faces_or_cube, np.ndarray) else \
            np.concatenate(faces_or_cube, axis=1)
        path = self._path(folder, name)
        meta = {"generator": "glossy-blender", "layout": "cube", "size": cube.shape[0],
                "object": name, "centre": [float(c) for c in centre], "centre_mode": used,
                "source": settings.probe_source, "engine": settings.capture_engine,
                "samples": settings.capture_samples, "time": time.time()}
        exr.write(path, cube, meta)
        settings.probe_path = str(path)
        settings.probe_centre = tuple(float(c) for c in centre)
        return path

    def _world_cube(self, context, size):
        image = find_environment_image(context.scene.world)
        return envmap.convert(image_pixels(image), "latlong", "cube", size)

    def _capture(self, context, name):
        obj = bpy.data.objects[name]
        settings = obj.glossy
        hidden = [obj] if settings.hide_self else []
        return CubeCapture(context.scene, obj.glossy.probe_centre, settings.probe_resolution,
                           settings.capture_engine, settings.capture_samples,
                           settings.clip_start, settings.clip_end, hidden)

    # --- synchronous (scripts, background) --------------------------------------
    def execute(self, context):
        try:
            plan = self._plan(context)
            folder = output_folder()
            for name, _, _ in plan:
                self._path(folder, name)
            written = []
            with BlenderProgress(context, "capture probes") as progress:
                for index, (name, centre, used) in enumerate(plan):
                    obj = bpy.data.objects[name]
                    obj.glossy.probe_centre = tuple(float(c) for c in centre)
                    if obj.glossy.probe_source == "WORLD":
                        result = self._world_cube(context, obj.glossy.probe_resolution)
                    else:
                        result = []
                        with self._capture(context, name) as capture:
                            for face in range(6):
                                progress((index * 6 + face) / (6 * len(plan)),
                                         f"{name}: face {face + 1}/6")
                                result.append(capture.render_face(face))
                    written.append(self._finish(context, name, centre, used, result, folder))
                progress(1.0, f"{len(written)} probe(s) captured")
        except (BakeError, ValueError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, f"Glossy captured {len(written)} probe(s) into {folder}")
        return {"FINISHED"}

    # --- modal (UI): one face (or one world resample) per timer tick ---------------
    progress_title = "capture probes"

    def _begin(self, context):
        self._plan_items = self._plan(context)
        self._folder = output_folder()
        for name, _, _ in self._plan_items:
            self._path(self._folder, name)
        self._faces = {}
        steps = []
        for index, (name, _, _) in enumerate(self._plan_items):
            world = bpy.data.objects[name].glossy.probe_source == "WORLD"
            steps += [(index, None)] if world else [(index, face) for face in range(6)]
        return steps

    def _run_step(self, context, step):
        index, face = step
        name, centre, used = self._plan_items[index]
        obj = bpy.data.objects[name]
        obj.glossy.probe_centre = tuple(float(c) for c in centre)
        if face is None:
            result = self._world_cube(context, obj.glossy.probe_resolution)
        else:
            with self._capture(context, name) as capture:
                self._faces.setdefault(index, []).append(capture.render_face(face))
            if face < 5:
                return f"{name}: face {face + 1}/6"
            result = self._faces.pop(index)
        self._finish(context, name, centre, used, result, self._folder)
        return f"{name}: probe written"

    def _done_message(self):
        return f"Glossy captured {len(self._plan_items)} probe(s)"

    def _cancel_message(self):
        return "Probe capture cancelled; no unfinished probe was written"


classes = (GLOSSY_OT_capture_probes,)
