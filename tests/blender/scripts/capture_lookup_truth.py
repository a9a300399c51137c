"""A Cycles capture sees other objects' attached lookups as their true BSDFs.

    python capture_lookup_truth.py WORKDIR HDRI RESULT.json

A sphere B with a GGX 0.3 material on the default method (Auto: the Hybrid,
whose runtime-sampling nodes Cycles' SVM cannot compile) is captured from the
world, baked and attached; then sphere A's probe is captured with Cycles from
next to it, twice: with B's lookup attached (glossy_addon.capture swaps in its
true BSDF for the capture) and with B's slot set by hand to the true BSDF
(glossy_addon.validation.truth_material). Records the two probes' largest
difference, what B's slot holds after each capture, the materials left over,
and how much of A's probe B covers (so the comparison sees B).
"""

import json
import sys
from pathlib import Path

workdir, hdri, result_path = Path(sys.argv[1]), sys.argv[2], Path(sys.argv[3])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402
from glossy.glossy_addon.validation import truth_material  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))  # outputs go beside it
result = {}


def select(obj):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24, radius=1.0, location=(1.6, 0, 0))
bpy.ops.object.shade_smooth()
b = bpy.context.object
b.name = "B"
material = bpy.data.materials.new("B glossy")
material.glossy.model, material.glossy.roughness = "ggx", 0.3
b.data.materials.append(material)
b.glossy.probe_source = "WORLD"
b.glossy.probe_size_mode, b.glossy.probe_resolution = "FIXED", 32
select(b)
result["b"] = [sorted(bpy.ops.glossy.capture_probes()), sorted(bpy.ops.glossy.bake_materials()),
               sorted(bpy.ops.glossy.attach_materials())]
lookup = b.material_slots[0].material
result["b_method"] = lookup.glossy.method_used()

bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12, radius=0.3, location=(0, 0, 0))
a = bpy.context.object
a.name = "A"
a.data.materials.append(bpy.data.materials.new("A plain"))
a.glossy.probe_size_mode, a.glossy.probe_resolution = "FIXED", 16
a.glossy.capture_engine, a.glossy.capture_samples = "CYCLES", 4


def capture_a():
    select(a)
    status = sorted(bpy.ops.glossy.capture_probes())
    image, _ = exr.read(bpy.path.abspath(a.glossy.probe_path))
    return status, image[..., :3].astype(np.float64)


status, swapped = capture_a()
result["swapped"] = {"status": status, "slot_after": b.material_slots[0].material.name,
                     "truths_left": sorted(m.name for m in bpy.data.materials
                                           if m.name.endswith("(Glossy truth)"))}
truth = truth_material(lookup)[0]
b.material_slots[0].material = truth
status, by_hand = capture_a()
result["by_hand"] = {"status": status}
# B's share of A's probe: texels that change when B is hidden.
b.material_slots[0].material = lookup
b.hide_render = True
_, without_b = capture_a()
b.hide_render = False
result["b_share"] = float(np.mean(np.abs(without_b - by_hand).max(axis=-1) > 1e-3))
scale = float(np.max(by_hand))
result["max_difference"] = float(np.max(np.abs(swapped - by_hand))) / scale

# glossy.validate of A alone (B is not selected): A's Cycles truth reflects B, which
# must be B's true BSDF there too. Figures that depend only on the Cycles renders:
# Cycles' noise (the two seeds) and the NumPy reference against Cycles.
a.glossy.method = "3d"
select(a)
result["a"] = [sorted(bpy.ops.glossy.capture_probes()), sorted(bpy.ops.glossy.bake_materials()),
               sorted(bpy.ops.glossy.attach_materials())]
scene.glossy.validate_resolution, scene.glossy.validate_samples = 48, 16
scene.glossy.validate_eevee_samples = 1
figures = {}
for how in ("lookup", "by_hand"):
    b.material_slots[0].material = lookup if how == "lookup" else truth
    select(a)
    status = sorted(bpy.ops.glossy.validate())
    report = json.loads(Path(scene.glossy.last_report).with_suffix(".json").read_text())
    entry = next(e for e in report["objects"] if e["object"] == "A")["figures"]
    figures[how] = {"status": status, "noise": entry["cycles_noise"],
                    "reference": entry["methods"]["reference"]["relative_rms"],
                    "slot_after": b.material_slots[0].material.name}
result["validate"] = figures
result["truths_left_after_validate"] = sorted(
    m.name for m in bpy.data.materials if m.name.endswith("(Glossy truth)") and m != truth)
result_path.write_text(json.dumps(result, indent=1))
