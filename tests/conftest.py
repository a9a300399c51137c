"""Shared fixtures: repository paths and Blender's bundled HDRIs."""

from pathlib import Path

import pytest

from tools import bpy_wheel

ROOT = Path(__file__).resolve().parent.parent


def studio_lights() -> Path:
    """Folder of the HDRIs that ship inside the bpy wheel (no bpy import needed)."""
    try:
        return bpy_wheel.studio_lights()
    except bpy_wheel.BpyWheelMissing as error:
        pytest.skip(str(error))


@pytest.fixture(scope="session")
def hdri_dir() -> Path:
    return studio_lights()


@pytest.fixture(scope="session")
def forest(hdri_dir):
    """forest.exr (1024 x 512 lat-long, DWAB-compressed) as read by bake.exr."""
    from bake import exr

    image, _ = exr.read(hdri_dir / "forest.exr")
    return image
