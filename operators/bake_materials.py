"""glossy.bake_materials and glossy.attach_materials: the Glossy materials of the
selected mesh objects (the active object when none is selected), each against
its own object's probe."""

import json
import time

import bpy
import numpy as np

from ..bake import (
    atlas,
    brdf,
    exr,
    hybrid,
    knot_lights,
    lamp_spread,
    outputs,
    prefilter,
    probe_content,
    probe_lights,
    sampling_runtime,
    separable,
    world_lights,
)
from ..bake.errors import BakeError
from ..bake.progress import (
    background_steps,
    blas_limited_steps,
    prefixed_steps,
    run_steps,
    scaled,
    scaled_steps,
)
from ..glossy_addon import ownership
from ..glossy_addon.bookkeeping import bake_inputs_hash, bake_status
from ..glossy_addon.checks import check_settings
from ..glossy_addon.emission import values as emission_values
from ..glossy_addon.lamps import lamp_set, scene_lamps
from ..glossy_addon.material_source import parts as material_parts
from ..glossy_addon.materials import effective_tangent, stash_original
from ..glossy_addon.method_choice import knot_lights_apply
from ..glossy_addon.modal import TimerSteps
from ..glossy_addon.nodes import build_lookup, load_atlas, user_output
from ..glossy_addon.paths import output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.spatial import (
    COAT,
    DIELECTRIC,
    GLOSSY,
    HIGH,
    LOW,
    METAL,
    colour_responses,
    input_socket,
    lookup_sockets,
    map_variants,
    split_order,
    split_plan,
    split_share,
)
from ..glossy_addon.world import (
    WorldNotReadable,
    world_digest,
    world_environment,
    world_pixels,
)

#: Factorizations of this session by (spec, parameterization, method, terms,
#: sizes): they depend on the BRDF alone, not on the probe, so re-bakes and
#: materials sharing a BRDF reuse them (at most _FACTOR_CACHE_SIZE, oldest dropped).
_FACTOR_CACHE = {}
_FACTOR_CACHE_SIZE = 16


def _factor_steps(settings):
    """The material's BRDF factored for lamps (bake.separable) with the cap levels
    of its g factors (bake.lamp_spread: lamps of any size), as steps: one
    (fraction, message) before each part, (Factorization, Levels) as the value."""
    size_h = settings.lamp_size_h if settings.lamp_method == "sampled" else None
    key = (brdf.parse(settings.brdf_spec()).spec, settings.lamp_parameterization,
           settings.lamp_method, settings.lamp_terms, settings.lamp_size, size_h)
    if key in _FACTOR_CACHE:
        yield 1.0, "lamp factors: reused from this session"
        return _FACTOR_CACHE[key]
    yield 0.0, (f"factoring the BRDF for lamps ({settings.lamp_size}^2 and "
                f"{settings.lamp_size_h}^2 x {settings.lamp_terms})")
    factors = separable.factorize(key[0], settings.lamp_parameterization,
                                  settings.lamp_method, settings.lamp_terms, settings.lamp_size,
                                  "xy", size_h=size_h)
    yield 0.8, "lamp factors: averaging g over lamp-sized caps"
    levels = lamp_spread.blur_levels(factors)
    while len(_FACTOR_CACHE) >= _FACTOR_CACHE_SIZE:
        _FACTOR_CACHE.pop(next(iter(_FACTOR_CACHE)))
    _FACTOR_CACHE[key] = factors, levels
    return factors, levels


