"""Six 90-degree renders from a point, assembled into a Glossy cube map.

The cube layout is DESIGN.md's (bake/envmap/cube.py). A face seen from inside
is a mirror image of a camera view, so each face is rendered by a camera
whose x axis is the face's -s direction, then flipped left to right.
"""

import math
import tempfile
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ..bake import exr
from ..bake.envmap.cube import _FACE_TABLE
from .scenes import casts_shadows, render_engine
from .world import CameraRayMixesOpen

#: GL frame -> Blender: (x, y, z) = (g0, -g2, g1).
_GL_TO_BLENDER = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])


def face_rotation(face: int) -> Matrix:
    """World rotation of the camera that renders cube face ``face`` (mirrored in x).

    Face texel (a, b) looks along c0 + a c1 + b c2 (Blender frame); a camera
    ray (x, y, -1) with x = -a, y = -b gives the same direction when the
    camera's axes are (-c1, -c2, -c0).
    """
    columns = _GL_TO_BLENDER @ _FACE_TABLE[face]
    rotation = np.stack([-columns[:, 1], -columns[:, 2], -columns[:, 0]], axis=1)
    return Matrix(rotation.tolist())


def lookup_truths(scene, hidden=()):
    """[(slot, lookup material, truth material)] for the material slots of the objects
    ``scene`` renders (``hidden`` left out) that hold an attached Glossy lookup
    (``glossy.original`` set by the first attach), each with its true BSDF
    (glossy_addon.validation.truth_material, its tangent as the object gives it);
    lookups Cycles has no BSDF for are left out (their lookup is rendered)."""
    from .materials import effective_tangent
    from .validation import truth_material

    skip = {obj.name for obj in hidden}
    truths, out = {}, []
    for obj in scene.objects:
        if obj.name in skip or obj.hide_render:
            continue
        for slot in getattr(obj, "material_slots", ()):
            material = slot.material
            if material is None or material.glossy.original is None:
                continue
            key = (material.name, effective_tangent(material, obj)[0])
            if key not in truths:
                truths[key] = truth_material(material, key[1])[0]
            if truths[key] is not None:
                out.append((slot, material, truths[key]))
    return out


#: Camera samples each face gets at least (:func:`cycles_face_settings`): a disc of
#: 0.5 degrees (7.1e-5 sr; the Sky Texture's default sun is 0.545) inside a texel at
#: a face's centre, (pi / 2 / size)^2 sr, the coarsest, is hit by SUN_HITS samples on
#: average when the face takes SUN_HITS (pi / 2)^2 / 7.1e-5 samples, whatever its
#: size: 1358 per texel at 16 px faces, 85 at 64, 22 at 128. A 0.5 degree disc
#: holding 3/4 of a world's energy (tests/blender/test_capture_probes.py) came out
#: of 16 / 32 px Render Scene probes at -75% / +49% of its energy with the user's
#: 32 samples and the scene's pixel filter; with these settings -5.1..+2.6% /
#: -7.6..+1.4% over Cycles seeds 0-5 (20 hits and adaptive sampling up to 4x:
#: -2.3..0% / -7.5..+1.8%, for captures up to 2.4x as long as 10 and 2x).
SUN_HITS = 10
MIN_FACE_SAMPLES = math.ceil(SUN_HITS * (math.pi / 2) ** 2 / 7.1e-5)
#: Cycles' adaptive sampling may take a texel that is still noisy to this many times
#: the minimum, at Cycles' own default noise threshold.
ADAPTIVE_FACTOR = 2
ADAPTIVE_THRESHOLD = 0.01


