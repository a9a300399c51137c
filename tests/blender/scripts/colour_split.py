"""A metal whose base colour comes from a node chain, against the same metal typed in.

    python colour_split.py HDRI WORKDIR [ratio] RESULT.json

Isolated spheres (World Only probes, From Material, Principled Metallic 1,
roughness 0.3): "Direct" has the base colour COLOUR typed into the node;
"Chain" has Base Color linked from a Gamma node (gamma 1) fed by an RGB node
of COLOUR, while its own unlinked Base Color is a light grey: the node reader
takes the unlinked value as the bake's colour, and the lookup reads COLOUR per
pixel. "Mix Direct" and "Mix Chain" do the same with
the Color of a Diffuse BSDF mixed half and half with a GGX 0.3 Glossy BSDF
(the diffuse part's factor in a Mix tree); "Coat Direct" and "Coat Chain" as
the first two under a coat (Coat Weight 1: a third map of the coat alone);
"Metallic Chain" as "Chain" with Metallic 1 also through a chain whose
unlinked value is 0 (maps at Metallic 0 and 1 mixed per pixel; compare with
"Direct"); "Half Direct" and "Half Chain" a half metal (Metallic 0.5 typed in,
or through the chain) of colour COLOUR; "Glossy Direct" and "Glossy Chain"
the Color of a Multiscatter GGX Glossy BSDF of roughness 0.5 (a white map
times the colour and the energy term); "Coat Tint Direct" and "Coat Tint
Chain" a light grey plastic under a coat (weight 1, roughness 0.2) of tint
TINT (a map of the coat alone; below it scaled per pixel).
The spheres are captured, baked,
attached and validated together, on a grid seen by an orthographic camera,
each hidden from the others' rays (isolated under distant light) and 64 px
across its cell; the report's errors against Cycles are recorded. With the split
(bake.colour_response) both spheres show the same reflection; scaling the
grey map by COLOUR / grey (the ratio) is far off at grazing views, where the
metal's Fresnel goes to white. "ratio" forces the ratio (and the tint's
unlinked value; for the figures in the test's comment).
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[-1])
RATIO = "ratio" in sys.argv[3:-1]
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
from _operators import (  # noqa: E402
    errors,
    shader_material,
    validate_together,
    validation_scene,
    world_probe,
)
from glossy.glossy_addon import spatial  # noqa: E402
from glossy.glossy_addon.material_source import parts  # noqa: E402

COLOUR = (0.06, 0.25, 0.05)
TINT = (0.9, 0.3, 0.05)
GREY = (0.8, 0.8, 0.8)
if RATIO:
    spatial._split_knots = lambda parts, colour=True: []  # no split: the c / mean factor

scene = validation_scene(hdri, workdir, 64, reference=False)  # only the figures against Cycles
# Cycles 2 x 128 spp: the test compares the chain with the value typed in, both
# against the same Cycles images, within twice Cycles' noise (which this measures).
scene.glossy.validate_samples = 128
result = {}

spheres = {}
# (name, the input driven, whether through the chain, coat weight)
CASES = (("Direct", "Base Color", False, 0.0), ("Chain", "Base Color", True, 0.0),
         ("Mix Direct", "Color", False, 0.0), ("Mix Chain", "Color", True, 0.0),
         ("Coat Direct", "Base Color", False, 1.0), ("Coat Chain", "Base Color", True, 1.0),
         ("Metallic Chain", "Base Color", True, 0.0), ("Half Direct", "Metallic", False, 0.0),
         ("Half Chain", "Metallic", True, 0.0), ("Glossy Direct", "Glossy", False, 0.0),
         ("Glossy Chain", "Glossy", True, 0.0), ("Coat Tint Direct", "Coat Tint", False, 1.0),
         ("Coat Tint Chain", "Coat Tint", True, 1.0))
for name, input_name, chained, coat in CASES:
    bpy.ops.mesh.primitive_uv_sphere_add(segments=48, ring_count=24)
    obj = bpy.context.object
    obj.name = name
    bpy.ops.object.shade_smooth()
    if input_name == "Color":  # a Mix Shader of a Diffuse and a Glossy BSDF
        material, tree, glossy_bsdf = shader_material(name, "ShaderNodeBsdfGlossy")
        glossy_bsdf.distribution = "GGX"
        glossy_bsdf.inputs["Roughness"].default_value = 0.3
        bsdf = tree.nodes.new("ShaderNodeBsdfDiffuse")
        mix = tree.nodes.new("ShaderNodeMixShader")
        tree.links.new(bsdf.outputs[0], mix.inputs[1])
        tree.links.new(glossy_bsdf.outputs[0], mix.inputs[2])
        tree.links.new(mix.outputs[0], tree.nodes["Material Output"].inputs["Surface"])
    elif input_name == "Glossy":  # a Multiscatter GGX Glossy BSDF's Color
        material, tree, bsdf = shader_material(name, "ShaderNodeBsdfGlossy")
        bsdf.distribution = "MULTI_GGX"
        bsdf.inputs["Roughness"].default_value = 0.5
        input_name = "Color"
    else:
        material, tree, bsdf = shader_material(name)
        bsdf.inputs["Metallic"].default_value = 1.0
        bsdf.inputs["Roughness"].default_value = 0.3
        bsdf.inputs["Coat Weight"].default_value = coat
    if input_name == "Coat Tint":  # a light grey plastic under a tinted coat
        bsdf.inputs["Metallic"].default_value = 0.0
        bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
        bsdf.inputs["Coat Roughness"].default_value = 0.2
    value = TINT if input_name == "Coat Tint" else COLOUR
    if name.startswith(("Metallic", "Half")):
        # Metallic (1, or 0.5 for "Half") typed in or through a chain (a Value node
        # plus 0) whose unlinked value is 0: the bake's spec is then a dielectric.
        metallic = 0.5 if name.startswith("Half") else 1.0
        bsdf.inputs["Base Color"].default_value = (*COLOUR, 1.0)
        bsdf.inputs["Metallic"].default_value = metallic
        if chained:
            bsdf.inputs["Metallic"].default_value = 0.0
            number = tree.nodes.new("ShaderNodeValue")
            number.outputs[0].default_value = metallic
            add = tree.nodes.new("ShaderNodeMath")
            add.inputs[1].default_value = 0.0
            tree.links.new(number.outputs[0], add.inputs[0])
            tree.links.new(add.outputs[0], bsdf.inputs["Metallic"])
    if input_name == "Metallic":
        pass  # the colour typed in
    elif chained:
        bsdf.inputs[input_name].default_value = (*GREY, 1.0)
        rgb = tree.nodes.new("ShaderNodeRGB")
        rgb.outputs[0].default_value = (*value, 1.0)
        gamma = tree.nodes.new("ShaderNodeGamma")
        gamma.inputs["Gamma"].default_value = 1.0
        tree.links.new(rgb.outputs[0], gamma.inputs["Color"])
        tree.links.new(gamma.outputs[0], bsdf.inputs[input_name])
    else:
        bsdf.inputs[input_name].default_value = (*value, 1.0)
    material.glossy.model = "MATERIAL"
    material.glossy.method = "3d"  # the 3D map's splits, chained and typed in alike
    material.glossy.slices = 8
    obj.data.materials.append(material)
    world_probe(obj, 64)
    spheres[name] = obj

for name, (steps, figures) in validate_together(spheres, workdir, 4, 2.5).items():
    material = spheres[name].material_slots[0].material
    glossy_error, native_error = errors(figures)
    result[name] = {
        "steps": steps, "spec": material.glossy.brdf_spec(),
        "probe_reason": spheres[name].glossy.probe_reason,
        "approximated": list(parts(material).derived.approximated),
        "glossy": glossy_error, "native": native_error,
        "bias": figures["methods"]["eevee_glossy"].get("bias"),
        "noise": figures["cycles_noise"],
        "colours": sorted({c for _, _, c in material.glossy.roughness_map_list()
                           if c is not None}),
        "spatial": sorted(parts(material).derived.spatial),
        "maps": [Path(p).stem.rsplit("_", 1)[-1]
                 for _, p, _ in material.glossy.roughness_map_list()],
    }
report = json.loads((workdir / "glossy" / "validation" / "report.json").read_text())
result["report"] = {"reference": report["reference"], "notes": report["notes"],
                    "timings": sorted(report["timings_s"]),
                    "files": sorted(p.name for p in (workdir / "glossy" / "validation").iterdir()),
                    "figures": sorted({key for entry in report["objects"]
                                       for key in (*entry["figures"],
                                                   *entry["figures"]["methods"])})}
result_path.write_text(json.dumps(result, indent=1, default=str))
