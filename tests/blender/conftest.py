"""Blender tests run the real bpy module in subprocesses, as a user's script would.

Each script gets its own process (bpy holds global state, and the install
test needs BLENDER_USER_RESOURCES set before bpy is imported) and writes a
JSON file of what it observed.
"""

import json
import os
import subprocess
import sys
import tempfile
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


@pytest.fixture(scope="session")
def blender_executable():
    """A real ``blender`` executable (4.2+): GLOSSY_BLENDER, else Debian trixie's
    Blender 4.3 in a chroot that tools/debian_blender.py makes once (root only)."""
    from tools import debian_blender

    named = os.environ.get("GLOSSY_BLENDER")
    if named:
        if not os.access(named, os.X_OK):
            pytest.fail(f"GLOSSY_BLENDER={named} is not an executable")
        return Path(named)
    if sys.platform != "linux" or os.geteuid() != 0:
        pytest.skip("no blender executable: set GLOSSY_BLENDER, or run as root so that "
                    "tools/debian_blender.py can make one")
    try:
        return debian_blender.provision(log=lambda line: print(line, file=sys.stderr))
    except debian_blender.ProvisionError as error:
        if error.unprivileged:  # this machine forbids chroot / mount namespaces
            pytest.skip(f"no blender executable: {error}")
        pytest.fail(f"could not set up Debian's Blender: {error}")


@pytest.fixture(scope="session")
def live_blender(blender_executable):
    """The same Blender with a real window: the chroot's xvfb-blender wrapper,
    or ``xvfb-run -a`` around GLOSSY_BLENDER."""
    beside = blender_executable.parent / "xvfb-blender"
    if beside.exists() and not os.environ.get("GLOSSY_BLENDER"):
        return beside
    import shutil

    if shutil.which("xvfb-run") is None:
        pytest.skip("a live window needs xvfb-run next to GLOSSY_BLENDER")
    wrapper = Path(tempfile.mkdtemp(prefix="glossy_xvfb_")) / "xvfb-blender"
    wrapper.write_text(f'#!/bin/sh\nexec xvfb-run -a "{blender_executable}" "$@"\n')
    wrapper.chmod(0o755)
    return wrapper


def run_blender(executable, *args, user_dir, cwd=None, timeout=600, check=True):
    """Run ``blender ARGS`` with BLENDER_USER_RESOURCES=user_dir; returns the
    CompletedProcess (stdout and stderr together in .stdout)."""
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user_dir))
    if "--python" in args or "--python-expr" in args:  # a script's exception fails the run
        args = ("--python-exit-code", "1", *args)
    process = subprocess.run([str(executable), *map(str, args)], cwd=cwd, env=env,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                             timeout=timeout)
    if check and process.returncode != 0:
        pytest.fail(f"blender {' '.join(map(str, args))[:200]} failed "
                    f"({process.returncode}):\n{process.stdout[-4000:]}")
    return process


@pytest.fixture(scope="session")
def installed(blender_executable, extension_zip, tmp_path_factory):
    """A user directory with the zip installed and enabled by Blender's own CLI."""
    user = tmp_path_factory.mktemp("blender_user")
    out = run_blender(blender_executable, "--background", "--factory-startup", "--command",
                      "extension", "install-file", "-r", "user_default", "-e", extension_zip,
                      user_dir=user).stdout
    assert 'Installed "glossy"' in out, out
    assert "incompatible" not in out, out
    return user
