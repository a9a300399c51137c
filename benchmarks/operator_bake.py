"""glossy.bake_materials as a user runs it: time per material, and eight at once (issue 10).

benchmarks/prefilter.py times the NumPy steps of a bake (``bake_like_blender``,
GGX specs). A user's bake goes through the operator: the material's own node
tree read as a BRDF (From Material, the default: a Principled BSDF is the
``principled`` model, slower to evaluate than plain GGX), the default method
(Auto: the Hybrid for these lobes, so also probe lights, the runtime level
stack and albedo table), the world's lights re-measured on its own image, and
the files written by Glossy's NumPy OpenEXR codec (what runs inside
Blender). This script times exactly that, headless, each single bake in a
fresh Python process (every cache cold), on one sphere with a World Only probe
of 128 px faces in sunset.exr:

- one Principled BSDF, Metallic 1, Roughness 0.05 / 0.1 / 0.3 / 0.6 / 1.0, and
  Blender's default Principled BSDF (a dielectric with its diffuse part,
  Roughness 0.5): the issue's "under 3 s" per material;
- eight materials on the sphere baked by one operator call (Principled metal
  at Roughness 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8 and a Glossy BSDF with
  Beckmann 0.4), against the mean of the same eight baked one by one cold:
  the issue's "8 materials < 3x one";
- eight colours of Blender's default material (Principled dielectric,
  Roughness 0.5, Base Color varied) in one call, against single bakes of two of
  them: materials that share a lobe shape share its fit and its filtering.

- with ``--default-scene``: Blender's default scene instead (its Light, its
  grey World, the Cube replaced by the sphere, the probe at Glossy's defaults:
  Render Scene, Auto), where every bake also factors the material's BRDF for
  the lamp (bake.separable, bake.lamp_spread): each single bake with the
  material's Lamps on and, in a second fresh process, off, so the difference
  is what the lamp factors cost, measured in the same run. Anisotropic metal
  (Roughness 0.3, Anisotropic 0.8) is added.

    .venv/bin/python benchmarks/operator_bake.py [--hdri sunset.exr] [--face 128]
        [--singles-only | --colours-only | --default-scene]

Times are wall-clock seconds of the operator call alone (the capture before it
is not counted); no timing is asserted anywhere.
"""

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tools.bpy_wheel import studio_lights  # noqa: E402

SCENE = r'''
import json, sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import _checkout  # noqa
import bpy
import glossy
from _operators import run, world_probe, shader_material
from glossy.glossy_addon.scenes import environment_world

hdri, work, face = sys.argv[2], Path(sys.argv[3]), int(sys.argv[4])
materials = json.loads(sys.argv[5])
bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
bpy.ops.wm.save_as_mainfile(filepath=str(work / "scene.blend"))
environment_world(scene, hdri)
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
sphere = bpy.context.object
world_probe(sphere, face)
for index, (shader, roughness, metallic, *colour) in enumerate(materials):
    material, tree, node = shader_material(f"M{index}", shader)
    node.inputs["Roughness"].default_value = roughness
    if colour:
        node.inputs["Base Color" if "Base Color" in node.inputs else "Color"].default_value = \
            (*colour, 1.0)
    if shader == "ShaderNodeBsdfPrincipled":
        node.inputs["Metallic"].default_value = metallic
    else:
        node.distribution = "BECKMANN"
    sphere.data.materials.append(material)
capture = run(bpy.ops.glossy.capture_probes)
start = time.perf_counter()
outcome = run(bpy.ops.glossy.bake_materials)
elapsed = time.perf_counter() - start
methods = [slot.material.glossy.method_used() for slot in sphere.material_slots]
print(json.dumps({"seconds": elapsed, "outcome": [capture, outcome], "methods": methods}))
'''

DEFAULT_SCENE = r'''
import json, sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import _checkout  # noqa
import bpy
import glossy
from _operators import run, shader_material

work, inputs, lamps = Path(sys.argv[2]), json.loads(sys.argv[3]), sys.argv[4] == "1"
bpy.ops.wm.read_homefile(use_empty=False)  # the default scene: Cube, Light, Camera, World
glossy.register()
scene = bpy.context.scene
bpy.ops.wm.save_as_mainfile(filepath=str(work / "scene.blend"))
bpy.data.objects.remove(bpy.data.objects["Cube"])
bpy.ops.mesh.primitive_uv_sphere_add(segments=32, ring_count=16)
sphere = bpy.context.object
material, tree, node = shader_material("Material")
for name, value in inputs.items():
    node.inputs[name].default_value = value
material.glossy.lamps = lamps
sphere.data.materials.append(material)
capture = run(bpy.ops.glossy.capture_probes)
start = time.perf_counter()
outcome = run(bpy.ops.glossy.bake_materials)
elapsed = time.perf_counter() - start
print(json.dumps({"seconds": elapsed, "outcome": [capture, outcome],
                  "methods": [material.glossy.method_used()],
                  "lights": [o.type for o in scene.objects if o.type == "LIGHT"]}))
'''

PRINCIPLED = "ShaderNodeBsdfPrincipled"
SINGLES = [(PRINCIPLED, r, 1.0) for r in (0.05, 0.1, 0.3, 0.6, 1.0)] + [(PRINCIPLED, 0.5, 0.0)]
EIGHT = [(PRINCIPLED, r, 1.0) for r in (0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8)]
EIGHT.append(("ShaderNodeBsdfGlossy", 0.4, 0.0))
#: Eight colours of Blender's default material (a Principled dielectric, Roughness
#: 0.5): one specular lobe shape, so one fit (rescaled, bake.lobes.shape_key), one
#: filtering and one white irradiance serve all eight.
COLOURS = [(PRINCIPLED, 0.5, 0.0, 0.1 + 0.1 * i, 0.9 - 0.1 * i, 0.5) for i in range(8)]


