"""The Glossy tab of the 3D viewport sidebar."""

import bpy

from . import ownership
from .method_choice import choose
from .world import WorldNotReadable, find_environment_image, world_environment


def _reason(layout, text, icon="INFO"):
    """A chosen size and its reason, wrapped over lines of about 40 characters."""
    words, line, lines = text.split(), "", []
    for word in words:
        if line and len(line) + len(word) > 40:
            lines.append(line)
            line = word
        else:
            line = f"{line} {word}".strip()
    lines.append(line)
    column = layout.column(align=True)
    for index, part in enumerate(lines):
        column.label(text=part, icon=icon if index == 0 else "BLANK1")


def _props(layout, settings, names):
    """An aligned column of ``settings``' properties; returns the column."""
    column = layout.column(align=True)
    for name in names:
        column.prop(settings, name)
    return column


#: The panel's line for bake.validation.diagnosis's cause (report.md has the figures).
CAUSE_LABELS = {
    "bake": "Mostly the bake's own error: a larger map helps",
    "probe": "Mostly what one probe cannot hold (self-reflection, parallax)",
    "noise": "Mostly Cycles' noise: raise the validation samples",
    "mixed": "Bake, probe and noise alike (report.md)",
}

class _Sidebar:
    """The Glossy tab of the 3D viewport's sidebar."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Glossy"


class GLOSSY_PT_environment(_Sidebar, bpy.types.Panel):
    bl_label = "Environment"
    bl_idname = "GLOSSY_PT_environment"

    def draw(self, context):
        layout = self.layout
        settings = context.scene.glossy
        image = find_environment_image(context.scene.world)
        if image is None:
            layout.label(text="World has no Environment Texture image", icon="INFO")
        else:
            layout.label(text=f"{image.name} ({image.size[0]}x{image.size[1]})", icon="WORLD")
        _props(layout, settings, ("export_layout", "export_size", "export_mip"))
        layout.operator("glossy.export_environment", icon="EXPORT")
        if settings.last_export:
            layout.label(text=bpy.path.basename(settings.last_export), icon="FILE_IMAGE")


class GLOSSY_PT_probe(_Sidebar, bpy.types.Panel):
    bl_label = "Probe"
    bl_idname = "GLOSSY_PT_probe"

    @classmethod
    def poll(cls, context):
        return context.object is not None and context.object.type == "MESH"

    def draw(self, context):
        settings = context.object.glossy
        layout = self.layout
        column = _props(layout, settings, ("probe_source", "centre_mode", "probe_size_mode"))
        column.prop(settings, "probe_resolution",
                    text="Max Probe Resolution" if settings.probe_size_mode == "AUTO"
                    else "Probe Resolution")
        if settings.probe_source == "RENDER":
            for name in ("capture_engine", "capture_samples", "clip_start", "clip_end",
                         "hide_self"):
                column.prop(settings, name)
        elif find_environment_image(context.scene.world) is not None:
            try:  # what World Only will apply, or why it cannot resample this world
                mapping = world_environment(context.scene.world)[1]
                if not mapping.is_identity:
                    _reason(layout, f"World Only applies the world's Mapping "
                            f"({mapping.vector_type.lower()}) and Strength "
                            f"{mapping.strength:g}")
            except WorldNotReadable as error:
                _reason(layout, f"World Only cannot resample this world: {error}",
                        icon="ERROR")
        row = layout.row(align=True)
        row.operator("glossy.capture_probes", icon="RENDER_STILL")
        row.operator("glossy.clear", icon="TRASH")
        row = layout.row(align=True)  # the selection's materials, each with its own probe
        row.operator("glossy.bake_materials", icon="RENDER_RESULT")
        row.operator("glossy.attach_materials", icon="NODETREE")
        if settings.probe_path:
            layout.label(text=bpy.path.basename(settings.probe_path), icon="FILE_IMAGE")
            problem = ownership.probe_problem(context.object)
            if problem:
                _reason(layout, problem, icon="ERROR")
            elif settings.probe_reason:
                _reason(layout, settings.probe_reason)


def _draw_lamps(layout, material, scene):
    """The lamp factors' settings and what the last bake and attach did with lamps."""
    import json

    from ..bake import brdf
    from .lamps import lamp_set_changed, scene_lamps

    settings = material.glossy
    box = layout.box()
    box.prop(settings, "lamps")
    if not settings.lamps:
        return
    _props(box, settings, ("lamp_parameterization", "lamp_method", "lamp_size", "lamp_size_h",
                           "lamp_terms"))
    lamps, skipped = scene_lamps(scene)
    if settings.lamp_path and settings.lamp_error >= 0:
        box.label(text=f"Factors: {100 * settings.lamp_error:.1f}% BRDF error", icon="TEXTURE")
    elif lamps:
        _reason(box, f"The scene has {len(lamps)} lamp(s) and this material no factors: bake "
                     f"to light it", icon="ERROR")
    if settings.lamp_set:
        if lamp_set_changed(material, scene):
            _reason(box, "The scene's lamps changed since the last attach: attach again",
                    icon="ERROR")
        else:
            names = ", ".join(name for name, _ in json.loads(settings.lamp_set))
            _reason(box, f"Lit by {names or 'no lamp'} (unshadowed)", icon="LIGHT")
    for name, reason in skipped:
        _reason(box, f"{name} skipped: {reason}", icon="ERROR")
    spec = settings.brdf_spec()
    if spec.strip().lower().startswith("bump:"):
        return  # parsing would compute its table: never in a redraw
    try:
        model = brdf.parse(spec)
    except Exception:  # a bad spec is reported by the bake
        return
    if getattr(model, "name", "") == "ggx" and model.isotropic:
        _reason(box, "EEVEE renders isotropic GGX under lamps itself, no more accurately "
                     "than these factors (measured against Cycles: 2.8% vs 1.9%), and a native "
                     "BSDF would add EEVEE's world reflection to Glossy's: the factors are kept",
                icon="INFO")


