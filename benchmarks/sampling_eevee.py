"""EEVEE frame time and shader compile time of runtime sampling (issue 11, item 5).

The regular-sampling paper's Figure 7 on this machine: one sphere filling a
256 x 256 frame (software GL here), lit by a bundled HDRI, rendered by EEVEE
at one sample per frame with

- EEVEE's own BSDF (the baseline, measured in the same run; world
  sun_threshold 0 and clamp_surface_indirect 0, the careful user's settings),
- Glossy's 3D map lookup (16 slices) and, for isotropic lobes, the Hybrid,
- Glossy's runtime sampling at each pattern size (samples per pixel).

The default method, Auto (glossy_addon.method_choice), is the Hybrid of 19
samples for an isotropic lobe and Runtime Sampling of 14 for an anisotropic
one, both with Probe Lights on (one light group per light taken from the
probe: night.exr gives the most, 8): its frame time against native's and its
compile time close each table.

For each: the first render at 1 sample (shader compile + render), the median of
two more (the frame time; the compile time is the difference), and the time
of one more EEVEE sample: (median of two 9-sample renders - frame time) / 8,
which leaves out the render pipeline's fixed cost per frame (several seconds
here, the same for every material). Printed with the ratio of that per-sample
shading time to native EEVEE's, and the node count (the runtime samples are a
loop, so it does not grow with them).

    .venv/bin/python benchmarks/sampling_eevee.py [--hdri sunset.exr] [--size 256]
        [--spec ggx:roughness=0.3,anisotropy=0.8] [--probe 128|auto]
        [--max-map-size 384]

``--probe auto`` captures the probe at the face glossy.capture_probes' Auto
gives an isotropic GGX material in that world (the lobe rule raised for the
world's small lights: night.exr at GGX 0.1 gets 328 px), and the textures are
sized as glossy.bake_materials sizes them there (the runtime level stack
twice the face's rows, at most Max Map Size, as a power of two or three times
one; the map at Auto, at most Max Map Size rows). ``--max-map-size``: the bound
(default the bake's, 384; the figures before stop 73 were measured at 256).
"""

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from bake.prefilter import DEFAULT_MAX_SIZE  # noqa: E402
from tools.bpy_wheel import studio_lights  # noqa: E402

SCENE = r'''
import json, statistics, sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
import _checkout  # noqa
import bpy
import numpy as np
from glossy.bake import (atlas, brdf, envmap, exr, hybrid, prefilter, probe_lights, sampling,
                         sampling_runtime)
from glossy.glossy_addon.nodes import build_lookup, load_atlas
from glossy.glossy_addon.scenes import environment_world
from _ortho_sphere import add_sphere_and_camera

hdri, work, spec, size = sys.argv[2], Path(sys.argv[3]), sys.argv[4], int(sys.argv[5])
face = int(sys.argv[6])
max_map = int(sys.argv[7])
#: The runtime level stack as glossy.bake_materials makes it (operators.bake_materials.
#: runtime_height at Auto): twice the face's rows, at most Max Map Size (the Hybrid's)
#: or twice it (Runtime Sampling's of a near-mirror lobe), a power of two or three times
#: one (bake.sampling_runtime.stack_height).
stack_rows = sampling_runtime.stack_height((face, 6 * face), "cube", cap=max_map)[0]
alone_rows = sampling_runtime.stack_height(
    (face, 6 * face), "cube", cap=max_map,
    alone=sampling_runtime.near_mirror(sampling_runtime.check(spec)[0]))[0]
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
environment_world(scene, hdri)
scene.world.sun_threshold = 0.0
scene.render.engine = "BLENDER_EEVEE"
scene.eevee.taa_render_samples = 1
scene.eevee.clamp_surface_indirect = 0.0
scene.render.resolution_x = scene.render.resolution_y = size
scene.render.image_settings.file_format = "OPEN_EXR"
sphere = add_sphere_and_camera(scene, 96, 48, 2.1)
model = brdf.parse(spec)
environment, _ = exr.read(hdri)
probe = envmap.convert(environment[..., :3], "latlong", "cube", face)


def native():
    material = bpy.data.materials.new("native")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    bsdf = tree.nodes.new("ShaderNodeBsdfAnisotropic")
    bsdf.distribution = "GGX"
    bsdf.inputs["Roughness"].default_value = model.params["roughness"]
    bsdf.inputs["Anisotropy"].default_value = model.params.get("anisotropy", 0.0)
    bsdf.inputs["Rotation"].default_value = model.params.get("rotation", 0.0)
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    return material


def texture(name, data, meta):
    path = work / f"{name}.exr"
    exr.write(path, data, meta)
    return load_atlas(path), meta


map_texture = None
if model.isotropic:
    baked = prefilter.prefilter(probe, model, "3d", "auto", slices=16, layout="cube",
                                max_size=max_map)
    map_texture = texture("map", *atlas.pack(baked))


def glossy(name, runtime=None):
    material = bpy.data.materials.new(name)
    image, meta = map_texture if map_texture is not None and name != "runtime" else (None, None)
    build_lookup(material, image, meta, runtime=runtime)
    return material


def runtime(budget, for_hybrid=False, lights=False):
    """The runtime texture; ``lights``: as the bake makes it with Probe Lights on
    (the default): the probe's small bright lights taken out, one light group each."""
    source, taken = probe, ()
    if lights:
        lobe = sampling_runtime.check(spec)[0]
        source, taken = probe_lights.extract_for(probe, "cube", lobe.mx, lobe.my)
    data, meta = sampling_runtime.pack(source, spec, budget=budget,
                                        height=stack_rows if for_hybrid else alone_rows,
                                        lights=taken)
    if for_hybrid:
        centres, weights = hybrid.weight_curve(float(np.sqrt(meta["ax"])),
                                               samples=len(meta["prob"]))
        meta.update({"blend_mu": centres.tolist(), "blend_weight": weights.tolist()})
    return texture(f"runtime{budget}", data, meta), len(meta["prob"])


def render(samples):
    scene.eevee.taa_render_samples = samples
    start = time.perf_counter()
    bpy.ops.render.render(write_still=False)
    return time.perf_counter() - start


def timed(material):
    sphere.data.materials.clear()
    sphere.data.materials.append(material)
    first = render(1)
    frame = statistics.median([render(1), render(1)])
    nine = statistics.median([render(9), render(9)])
    return first, frame, (nine - frame) / 8.0


cases = [("EEVEE native", native())]
if map_texture is not None:
    cases.append(("Glossy 3D map", glossy("map")))
anisotropic = not model.isotropic
for budget in ((14, 52, 114, 200) if anisotropic else (7, 19, 61, 127)):
    tex, count = runtime(budget)
    cases.append((f"runtime {count} samples", glossy("runtime", tex)))
    if anisotropic and budget == 14:
        tex, count = runtime(budget, lights=True)
        lit = len(tex[1]["lights"])
        cases.append((f"runtime {count} + {lit} lights = Auto", glossy("runtime", tex)))
if map_texture is not None:
    tex, count = runtime(19, True)
    cases.append((f"Hybrid (map + {count} samples)", glossy("hybrid", tex)))
    tex, count = runtime(19, True, lights=True)
    lit = len(tex[1]["lights"])
    cases.append((f"Hybrid ({count} smp + {lit} lights) = Auto", glossy("hybrid", tex)))
rows = []
for name, material in cases:
    first, frame, per_sample = timed(material)
    nodes = len(material.node_tree.nodes)
    rows.append({"name": name, "first": first, "frame": frame, "sample": per_sample,
                 "nodes": nodes})
    print(json.dumps(rows[-1]), flush=True)
'''


