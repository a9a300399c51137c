"""glossy.export_environment as a user's script drives it, on the installed extension.

    python export_operator.py ZIP HDRI WORKDIR RESULT.json

Records what the operator did in each situation (JSON); pytest asserts.
"""

import json
import sys
import traceback
from pathlib import Path

from _installed import MODULE, install  # first: hides the venv's OpenEXR

# isort: split
import bpy


def run_export(**settings):
    """Run the operator; return (result set or None, error text or None)."""
    glossy = bpy.context.scene.glossy
    for key, value in settings.items():
        setattr(glossy, key, value)
    try:
        return sorted(bpy.ops.glossy.export_environment()), None
    except RuntimeError as error:
        return None, str(error)


def main(zip_path, hdri, workdir, result_path):
    workdir = Path(workdir)
    install(zip_path)
    exr = __import__(MODULE + ".bake.exr", fromlist=["read"])
    result = {}

    world = bpy.data.worlds.new("env")
    bpy.context.scene.world = world
    world.use_nodes = True
    result["poll_no_image"] = bpy.ops.glossy.export_environment.poll()

    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(hdri)
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    result["poll_with_image"] = bpy.ops.glossy.export_environment.poll()

    # Unsaved file: goes to the extension's user folder.
    status, error = run_export(export_layout="cube", export_size=32, export_mip="gauss4")
    written = Path(bpy.context.scene.glossy.last_export)
    result["unsaved"] = {"status": status, "error": error, "path": str(written),
                         "files": sorted(p.name for p in written.parent.glob("*.exr"))}
    cube, meta = exr.read(written)
    result["unsaved"]["shape"] = list(cube.shape)
    result["unsaved"]["meta_layout"] = meta.get("layout")
    # Blender's loaded pixels must give what bake gives from the file itself.
    envmap = __import__(MODULE + ".bake.envmap", fromlist=["convert"])
    source, _ = exr.read(hdri)
    expected = envmap.convert(source, "latlong", "cube", 32)
    scale = float(abs(expected).max())
    result["unsaved"]["max_abs_diff_over_peak"] = float(abs(cube - expected).max()) / scale

    # Saved file: goes to //glossy/ beside it.
    blend = workdir / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    status, error = run_export(export_layout="paraboloid", export_size=16, export_mip="none")
    result["saved"] = {"status": status, "error": error,
                       "path": bpy.context.scene.glossy.last_export}

    # A file Glossy did not write is never overwritten.
    foreign = workdir / "glossy" / "forest_sphere16.exr"
    foreign.write_bytes(b"user data")
    status, error = run_export(export_layout="sphere", export_size=16)
    result["foreign"] = {"status": status, "error": error,
                         "unchanged": foreign.read_bytes() == b"user data"}

    # Bad settings are reported, not raised, and write nothing.
    before = sorted(p.name for p in (workdir / "glossy").iterdir())
    status, error = run_export(export_layout="cube", export_size=8192)
    result["too_large"] = {"status": status, "error": error}
    status, error = run_export(export_layout="sphere", export_size=16, export_mip="box")
    result["mip_on_sphere"] = {"status": status, "error": error}
    result["files_unchanged"] = before == sorted(p.name for p in (workdir / "glossy").iterdir())
    result["still_usable"] = bpy.ops.glossy.export_environment.poll()
    with open(result_path, "w") as handle:
        json.dump(result, handle, indent=1)


if __name__ == "__main__":
    try:
        main(*sys.argv[1:5])
    except Exception:
        traceback.print_exc()
        sys.exit(1)