def _draw_from_material(layout, material):
    """The spec read from the node tree, what it ignores or approximates, and which
    inputs changed since the bake (glossy_addon.material_source)."""
    from .material_source import NodeReadError, changed_inputs, derive

    box = layout.box()
    try:
        derived = derive(material)
    except NodeReadError as error:
        _reason(box, f"Cannot read the material: {error}", icon="ERROR")
        return
    _reason(box, f"Spec: {derived.spec}", icon="NODETREE")
    for line in derived.ignored:
        _reason(box, f"Ignored: {line}", icon="ERROR")
    for line in derived.approximated:
        _reason(box, f"Approximated: {line}", icon="INFO")
    settings = material.glossy
    if settings.bake_inputs:
        changed = changed_inputs(settings.bake_inputs, derived)
        if changed:
            _reason(box, f"Changed since the bake: {', '.join(changed)}", icon="ERROR")


def _draw_bump(layout, column, settings):
    """The Bump-Map BRDF fields, the compute button, its status and the plot."""
    column.prop(settings, "bump_source")
    if settings.bump_source == "IMAGE":
        column.prop(settings, "bump_file")
        column.prop(settings, "bump_texel")
        column.prop(settings, "bump_height")
    else:
        column.prop(settings, "bump_size")
        if settings.bump_source == "grooves":
            column.prop(settings, "bump_period")
            column.prop(settings, "bump_depth")
        else:
            column.prop(settings, "bump_slope")
            column.prop(settings, "bump_seed")
    column.prop(settings, "bump_ior")
    column.prop(settings, "bump_k")
    column.prop(settings, "bump_isotropic")
    layout.operator("glossy.bump_brdf", icon="MOD_DISPLACE")
    if settings.bump_status:
        _reason(layout, settings.bump_status, icon="INFO")
    image = bpy.data.images.get(f"Glossy BRDF {settings.id_data.name}")
    if image is not None:  # the plot glossy.bump_brdf wrote
        layout.label(text="f cos in the plane of incidence: 0, 30, 60 degrees")
        layout.template_icon(icon_value=layout.icon(image), scale=8.0)