def _write_bake(material, path, environment, diffuse, diffuse_path, lamp_path, lamp_factors,
                probe_path, obj_name, reason, rows=0, runtime_path=None, runtime=None,
                knots=()):
    """Write one material's files together (all or none, each whole) and record
    them in its settings; a generator (it yields nothing) so that steps can
    ``yield from`` it. ``lamp_factors``: (Factorization, Levels) or None.
    ``runtime``: the (image, meta) of a Hybrid's second texture
    (bake.sampling_runtime), written to ``runtime_path``. Returns the step's
    message."""
    settings = material.glossy
    factors, levels = lamp_factors if lamp_factors is not None else (None, None)
    stamp_meta = {"generator": "glossy-blender", "probe": probe_path, "material": material.name}
    written = []
    with outputs.Staged() as staged:
        textures = [(path, environment), (runtime_path, runtime)] + \
            [(knot_path, texture) for _, knot_path, texture, _ in knots if knot_path != path]
        for target_path, texture in textures:
            if texture is None:
                continue
            image, atlas_meta = texture
            # The knots' lights texture is a few KB of light directions, which a half
            # float would move by up to 5e-4 rad (a narrow lobe's highlight): float32.
            precise = atlas_meta.get("mode") == knot_lights.MODE
            half = not precise and atlas.storage_precision(image) == "half"
            if not half and not precise and "32-bit" not in reason:
                reason += "; kept as 32-bit float (brighter than a half float's 65504)"
            atlas_meta.update({**stamp_meta, "size_reason": reason,
                               "precision": "half" if half else "float32"})
            staged.add(target_path, lambda target, image=image, atlas_meta=atlas_meta,
                       half=half: exr.write(target, image, atlas_meta, half=half))
            written.append(target_path)
        if diffuse is not None:
            diffuse_image, diffuse_meta = diffuse
            diffuse_meta.update({**stamp_meta, "precision": "float32"})
            staged.add(diffuse_path, lambda target: exr.write(target, diffuse_image,
                                                              diffuse_meta))
            written.append(diffuse_path)
        if factors is not None:
            lamp_image, lamp_meta = separable.pack(factors, levels)
            lamp_meta.update({**stamp_meta, "precision": "float32"})
            staged.add(lamp_path, lambda target: exr.write(target, lamp_image, lamp_meta))
            written.append(lamp_path)
    settings.bake_path = str(path) if environment is not None else ""
    settings.runtime_path = str(runtime_path) if runtime is not None else ""
    settings.roughness_maps = json.dumps([[r, str(p), c] for r, p, _, c in knots]) \
        if knots else ""
    settings.diffuse_path = str(diffuse_path) if diffuse is not None else ""
    settings.lamp_path = str(lamp_path) if factors is not None else ""
    settings.lamp_error = separable.error(factors, settings.brdf_spec()) \
        if factors is not None else -1.0
    settings.bake_owner = material.name
    settings.bake_probe = probe_path
    settings.bake_object = obj_name
    settings.bake_stamp = json.dumps({str(p): ownership.stamp(p) for p in written})
    ownership.remember(settings, "bake_history", *map(str, written))
    settings.chosen_size = rows
    settings.size_reason = reason
    settings.bake_hash = bake_inputs_hash(settings, probe_path)
    settings.bake_inputs = material_parts(material).derived.inputs_json() \
        if settings.model == "MATERIAL" else ""
    settings.bake_time = time.time()
    return f"baked {material.name}: {reason}"
    yield  # a generator


def runtime_height(settings, probe, layout, alone=False) -> tuple:
    """(rows, why) of the runtime-sampling level stack
    (bake.sampling_runtime.stack_height): the probe's own detail, at most Map Size
    (Auto; twice it, up to 1024, when ``alone``: Runtime Sampling of a near-mirror
    lobe, bake.sampling_runtime.near_mirror, whose only texture the stack is) or
    Map Size (Fixed), as a power of two or three times one; a probe whose content
    is smoother than its texels (bake.probe_content) gets its content's rows."""
    fixed = settings.map_size if settings.size_mode == "FIXED" else None
    return sampling_runtime.stack_height(probe.shape, layout, fixed=fixed,
                                         cap=settings.map_size, alone=alone,
                                         content_shape=probe_content.of_probe(probe,
                                                                              layout).shape)


def _light_steps(probe, layout, ax, ay, world=None):
    """bake.world_lights.split_for as steps (no bpy: runs on a worker thread, so
    the UI stays responsive: a probe of 1024 px faces takes about 5 s here): one
    message, then (residual probe, lights, why). ``world``: (image, Mapping,
    digest) of a World Only probe's world (:func:`world_of`), or None."""
    yield 0.0, "taking the probe's small bright lights out (Probe Lights)"
    image, mapping, digest = world if world is not None else (None, None, None)
    return world_lights.split_for(probe, layout, ax, ay, image, mapping, world_digest=digest)


def world_of(scene, meta):
    """(pixels (H, 2H, 3) float32, bake.world_mapping.WorldMapping, their digest) of
    the scene's world when ``meta`` is a World Only probe's that was resampled
    from that very image through that Mapping and Strength (its recorded
    world_digest and world_mapping), so the bake may measure the probe's lights
    on the world's texels (bake.world_lights); else (None, why not)."""
    if meta.get("source") != "WORLD":
        return None, None
    if "world_digest" not in meta:
        return None, "the probe predates world lights: capture it again to measure its " \
                     "lights on the world's texels"
    try:
        image, mapping = world_environment(scene.world)
        pixels = world_pixels(image)
    except (WorldNotReadable, ValueError) as error:
        return None, f"the world can no longer be read ({error})"
    if mapping.to_meta() != meta.get("world_mapping") or \
            world_digest(image, pixels) != meta["world_digest"]:
        return None, "the world changed since the capture: capture the probe again"
    return (pixels, mapping, meta["world_digest"]), None


