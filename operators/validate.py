"""glossy.validate: the selected objects' Glossy materials against Cycles.

Renders the scene with the camera (or a temporary one framing the selection):
Cycles with the true BSDFs (two seeds), EEVEE with EEVEE's own BSDFs (the
scene's settings, and once more without sun extraction and indirect clamp
when the scene has them), EEVEE with Glossy's lookups, and the NumPy
reference at the same pixels (unless the scene's NumPy Reference is off, where
only objects without a Cycles truth get it); then writes per object a PNG sheet plus
report.json / report.md / the renders into ``//glossy/validation/`` and
stores the figures on each material. Everything it changes is put back
however it ends; a cancelled or failed validation leaves no report.
"""

import datetime
import os
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import bpy
import numpy as np

from ..bake import brdf, exr, lamp_reference, metrics, reference, validation
from ..bake.brdf import fresnel
from ..bake.errors import BakeError
from ..bake.progress import blas_limited_steps, prefixed_steps, run_steps
from ..glossy_addon import lamps as glossy_lamps
from ..glossy_addon import validation as glue
from ..glossy_addon.capture import lookup_truths
from ..glossy_addon.material_source import parts as material_parts
from ..glossy_addon.materials import effective_tangent
from ..glossy_addon.modal import TimerSteps
from ..glossy_addon.paths import output_folder
from ..glossy_addon.progress import BlenderProgress
from ..glossy_addon.spatial import with_roughness

#: Cycles samples of the passes of per-pixel inputs (an emission: converged in a
#: few; these anti-alias it as the truth renders are).
INPUT_PASS_SAMPLES = 16


@dataclass
class _Pixels:
    """One material's pixels as the reference shades them: world positions, unit
    normals and views (P, 3), tangents (P, 3) or None, the Base Color pass's
    colours (P, 3) or None, the lamps and their visibility (P, lamps) or None,
    the Metallic pass's values (P,) or None."""

    positions: np.ndarray
    normals: np.ndarray
    views: np.ndarray
    tangents: np.ndarray | None
    colour: np.ndarray | None = None
    lamps: list = field(default_factory=list)
    visibility: np.ndarray | None = None
    metallic: np.ndarray | None = None

    @property
    def cos_view(self):
        return np.clip(np.sum(self.normals * self.views, axis=1), 0.0, 1.0)

    def subset(self, use):
        """The pixels where ``use`` (P,) is True."""
        def pick(array):
            return None if array is None else array[use]
        return _Pixels(self.positions[use], self.normals[use], self.views[use],
                       pick(self.tangents), pick(self.colour), self.lamps,
                       pick(self.visibility), pick(self.metallic))


def _transparent(material):
    """Whether ``material``'s lookup mixes in a Transparent BSDF by the user's Alpha."""
    from ..glossy_addon.nodes import user_output
    from ..glossy_addon.transparency import alpha_input

    output = user_output(material) if material.glossy.model == "MATERIAL" else None
    return output is not None and alpha_input(output.inputs["Surface"]) is not None


def _glossy_materials(obj):
    out = []
    for slot in obj.material_slots:
        material = slot.material
        if material is not None and (material.glossy.bake_path or material.glossy.original):
            if material not in out:
                out.append(material)
    return out


def _targets(context):
    """[(object, [Glossy materials])] of the selection, or raise BakeError saying why not."""
    selected = [obj for obj in context.selected_objects if obj.type == "MESH"]
    if not selected and context.object is not None and context.object.type == "MESH":
        selected = [context.object]
    if not selected:
        raise BakeError("Select the mesh objects to validate")
    if not any(slot.material for obj in selected for slot in obj.material_slots):
        raise BakeError("The selected objects have no material: give them a Glossy material, "
                        "then capture, bake and attach")
    targets = [(obj, _glossy_materials(obj)) for obj in selected]
    targets = [(obj, materials) for obj, materials in targets if materials]
    if not targets:
        raise BakeError("Nothing baked for the selected objects: capture, bake and attach "
                        "their Glossy materials first")
    for obj, materials in targets:
        for material in materials:
            path = material.glossy.bake_path
            if not path or not Path(bpy.path.abspath(path)).exists():
                raise BakeError(f"{material.name}: nothing baked: bake it first")
            if material.glossy.original is None:
                raise BakeError(f"{material.name}: baked but not attached: attach it first")
        if not obj.glossy.probe_path or not Path(bpy.path.abspath(obj.glossy.probe_path)).exists():
            raise BakeError(f"{obj.name}: its probe is missing: capture it again")
    return targets


