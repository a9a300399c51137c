"""Where does Blender's Environment Texture look up a lat-long texel written by bake?

Writes an index-coded lat-long EXR with ``bake.exr`` (R = column + 0.5, G =
row + 0.5, B = 1), sets it as the world's Environment Texture with Closest
interpolation, and renders the world with Cycles through perspective cameras
aimed at several directions (one sample through each pixel centre). For every
pixel it records the texel Cycles showed and the texel ``bake``'s lat-long
layout predicts for that pixel's camera ray, computed independently from the
camera's matrix, focal length and sensor.

    python envtexture_direction.py REPO_ROOT WORKDIR RESULT.json
"""

import json
import math
import sys
from pathlib import Path

import numpy as np

repo, workdir, result_path = Path(sys.argv[1]), Path(sys.argv[2]), sys.argv[3]
sys.path.insert(0, str(repo))

import _checkout  # noqa: E402,F401  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from glossy.glossy_addon.scenes import environment_world, exact_cycles, float_exr_output  # noqa: E402
from mathutils import Euler, Matrix  # noqa: E402

from bake import exr  # noqa: E402
from bake.envmap import get_layout  # noqa: E402

HEIGHT, WIDTH = 32, 64
PIXELS = 24
FOCAL_MM, SENSOR_MM = 18.0, 36.0
# (name, rotation_euler XYZ in degrees): cameras look along their local -Z.
VIEWS = [
    ("up", (0, 0, 0)),
    ("down", (180, 0, 0)),
    ("plus_x", (90, 0, -90)),
    ("plus_y", (90, 0, 0)),
    ("minus_y", (90, 0, 180)),
    ("tilted", (60, 10, 35)),
]

rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH]
coded = np.stack([cols + 0.5, rows + 0.5, np.ones_like(rows, dtype=float)], -1).astype(np.float32)
env_path = workdir / "index_coded_latlong.exr"
exr.write(env_path, coded, {"layout": "latlong"})

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
exact_cycles(scene, 1)
float_exr_output(scene, PIXELS)
env = environment_world(scene, env_path, "coded")
background = scene.world.node_tree.nodes["Background"]
env.image.colorspace_settings.name = "Non-Color"
env.interpolation = "Closest"
background.inputs["Strength"].default_value = 1.0

camera_data = bpy.data.cameras.new("cam")
camera_data.lens = FOCAL_MM
camera_data.sensor_width = SENSOR_MM
camera_data.sensor_fit = "AUTO"
camera = bpy.data.objects.new("cam", camera_data)
scene.collection.objects.link(camera)
scene.camera = camera
layout = get_layout("latlong")

report = {"views": {}}
for name, degrees in VIEWS:
    camera.rotation_euler = Euler([math.radians(a) for a in degrees], "XYZ")
    bpy.context.view_layer.update()
    out = workdir / f"render_{name}.exr"
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    image, _ = exr.read(out)
    seen_col = np.floor(image[..., 0]).astype(int)
    seen_row = np.floor(image[..., 1]).astype(int)
    rotation = np.array(Matrix(camera.matrix_world).to_3x3())

    def predicted(dx=0.0, dy=0.0, rotation=rotation):
        """Texel bake predicts for the ray through (pixel centre + (dx, dy) px)."""
        j = np.arange(PIXELS) + 0.5
        xx, yy = np.meshgrid((j + dx) / PIXELS - 0.5, 0.5 - (j + dy) / PIXELS)
        local = np.stack([xx * SENSOR_MM, yy * SENSOR_MM, -np.full_like(xx, FOCAL_MM)], -1)
        rays = local @ rotation.T
        rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
        return layout.direction_to_texel(rays, (HEIGHT, WIDTH))

    want_row, want_col = predicted()
    exact = (seen_col == want_col) & (seen_row == want_row)
    # The 0.01 px Blackman-Harris filter moves a ray by at most 0.005 px: any
    # texel bake predicts within that neighbourhood is consistent.
    consistent = exact.copy()
    for dx, dy in [(-0.005, 0), (0.005, 0), (0, -0.005), (0, 0.005)]:
        row, col = predicted(dx, dy)
        consistent |= (seen_col == col) & (seen_row == row)
    report["views"][name] = {
        "exact": float(np.mean(exact)),
        "consistent": float(np.mean(consistent)),
        "blue": float(np.abs(image[..., 2] - 1.0).max()),
    }
with open(result_path, "w") as handle:
    json.dump(report, handle, indent=1)
