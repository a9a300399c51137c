"""The Bump-Map BRDF in Blender, as a user's script drives it: compute the table and
its plot, then the usual capture, bake and attach; and a bad height field.

    python bump_brdf.py WORKDIR HDRI RESULT.json
"""

import json
import os
import sys
from pathlib import Path

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
os.environ["GLOSSY_CACHE_DIR"] = str(workdir / "cache")
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24)
bpy.ops.object.shade_smooth()
sphere = bpy.context.object
material = bpy.data.materials.new("Sand")
sphere.data.materials.append(material)
settings = material.glossy
settings.model = "BUMP"
settings.bump_source = "gaussian"
settings.bump_size = 64
settings.bump_slope = 0.25
settings.bump_ior = 0.2  # a conductor (gold-like): a nearly flat Fresnel factor
settings.bump_k = 3.5
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_size_mode = "FIXED"
sphere.glossy.probe_resolution = 32
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
report = {"spec": settings.brdf_spec()}
report["compute"] = sorted(bpy.ops.glossy.bump_brdf())
report["plot"] = settings.bump_plot
report["status"] = settings.bump_status
report["plot_image"] = f"Glossy BRDF {material.name}" in bpy.data.images


class Recorder:
    """A stand-in for a panel's layout: records every call (background mode draws
    no panels), so the Glossy material panel's draw code runs on these settings."""

    def __init__(self, calls):
        self.calls = calls

    def __getattr__(self, name):
        def call(*args, **kwargs):
            self.calls.append([name, [a if isinstance(a, (str, int, float)) else type(a).__name__
                                      for a in args], sorted(kwargs)])
            return self
        return call


from types import SimpleNamespace  # noqa: E402

from glossy.glossy_addon.panels import GLOSSY_PT_material  # noqa: E402

calls = []
for source in ("IMAGE", "grooves", "gaussian"):
    settings.bump_source = source
    GLOSSY_PT_material.draw(SimpleNamespace(layout=Recorder(calls)),
                            SimpleNamespace(material=material, object=sphere, scene=scene))
report["panel_props"] = sorted({c[1][1] for c in calls if c[0] == "prop"})
report["panel_missing"] = [name for name in report["panel_props"] if not hasattr(settings, name)]
report["panel_calls"] = sorted({c[0] for c in calls})
report["capture"] = sorted(bpy.ops.glossy.capture_probes())
report["bake"] = sorted(bpy.ops.glossy.bake_materials())
report["attach"] = sorted(bpy.ops.glossy.attach_materials())
report["bake_path"] = bpy.path.abspath(settings.bake_path)
report["probe_path"] = bpy.path.abspath(sphere.glossy.probe_path)
# Validation takes the bump BRDF like any other: Cycles has no such BSDF, so the
# NumPy reference is the truth (said in the report).
bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
scene.glossy.validate_resolution = 48
scene.glossy.validate_samples = 4
scene.glossy.validate_eevee_samples = 1
report["validate"] = sorted(bpy.ops.glossy.validate())
validation = json.loads((workdir / "glossy" / "validation" / "report.json").read_text())
figures = validation["objects"][0]["figures"]
report["validation_truth"] = figures["truth"]
report["validation_error"] = figures["methods"]["eevee_glossy"]["relative_rms"]
report["validation_notes"] = validation["notes"]

# A height field that is not an image: one clear message, nothing written.
bad_file = workdir / "heights.png"
bad_file.write_text("not an image")
bad = bpy.data.materials.new("Bad")
sphere.data.materials.append(bad)
sphere.active_material_index = 1
bad.glossy.model = "BUMP"
bad.glossy.bump_source = "IMAGE"
bad.glossy.bump_file = str(bad_file)
try:
    report["bad"] = [sorted(bpy.ops.glossy.bump_brdf()), ""]
except RuntimeError as error:
    report["bad"] = [["CANCELLED"], str(error)]
report["bad_plot"] = (workdir / "glossy" / "bump" / "Bad.png").exists()
report["cache_files"] = len(list((workdir / "cache" / "bump").glob("*.npz")))
result_path.write_text(json.dumps(report))