def label(material):
    shader, roughness, metallic = material[:3]
    if shader != PRINCIPLED:
        return f"Glossy BSDF, Beckmann {roughness:g}"
    kind = "metal" if metallic else "dielectric + diffuse"
    return f"Principled {kind}, Roughness {roughness:g}"


def hdri_path(hdri):
    """A bundled HDRI's name, or a path to any lat-long EXR."""
    given = Path(hdri)
    return given if given.is_file() else studio_lights() / hdri


def bake(materials, hdri, face):
    """(seconds, methods) of one glossy.bake_materials call in a fresh process."""
    return _run_scene(SCENE, [str(hdri_path(hdri)), "{tmp}", str(face),
                              json.dumps(materials)])[:2]


#: The default scene's materials: node inputs of a Principled BSDF.
DEFAULT_SCENE_MATERIALS = [
    ("Principled metal, Roughness 0.1", {"Metallic": 1.0, "Roughness": 0.1}),
    ("Principled metal, Roughness 0.5", {"Metallic": 1.0, "Roughness": 0.5}),
    ("Blender's default material", {}),
    ("Anisotropic metal 0.3, Anisotropic 0.8",
     {"Metallic": 1.0, "Roughness": 0.3, "Anisotropic": 0.8}),
]


def default_scene():
    """Single bakes in Blender's default scene, with and without lamp factors."""
    print("glossy.bake_materials in Blender's default scene (its Light and grey World, "
          "the Cube replaced by a sphere; probe: Render Scene, Auto), caches cold:",
          flush=True)
    for name, inputs in DEFAULT_SCENE_MATERIALS:
        seconds = {}
        for lamps in (True, False):
            seconds[lamps], methods, lights = _run_scene(
                DEFAULT_SCENE, ["{tmp}", json.dumps(inputs), "1" if lamps else "0"])
        print(f"  {name:40s} {seconds[True]:6.2f} s with the lamp's factors, "
              f"{seconds[False]:5.2f} s without ({methods[0]}; {len(lights)} lamp; "
              f"factors {seconds[True] - seconds[False]:.2f} s)", flush=True)


def _run_scene(script_text, arguments):
    """The JSON row (seconds, methods[, ...]) a scene script prints, run in a fresh
    process; "{tmp}" in ``arguments`` is its temporary folder."""
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "scene.py"
        script.write_text(script_text)
        result = subprocess.run(
            [sys.executable, str(script), str(ROOT / "tests" / "blender" / "scripts"),
             *[argument.replace("{tmp}", tmp) for argument in arguments]],
            capture_output=True, text=True)
        rows = [line for line in result.stdout.splitlines() if line.startswith("{")]
        if result.returncode or not rows:
            sys.exit(f"the bake failed (exit {result.returncode}): {result.stderr[-2000:]}")
        row = json.loads(rows[-1])
        for outcome, message in row["outcome"]:
            if outcome != ["FINISHED"]:
                sys.exit(f"an operator did not finish: {outcome} {message}")
        return row["seconds"], row["methods"], row.get("lights", [])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--hdri", default="sunset.exr",
                        help="a bundled HDRI's name or a lat-long EXR's path")
    parser.add_argument("--face", type=int, default=128, help="probe face px (Fixed)")
    parser.add_argument("--singles-only", action="store_true",
                        help="the single bakes only (not the eight)")
    parser.add_argument("--colours-only", action="store_true",
                        help="the eight colours of the default material only")
    parser.add_argument("--default-scene", action="store_true",
                        help="Blender's default scene, with and without lamp factors")
    args = parser.parse_args()
    if args.default_scene:
        return default_scene()
    if args.colours_only:
        return colours(args)
    print(f"glossy.bake_materials, one sphere, World Only probe of {args.face} px faces in "
          f"{args.hdri}, caches cold (a fresh process per call):", flush=True)
    for material in SINGLES:
        seconds, methods = bake([material], args.hdri, args.face)
        print(f"  {label(material):46s} {seconds:6.2f} s  ({methods[0]}; target < 3 s)",
              flush=True)
    if args.singles_only:
        return
    together_against_singles(args, EIGHT, EIGHT,
                             "eight materials (Principled metal 0.05-0.8, Glossy BSDF "
                             "Beckmann 0.4", "the same eight")
    colours(args)


def colours(args):
    """Eight colours of the default material in one call against two single bakes."""
    together_against_singles(args, COLOURS, COLOURS[:2], "eight colours of the default "
                             "material (Principled dielectric, Roughness 0.5", "two of them")


def together_against_singles(args, materials, singles_of, title, which):
    """Print one call baking ``materials`` against the mean single bake of ``singles_of``."""
    singles = [bake([material], args.hdri, args.face)[0] for material in singles_of]
    together, methods = bake(materials, args.hdri, args.face)
    mean = sum(singles) / len(singles)
    print(f"  {title}; methods {', '.join(sorted(set(methods)))}) in one call: "
          f"{together:.2f} s, against {mean:.2f} s for the mean single bake of {which} "
          f"({' / '.join(f'{s:.2f}' for s in singles)}): ratio {together / mean:.1f} "
          f"(target < 3)", flush=True)


if __name__ == "__main__":
    main()
