"""glossy.capture_probes: a cube probe at the centre of each selected mesh object."""

import json
import time

import bpy
import numpy as np

from ..bake import exr, lobes, probe_detail, resolution, sampling_runtime
from ..bake.errors import BakeError
from ..bake.progress import background_steps
from ..glossy_addon import ownership
from ..glossy_addon.capture import CubeCapture, world_render_steps
from ..glossy_addon.centres import probe_centre
from ..glossy_addon.modal import TimerSteps
from ..glossy_addon.paths import output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.world import (
    WorldNotReadable,
    find_environment_image,
    world_cube,
    world_digest,
    world_environment,
    world_pixels,
)

MIN_RESOLUTION, MAX_RESOLUTION = 8, 4096


def _targets(context):
    return [obj for obj in context.selected_objects if obj.type == "MESH"]


def _lobe_widths(obj):
    """Widths (rad) of the lobes of the object's Glossy materials, as their bakes fit them
    (the fits are cached, so the bake that follows does not fit again)."""
    widths = []
    for slot in obj.material_slots:
        material = slot.material
        if material is None:
            continue
        settings = material.glossy
        method = settings.method_used()
        if method in ("runtime", "hybrid"):  # the sampled lobe, at every view elevation
            try:
                widths += sampling_runtime.probe_widths(settings.brdf_spec(), settings.samples)
            except (BakeError, ValueError):
                pass  # refused by the bake, which says so
            if method == "runtime" or settings.anisotropy != 0.0:
                continue
        mode = method if method in ("3d", "2d") else "3d"
        try:
            fit = lobes.fit(settings.brdf_spec(), slices=max(2, settings.slices),
                            lobes=settings.lobes if mode == "3d" else 1, mode=mode)
        except (BakeError, ValueError):
            continue  # a BRDF the bake refuses says so there
        widths += [resolution.lobe_half_width(lobes.GAMMA, lobe.profile)
                    for s in fit.slices for lobe in s.lobes]
    return widths


def _face_size(context, obj):
    """(face size, reason, detail) of the object's probe: Fixed, or Auto from its lobes.

    detail: (narrowest lobe width in rad, largest face) when Auto must also measure
    the world image's own detail (:func:`_world_detail_face`), else None."""
    settings = obj.glossy
    size = settings.probe_resolution
    if not MIN_RESOLUTION <= size <= MAX_RESOLUTION:
        kind = "maximum probe resolution" if settings.probe_size_mode == "AUTO" \
            else "probe resolution"
        raise BakeError(f"{obj.name}: {kind} must be between {MIN_RESOLUTION} "
                        f"and {MAX_RESOLUTION}, not {size}")
    image = find_environment_image(context.scene.world)
    world_rows = None
    if settings.probe_source == "WORLD" and image is not None:
        world_rows = int(image.size[1])
    widths = _lobe_widths(obj)
    if settings.probe_size_mode == "FIXED":
        return size, resolution.fixed_face_reason(size, widths, MAX_RESOLUTION,
                                                  world_rows), None
    choice = resolution.choose_probe_face(widths, size, world_rows)
    face = max(MIN_RESOLUTION, choice.value)
    detail = None
    if widths and image is not None and choice.limited_by == "lobe" and \
            int(image.size[0]) == 2 * int(image.size[1]) and \
            min(widths) < 0.5 * np.pi:  # a lat-long world whose lamps the lobe may resolve
        cap = min(size, resolution.world_detail_face(int(image.size[1])))
        if cap > face:
            detail = (float(min(widths)), int(cap))
    return face, choice.reason, detail


