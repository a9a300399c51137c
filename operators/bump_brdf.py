"""glossy.bump_brdf: compute the active material's Bump-Map BRDF table and its plot.

The table (bake.bumpbrdf: horizon tables, then one incident elevation per
step) goes to Glossy's BRDF cache, so the material's bake takes it at once;
the plot (in-plane slices of f cos at 0, 30 and 60 degrees, no matplotlib
needed) goes to ``//glossy/bump/<material>.png`` and is shown in the panel.
"""

import time

import bpy

from ..bake import bumpbrdf, preview
from ..bake.brdf.plot import polar_image
from ..bake.errors import BakeError
from ..bake.progress import run_steps
from ..glossy_addon.modal import TimerSteps
from ..glossy_addon.paths import output_folder
from ..glossy_addon.progress import BlenderProgress

PLOT_VIEWS = (0.0, 30.0, 60.0)


def _material(context):
    material = getattr(context, "material", None) or (
        context.object.active_material if context.object is not None else None)
    if material is None or material.glossy.model != "BUMP":
        raise BakeError("the active material's Glossy BRDF is not a Bump-Map BRDF")
    return material


def compute_steps(material):
    """Generator of (fraction, message): the table, then the plot; returns the report."""
    spec = material.glossy.bump_spec()
    start = time.perf_counter()
    model = yield from bumpbrdf.bump_model_steps(spec[len("bump:"):])
    folder = output_folder() / "bump"
    folder.mkdir(parents=True, exist_ok=True)
    plot = folder / f"{bpy.path.clean_name(material.name)}.png"
    preview.write_png(plot, polar_image(model, PLOT_VIEWS))
    image = bpy.data.images.get(f"Glossy BRDF {material.name}")
    if image is None or image.filepath != str(plot):
        image = bpy.data.images.load(str(plot), check_existing=False)
        image.name = f"Glossy BRDF {material.name}"
    else:
        image.reload()
    settings = material.glossy
    settings.bump_plot = str(plot)
    shape = "x".join(str(n) for n in model.values.shape[:-1])
    kind = "isotropic" if model.values.ndim == 4 else "anisotropic"
    settings.bump_status = f"table {shape} ({kind}), {time.perf_counter() - start:.1f} s"
    return f"Glossy computed {material.name}'s bump BRDF: {settings.bump_status}"


class GLOSSY_OT_bump_brdf(TimerSteps, bpy.types.Operator):
    """Compute the active material's BRDF from its height field and plot it"""

    bl_idname = "glossy.bump_brdf"
    bl_label = "Compute Bump BRDF"
    bl_options = {"REGISTER"}
    progress_title = "bump BRDF"

    @classmethod
    def poll(cls, context):
        try:
            _material(context)
        except BakeError as error:
            cls.poll_message_set(str(error))
            return False
        return True

    def _begin(self, context):
        material = _material(context)
        material.glossy.bump_spec()  # a bad field raises here, before any work
        self._material_name = material.name
        self._message = ""
        return [material.name]

    def _run_step(self, context, name):
        return self._remember(compute_steps(bpy.data.materials[name]))

    def _remember(self, steps):
        self._message = yield from steps
        return self._message

    def _done_message(self):
        return self._message

    def execute(self, context):
        try:
            material = _material(context)
            with BlenderProgress(context, self.progress_title) as progress:
                message = run_steps(compute_steps(material), progress)
        except (BakeError, ValueError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self.report({"INFO"}, message)
        return {"FINISHED"}


classes = (GLOSSY_OT_bump_brdf,)