def probe_face(probe, spec, hdri):
    """The probe face in px: ``probe`` as a number, or for ``auto`` the face the
    capture's Auto gives an isotropic GGX ``spec`` in the world ``hdri``
    (benchmarks.hybrid.world_face: the lobe rule raised for the world's small lights)."""
    if probe != "auto":
        return int(probe)
    from bake import brdf, exr
    from benchmarks.hybrid import world_face

    model = brdf.parse(spec)
    if model.name != "ggx" or not model.isotropic:
        sys.exit("--probe auto needs an isotropic GGX spec (its face rule is the Hybrid's)")
    image, _ = exr.read(studio_lights() / hdri)
    return world_face(image[..., :3], model.params["roughness"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hdri", default="sunset.exr")
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--spec", action="append",
                        help="BRDF spec (repeatable; default GGX 0.3 anisotropy 0.8, and 0.3)")
    parser.add_argument("--probe", default="128",
                        help="probe face px, or auto: the face Auto captures for the "
                             "(isotropic GGX) material in this world")
    parser.add_argument("--max-map-size", type=int, default=DEFAULT_MAX_SIZE,
                        help="Max Map Size: the bound of the map's and the level stack's "
                             "rows (default the bake's)")
    args = parser.parse_args()
    import json

    for spec in args.spec or ["ggx:roughness=0.3,anisotropy=0.8", "ggx:roughness=0.3"]:
        face = probe_face(args.probe, spec, args.hdri)
        work = Path(tempfile.mkdtemp())
        script = work / "scene.py"
        script.write_text(SCENE)
        print(f"{spec}, {args.hdri}, {face} px probe faces, {args.size}^2 px, EEVEE "
              f"(software GL here); compile = "
              f"first render - frame time (1 sample); per sample = (9-sample frame - "
              f"1-sample frame) / 8", flush=True)
        print(f"  {'method':34s} {'nodes':>6s} {'first s':>8s} {'frame s':>8s} "
              f"{'compile s':>9s} {'sample ms':>9s} {'x native':>8s}", flush=True)
        process = subprocess.Popen(
            [sys.executable, str(script), str(ROOT / "tests" / "blender" / "scripts"),
             str(studio_lights() / args.hdri), str(work), spec, str(args.size), str(face),
             str(args.max_map_size)],
            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        base = native = None
        for line in process.stdout:
            if not line.startswith("{"):
                continue
            row = json.loads(line)
            base = base or row["sample"]
            native = native or row
            if row["name"].endswith("= Auto"):
                auto = row
            print(f"  {row['name']:34s} {row['nodes']:6d} {row['first']:8.2f} "
                  f"{row['frame']:8.3f} {row['first'] - row['frame']:9.2f} "
                  f"{1e3 * row['sample']:9.1f} {row['sample'] / base:8.2f}", flush=True)
        if process.wait():
            sys.exit(f"the EEVEE scene failed (exit {process.returncode})")
        print(f"  the default method (Auto) is {auto['name'].removesuffix(' = Auto')}: frame "
              f"{auto['frame'] / native['frame']:.2f}x native's (target <= 1.5), per sample "
              f"{auto['sample'] / native['sample']:.2f}x, shader compile "
              f"{max(auto['first'] - auto['frame'], 0.0):.1f} s (target < 10)", flush=True)


if __name__ == "__main__":
    main()