def _world_detail_steps(context, face, reason, detail, cache):
    """Generator of (fraction, message) that returns (face, reason) once the world
    image's own detail is measured (bake.probe_detail): the lobe rule's ``face``,
    or the first larger one at which the probe adds at most probe_detail.TOLERANCE
    to the lobe-filtered world. ``cache``: a dict shared by the objects of one
    capture (same lobes, same world: measured once)."""
    width, cap = detail
    image = find_environment_image(context.scene.world)
    key = (image.name, round(width, 7), face, cap)
    if key not in cache:
        try:
            # The pixels through bpy here; the measuring (pure NumPy, up to a minute for
            # a 4096 x 2048 world) on a worker thread, so the UI stays responsive.
            cache[key] = yield from background_steps(probe_detail.world_face_steps(
                world_pixels(image), width, face, cap))
        except (BakeError, ValueError) as error:  # e.g. NaN texels: the lobe rule stands
            cache[key] = str(error)
    if isinstance(cache[key], str):
        return face, f"{reason}; the world image's detail was not measured ({cache[key]})"
    chosen, error, tried = cache[key]
    if not tried:  # finer than the lobe's face everywhere the measure resolves
        return chosen, (f"{chosen} px faces: the most the world image's detail or Max Probe "
                        f"Resolution allows (the measure resolves up to "
                        f"{probe_detail.measurable_face(image.size[1])} px, below the "
                        f"lobe's {face} px)")
    first = tried[0][1]
    if chosen != tried[-1][0]:  # no face passed up to the finest the measure resolves
        return chosen, (f"{chosen} px faces: the most the world image's detail or Max Probe "
                        f"Resolution allows (the probe adds {error:.1%} at {tried[-1][0]} px, "
                        f"the finest face the measure resolves; {first:.1%} at the lobe's "
                        f"{face} px)")
    if chosen == face:
        return face, f"{reason}; the world image's detail adds {first:.1%} there"
    if error <= probe_detail.TOLERANCE:
        return chosen, (f"{chosen} px faces: the world image's small lights need them (the "
                        f"probe adds {error:.1%} there, {first:.1%} at the lobe's {face} px)")
    return chosen, (f"{chosen} px faces: the most the world image's detail or Max Probe "
                    f"Resolution allows (the probe adds {error:.1%} there, {first:.1%} at the "
                    f"lobe's {face} px)")