def cycles_face_settings(samples: int, size: int) -> dict:
    """Cycles settings (scene.cycles attributes) a capture renders its ``size`` px
    faces with, ``samples`` the user's Samples: texel averages, and samples enough
    for a small bright source.

    A probe texel stands for the mean radiance over its solid angle (what World
    Only resampling and the bake's bilinear reconstruction take), so the pixel
    filter is a 1 px box, not the scene's (Blackman-Harris 1.5 px spreads a sun
    over its neighbours). A sun far smaller than a texel (the Sky Texture's is
    0.545 degrees; a 16 px face's texel 5.6) counts only through the samples that
    land on it: each face gets at least MIN_FACE_SAMPLES samples, and adaptive
    sampling goes on to ADAPTIVE_FACTOR times that where a texel is still noisy.
    A Multiple Scattering sky with its sun at 25 degrees, Principled metal 0.25,
    88 px faces (docs/HISTORY.md, stop 59): Glossy 36.4% from Cycles with the
    user's 32 samples through the scene's filter, 18.9% with the box filter alone,
    9.2% with these settings (native EEVEE 98.7%)."""
    floor = max(int(samples), math.ceil(MIN_FACE_SAMPLES / int(size) ** 2))
    return {"pixel_filter_type": "BOX", "filter_width": 1.0,
            "use_adaptive_sampling": True, "adaptive_threshold": ADAPTIVE_THRESHOLD,
            "adaptive_min_samples": floor, "samples": floor * ADAPTIVE_FACTOR}


