"""A grid of tilted planes seen straight down, for BRDF checks against Cycles.

cycles_glossy.py and cycles_principled.py share it: an orthographic camera
looks down -Z at GRID x GRID planes (each CELL pixels), Filter Glossy 0. Two
kinds of renders measure each plane's 6 x 6 central pixels:

- ``sun_renders``: world black, max bounces 0, a delta sun of strength 1 with
  shadows off: a pixel is exactly f(l, v) (n.l);
- ``furnace_renders``: world white, one bounce, two seeds, the planes hidden
  from glossy and diffuse rays: a pixel is the directional albedo, with noise
  measured from the pixels and the two seeds.
"""

import math

import bpy
import numpy as np
from glossy.glossy_addon.scenes import exact_cycles, float_exr_output
from mathutils import Vector

from bake import exr


class PlaneGrid:
    def __init__(self, workdir, grid=5, cell=16):
        self.workdir, self.grid, self.cell = workdir, grid, cell
        bpy.ops.wm.read_factory_settings(use_empty=True)
        self.scene = scene = bpy.context.scene
        exact_cycles(scene, 4)
        scene.cycles.caustics_reflective = True
        float_exr_output(scene, grid * cell)
        world = bpy.data.worlds.new("world")
        world.use_nodes = True
        scene.world = world
        self.background = world.node_tree.nodes["Background"]
        camera_data = bpy.data.cameras.new("camera")
        camera_data.type = "ORTHO"
        camera_data.ortho_scale = float(grid)
        camera = bpy.data.objects.new("camera", camera_data)
        camera.location = (0.0, 0.0, 10.0)
        scene.collection.objects.link(camera)
        scene.camera = camera

    def plane(self, index, normal, material):
        """Plane ``index`` (row-major) turned to ``normal``, with ``material``; returns
        its world normal as Blender computes it."""
        row, col = divmod(index, self.grid)
        bpy.ops.mesh.primitive_plane_add(size=0.6, location=(
            col - self.grid / 2 + 0.5, self.grid / 2 - 0.5 - row, 0.0))
        plane = bpy.context.object
        plane.rotation_euler = Vector((0, 0, 1)).rotation_difference(Vector(normal)).to_euler()
        plane.visible_shadow = False
        plane.visible_glossy = False
        plane.visible_diffuse = False  # the furnace: no plane hides the world from another
        plane.data.materials.append(material)
        bpy.context.view_layer.update()
        return list(plane.matrix_world.to_3x3() @ Vector((0, 0, 1)))

    def render(self, name):
        """(planes, 6, 6, 3) central pixels of each plane."""
        self.scene.render.filepath = str(self.workdir / f"{name}.exr")
        bpy.ops.render.render(write_still=True)
        image, _ = exr.read(self.workdir / f"{name}.exr")
        windows = []
        for index in range(self.grid * self.grid):
            row, col = divmod(index, self.grid)
            r, c = row * self.cell + self.cell // 2, col * self.cell + self.cell // 2
            windows.append(image[r - 3:r + 3, c - 3:c + 3, :3])
        return np.stack(windows)

    def sun_renders(self, directions):
        cycles = self.scene.cycles
        cycles.samples = 4
        cycles.max_bounces = 0
        self.background.inputs["Color"].default_value = (0, 0, 0, 1)
        sun_data = bpy.data.lights.new("sun", "SUN")
        sun_data.energy = 1.0
        sun_data.angle = 0.0
        sun = bpy.data.objects.new("sun", sun_data)
        self.scene.collection.objects.link(sun)
        results = []
        for k, direction in enumerate(directions):
            direction = direction / np.linalg.norm(direction)
            sun.rotation_euler = Vector((0, 0, 1)).rotation_difference(
                Vector(direction)).to_euler()
            windows = self.render(f"sun{k}")
            spread = windows.max(axis=(1, 2)) - windows.min(axis=(1, 2))
            results.append({"direction": direction.tolist(),
                            "mean": windows.mean(axis=(1, 2)).tolist(),
                            "spread": spread.tolist()})
        sun_data.energy = 0.0
        sun.hide_render = True
        return results

    def furnace_renders(self, samples):
        cycles = self.scene.cycles
        cycles.samples = samples
        cycles.max_bounces = 1
        cycles.glossy_bounces = 1
        cycles.diffuse_bounces = 1
        self.background.inputs["Color"].default_value = (1, 1, 1, 1)
        seeds = []
        for seed in (1, 2):
            cycles.seed = seed
            seeds.append(self.render(f"furnace{seed}"))
        pixels = np.concatenate(seeds, axis=1)
        count = pixels.shape[1] * pixels.shape[2]
        return {
            "mean": pixels.mean(axis=(1, 2)).tolist(),
            "stderr": (pixels.std(axis=(1, 2), ddof=1) / math.sqrt(count)).tolist(),
            "seed_difference": np.abs(seeds[0].mean(axis=(1, 2))
                                      - seeds[1].mean(axis=(1, 2))).tolist(),
        }