def _world_rendered_alone(context, obj):
    """Whether an EEVEE capture of ``obj`` renders the world alone by Cycles first
    (glossy_addon.capture.CubeCapture: a world World Only cannot read, seen by
    glossy rays)."""
    world = context.scene.world
    if obj.glossy.capture_engine == "CYCLES" or world is None or \
            not world.cycles_visibility.glossy:
        return False
    try:
        world_environment(world)
    except WorldNotReadable:
        return True
    return False


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
        """(object name, centre, settings) per target; raises BakeError on bad settings.
        The face size and its reason per object go to ``self._faces_chosen``."""
        depsgraph = context.evaluated_depsgraph_get()
        self._faces_chosen = {}
        self._world_notes = {}
        self._world_renders = {}  # EEVEE captures: a world World Only cannot read, by Cycles
        self._details = {}
        self._detail_cache = {}
        plan = []
        for obj in _targets(context):
            settings = obj.glossy
            problem = ownership.read_only_problem(obj)
            if problem:
                raise BakeError(problem)
            if settings.clip_end <= settings.clip_start:
                raise BakeError(f"{obj.name}: clip end must be beyond clip start")
            if settings.probe_source == "WORLD":
                if find_environment_image(context.scene.world) is None:
                    raise BakeError(f"{obj.name}: 'World Only' needs an Environment Texture "
                                    "image in the world")
                try:
                    world_environment(context.scene.world)
                except WorldNotReadable as error:
                    raise BakeError(f"{obj.name}: 'World Only' cannot resample this world "
                                    f"({error}); set Source to Render Scene") from None
            face, reason, detail = _face_size(context, obj)
            centre, used = probe_centre(obj, settings.centre_mode, depsgraph)
            plan.append((obj.name, centre, used))
            self._faces_chosen[obj.name] = (face, reason)
            if detail is not None:
                self._details[obj.name] = detail
        return plan

    def _measure_detail(self, context, name):
        """Generator: settle an Auto face on the world image's own detail (once per
        object); yields (fraction, message) as it measures."""
        detail = self._details.pop(name, None)
        if detail is not None:
            face, reason = self._faces_chosen[name]
            steps = _world_detail_steps(context, face, reason, detail, self._detail_cache)
            self._faces_chosen[name] = yield from steps
        return f"{name}: {self._faces_chosen[name][0]} px faces"

    def _claim_paths(self, folder, plan):
        """Each planned object's probe file, claimed before anything is rendered:
        never a file another object owns, never the same file twice in one run."""
        self._paths = {}
        for name, _, _ in plan:
            obj = bpy.data.objects[name]
            self._paths[name] = ownership.claim(folder, bpy.path.clean_name(name), "_probe.exr",
                                                obj, taken=set(self._paths.values()))

    def _finish(self, context, name, centre, used, faces_or_cube, folder):
        obj = bpy.data.objects[name]
        settings = obj.glossy
        cube = faces_or_cube if isinstance(faces_or_cube, np.ndarray) else \
            np.concatenate(faces_or_cube, axis=1)
        path = self._paths[name]
        meta = {"generator": "glossy-blender", "layout": "cube", "size": cube.shape[0],
                "object": name, "centre": [float(c) for c in centre], "centre_mode": used,
                "source": settings.probe_source, "engine": settings.capture_engine,
                "samples": settings.capture_samples, "time": time.time()}
        meta["size_reason"] = self._faces_chosen[name][1]
        if name in self._world_notes:  # a rendered probe: how its sky was made
            meta["world"] = self._world_notes[name]
        if settings.probe_source == "WORLD":  # the Mapping and Strength it was resampled with
            image, mapping = world_environment(context.scene.world)
            meta["world_mapping"] = mapping.to_meta()
            # which image: the bake re-measures the probe's lights on its texels
            meta["world_digest"] = world_digest(image)
        exr.write(path, cube, meta)
        settings.probe_path = str(path)
        settings.probe_owner = name
        settings.probe_stamp = json.dumps({str(path): ownership.stamp(path)})
        ownership.remember(settings, "probe_history", str(path))
        settings.probe_reason = self._faces_chosen[name][1]
        settings.probe_centre = tuple(float(c) for c in centre)
        return path

    def _world_cube(self, context, size):
        """The world resampled to a cube of ``size`` px faces as Cycles shows it: its
        Environment Texture's image through the Mapping node and Strength."""
        return world_cube(context.scene.world, size)

    def _capture(self, context, name):
        obj = bpy.data.objects[name]
        settings = obj.glossy
        hidden = [obj] if settings.hide_self else []
        return CubeCapture(context.scene, obj.glossy.probe_centre, self._faces_chosen[name][0],
                           settings.capture_engine, settings.capture_samples,
                           settings.clip_start, settings.clip_end, hidden,
                           world_cache=self._world_renders)

    # --- synchronous (scripts, background) --------------------------------------
    def execute(self, context):
        try:
            plan = self._plan(context)
            folder = output_folder()
            self._claim_paths(folder, plan)
            written = []
            with BlenderProgress(context, "capture probes") as progress:
                for index, (name, centre, used) in enumerate(plan):
                    obj = bpy.data.objects[name]
                    obj.glossy.probe_centre = tuple(float(c) for c in centre)
                    for _, message in self._measure_detail(context, name):
                        progress(index / len(plan), f"{name}: {message}")
                    if obj.glossy.probe_source == "WORLD":
                        result = self._world_cube(context, self._faces_chosen[name][0])
                    else:
                        result = []
                        with self._capture(context, name) as capture:
                            self._world_notes[name] = capture.world_note
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
        self._claim_paths(self._folder, self._plan_items)
        self._faces = {}
        steps = []
        for index, (name, _, _) in enumerate(self._plan_items):
            world = bpy.data.objects[name].glossy.probe_source == "WORLD"
            if name in self._details:
                steps.append((index, "detail"))
            if not world and _world_rendered_alone(context, bpy.data.objects[name]):
                steps.append((index, "world"))
            steps += [(index, None)] if world else [(index, face) for face in range(6)]
        return steps

    def _run_step(self, context, step):
        index, face = step
        name, centre, used = self._plan_items[index]
        if face == "detail":
            return self._measure_detail(context, name)
        obj = bpy.data.objects[name]
        obj.glossy.probe_centre = tuple(float(c) for c in centre)
        if face == "world":  # one Cycles face per timer tick, before EEVEE's six
            settings = obj.glossy
            return world_render_steps(context.scene, tuple(settings.probe_centre),
                                      self._faces_chosen[name][0], settings.capture_samples,
                                      (settings.clip_start, settings.clip_end),
                                      self._world_renders)
        if face is None:
            result = self._world_cube(context, self._faces_chosen[name][0])
        else:
            with self._capture(context, name) as capture:
                self._world_notes[name] = capture.world_note
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
