"""The "From Material" source end to end, as a user's script drives it.

    python from_material.py HDRI WORKDIR RESULT.json

A sphere with a user's Principled plastic (MULTI_GGX, the node's default) and
an Emission shader mixed in at 0 (a listed input, hidden by the mix) is captured (World
Only), baked and attached with the BRDF read from its node tree, then
validated (Cycles renders the user's own material). Then: editing the
user's Roughness (the user's nodes stay in the attached material) makes the
bake stale and names the input, editing its emission (not baked: the
lookup adds it, glossy_addon.emission) does not and asks for Attach again; an
emission-only material and one behind a node group are refused with a
message and keep their nodes; ``python -m bake brdf --from-blend`` prints
the same spec.
"""

import json
import sys
from pathlib import Path

hdri, workdir, result_path = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
import _checkout  # noqa: F401,E402  (makes ``import glossy`` the repository)
import bpy  # noqa: E402
import glossy  # noqa: E402
from _operators import run  # noqa: E402
from glossy.glossy_addon.bookkeeping import bake_status  # noqa: E402
from glossy.glossy_addon.emission import emission_changed  # noqa: E402
from glossy.glossy_addon.material_source import changed_inputs, derive  # noqa: E402
from glossy.glossy_addon.nodes import lookup_nodes  # noqa: E402
from glossy.glossy_addon.scenes import environment_world  # noqa: E402

bpy.ops.wm.read_factory_settings(use_empty=True)
glossy.register()
scene = bpy.context.scene
environment_world(scene, hdri)
settings = scene.glossy
settings.validate_resolution = 64
settings.validate_samples = 256
settings.validate_eevee_samples = 4
result = {}


bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
bpy.ops.object.shade_smooth()
sphere = bpy.context.object
sphere.glossy.probe_source = "WORLD"
sphere.glossy.probe_size_mode = "FIXED"
sphere.glossy.probe_resolution = 64

material = bpy.data.materials.new("Plastic")
material.use_nodes = True
tree = material.node_tree
tree.nodes.clear()
principled = tree.nodes.new("ShaderNodeBsdfPrincipled")
principled.name = "Principled BSDF"
principled.inputs["Base Color"].default_value = (0.2, 0.4, 0.8, 1.0)
principled.inputs["Roughness"].default_value = 0.35
principled.inputs["Emission Strength"].default_value = 0.0
output = tree.nodes.new("ShaderNodeOutputMaterial")
tree.links.new(principled.outputs[0], output.inputs["Surface"])
sphere.data.materials.append(material)
material.glossy.model = "MATERIAL"
material.glossy.slices = 8
derived = derive(material)
result["spec"] = derived.spec
result["glossy_spec"] = material.glossy.brdf_spec()
result["diffuse"] = list(material.glossy.diffuse_colour())
result["ignored_before"] = list(derived.ignored)
bpy.ops.wm.save_as_mainfile(filepath=str(workdir / "scene.blend"))

bpy.ops.object.select_all(action="DESELECT")
sphere.select_set(True)
bpy.context.view_layer.objects.active = sphere
result["capture"] = run(bpy.ops.glossy.capture_probes)
result["bake"] = run(bpy.ops.glossy.bake_materials)
result["attach"] = run(bpy.ops.glossy.attach_materials)
result["status_after_bake"] = bake_status(material.glossy, sphere.glossy.probe_path)
result["curve_nodes"] = sum(n.bl_idname == "ShaderNodeRGBCurve"
                            for n in lookup_nodes(material))
result["spec_after_attach"] = derive(material).spec  # read from the user's kept nodes
result["user_nodes_kept"] = sorted(n.bl_idname for n in material.node_tree.nodes
                                   if not n.get("glossy_lookup"))
result["active_output_is_glossy"] = bool(
    material.node_tree.get_output_node("ALL").get("glossy_lookup"))
result["validate"] = run(bpy.ops.glossy.validate)
report = json.loads((workdir / "glossy" / "validation" / "report.json").read_text())
result["report"] = report

node = material.node_tree.nodes["Principled BSDF"]  # the user's node, beside the lookup
result["emission_changed_before_edit"] = emission_changed(material)
node.inputs["Emission Strength"].default_value = 2.0  # not baked (emission): not stale
result["status_after_ignored_edit"] = bake_status(material.glossy, sphere.glossy.probe_path)
result["ignored_after_edit"] = derive(material).ignored
result["emission_after_edit"] = [line for line in derive(material).approximated
                                 if "emission" in line]
result["emission_changed_after_edit"] = emission_changed(material)  # attach again
node.inputs["Emission Strength"].default_value = 0.0
node.inputs["Roughness"].default_value = 0.5
result["status_after_roughness_edit"] = bake_status(material.glossy, sphere.glossy.probe_path)
result["changed"] = changed_inputs(material.glossy.bake_inputs, derive(material))
node.inputs["Roughness"].default_value = 0.35
result["status_after_undo"] = bake_status(material.glossy, sphere.glossy.probe_path)

# Materials Glossy cannot read: refused with a message, nothing attached.
for name in ("Glow", "Grouped"):
    bad = bpy.data.materials.new(name)
    bad.use_nodes = True
    bad.node_tree.nodes.clear()
    out = bad.node_tree.nodes.new("ShaderNodeOutputMaterial")
    if name == "Glow":
        shader = bad.node_tree.nodes.new("ShaderNodeEmission")
    else:
        group = bpy.data.node_groups.new("My Shader", "ShaderNodeTree")
        group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
        shader = bad.node_tree.nodes.new("ShaderNodeGroup")
        shader.node_tree = group
    bad.node_tree.links.new(shader.outputs[0], out.inputs["Surface"])
    bad.glossy.model = "MATERIAL"
    bpy.ops.mesh.primitive_cube_add(location=(4.0, 0.0, 0.0))
    cube = bpy.context.object
    cube.data.materials.append(bad)
    cube.glossy.probe_source = "WORLD"
    cube.glossy.probe_resolution = 16
    bpy.ops.object.select_all(action="DESELECT")
    cube.select_set(True)
    bpy.context.view_layer.objects.active = cube
    before = sorted(n.bl_idname for n in bad.node_tree.nodes)
    run(bpy.ops.glossy.capture_probes)
    result[f"bake_{name}"] = run(bpy.ops.glossy.bake_materials)
    result[f"kept_{name}"] = sorted(n.bl_idname for n in bad.node_tree.nodes) == before
    result[f"original_{name}"] = bad.glossy.original is not None
bpy.ops.wm.save_mainfile()
result["blend"] = str(workdir / "scene.blend")
result_path.write_text(json.dumps(result, indent=1, default=str))