class CubeCapture:
    """Renders the six faces at a point; restores every setting it touches.

    Use as a context manager; ``render_face(face)`` returns (N, N, 3) float32
    in cube-face orientation (row 0 at the top, s along columns).

    With Cycles, other objects that show a Glossy lookup are rendered with their
    true BSDF for the capture (:func:`lookup_truths`), as Cycles would see them:
    a lookup is an EEVEE material (an Emission of the baked reflection), and
    Cycles' SVM cannot compile the Runtime Sampling and Hybrid ones (out of
    stack space, so the object came out wrong in the probe). EEVEE captures see
    the lookups, as EEVEE renders the scene. A world that shows the camera a
    plain colour (a Mix Shader on Light Path's Is Camera Ray) shows the probe
    what reflections see (world.CameraRayMixesOpen), and camera rays get the
    world's and objects' glossy ray visibility for the capture.

    An EEVEE capture renders the scene over a transparent film and composites
    the world behind it, resampled from its image as World Only resamples it
    (world.world_cube: each texel the mean over its solid angle), where the
    film's alpha shows sky: EEVEE draws the world at each pixel's centre, so a
    sun smaller than a texel was missed or caught whole by chance (a 0.5 degree
    disc holding 3/4 of a world's energy came out at -75% / -34% of it on 16 /
    32 px faces). A world World Only cannot read (a Sky Texture, an image
    through other nodes) is rendered alone by Cycles from the same point, every
    object hidden, with the sample floor of :func:`cycles_face_settings`, and
    composited the same way (``world_cache``: a dict the caller keeps across
    the captures of one run, so that one probe's world is rendered once however
    many CubeCaptures render its faces). A world hidden from glossy rays is
    left out (black behind the scene), as a Cycles capture, whose camera rays
    get the glossy visibility, leaves it out. ``world_note`` says which.
    """

    def __init__(self, scene, centre, size, engine="CYCLES", samples=16, clip_start=0.01,
                 clip_end=1000.0, hidden=(), world_cache=None):
        self.world_cache = {} if world_cache is None else world_cache
        self.scene = scene
        self.centre = Vector(centre)
        self.size = int(size)
        self.engine = engine
        self.samples = int(samples)
        self.clip = (float(clip_start), float(clip_end))
        self.hidden = list(hidden)

    def __enter__(self):
        scene = self.scene
        render = scene.render
        settings = render.image_settings
        self._saved = {
            "camera": scene.camera, "engine": render.engine,
            "resolution": (render.resolution_x, render.resolution_y,
                           render.resolution_percentage, render.pixel_aspect_x,
                           render.pixel_aspect_y),
            "filepath": render.filepath, "film": render.film_transparent,
            "format": (settings.file_format, settings.color_depth, settings.color_mode),
            "codec": settings.exr_codec,
            "hidden": [(obj.name, obj.hide_render) for obj in self.hidden],
        }
        if self.engine == "CYCLES":
            self._saved["samples"] = scene.cycles.samples
            self._saved["denoise"] = scene.cycles.use_denoising
            self._saved["cycles"] = {name: getattr(scene.cycles, name) for name in
                                     cycles_face_settings(self.samples, self.size)}
        else:
            self._saved["samples"] = scene.eevee.taa_render_samples
            self._saved["shadows"] = scene.eevee.use_shadows
        # Before CameraRayMixesOpen cuts the world's Is Camera Ray links, which
        # world_environment follows to the shader reflections see.
        self.world_faces, self.world_note = (None, "rendered by Cycles") \
            if self.engine == "CYCLES" else self._world_behind(scene)
        data = bpy.data.cameras.new("Glossy probe camera")
        data.type = "PERSP"
        data.sensor_fit = "AUTO"
        data.angle = math.pi / 2
        data.clip_start, data.clip_end = self.clip
        self.camera = bpy.data.objects.new("Glossy probe camera", data)
        scene.collection.objects.link(self.camera)
        scene.camera = self.camera
        render.engine = render_engine(self.engine)
        render.resolution_x = render.resolution_y = self.size
        render.resolution_percentage = 100
        render.pixel_aspect_x = render.pixel_aspect_y = 1.0
        render.film_transparent = self.world_faces is not None
        settings.file_format = "OPEN_EXR"
        settings.color_depth = "32"
        settings.color_mode = "RGB" if self.world_faces is None else "RGBA"
        settings.exr_codec = "ZIP"  # lossless, and what bake.exr_codec reads
        if self.engine == "CYCLES":
            # A denoiser changes radiance (and may be missing from the build).
            scene.cycles.use_denoising = False
            for name, value in cycles_face_settings(self.samples, self.size).items():
                setattr(scene.cycles, name, value)
        else:
            scene.eevee.taa_render_samples = self.samples
        for obj in self.hidden:
            obj.hide_render = True
        if self.engine != "CYCLES":  # exact: no light casts one (scenes.casts_shadows)
            scene.eevee.use_shadows = scene.eevee.use_shadows and casts_shadows(scene)
        self._swapped = lookup_truths(scene, self.hidden) if self.engine == "CYCLES" else []
        for slot, _, truth in self._swapped:
            slot.material = truth
        self._folder = tempfile.TemporaryDirectory(prefix="glossy_capture_")
        self._world_mixes = CameraRayMixesOpen(scene.world).__enter__()
        self._visibility = self._as_glossy_rays(scene)
        return self

    def _world_behind(self, scene):
        """(world cube (size, 6 size, 3) or None, note): what an EEVEE capture
        composites behind the scene (the class docstring)."""
        from .world import WorldNotReadable, world_cube

        world = scene.world
        if world is None:
            return None, "no world"
        if not world.cycles_visibility.glossy:  # as a Cycles capture shows it: nothing
            return np.zeros((self.size, 6 * self.size, 3), np.float32), \
                "the world is hidden from glossy rays: none behind the scene"
        try:
            return world_cube(world, self.size), "the world's image composited behind the scene"
        except (WorldNotReadable, ValueError) as error:
            reason = str(error)
        for _ in world_render_steps(scene, self.centre, self.size, self.samples, self.clip,
                                    self.world_cache):
            pass
        return self.world_cache[world_render_key(self.centre, self.size, self.samples,
                                                 self.clip)], \
            f"the world rendered alone by Cycles, composited behind the scene ({reason})"

    def _as_glossy_rays(self, scene):
        """Give camera rays the visibility glossy rays have (the world's and each
        object's), as a probe stands for what reflections see: a world or an
        object hidden from the camera but seen in reflections is in the probe,
        one seen by the camera but not in reflections is not. Lamps are left
        alone. Returns what to restore: [(object name, or None for the world,
        camera visibility)]."""
        changed = []
        world = scene.world
        if world is not None and world.cycles_visibility.camera != \
                world.cycles_visibility.glossy:
            changed.append((None, world.cycles_visibility.camera))
            world.cycles_visibility.camera = world.cycles_visibility.glossy
        for obj in scene.objects:
            # Lamps stay as the capture finds them (hidden from the camera by
            # default): a material's lamp term shades them (glossy_addon.lamps),
            # so showing them in the probe too would count them twice.
            if obj.type == "LIGHT" or obj.hide_render or \
                    obj.visible_camera == obj.visible_glossy:
                continue
            changed.append((obj.name, obj.visible_camera))
            obj.visible_camera = obj.visible_glossy
        return changed

    def render_face(self, face: int) -> np.ndarray:
        self.camera.matrix_world = Matrix.Translation(self.centre) @ face_rotation(face).to_4x4()
        path = Path(self._folder.name) / f"face{face}.exr"
        self.scene.render.filepath = str(path)
        bpy.ops.render.render(write_still=True, scene=self.scene.name)
        image, _ = exr.read(path, nonfinite="sanitize")
        image = image[:, ::-1]
        if self.world_faces is None:
            return np.ascontiguousarray(image[..., :3])
        # Blender's film holds premultiplied colour: the scene over the world.
        size = self.size
        behind = self.world_faces[:, face * size:(face + 1) * size]
        sky = np.clip(1.0 - image[..., 3:4], 0.0, 1.0)
        return np.ascontiguousarray(image[..., :3] + sky * behind, dtype=np.float32)

    def __exit__(self, *exc):
        scene = self.scene
        render = scene.render
        saved = self._saved
        scene.camera = saved["camera"]
        render.engine = saved["engine"]
        (render.resolution_x, render.resolution_y, render.resolution_percentage,
         render.pixel_aspect_x, render.pixel_aspect_y) = saved["resolution"]
        render.filepath = saved["filepath"]
        render.film_transparent = saved["film"]
        (render.image_settings.file_format, render.image_settings.color_depth,
         render.image_settings.color_mode) = saved["format"]
        if render.image_settings.file_format == "OPEN_EXR":
            render.image_settings.exr_codec = saved["codec"]
        if self.engine == "CYCLES":
            scene.cycles.use_denoising = saved["denoise"]
            for name, value in saved["cycles"].items():
                setattr(scene.cycles, name, value)
            scene.cycles.samples = saved["samples"]
        else:
            scene.eevee.taa_render_samples = saved["samples"]
            scene.eevee.use_shadows = saved["shadows"]
        for name, hidden in saved["hidden"]:
            if name in bpy.data.objects:
                bpy.data.objects[name].hide_render = hidden
        self._world_mixes.__exit__(*exc)
        for name, camera in reversed(self._visibility):
            if name is None:
                if scene.world is not None:
                    scene.world.cycles_visibility.camera = camera
            elif name in bpy.data.objects:
                bpy.data.objects[name].visible_camera = camera
        for slot, lookup, _ in reversed(self._swapped):
            slot.material = lookup
        for truth in {id(t): t for _, _, t in self._swapped}.values():
            if truth.users == 0:
                bpy.data.materials.remove(truth)
        data = self.camera.data
        bpy.data.objects.remove(self.camera)
        bpy.data.cameras.remove(data)
        self._folder.cleanup()
        return False