class GLOSSY_PT_material(bpy.types.Panel):
    bl_label = "Glossy"
    bl_idname = "GLOSSY_PT_material"
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "material"

    @classmethod
    def poll(cls, context):
        return context.material is not None

    def draw(self, context):
        from .bookkeeping import bake_status
        from .emission import emission_changed

        settings = context.material.glossy
        layout = self.layout
        column = layout.column(align=True)
        column.prop(settings, "model")
        if settings.model == "MATERIAL":
            _draw_from_material(layout, context.material)
        elif settings.model == "CUSTOM":
            column.prop(settings, "spec")
        elif settings.model == "BUMP":
            _draw_bump(layout, column, settings)
        elif settings.model == "phong":
            column.prop(settings, "exponent")
            column.prop(settings, "color")
        else:
            if settings.model != "lambert":
                column.prop(settings, "roughness")
            if settings.model in ("ggx", "beckmann", "ashikhmin_shirley"):
                column.prop(settings, "anisotropy")
                if settings.anisotropy != 0.0:
                    column.prop(settings, "rotation")
                    row = column.row(align=True)
                    row.prop(settings, "tangent_type", text="")
                    if settings.tangent_type == "RADIAL":
                        row.prop(settings, "tangent_axis", text="")
                    elif context.object is not None and context.object.type == "MESH":
                        row.prop_search(settings, "tangent_uv_map", context.object.data,
                                        "uv_layers", text="")
                    else:
                        row.prop(settings, "tangent_uv_map", text="")
                    if settings.tangent_note:
                        _reason(column, settings.tangent_note, icon="ERROR")
            column.prop(settings, "color")
        if settings.model != "MATERIAL":
            layout.prop(settings, "diffuse")
            layout.prop(settings, "fresnel_ior")
        column = _props(layout, settings, ("method",))
        method, why = choose(settings)
        if why:
            _reason(column, f"Auto: {why}", icon="INFO")
        if method in ("3d", "2d", "hybrid"):
            column.prop(settings, "slices")
        if method in ("3d", "hybrid"):
            column.prop(settings, "lobes")
        if method in ("runtime", "hybrid"):
            column.prop(settings, "samples")
        if method in ("runtime", "hybrid") or (method == "3d" and settings.method == "auto"
                                                and settings.model == "MATERIAL"):
            column.prop(settings, "probe_lights")
        column.prop(settings, "size_mode")
        column.prop(settings, "map_size",
                    text="Max Map Size" if settings.size_mode == "AUTO" else "Map Size")
        obj = context.object
        probe = obj.glossy.probe_path if obj is not None else ""
        layout.label(text=f"Bake: {bake_status(settings, probe)}", icon="INFO")
        if emission_changed(context.material):
            _reason(layout, "The material's emission or alpha changed since the last attach: "
                            "attach again", icon="ERROR")
        if settings.copy_of:
            _reason(layout, f"Glossy's copy of '{settings.copy_of}' for "
                            f"{settings.bake_object or 'this object'}: it reflects that "
                            f"object's own probe", icon="DUPLICATE")
        if obj is not None and settings.bake_object and settings.bake_object != obj.name:
            _reason(layout, f"Shows {settings.bake_object}'s bake: Bake Materials gives "
                            f"{obj.name} its own copy of this material", icon="ERROR")
        elif obj is not None:
            others = ownership.shared_probe_users(context.material, obj)
            if others:
                _reason(layout, f"Shared with {', '.join(others)} (other probes): each object "
                                f"that bakes gets its own copy", icon="INFO")
        if settings.size_reason:
            _reason(layout, f"Baked at {settings.size_reason}", icon="TEXTURE")
        _draw_lamps(layout, context.material, context.scene)
        row = layout.row(align=True)
        row.operator("glossy.bake_materials", icon="RENDER_RESULT")
        row.operator("glossy.attach_materials", icon="NODETREE")
        if settings.original is not None:
            layout.label(text=f"Original kept as '{settings.original.name}'", icon="MATERIAL")
        if settings.validation_date:
            stale = settings.validation_bake_hash != settings.bake_hash
            box = layout.box()
            box.label(text=f"Validated {settings.validation_date}"
                      + (" (STALE: re-baked since)" if stale else ""),
                      icon="ERROR" if stale else "CHECKMARK")
            truth = "Cycles" if settings.validation_truth == "cycles" else "NumPy reference"
            box.label(text=f"Glossy vs {truth}: {100 * settings.validation_error:.1f}% RMS")
            if settings.validation_native_error >= 0:
                box.label(text=f"EEVEE native: {100 * settings.validation_native_error:.1f}% RMS")
            cause = CAUSE_LABELS.get(settings.validation_cause)
            if cause:
                box.label(text=cause, icon="INFO")


class GLOSSY_PT_validate(_Sidebar, bpy.types.Panel):
    bl_label = "Validate"
    bl_idname = "GLOSSY_PT_validate"

    def draw(self, context):
        settings = context.scene.glossy
        layout = self.layout
        _props(layout, settings, ("validate_resolution", "validate_samples",
                                  "validate_eevee_samples", "validate_reference"))
        layout.operator("glossy.validate", icon="CHECKMARK")
        if settings.last_report:
            layout.label(text=settings.last_report, icon="FILE_TEXT")


classes = (GLOSSY_PT_environment, GLOSSY_PT_probe, GLOSSY_PT_material, GLOSSY_PT_validate)
register, unregister = bpy.utils.register_classes_factory(classes)
