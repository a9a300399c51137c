"""One material on two objects whose probes differ, as a user's script drives it.

    python shared_probes.py WORKDIR RESULT.json

Spheres A (left) and B (right) share the Glossy material "Chrome" (GGX 0.3,
white). A's probe is captured under a red world, B's under a blue one (World
Only probes of constant-colour environment images: each is the world it
was captured in). Bake and attach for A,
then for B; EEVEE renders both (orthographic, 96 x 48 px): each sphere must
show its own probe's colour. Then B's probe is captured again under a green
world, and B re-baked and re-attached: A's pixels must not change.
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
result_path.write_text(json.dumps(result, indent=1))