def _runtime_steps(spec, samples, rows, why, probe, layout, for_hybrid, lights=()):
    """The runtime-sampling texture (bake.sampling_runtime.pack) of ``rows``
    lat-long rows as steps (no bpy: runs on a worker thread): one message, then
    ((image, meta), reason); a Hybrid's meta carries its w(mu) knots
    (bake.hybrid.weight_curve at the lobe's roughness and the pattern's sample count,
    from the table of the lobe's kind: GGX or Beckmann).
    ``lights``: the probe's lights (bake.probe_lights) when ``probe`` is the residual."""
    yield 0.0, f"pre-blurring {rows}-row probe levels and the albedo table for runtime sampling"
    image, meta = sampling_runtime.pack(probe, spec, layout=layout, budget=samples, height=rows,
                                        lights=lights)
    if for_hybrid:
        centres, weights = hybrid.weight_curve(float(np.sqrt(meta["ax"])),
                                               samples=len(meta["prob"]),
                                               kind=meta.get("kind", "ggx"))
        meta.update({"blend_mu": centres.tolist(), "blend_weight": weights.tolist()})
    reason = f"runtime sampling: {sampling_runtime.stack_reason(meta, why)}"
    if lights:
        reason += f"; {probe_lights.describe(lights)}"
    return (image, meta), reason


def _targets(context):
    """(mesh objects to work on, sorted by name, or [], why none): the selected mesh
    objects that have a material, else the active object when it is a mesh with
    one (a script that sets only the active object)."""
    selected = [obj for obj in context.selected_objects if obj.type == "MESH"]
    if not selected and context.object is not None and context.object.type == "MESH":
        selected = [context.object]
    if not selected:
        return [], "Select a mesh object"
    objects = [obj for obj in selected
               if any(slot.material for slot in obj.material_slots)]
    if not objects:
        return [], ("The object has no material" if len(selected) == 1
                    else "The selected objects have no material")
    return sorted(objects, key=lambda obj: obj.name), None


def _materials(obj):
    seen, out = set(), []
    for slot in obj.material_slots:
        if slot.material is not None and slot.material.name not in seen:
            seen.add(slot.material.name)
            out.append(slot.material)
    return out


class _MaterialsOperator:
    """poll() shared by the operators that work on the selected objects' materials."""

    @classmethod
    def poll(cls, context):
        objects, message = _targets(context)
        if not objects:
            cls.poll_message_set(message)
            return False
        return True


