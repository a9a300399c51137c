"""Print the node reader's spec of one material of a .blend as one JSON line.

    python read_blend.py REPOSITORY FILE.blend MATERIAL

Run by ``python -m bake brdf --from-blend`` in a subprocess, so that bake/
never imports bpy. Prints {"spec", "ignored", "approximated"} or {"error"}.
"""

import json
import os
import shutil
import sys
import tempfile


def main(root, blend, name) -> dict:
    folder = tempfile.mkdtemp(prefix="glossy_read_")
    try:
        return _read(folder, root, blend, name)
    finally:
        shutil.rmtree(folder, ignore_errors=True)  # the link only, never the repository


def _read(folder, root, blend, name) -> dict:
    os.symlink(root, os.path.join(folder, "glossy"))  # the repository as package ``glossy``
    sys.path.insert(0, folder)
    try:
        import bpy
    except ImportError:
        return {"error": "reading a .blend needs the bpy module (pip install bpy==5.0.1)"}
    bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    import glossy

    glossy.register()  # Material.glossy: the kept original of an attached material
    from glossy.glossy_addon.material_source import source_material
    from glossy.glossy_addon.node_reader import NodeReadError, read_material

    material = bpy.data.materials.get(name)
    if material is None:
        names = ", ".join(sorted(m.name for m in bpy.data.materials)) or "none"
        return {"error": f"{blend} has no material {name!r} (it has: {names})"}
    material = source_material(material)  # the user's nodes (or the kept original)
    try:
        found = read_material(material)
    except NodeReadError as error:
        return {"error": str(error)}
    return {"spec": found.spec, "ignored": found.ignored, "approximated": found.approximated}


if __name__ == "__main__":
    print(json.dumps(main(*sys.argv[1:4])))
