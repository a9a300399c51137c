"""Blender tests run the real bpy module in subprocesses, as a user's script would.

Each script gets its own process (bpy holds global state, and the install
test needs BLENDER_USER_RESOURCES set before bpy is imported) and writes a
JSON file of what it observed.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT

SCRIPTS = Path(__file__).resolve().parent / "scripts"


def run_script(name, *args, user_dir=None, timeout=600):
    """Run tests/blender/scripts/<name> with args; return its JSON result (last arg)."""
    env = dict(os.environ)
    if user_dir is not None:
        env["BLENDER_USER_RESOURCES"] = str(user_dir)
    process = subprocess.run(
        [sys.executable, str(SCRIPTS / name), *map(str, args)],
        cwd=SCRIPTS, env=env, capture_output=True, text=True, timeout=timeout,
    )
    if process.returncode != 0:
        pytest.fail(f"{name} failed ({process.returncode}):\n{process.stdout[-3000:]}\n"
                    f"{process.stderr[-3000:]}")
    return json.loads(Path(args[-1]).read_text())


@pytest.fixture(scope="session")
def extension_zip(tmp_path_factory):
    """The extension built by tools/build_extension.py (Blender's builder + validator)."""
    out = tmp_path_factory.mktemp("extension")
    process = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_extension.py"), "--output-dir", str(out)],
        capture_output=True, text=True, timeout=600,
    )
    if process.returncode != 0:
        pytest.fail(f"building the extension failed:\n{process.stdout}\n{process.stderr}")
    zips = list(out.glob("*.zip"))
    assert len(zips) == 1, zips
    return zips[0]