class GLOSSY_OT_bake_materials(TimerSteps, _MaterialsOperator, bpy.types.Operator):
    """Prefilter each selected object's probe for its materials' BRDFs (skips up-to-date bakes)"""

    bl_idname = "glossy.bake_materials"
    bl_label = "Bake Materials"
    bl_options = {"REGISTER", "UNDO"}

    def _prepare(self, context):
        """The bake's jobs, [(object name, material name, map path, diffuse path, lamp
        path, runtime path, knot paths)], or raise BakeError.

        Every check that can refuse a bake runs here, before any file is written:
        each object's own probe, the settings, the atlas against the GPU's texture
        limit, and the output files (claimed: never another owner's or a user's).
        Selected objects without a probe are skipped and named in
        ``self._warnings`` (refused when none has one), as are materials shared
        with objects that have other probes. The probes' pixels are read when
        their object's first material bakes (:meth:`_probe_of`)."""
        objects, message = _targets(context)
        if not objects:
            raise BakeError(message)
        folder = output_folder()
        todo, taken = [], set()
        self._warnings = []
        self._probes = {}  # object name: (probe path, meta, world, world note)
        self._loaded = (None, None)  # (object name, probe pixels) of the last one read
        lamp_objects = scene_lamps(context.scene)[0]
        without = [obj.name for obj in objects if not obj.glossy.probe_path]
        if len(without) == len(objects):
            raise BakeError(f"{without[0]} has no probe yet: capture one first" if
                            len(objects) == 1 else
                            f"None of the selected objects has a probe yet "
                            f"({', '.join(without)}): capture probes first")
        if without:
            self._warnings.append(f"Skipped {', '.join(without)}: no probe yet (capture "
                                  f"one first)")
        for obj in objects:
            if obj.name not in without:
                problem = ownership.probe_problem(obj)
                if problem:
                    raise BakeError(problem)
                for material in _materials(obj):
                    problem = ownership.read_only_problem(material)
                    if problem:
                        raise BakeError(problem)
        for obj in objects:
            if obj.name in without:
                continue
            probe_path = obj.glossy.probe_path
            try:
                meta = exr.read_meta(bpy.path.abspath(probe_path))
            except (OSError, ValueError) as error:
                raise BakeError(f"{obj.name}: its probe {probe_path} cannot be read "
                                f"({error}): capture it again") from error
            todo.extend(self._object_jobs(obj, probe_path, meta, folder, taken,
                                          lamp_objects))
            # The world's pixels (read and hashed: about a second for an 8k HDRI) only
            # when some material shades probe lights (Runtime Sampling, the Hybrid).
            # (and the 3D map's knots with their lights' texture: job[5]).
            lit = any(bpy.data.materials[job[1]].glossy.probe_lights
                      and (bpy.data.materials[job[1]].glossy.method_used() in
                           ("runtime", "hybrid") or job[5] is not None)
                      for job in todo if job[0] == obj.name)
            world, note = world_of(context.scene, meta) if lit else (None, None)
            self._probes[obj.name] = (probe_path, meta, world, note)
        return todo

    def _probe_of(self, obj_name):
        """(probe pixels, meta, probe path, world, world note) of ``obj_name``'s
        probe; the pixels of one probe at a time are kept."""
        probe_path, meta, world, note = self._probes[obj_name]
        if self._loaded[0] != obj_name:
            self._loaded = (None, None)  # free the last one before reading the next
            probe, _ = exr.read(bpy.path.abspath(probe_path))
            self._loaded = (obj_name, probe)
        return self._loaded[1], meta, probe_path, world, note

    def _object_jobs(self, obj, probe_path, meta, folder, taken, lamp_objects):
        """The jobs of one object's materials (:meth:`_prepare`); claims their files
        in ``taken``."""
        todo = []
        for material in _materials(obj):
            check_settings(material)
            if ownership.needs_own_copy(material, obj):
                others = ownership.shared_probe_users(material, obj)
                material = ownership.object_copy(material, obj)
                self._warnings.append(
                    f"{material.glossy.copy_of} is shared with {', '.join(others)}, whose "
                    f"probe differs: {obj.name} now has its own copy '{material.name}', so "
                    f"each object reflects its own probe")
            settings = material.glossy
            wants_lamps = settings.lamps and bool(lamp_objects)
            if bake_status(settings, probe_path) == "up to date" and \
                    (settings.lamp_path or not wants_lamps):
                continue
            stem = f"{bpy.path.clean_name(obj.name)}_{bpy.path.clean_name(material.name)}"
            method = settings.method_used()
            path = ownership.claim(folder, stem, f"_{method}.exr", material, taken)
            taken.add(path)
            diffuse_path = lamp_path = None
            runtime_path = None
            isotropic = brdf.parse(settings.brdf_spec()).isotropic
            knot_paths = []
            if settings.model == "MATERIAL" and isotropic:
                found = material_parts(material)
                knots = found.roughness_set
                variants = map_variants(found, colour=method in ("3d", "2d", "hybrid"))
                if variants and method in ("3d", "2d", "hybrid"):
                    order = sorted({r for r, _, _ in variants if r is not None})
                    for roughness, colour, _ in variants:
                        suffix = (f"_r{order.index(roughness)}" if roughness is not None
                                  else "") + (f"_{colour}" if colour is not None else "")
                        knot_path = ownership.claim(folder, stem,
                                                    f"_{method}{suffix}.exr",
                                                    material, taken)
                        taken.add(knot_path)
                        knot_paths.append((roughness, colour, knot_path))
                elif knots:
                    self._warnings.append(
                        f"{material.name}: the roughness texture is taken at its mean with the "
                        f"{method} method (the 3D map, 2D map and Hybrid blend maps "
                        f"baked at several roughnesses)")
            if method == "hybrid" and isotropic:
                runtime_path = ownership.claim(folder, stem, "_hybrid_runtime.exr", material,
                                               taken)
                taken.add(runtime_path)
            elif method == "3d" and knot_paths and knot_lights_apply(settings):
                # The probe lights beside the knots' maps (bake.knot_lights).
                runtime_path = ownership.claim(folder, stem, "_3d_lights.exr", material,
                                               taken)
                taken.add(runtime_path)
            if any(settings.diffuse_colour()):
                diffuse_path = ownership.claim(folder, stem, "_diffuse.exr", material, taken)
                taken.add(diffuse_path)
            if wants_lamps:
                lamp_path = ownership.claim(folder, stem, "_lamps.exr", material, taken)
                taken.add(lamp_path)
            if not isotropic and method == "hybrid":
                self._warnings.append(
                    f"{material.name}: anisotropic BRDF: the Hybrid uses runtime sampling "
                    f"alone (the 3D map needs an isotropic lobe)")
            elif not isotropic and method != "runtime":
                if not wants_lamps:
                    raise BakeError(
                        f"{material.name}: {settings.brdf_spec()} is anisotropic: the "
                        f"{method} map needs an isotropic BRDF; choose the Runtime "
                        f"Sampling or Hybrid method (or add a lamp and turn on Lamps for its "
                        f"lamp response alone)")
                self._warnings.append(
                    f"{material.name}: anisotropic BRDF: lamps only (the {method} map "
                    f"needs an isotropic BRDF; Runtime Sampling and Hybrid reflect the "
                    f"environment), the environment reflection is left out")
            todo.append((obj.name, material.name, path, diffuse_path, lamp_path,
                         runtime_path, knot_paths))
        return todo

    @staticmethod
    def _bake_steps(material, path, diffuse_path, lamp_path, probe, meta, probe_path,
                    obj_name, runtime_path=None, knot_paths=(), world=None, world_note=None):
        """One material's bake as steps: yields (fraction, message) after the fit, each
        batch of slices and the diffuse map; writes the files only at the end, both
        or neither, so a bake stopped between steps leaves nothing. Returns the step's
        message. ``world``, ``world_note``: :func:`world_of` the probe."""
        settings = material.glossy
        method = settings.method_used()
        spec = settings.brdf_spec()
        isotropic = brdf.parse(spec).isotropic
        sampled = method == "runtime" or (method == "hybrid" and not isotropic)
        if not isotropic and not sampled:  # lamps only (checked in _prepare)
            path = diffuse_path = None
        lamp_factors = None
        if lamp_path is not None:
            lamp_factors = yield from scaled_steps(background_steps(_factor_steps(settings)),
                                                   0.0, 0.1 if path else 1.0)
        if path is None:
            return (yield from _write_bake(material, None, None, None, None, lamp_path,
                                           lamp_factors, probe_path, obj_name,
                                           "no environment map (anisotropic BRDF)"))
        layout = meta.get("layout", "cube")
        knots, sizes = [], []
        auto = settings.size_mode == "AUTO"
        size = "auto" if auto else settings.map_size
        max_size = settings.map_size if auto else None
        runtime = None
        glossy_probe, lights, light_note = probe, (), None
        # The 3D map's knots with the probe lights beside them (bake.knot_lights).
        knot_lit = method == "3d" and runtime_path is not None
        if settings.probe_lights and (sampled or runtime_path is not None):
            # The sampled part and the Hybrid's map see the probe without its small
            # bright lights; the lights are shaded exactly (bake.probe_lights).
            lobe = sampling_runtime.check(spec, settings.samples)[0]
            ax, ay = lobe.mx, lobe.my
            if knot_lit:  # tiles for the narrowest knot's lobe
                ax = ay = min([knot_lights.light_alpha(r) for r, _, _ in knot_paths
                               if r is not None] or [lobe.mx])
            glossy_probe, lights, measured = yield from scaled_steps(background_steps(
                _light_steps(probe, layout, ax, ay, world)),
                0.1 if lamp_path is not None else 0.0, 0.1)
            light_note = measured if world is not None else world_note
        if sampled or (runtime_path is not None and not knot_lit):
            alone = sampled and sampling_runtime.near_mirror(
                sampling_runtime.check(spec, settings.samples)[0])
            rows, why = runtime_height(settings, probe, layout, alone=alone)
            runtime, runtime_reason = yield from scaled_steps(background_steps(_runtime_steps(
                spec, settings.samples, rows, why, glossy_probe, layout,
                runtime_path is not None, lights)),
                0.1, 0.3 if runtime_path is not None else 0.95)
            if lights and light_note:
                runtime_reason += f" ({light_note})"
        if sampled:
            image, atlas_meta = runtime
            rows, reason, runtime = atlas_meta["slice_height"], runtime_reason, None
        elif method == "split-sum":
            face = 1 << max(2, int(np.log2(max(settings.map_size, 4))))
            baked = yield from scaled_steps(background_steps(prefilter.prefilter_steps(
                probe, spec, "split-sum", face, layout=layout)), 0.1, 0.85)
            image, atlas_meta = atlas.pack_split_sum(baked)
            rows, reason = image.shape[0] - 2, f"{face} px split-sum faces: set by Map Size"
        else:
            variants = {(r, c): variant_spec for r, c, variant_spec in map_variants(
                material_parts(material), colour=method in ("3d", "2d", "hybrid"))} \
                if knot_paths else {}
            jobs = [(r, c, knot_path, variants[(r, c)]) for r, c, knot_path in knot_paths] \
                or [(None, None, path, spec)]
            start = 0.3 if runtime is not None else 0.1
            share = split_share(material_parts(material).derived)
            bakes, highs = {}, {}
            for step, index in enumerate(split_order(jobs)):
                roughness, colour, _, job_spec = jobs[index]
                # A split's low map takes the high map's filtered lobes where the
                # material's mean colour hides the difference (prefilter.Companion).
                companion = highs.pop(roughness, None) if colour == LOW else None
                baked = yield from scaled_steps(background_steps(prefilter.prefilter_steps(
                    glossy_probe, job_spec, "3d" if method == "hybrid" else method,
                    size, slices=settings.slices,
                    lobes_count=settings.lobes if method in ("3d", "hybrid") else 1,
                    layout=layout, max_size=max_size, companion=companion,
                    keep_unit_layers=colour == HIGH and (roughness, LOW) in
                    {(r, c) for r, c, _, _ in jobs})),
                    start + (0.85 - start) * step / len(jobs),
                    start + (0.85 - start) * (step + 1) / len(jobs))
                if baked.unit_layers is not None:
                    highs[roughness] = prefilter.Companion(
                        baked.unit_fit, baked.unit_layers, baked.meta["size"], share)
                    baked.unit_layers = baked.unit_fit = None
                bakes[index] = (baked.meta, atlas.pack(baked))  # the layers let go
            for index, (roughness, colour, job_path, _) in enumerate(jobs):
                baked_meta, packed = bakes.pop(index)
                if roughness is not None or colour is not None:
                    knots.append((roughness, job_path, packed, colour))
                    sizes.append(baked_meta["size"])
                else:
                    image, atlas_meta = packed
                    rows, reason = baked_meta["size"], baked_meta["size_reason"]
            if knots:
                mean = float(brdf.parse(spec).params.get("roughness", 0.0))
                # The map recorded as the bake: a plain, white or metal one nearest the
                # mean roughness.
                nearest = min((k for k in knots if k[3] in (None, HIGH, METAL, GLOSSY)),
                              key=lambda knot: abs((knot[0] or mean) - mean))
                path, (image, atlas_meta) = nearest[1], nearest[2]
                rows = max(sizes)
                roughnesses = sorted({r for r, _, _, _ in knots if r is not None})
                what = []
                if roughnesses:
                    what.append(f"roughness {', '.join(f'{r:.3g}' for r in roughnesses)} for "
                                f"the roughness texture")
                keys = {k[3] for k in knots}
                if GLOSSY in keys:
                    what.append("the glossy part and the coat alone for the Coat Tint texture")
                if DIELECTRIC in keys:
                    what.append("Metallic 0 and 1 for the metallic texture")
                if HIGH in keys:
                    _, plan = split_plan(material_parts(material).derived)
                    what.append(f"{plan['input']} 0 and 1"
                                + (" and the coat alone" if COAT in keys else "")
                                + f" for the per-pixel {plan['input']}")
                reason = (f"{len(knots)} maps at {' and '.join(what)}, "
                          f"{min(sizes)}-{max(sizes)} rows "
                          f"({baked_meta['size_reason'].split(':')[-1].strip()})")
            if knot_lit and lights:
                runtime = knot_lights.pack(lights, [(r, c, job_spec)
                                                    for r, c, _, job_spec in jobs])
                reason += (f"; {probe_lights.describe(lights)}, shaded exactly at the "
                           f"pixel's roughness" + (f" ({light_note})" if light_note else ""))
            elif runtime is not None:
                reason += f"; {runtime_reason}"
        diffuse = None
        if diffuse_path is not None:
            color = "/".join(f"{c:g}" for c in settings.diffuse_colour())
            irradiance = yield from scaled_steps(background_steps(prefilter.prefilter_steps(
                probe, f"lambert:color={color}", "irradiance", size, layout=layout,
                max_size=max_size)), 0.85, 0.95)
            diffuse = atlas.pack_irradiance(irradiance)
        return (yield from _write_bake(material, path, (image, atlas_meta), diffuse,
                                       diffuse_path if diffuse is not None else None,
                                       lamp_path, lamp_factors, probe_path, obj_name, reason,
                                       int(rows), runtime_path, runtime, knots))

    def _job_steps(self, job):
        """One job of :meth:`_prepare` as :meth:`_bake_steps`, its messages prefixed
        with the object's name when the bake spans several objects."""
        obj_name, name, path, diffuse_path, lamp_path, runtime_path, knot_paths = job
        probe, meta, probe_path, world, world_note = self._probe_of(obj_name)
        # The parts on Blender's thread (packing, writing) hold BLAS to one thread too.
        steps = blas_limited_steps(self._bake_steps(
            bpy.data.materials[name], path, diffuse_path, lamp_path, probe, meta, probe_path,
            obj_name, runtime_path, knot_paths, world, world_note))
        return steps, (f"{obj_name}: " if len(self._probes) > 1 else "")

    def execute(self, context):
        try:
            todo = self._prepare(context)
            with BlenderProgress(context, "bake materials") as progress:
                for index, job in enumerate(todo):
                    steps, who = self._job_steps(job)
                    name = job[1]
                    progress(index / max(len(todo), 1), f"baking {who}{name}")
                    run_steps(steps, scaled(progress, index / len(todo),
                                            (index + 1) / len(todo)))
                    progress((index + 1) / len(todo), f"baked {who}{name} "
                             f"({bpy.data.materials[name].glossy.size_reason})")
                progress(1.0, f"baked {len(todo)} material(s)")
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        finally:
            self._loaded = (None, None)
        for warning in self._warnings:
            self.report({"WARNING"}, warning)
        self.report({"INFO"}, self._summary(len(todo)))
        return {"FINISHED"}

    def _summary(self, count):
        objects = len(self._probes)
        return f"Glossy baked {count} material(s)" + \
            (f" of {objects} objects" if objects > 1 else "")

    # UI: one part of a material (the fit, a pair of slices, the diffuse map) per
    # timer tick; Esc stops within a part and the unfinished material writes nothing.
    progress_title = "bake materials"

    def _begin(self, context):
        return self._prepare(context)

    def _run_step(self, context, step):
        steps, who = self._job_steps(step)
        return prefixed_steps(f"{who}{step[1]}: ", steps)

    def _done_message(self):
        self._loaded = (None, None)
        for warning in self._warnings:
            self.report({"WARNING"}, warning)
        return self._summary(self._done)

    def _cancel_message(self):
        self._loaded = (None, None)
        return (f"Bake cancelled after {self._done} material(s); the unfinished one wrote "
                f"nothing")