def world_render_key(centre, size, samples, clip):
    """What identifies a world rendered alone (:func:`world_render_steps`) in a cache."""
    return (tuple(round(float(c), 9) for c in centre), int(size), int(samples),
            tuple(float(c) for c in clip))


def world_render_steps(scene, centre, size, samples, clip, cache):
    """Generator: the world rendered alone by Cycles from ``centre`` (every object
    hidden, :func:`cycles_face_settings`), the cube (size, 6 size, 3) put in
    ``cache`` under :func:`world_render_key` once all six faces are done (nothing
    when it is there already). One face per part, each in a CubeCapture of its own,
    so that nothing of the capture's set-up outlives a part (the UI runs one part
    per timer tick, and Esc between parts leaves the scene as it was); yields
    (fraction, message) between faces and returns a message."""
    key = world_render_key(centre, size, samples, clip)
    if key in cache:
        return "the world was rendered already"
    faces = []
    for face in range(6):
        alone = [obj for obj in scene.objects if not obj.hide_render]
        with CubeCapture(scene, centre, size, "CYCLES", samples, *clip, hidden=alone) as capture:
            faces.append(capture.render_face(face))
        if face < 5:
            yield (face + 1) / 6, f"the world alone by Cycles: face {face + 1}/6"
    cache[key] = np.concatenate(faces, axis=1)
    return "the world rendered alone by Cycles"
