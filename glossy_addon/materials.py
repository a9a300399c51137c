"""The user's material before Glossy replaced its nodes: kept, and put back.

Attaching a lookup rebuilds the material's node tree. The first attach keeps
a copy of the material as it was (``<name> (before Glossy)``, with a fake
user, referenced by ``material.glossy.original``); :func:`restore_original`
remaps every user of the lookup material back to that copy, which takes the
original name and the current Glossy settings.
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
    """Put the kept original in place of ``material`` everywhere; returns the
    restored material (``material`` itself is removed), or None if none was kept."""
    original = material.glossy.original
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
