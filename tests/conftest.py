"""Shared fixtures: repository paths and Blender's bundled HDRIs."""

import contextlib
import os
import subprocess
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


@contextlib.contextmanager
def read_only_folder(folder: Path):
    """Make ``folder`` read-only for this process and its children, then restore it.

    A normal user gets chmod 555. root ignores file modes, so there the folder
    is bind-mounted read-only onto itself (needs CAP_SYS_ADMIN); where neither
    works the test is skipped, saying why.
    """
    folder = Path(folder)
    if os.geteuid() != 0:
        mode = folder.stat().st_mode
        folder.chmod(0o555)
        try:
            yield folder
        finally:
            folder.chmod(mode)
        return
    mounted = subprocess.run(["mount", "--bind", str(folder), str(folder)],
                             capture_output=True).returncode == 0
    if mounted and subprocess.run(["mount", "-o", "remount,bind,ro", str(folder)],
                                  capture_output=True).returncode != 0:
        subprocess.run(["umount", str(folder)], capture_output=True)
        mounted = False
    if not mounted:
        pytest.skip("root without mount rights: no way to make a folder read-only")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=True)


def listing(folder: Path) -> dict:
    """{relative path: (size, bytes hash)} of every file under ``folder`` (dot files too)."""
    import hashlib

    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(Path(folder).rglob("*")) if p.is_file()}