class GLOSSY_OT_validate(TimerSteps, bpy.types.Operator):
    """Render the selected Glossy objects in Cycles, native EEVEE, EEVEE with Glossy and the
    NumPy reference; write error sheets and a report beside the .blend"""

    bl_idname = "glossy.validate"
    bl_label = "Validate Against Cycles"
    bl_options = {"REGISTER"}
    progress_title = "validate"
    timer_interval = 0.02

    # --- set-up ---------------------------------------------------------------
    def _begin(self, context):
        scene = context.scene
        settings = scene.glossy
        self._targets = _targets(context)
        self._folder = output_folder() / "validation"
        self._work = Path(tempfile.mkdtemp(prefix="glossy-validate-"))
        self._changes = glue.SceneChanges()
        self._notes, self._images, self._timings = [], {}, {}
        self._references = {}
        self._lamp_noted = False
        try:
            self._setup(context, scene, settings)
        except BaseException:
            self._cleanup()
            raise
        steps = [("cycles", 1), ("cycles", 2), ("eevee_native", 0), ("eevee_glossy", 0)]
        for kind in sorted({kind for _, kind in self._passes}, reverse=True):
            steps.insert(2, ("input_pass", kind))
        if self._careful:
            steps.append(("eevee_native_careful", 0))
        # The reference of an object whose material has no Cycles truth is its truth.
        steps += [("reference", index) for index, (_, materials) in enumerate(self._targets)
                  if settings.validate_reference
                  or any(self._truth.get(m.name) is None for m in materials)]
        if not settings.validate_reference:
            self._notes.append("the NumPy reference was off (Validate panel): no 'Glossy vs "
                               "reference' figures and no diagnosis of where the error lies")
        steps.append(("report", 0))
        return steps

    def _setup(self, context, scene, settings):
        changes = self._changes
        if scene.camera is None:
            glue.framing_camera(changes, scene, [obj for obj, _ in self._targets])
            self._camera_note = "temporary camera framing the selection (the scene has none)"
            self._notes.append("the scene has no camera: a temporary one framed the selection")
        else:
            self._camera_note = f"scene camera '{scene.camera.name}'"
        self._size = glue.prepare_output(changes, scene, settings.validate_resolution)
        self._careful = glue.careful_differs(scene)
        self._truth, self._slots = {}, []
        # {object: {slot index: Glossy material name}}: which faces the reference
        # shades with which material (pixel_geometry's slot per pixel).
        self._slot_materials = {
            obj.name: {i: slot.material.name for i, slot in enumerate(obj.material_slots)
                       if slot.material in materials}
            for obj, materials in self._targets}
        # Inputs the reference follows per pixel: Base Color textures (with the plan
        # that uses them) and normal or bump maps, each rendered by Cycles as an
        # emission pass of its value: {(material name, kind): pass material}.
        self._colour_plans, self._passes = {}, {}
        for material in {m.name: m for _, materials in self._targets
                         for m in materials}.values():
            plan = glue.colour_plan(material)
            wanted = [(kind, socket) for kind, socket in plan[2].items()
                      if socket is not None] if plan is not None else []
            planned = {kind for kind, _ in wanted}
            for kind in ("normal", "roughness"):
                if glue.spatial_socket(material, kind) is not None:
                    wanted.append((kind, glue.spatial_socket(material, kind)))
            if material.glossy.model == "MATERIAL":
                wanted.append(("emission", None))  # what the user's shaders emit
            for kind, socket in wanted:
                if (material.name, kind) in self._passes:
                    continue
                shown = glue.emission_pass_material(material) if kind == "emission" else \
                    glue.input_pass_material(material, socket, kind)
                if shown is None:
                    continue
                changes.created(bpy.data.materials, shown)
                self._passes[(material.name, kind)] = shown
            if plan is not None and all((material.name, kind) in self._passes
                                        for kind in planned):
                self._colour_plans[material.name] = plan
        for obj, materials in self._targets:
            for material in materials:
                if material.name in self._truth:
                    continue
                tangent, warning = effective_tangent(material, obj)
                if warning:
                    self._notes.append(warning)
                truth, why = glue.truth_material(material, tangent)
                if truth is not None:
                    changes.created(bpy.data.materials, truth)
                else:
                    self._notes.append(f"{material.name}: no Cycles or EEVEE truth ({why}); "
                                       f"measured against the NumPy reference only")
                self._truth[material.name] = truth
            for slot in obj.material_slots:
                if slot.material in materials:
                    self._slots.append((slot, slot.material))
                    changes.set(slot, "material", slot.material)
        # Other objects showing a lookup are seen as their true BSDFs in the Cycles and
        # native renders too (Cycles cannot compile the runtime-sampling lookups), and
        # as their lookups in EEVEE with Glossy.
        for slot, lookup, truth in lookup_truths(scene, [obj for obj, _ in self._targets]):
            if self._truth.get(lookup.name) is None:
                self._truth[lookup.name] = truth
                changes.created(bpy.data.materials, truth)
            elif truth is not self._truth[lookup.name] and truth.users == 0:
                bpy.data.materials.remove(truth)
            self._slots.append((slot, lookup))
            changes.set(slot, "material", lookup)

    def _use(self, kind):
        """Put the true BSDF ("truth", where there is one) or Glossy's lookup in each slot."""
        for slot, material in self._slots:
            truth = self._truth.get(material.name)
            slot.material = truth if kind == "truth" and truth is not None else material

    # --- steps ----------------------------------------------------------------
    def _run_step(self, context, step):
        kind, value = step
        scene = context.scene
        settings = scene.glossy
        start = time.perf_counter()
        if kind == "cycles":
            self._use("truth")
            glue.configure_cycles(self._changes, scene, settings.validate_samples, value)
            name = f"cycles_seed{value}"
            message = f"Cycles, seed {value} ({settings.validate_samples} spp)"
        elif kind.startswith("eevee"):
            self._use("glossy" if kind == "eevee_glossy" else "truth")
            glue.configure_eevee(self._changes, scene, settings.validate_eevee_samples,
                                 careful=kind == "eevee_native_careful")
            name = kind
            message = validation.METHOD_TITLES[kind]
        elif kind == "input_pass":
            self._use("truth")
            for slot, material in self._slots:
                if (material.name, value) in self._passes:
                    slot.material = self._passes[(material.name, value)]
            glue.configure_cycles(self._changes, scene, INPUT_PASS_SAMPLES, 1)
            name = f"{value}_pass"
            message = {"colour": "the Base Color textures", "normal": "the normal and bump "
                       "maps", "roughness": "the roughness textures",
                       "emission": "what the materials emit",
                       "metallic": "the metallic textures"}[value]
        elif kind == "reference":  # NumPy threads of its own: BLAS held to one
            return blas_limited_steps(self._reference_steps(value))
        else:
            return self._write_report(context)
        self._images[name] = glue.render_to(scene, self._work / f"{name}.exr")
        if name == "cycles_seed1":  # what each pixel's centre ray meets, as Cycles saw it
            width, height = self._size
            self._index, self._positions, self._normals, self._slot = glue.pixel_geometry(
                scene, scene.camera, width, height, [obj for obj, _ in self._targets],
                slots=True)
            # Toward the camera along each pixel's centre ray: exact for perspective
            # and orthographic cameras alike.
            self._views = -glue.camera_rays(scene, scene.camera, width, height)[1]
        self._timings[name] = time.perf_counter() - start
        return f"rendered {message} in {self._timings[name]:.1f} s"

    def _mask(self, index):
        """The pixels of target ``index`` on faces with a Glossy material, each
        material's region eroded by one pixel (its silhouette and the edges between
        materials, where a pixel's filter mixes what its centre does not see)."""
        obj = self._targets[index][0]
        mask = np.zeros(self._index.shape, dtype=bool)
        for name in set(self._slot_materials[obj.name].values()):
            slots = [i for i, m in self._slot_materials[obj.name].items() if m == name]
            mask |= metrics.erode((self._index == index + 1) & np.isin(self._slot, slots), 1)
        return mask

    def _reference_steps(self, index):
        """The NumPy reference of one object at its pixels (a generator: one part per
        chunk of pixels), each face with its own Glossy material."""
        start = time.perf_counter()
        obj, materials = self._targets[index]
        probe, meta = exr.read(bpy.path.abspath(obj.glossy.probe_path))
        probe = probe[..., :3]
        layout = meta.get("layout", "cube")
        index_pass = self._index == index + 1
        radiance = np.zeros((*index_pass.shape, 3))
        slots = self._slot_materials[obj.name]
        if len(materials) > 1:
            self._notes.append(f"{obj.name}: {len(materials)} Glossy materials; the NumPy "
                               f"reference shades each face with its own")
        other = index_pass & ~np.isin(self._slot, list(slots))
        if other.any():
            self._notes.append(f"{obj.name}: {int(other.sum())} pixel(s) of faces without a "
                               f"Glossy material are left out of its figures")
        for material in materials:
            pixels = index_pass & np.isin(self._slot, [i for i, m in slots.items()
                                                        if m == material.name])
            if pixels.any():
                radiance[pixels] = yield from self._material_reference(
                    obj, material, pixels, probe, layout)
                if _transparent(material):
                    self._notes.append(
                        f"{obj.name}: the NumPy reference is opaque: {material.name}'s Alpha "
                        f"(which the lookup applies, glossy_addon.transparency) is not in it, "
                        f"so its figures include what shows through")
                if (material.name, "emission") in self._passes:
                    radiance[pixels] += self._images["emission_pass"][pixels][:, :3]
                    self._notes.append(
                        f"{obj.name}: the NumPy reference adds what {material.name} emits "
                        f"(rendered by Cycles as a pass of the term the lookup adds, "
                        f"glossy_addon.emission)")
        self._references[obj.name] = radiance
        self._timings[f"reference_{obj.name}"] = time.perf_counter() - start
        return f"NumPy reference of {obj.name}: {int(index_pass.sum())} pixels"

    def _material_reference(self, obj, material, pixels, probe, layout):
        """(P, 3) the reference of ``obj``'s ``pixels`` (H, W) shaded with ``material``
        (a generator, yielding progress)."""
        normals = self._normals[pixels]
        if (material.name, "normal") in self._passes:  # the normal or bump map's
            normals = glue.decode_normals(self._images["normal_pass"][pixels])
        normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-30)
        at = _Pixels(self._positions[pixels], normals, self._views[pixels], None)
        tangent, _ = effective_tangent(material, obj)
        if tangent[0] == "RADIAL":  # else bake.reference's hint frame: the lobe is isotropic
            at.tangents = glue.radial_tangents(obj, at.positions, tangent[1])
        elif not all(model.isotropic for model, _ in glue.reference_parts(material)):
            self._notes.append(f"{material.name}: the NumPy reference orients the "
                               f"anisotropic lobe by a fixed hint, not the UV tangent")
        self._note_per_pixel_inputs(obj, material)
        if (material.name, "normal") in self._passes:
            self._notes.append(f"{obj.name}: the NumPy reference takes each pixel's "
                               f"normal from the material's normal or bump map (a Cycles "
                               f"emission pass of it)")
        if material.name in self._colour_plans:
            sockets = self._colour_plans[material.name][2]
            if sockets["colour"] is not None:
                socket = sockets["colour"]
                at.colour = self._images["colour_pass"][pixels][:, :3]
                self._notes.append(
                    f"{obj.name}: the NumPy reference follows {socket[0]}: {socket[1]} per "
                    f"pixel (its value rendered by Cycles as an emission pass; the "
                    f"reflection from integrals at colours 0 and 1, bake.colour_response)")
            if sockets["metallic"] is not None:
                socket = sockets["metallic"]
                at.metallic = self._images["metallic_pass"][pixels][:, 0]
                self._notes.append(
                    f"{obj.name}: the NumPy reference follows {socket[0]}: {socket[1]} per "
                    f"pixel (its value rendered by Cycles as an emission pass; integrals at "
                    f"Metallic 0 and 1 mixed by it: the Principled BSDF is affine in it)")
        at.lamps, at.visibility = self._lamps(obj, at.positions, normals)
        if (material.name, "roughness") not in self._passes:
            return (yield from self._shade(obj, material, None, at, probe, layout))
        knots, weights = glue.roughness_weights(self._images["roughness_pass"][pixels][:, 0])
        spec = material_parts(material).derived.spec
        self._notes.append(
            f"{obj.name}: the NumPy reference follows the roughness texture per pixel "
            f"(its value rendered by Cycles as an emission pass; integrals at "
            f"{len(knots)} roughness knots from {knots[0]:.3g} to {knots[-1]:.3g}, at most "
            f"{glue.REFERENCE_ROUGHNESS_RATIO:g}x apart, interpolated in log roughness)")
        total = np.zeros((int(pixels.sum()), 3))
        for k, knot in enumerate(knots):
            use = weights[:, k] > 0.0
            if use.any():
                part = yield from self._shade(obj, material, with_roughness(spec, knot),
                                              at.subset(use), probe, layout)
                total[use] += weights[use, k, None] * part
        return total

    def _shade(self, obj, material, spec, at, probe, layout):
        """(P, 3) the reference at the pixels ``at`` (a _Pixels) of ``material`` (its
        read BSDF, or ``spec``: the same at one roughness), its Base Color followed
        per pixel where a colour pass is there (a generator)."""
        plan = glue.colour_plan(material, spec) \
            if at.colour is not None or at.metallic is not None else None
        if plan is not None:
            values = []
            for part_spec in plan[0]:
                values.append((yield from self._integrate(obj, brdf.parse(part_spec), probe,
                                                          layout, at)))
            return plan[1](values, at.colour, at.cos_view, at.metallic)
        fresnel_weight = fresnel.dielectric(at.cos_view, material.glossy.fresnel_ior) \
            if material.glossy.fresnel_ior > 1.0 else None
        parts = [(brdf.parse(spec), "one")] if spec else glue.reference_parts(material)
        total = np.zeros((len(at.normals), 3))
        for model, weight in parts:
            part = yield from self._integrate(obj, model, probe, layout, at)
            if weight == "fresnel":
                part = part * fresnel_weight[:, None]
            elif weight == "one_minus_fresnel":
                part = part * (1.0 - fresnel_weight)[:, None]
            total += part
        return total

    def _integrate(self, obj, model, probe, layout, at):
        """(P, 3) the reference of one BRDF at the pixels ``at`` (a _Pixels): the
        probe's integral plus the lamps' light (a generator, yielding progress)."""
        factor, why = reference.reconstruction_factor(model, probe.shape, layout,
                                                      at.normals, at.views,
                                                      tangents=at.tangents)
        if factor > 1:
            self._notes.append(f"{obj.name}: the NumPy reference ({model.spec}) "
                               f"integrates the probe's bilinear reconstruction "
                               f"sampled {factor}x finer ({why})")
        part = yield from prefixed_steps(f"{obj.name}: ", reference.render_steps(
            model, probe, layout, at.normals, at.views, tangents=at.tangents,
            reconstruction="bilinear"))
        if at.lamps:
            yield 1.0, f"{obj.name}: the light of {len(at.lamps)} lamp(s)"
            start = time.perf_counter()
            part = part + lamp_reference.radiance(
                model, at.lamps, at.positions, at.normals, at.views, tangents=at.tangents,
                visibility=at.visibility,
                unblocked=glue.lamp_ray_test(bpy.context.scene, at.lamps))
            key = f"reference_lamps_{obj.name}"
            self._timings[key] = self._timings.get(key, 0.0) + time.perf_counter() - start
        return part

    def _note_per_pixel_inputs(self, obj, material):
        """A note where the lookup applies inputs per pixel (textures, a normal map)
        that the NumPy reference, one BRDF for all the object's pixels, takes at one
        value: its columns then include the texture's variation; and the node
        reader's inputs taken at one value by Glossy and the reference alike (a
        procedural texture at the socket's unlinked value, an image at its mean)."""
        derived = material_parts(material).derived if material.glossy.model == "MATERIAL" \
            else None
        for line in getattr(derived, "approximated", None) or []:
            if "driven by" in line or "taken at its mean" in line:  # Glossy's and the
                self._notes.append(f"{obj.name}: {line}")  # reference's alike
        spatial = {kind: entry for kind, entry in
                   (getattr(derived, "spatial", None) or {}).items()
                   if (material.name, kind) not in self._passes}
        if not spatial:
            return
        inputs = ", ".join(sorted(f"{entry.get('node', '?')}: {entry.get('input', kind)}"
                                  for kind, entry in spatial.items()))
        self._notes.append(
            f"{obj.name}: the lookup applies {inputs} per pixel; the NumPy reference shades "
            f"every pixel with one BRDF (those inputs at one value), so the reference and "
            f"'Glossy vs reference' include the texture's variation")

    def _lamps(self, obj, positions, normals):
        """(the scene's lamps as the reference integrates them, (N, lamps) visibility
        of each from ``obj``'s pixels); the notes once per validation."""
        scene = bpy.context.scene
        lamps, notes = glossy_lamps.reference_lamps(scene)
        if not self._lamp_noted:
            self._lamp_noted = True
            self._notes.extend(notes)
            if lamps:
                self._notes.append(
                    f"the NumPy reference adds the light of {len(lamps)} lamp(s) "
                    f"({', '.join(lamp.name for lamp in lamps)}), shadowed by the scene's "
                    f"objects (16 rays to each lamp per pixel; in a penumbra every "
                    f"sample's ray)")
        if not lamps:
            return [], None
        start = time.perf_counter()
        visibility = glue.lamp_visibility(scene, lamps, positions, normals)
        key = f"reference_lamps_{obj.name}"
        self._timings[key] = self._timings.get(key, 0.0) + time.perf_counter() - start
        return lamps, visibility

    def _write_report(self, context):
        scene = context.scene
        settings = scene.glossy
        staging = self._work / "report"
        staging.mkdir()
        if self._references:
            reference_image = np.zeros_like(self._images["cycles_seed1"])
            for image in self._references.values():
                reference_image += image
            exr.write(staging / "reference.exr", reference_image.astype(np.float32),
                      {"generator": "glossy-validate", "kind": "reference"})
        masks = {}
        cos_view = self._cos_view()
        entries, sheets = [], {}
        date = datetime.datetime.now().isoformat(timespec="seconds")
        for index, (obj, materials) in enumerate(self._targets):
            mask = self._mask(index)
            if not mask.any():
                self._notes.append(f"{obj.name}: not visible from the camera (no pixel)")
                continue
            masks[f"mask.{obj.name}"] = mask.astype(np.float32)
            material = materials[0]
            has_truth = self._truth.get(material.name) is not None
            renders = {"eevee_glossy": self._images["eevee_glossy"],
                       "reference": self._references.get(obj.name)}
            if has_truth:
                renders["eevee_native"] = self._images["eevee_native"]
                if "eevee_native_careful" in self._images:
                    renders["eevee_native_careful"] = self._images["eevee_native_careful"]
            seeds = (self._images["cycles_seed1"], self._images["cycles_seed2"]) \
                if has_truth else None
            figures = validation.evaluate_object(renders, mask, seeds, cos_view)
            truth = 0.5 * (seeds[0] + seeds[1]) if seeds else renders["reference"]
            sheet_name = f"sheet_{bpy.path.clean_name(obj.name)}.png"
            sheets[sheet_name] = validation.object_sheet(renders, truth, mask, figures,
                                                         f"{obj.name} / {material.name}")
            entries.append({"object": obj.name, "material": material.name,
                            "materials": [m.name for m in materials],
                            "brdf": material_parts(material).full_spec, "sheet": sheet_name,
                            "mask_layer": f"mask.{obj.name}", "figures": figures})
            self._store(materials, figures, date)
        if not entries:
            raise BakeError("none of the selected objects is visible from the camera")
        masks["cos_view"] = cos_view  # the n.v of the report's by-view bands
        exr.write(staging / "masks.exr", masks, {"generator": "glossy-validate"})
        for name in list(self._images):
            shutil.copyfile(self._work / f"{name}.exr", staging / f"{name}.exr")
        width, height = self._size
        report = {"date": date, "scene": scene.name, "camera": self._camera_note,
                  "resolution": [width, height], "cycles_samples": settings.validate_samples,
                  "eevee_samples": settings.validate_eevee_samples,
                  "flip": metrics.flip_available(), "notes": self._notes,
                  "renders": {name: f"{name}.exr" for name in self._images},
                  "reference": "reference.exr" if self._references else None,
                  "masks": "masks.exr",
                  "timings_s": {k: round(v, 2) for k, v in self._timings.items()},
                  "objects": entries}
        validation.write_report(staging, report, sheets)
        self._folder.mkdir(parents=True, exist_ok=True)
        for path in sorted(staging.iterdir()):  # whole files, each replaced atomically
            os.replace(path, self._folder / path.name)
        if not self._references:  # an earlier validation's, which this report does not name
            (self._folder / "reference.exr").unlink(missing_ok=True)
        settings.last_report = str(self._folder / "report.md")
        return f"wrote {len(entries)} sheet(s) and the report to {self._folder}"

    def _cos_view(self):
        """(H, W) float32 n.v of each pixel: its shading normal and the direction to the
        camera along its centre ray (0 where no object was hit); float32 as masks.exr
        keeps it, so the report's bands recompute from the file exactly."""
        normals = self._normals / np.maximum(
            np.linalg.norm(self._normals, axis=-1, keepdims=True), 1e-30)
        return np.clip(np.sum(normals * self._views, axis=-1), 0.0, 1.0).astype(np.float32)

    @staticmethod
    def _store(materials, figures, date):
        methods = figures["methods"]
        natives = [methods[m]["relative_rms"] for m in ("eevee_native", "eevee_native_careful")
                   if m in methods]
        for material in materials:
            settings = material.glossy
            settings.validation_error = methods["eevee_glossy"]["relative_rms"]
            settings.validation_native_error = min(natives) if natives else -1.0
            settings.validation_truth = figures["truth"]
            settings.validation_date = date
            settings.validation_cause = figures.get("diagnosis", {}).get("cause", "")
            settings.validation_bake_hash = settings.bake_hash

    # --- ending ---------------------------------------------------------------
    def _cleanup(self):
        changes = getattr(self, "_changes", None)
        if changes is not None:
            changes.restore()
            self._changes = None
        work = getattr(self, "_work", None)
        if work is not None:
            shutil.rmtree(work, ignore_errors=True)
            self._work = None

    def _stop(self, context):
        try:
            super()._stop(context)
        finally:
            self._cleanup()

    def modal(self, context, event):
        try:
            return super().modal(context, event)
        except BaseException:
            self._cleanup()
            raise

    def _done_message(self):
        return f"Glossy validation written to {self._folder}"

    def _cancel_message(self):
        return "Validation cancelled: scene restored, no report written"

    def execute(self, context):
        try:
            steps = self._begin(context)
        except (BakeError, ValueError, TypeError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        try:
            with BlenderProgress(context, self.progress_title) as progress:
                for index, step in enumerate(steps):
                    result = self._run_step(context, step)
                    if not isinstance(result, str):
                        result = run_steps(result, None)
                    progress((index + 1) / len(steps), result)
        except (BakeError, ValueError, RuntimeError) as error:
            self.report({"ERROR"}, f"Validation failed, no report written: {error}")
            return {"CANCELLED"}
        finally:
            self._cleanup()
        self.report({"INFO"}, self._done_message())
        return {"FINISHED"}


classes = (GLOSSY_OT_validate,)
