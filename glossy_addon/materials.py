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
