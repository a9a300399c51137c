"""One material on two objects whose probes differ, as a user's script drives it.

    python shared_probes.py WORKDIR RESULT.json

Spheres A (left) and B (right) share the Glossy material "Chrome" (GGX 0.3,
white). A's probe is captured under a red world, B's under a blue one (World
Only probes of constant-colour environment images: each is the world it
was captured in). Bake and attach for A,
then for B; EEVEE renders both (orthographic, 96 x 48 px): each sphere must
show its own probe's colour. Then B's probe is captured again under a green
world, and B re-baked and re-attached: A's pixels must not change.

Then, as a user does with a whole scene: both materials' Roughness set to 0.5
(and Map Size to Auto: the constant worlds' maps take the fewest rows), A, B
and a third object C (outside the camera, with a material but no probe)
selected, and one Bake Materials and one Attach Lookups for the selection:
each sphere must show its own probe at the new roughness; C is skipped.
"""

import json
import sys
from pathlib import Path

workdir, result_path = Path(sys.argv[1]), Path(sys.argv[2])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
import numpy as np  # noqa: E402
from _operators import run, world_probe  # noqa: E402
from glossy.bake import exr  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402
from glossy.glossy_addon.scenes import environment_world, float_exr_output  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))
float_exr_output(scene, 96, 48)
scene.render.engine = "BLENDER_EEVEE"
scene.eevee.taa_render_samples = 1
scene.render.film_transparent = True

material = bpy.data.materials.new("Chrome")
material.glossy.model = "ggx"
material.glossy.roughness = 0.3
material.glossy.slices = 4
material.glossy.size_mode = "FIXED"
material.glossy.map_size = 16
spheres = {}
for name, x in (("A", -1.2), ("B", 1.2)):
    bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16, radius=1.0,
                                         location=(x, 0.0, 0.0))
    bpy.ops.object.shade_smooth()
    sphere = bpy.context.object
    sphere.name = name
    sphere.data.materials.append(material)
    world_probe(sphere)
    spheres[name] = sphere
camera_data = bpy.data.cameras.new("camera")
camera_data.type = "ORTHO"
camera_data.ortho_scale = 5.0
camera = bpy.data.objects.new("camera", camera_data)
camera.location = (0.0, 0.0, 6.0)
scene.collection.objects.link(camera)
scene.camera = camera
result = {}


def select(obj):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj


def glossy_for(name, colour):
    """A world of constant ``colour`` (an environment image, as World Only probes
    need); capture, bake and attach for sphere ``name``."""
    path = workdir / f"world_{'_'.join(f'{c:g}' for c in colour)}.exr"
    exr.write(path, np.broadcast_to(np.float32(colour), (8, 16, 3)).copy(), {})
    environment_world(scene, path)
    select(spheres[name])
    return [run(bpy.ops.glossy.capture_probes), run(bpy.ops.glossy.bake_materials),
            run(bpy.ops.glossy.attach_materials)]


def render_alpha(tag):
    """The alpha of render ``tag``'s image (H, W)."""
    return exr.read(workdir / f"{tag}.exr")[0][..., 3]


def render(tag):
    """Mean RGB over each sphere's pixels (alpha 1: the left and right halves)."""
    path = workdir / f"{tag}.exr"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image, _ = exr.read(path)
    covered = image[..., 3] > 0.999
    out = {}
    for name, columns in (("A", slice(0, 48)), ("B", slice(48, 96))):
        mask = np.zeros(covered.shape, bool)
        mask[:, columns] = covered[:, columns]
        out[name] = {"mean": image[mask][:, :3].mean(axis=0).tolist(),
                     "pixels": image[..., :3][mask]}
    return out


result["a"] = glossy_for("A", (1.0, 0.05, 0.05))
result["b"] = glossy_for("B", (0.05, 0.05, 1.0))
result["materials"] = {name: s.material_slots[0].material.name for name, s in spheres.items()}
first = render("first")
result["first"] = {name: v["mean"] for name, v in first.items()}
result["b_again"] = glossy_for("B", (0.05, 1.0, 0.05))
second = render("second")
result["second"] = {name: v["mean"] for name, v in second.items()}
result["a_max_change"] = float(np.abs(second["A"]["pixels"] - first["A"]["pixels"]).max())
result["a_pixels"] = int(len(first["A"]["pixels"]))

# The whole selection in one call: A (red probe) and B (green probe), and C,
# which has a material but no probe of its own.
bpy.ops.mesh.primitive_cube_add(size=0.5, location=(0.0, 6.0, 0.0))
other = bpy.context.object
other.name = "C"
plain = bpy.data.materials.new("Plain")
plain.glossy.model = "ggx"
other.data.materials.append(plain)
for sphere in spheres.values():
    sphere.material_slots[0].material.glossy.roughness = 0.5
    # Auto map size within the default bound: a constant world holds no detail,
    # so Auto bakes the fewest rows (bake.probe_content) and says why.
    sphere.material_slots[0].material.glossy.size_mode = "AUTO"
    sphere.material_slots[0].material.glossy.map_size = 384
only_c = run(bpy.ops.glossy.bake_materials)  # C alone is selected: refused
bpy.ops.object.select_all(action="DESELECT")
for obj in (spheres["A"], spheres["B"], other):
    obj.select_set(True)
bpy.context.view_layer.objects.active = other
together = [run(bpy.ops.glossy.bake_materials), run(bpy.ops.glossy.attach_materials)]
third = render("together")
result["together"] = {
    "only_c": only_c, "steps": together,
    "means": {name: v["mean"] for name, v in third.items()},
    "baked": {name: {"material": s.material_slots[0].material.name,
                     "object": s.material_slots[0].material.glossy.bake_object,
                     "roughness": s.material_slots[0].material.glossy.roughness,
                     "chosen_size": s.material_slots[0].material.glossy.chosen_size,
                     "size_reason": s.material_slots[0].material.glossy.size_reason,
                     "status": bake_status(s.material_slots[0].material.glossy,
                                           s.glossy.probe_path)}
              for name, s in spheres.items()},
    "plain_path": plain.glossy.bake_path,
}
# A constant world of colour c reflects c times the GGX albedo at n.v: the
# expected red of A's pixels (orthographic camera straight down, sphere of
# radius 1 at x = -1.2: 96 px span 5 units).
from glossy.bake import brdf  # noqa: E402

rows, cols = np.nonzero((np.arange(96)[None, :] < 48) & (render_alpha("together") > 0.999))
x = (cols + 0.5) / 96 * 5.0 - 2.5 + 1.2
y = 1.25 - (rows + 0.5) / 48 * 2.5
mu = np.sqrt(np.clip(1.0 - x * x - y * y, 0.0, 1.0))
views = np.stack([np.sqrt(1.0 - mu * mu), np.zeros_like(mu), mu], axis=-1)
albedo = brdf.parse("ggx:roughness=0.5").albedo(views)[..., 0]
result["together"]["a_red_expected"] = float(np.mean(1.0 * albedo))
result_path.write_text(json.dumps(result, indent=1))
