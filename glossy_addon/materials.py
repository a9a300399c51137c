"""The user's material before Glossy attached its lookup: kept, and put back.

Attaching a lookup adds Glossy's nodes beside the user's and makes its own
Material Output active (glossy_addon.nodes.build_lookup). The first attach
also keeps a copy of the material as it was (``<name> (before Glossy)``, with
a fake user, referenced by ``material.glossy.original``): the truth of
validation where the user's nodes are gone, and what an older attach (which
replaced the nodes) is restored from. :func:`restore_original` takes the
lookup off again.
"""

import bpy

_SKIP = {"rna_type", "original"}


def stash_original(material) -> None:
    """Keep ``material`` as it is now, unless a copy is already kept."""
    if material.glossy.original is not None:
        return
    original = material.copy()
    original.name = f"{material.name} (before Glossy)"
    original.use_fake_user = True
    material.glossy.original = original


def restore_original(material):
    """Take Glossy's lookup off ``material``; returns the restored material.

    An attach keeps the user's nodes beside the lookup: the lookup's nodes are
    removed and the user's Material Output is active again (edits made since
    the attach stay), and the kept copy is dropped when no other material
    keeps it. A material whose nodes an older attach replaced gets the kept
    original back in its place everywhere (``material`` itself is removed).
    None if there is no lookup to take off."""
    from .nodes import is_lookup_node, strip_lookup, user_output

    original = material.glossy.original
    tree = material.node_tree if material.use_nodes else None
    if tree is not None and any(is_lookup_node(n) for n in tree.nodes) and \
            user_output(material) is not None:
        strip_lookup(material)
        material.glossy.original = None
        if original is not None and original.use_fake_user and not any(
                other.glossy.original == original for other in bpy.data.materials):
            bpy.data.materials.remove(original)
        return material
    if original is None:
        return None
    for prop in material.glossy.bl_rna.properties:
        if prop.identifier not in _SKIP and not prop.is_readonly:
            setattr(original.glossy, prop.identifier, getattr(material.glossy, prop.identifier))
    name = material.name
    material.glossy.original = None
    material.user_remap(original)
    material.name = f"{name} (Glossy lookup)"
    original.name = name
    original.use_fake_user = False
    bpy.data.materials.remove(material)
    return original


def effective_tangent(material, obj):
    """(tangent, warning or None): the material's tangent setting (("RADIAL", axis)
    or ("UV_MAP", name)) as ``obj`` can give it; a UV tangent on a mesh without
    that UV map falls back to radial about Z (Cycles' default), with a warning
    when the lobe is anisotropic (where the tangent matters)."""
    from ..bake import brdf

    tangent = material.glossy.tangent()
    if tangent[0] != "UV_MAP":
        return tangent, None
    layers = obj.data.uv_layers if obj is not None and obj.type == "MESH" else ()
    if len(layers) and (not tangent[1] or tangent[1] in layers):
        return tangent, None
    warning = None
    if not brdf.parse(material.glossy.brdf_spec()).isotropic:
        missing = f"no UV map '{tangent[1]}'" if tangent[1] else "no UV map"
        warning = (f"{material.name}: {obj.name if obj else 'the object'} has {missing}: the "
                   f"anisotropic tangent falls back to radial about Z")
    return ("RADIAL", "Z"), warning