class GLOSSY_OT_attach_materials(_MaterialsOperator, bpy.types.Operator):
    """Rebuild the selected objects' baked materials as Glossy lookups (EEVEE and Cycles)"""

    bl_idname = "glossy.attach_materials"
    bl_label = "Attach Lookups"
    bl_options = {"REGISTER", "UNDO"}

    @staticmethod
    def _combined_maps(material, found, image, spatial):
        """build_lookup's (roughness_maps, map_inputs) for the maps a From Material
        bake wrote per roughness knot, split colour and metallic
        (glossy_addon.spatial.map_variants), or (None, None) where the bake is one
        map or the user's sockets are gone (the one map is then used, the colour
        as a factor). Removes the glossy colour factor from ``spatial`` where a
        split replaces it."""
        knots = material.glossy.roughness_map_list()
        if not knots or image is None or found.derived is None:
            return None, None
        keys = {key for _, _, key in knots}
        inputs = {"colour": None, "responses": {}, "metallic": None}
        roughness_socket = None
        if any(r is not None for r, _, _ in knots):
            texture = found.derived.spatial.get("roughness")
            roughness_socket = input_socket(material, texture["node"], texture["input"]) \
                if texture else None
            if roughness_socket is None:
                return None, None
        if HIGH in keys:
            _, plan = split_plan(found.derived)
            inputs["colour"] = input_socket(material, plan["node"], plan["input"]) \
                if plan else None
            inputs["responses"] = colour_responses(found)
            inputs["colour_mean"] = plan["mean"] if plan else None
            if inputs["colour"] is None or \
                    set(inputs["responses"]) != {r for r, _, _ in knots}:
                return None, None
        if DIELECTRIC in keys:
            plan = found.derived.spatial.get("metallic")
            inputs["metallic"] = input_socket(material, plan["node"], plan["input"]) \
                if plan else None
            inputs["metallic_mean"] = float(plan["mean"]) if plan else 0.0
            if inputs["metallic"] is None:
                return None, None
        if COAT in keys and spatial.get("coat_tint"):
            inputs["coat_tint"] = spatial["coat_tint"]
        maps = []
        for roughness, knot_path, key in knots:
            knot_meta = exr.read_meta(knot_path)
            maps.append((roughness, key, load_atlas(
                knot_path, precision=knot_meta.get("precision", "float32")), knot_meta))
        if HIGH in keys:
            spatial.pop("glossy", None)
        return (roughness_socket, maps), inputs

    def execute(self, context):
        objects, message = _targets(context)
        if not objects:
            self.report({"ERROR"}, message)
            return {"CANCELLED"}
        attached, warnings, done = 0, [], set()
        try:
            for obj in objects:  # every check before the first change
                for material in _materials(obj):
                    problem = ownership.read_only_problem(material)
                    if problem:
                        raise BakeError(problem)
                    if material.glossy.bake_path or material.glossy.lamp_path:
                        check_settings(material)
                        if bake_status(material.glossy, obj.glossy.probe_path) == "damaged":
                            raise BakeError(f"{material.name}: the baked file "
                                            f"{material.glossy.bake_path} is damaged or was "
                                            f"changed since the bake: bake again")
            lamps, skipped = scene_lamps(context.scene)
            for obj, material in [(each, material) for each in objects
                                  for material in _materials(each)]:
                if material.name in done:  # one material on several selected objects
                    continue
                done.add(material.name)
                settings = material.glossy
                path = settings.bake_path
                if not path and not settings.lamp_path:
                    continue
                image = meta = diffuse = lamp_terms = runtime = None
                if path:
                    meta = exr.read_meta(path)
                    image = load_atlas(path, precision=meta.get("precision", "float32"))
                    if meta.get("mode") == sampling_runtime.MODE:  # Runtime Sampling
                        runtime, image, meta = (image, meta), None, None
                lights = None
                if settings.runtime_path:  # the Hybrid's second texture, or the knots' lights
                    runtime_meta = exr.read_meta(settings.runtime_path)
                    runtime = (load_atlas(settings.runtime_path,
                                          precision=runtime_meta.get("precision", "float32")),
                               runtime_meta)
                    if runtime_meta.get("mode") == knot_lights.MODE:
                        runtime, lights = None, runtime
                tangent, warning = effective_tangent(material, obj)
                settings.tangent_note = warning or ""
                if warning:
                    warnings.append(warning)
                if settings.diffuse_path:
                    diffuse_meta = exr.read_meta(settings.diffuse_path)
                    diffuse = (load_atlas(settings.diffuse_path,
                                          precision=diffuse_meta.get("precision", "float32")),
                               diffuse_meta)
                if settings.lamp_path and settings.lamps:
                    lamp_meta = exr.read_meta(settings.lamp_path)
                    lamp_terms = (load_atlas(settings.lamp_path, precision="float32"), lamp_meta,
                                  lamps, settings.diffuse_colour())
                stash_original(material)
                found = material_parts(material)
                weighting = found.weighting
                spatial = lookup_sockets(material, found.derived.spatial) \
                    if found.derived is not None else {}
                roughness_maps, map_inputs = self._combined_maps(material, found, image,
                                                                 spatial)
                if lights is not None and roughness_maps is None:
                    raise BakeError(f"{material.name}: the textures its maps follow are no "
                                    f"longer linked as at the bake: bake again")
                build_lookup(material, image, meta, diffuse,
                             weighting[1] if weighting[0] == "fresnel" else 0.0, lamp_terms,
                             runtime=runtime, tangent=tangent,
                             diffuse_curve=weighting[1:] if weighting[0] == "curve" else None,
                             spatial=spatial, roughness_maps=roughness_maps,
                             map_inputs=map_inputs,
                             from_material=settings.model == "MATERIAL", knot_lights=lights)
                settings.lamp_set = lamp_set(lamps) if lamp_terms else ""
                output = user_output(material)
                emitted = emission_values(output.inputs["Surface"]) \
                    if settings.model == "MATERIAL" and output is not None else []
                settings.emission_set = json.dumps(emitted) \
                    if settings.model == "MATERIAL" else ""
                settings.lamp_skipped = json.dumps(skipped) if lamp_terms else ""
                attached += 1
        except (BakeError, ValueError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        if not attached:
            self.report({"ERROR"}, "No baked material to attach: bake first")
            return {"CANCELLED"}
        for name, reason in skipped:
            self.report({"WARNING"}, f"Lamp {name} skipped: {reason}")
        for warning in warnings:
            self.report({"WARNING"}, warning)
        self.report({"INFO"}, f"Glossy attached {attached} material(s)"
                    + (f" of {len(objects)} objects" if len(objects) > 1 else "")
                    + (f" lit by {len(lamps)} lamp(s)" if lamps else ""))
        return {"FINISHED"}


classes = (GLOSSY_OT_bake_materials, GLOSSY_OT_attach_materials)
