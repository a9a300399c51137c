"""A real ``blender`` executable for the tests: Debian trixie's Blender in a chroot.

The bpy wheel has no executable, and this machine's Debian (bookworm) ships
Blender 3.4, older than the 4.2 extension platform. Debian trixie ships
Blender 4.3 (Python 3.13, NumPy 2), so ``make test`` builds a minimal trixie
root with debootstrap, installs Blender, Xvfb and Mesa's software OpenGL into
it, and writes an executable wrapper that runs that Blender in its own mount
namespace with /tmp, /dev and the repository visible at their usual paths.
Command-line use is then exactly a user's ``blender --background ...``.

    python tools/debian_blender.py provision   # prints the wrapper's path
    build/debian-blender/blender --background scene.blend --python-expr "..."

Set GLOSSY_BLENDER to another Blender (4.2 or newer) to test that one instead.
Needs root (debootstrap, chroot, mount namespaces) on a Debian-like Linux; the
packages come from the Debian archive that the host's apt already uses.
"""

import argparse
import contextlib
import fcntl
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
HOME = ROOT / "build" / "debian-blender"
SUITE = "trixie"
# Pinned to Blender 4.3 (the exact Debian revision first; a later trixie
# revision of 4.3 if the archive has moved on).
BLENDER_VERSIONS = ("4.3.2+dfsg-2", "4.3*")
PACKAGES = ("python3-numpy", "xvfb", "xauth", "libegl1", "libgl1", "libglx-mesa0",
            "libgl1-mesa-dri", "libegl-mesa0")
STAMP = f"{SUITE} blender {BLENDER_VERSIONS[0]} " + " ".join(PACKAGES)

WRAPPER = """#!/bin/sh
# Debian {suite}'s Blender in the chroot {root} (made by tools/debian_blender.py).
# Runs in a private mount namespace: /proc, /dev, /tmp, the repository and the
# current folder are visible at their usual paths; nothing stays mounted.
exec unshare --mount --fork /bin/sh -c '
  R=$1; shift
  mount -t proc proc "$R/proc" && mount --bind /dev "$R/dev" && mount --bind /tmp "$R/tmp" \\
    || {{ echo "debian-blender: cannot mount into $R (root needed)" >&2; exit 97; }}
  for d in "{repo}" "$PWD"; do
    case "$d" in /|/tmp|/tmp/*|/proc*|/dev*) continue ;; esac
    mkdir -p "$R$d" && mount --bind "$d" "$R$d" || exit 97
  done
  exec chroot "$R" /usr/bin/env -u PYTHONPATH -u PYTHONHOME -u VIRTUAL_ENV \\
    PATH=/usr/sbin:/usr/bin:/sbin:/bin /bin/sh -c "cd \\"\\$0\\" && exec \\"\\$@\\"" "$PWD" "$@"
' sh "{root}" {program} "$@"
"""


class ProvisionError(RuntimeError):
    """The chroot could not be made (not root, no debootstrap, archive unreachable).

    ``unprivileged`` is True when this machine does not allow what the wrapper
    needs (root, chroot, mount namespaces) rather than something having failed.
    """

    def __init__(self, message, unprivileged=False):
        super().__init__(message)
        self.unprivileged = unprivileged


def _host_mirror() -> str | None:
    """The main Debian archive URI the host's apt uses (None: debootstrap's default)."""
    candidates = []
    sources = Path("/etc/apt/sources.list.d")
    for path in sorted(sources.glob("*.sources")) if sources.is_dir() else []:
        for line in path.read_text().splitlines():
            if line.startswith("URIs:"):
                candidates += line.split()[1:]
    legacy = Path("/etc/apt/sources.list")
    if legacy.exists():
        for line in legacy.read_text().splitlines():
            parts = line.split()
            if parts[:1] == ["deb"]:
                candidates += [p for p in parts[1:] if "://" in p][:1]
    for uri in candidates:
        if "security" not in uri and "debian" in uri:
            return uri
    return None


def _run(command, **kwargs):
    process = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if process.returncode != 0:
        tail = (process.stdout + process.stderr).strip().splitlines()[-5:]
        raise ProvisionError(f"{' '.join(command[:4])} ... failed: " + " | ".join(tail))
    return process.stdout


def _chroot_apt(root: Path, *args):
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    return _run(["chroot", str(root), "apt-get", *args], env=env)


def write_wrappers(home: Path = HOME) -> Path:
    """(Re)write the ``blender`` and ``xvfb-blender`` wrappers; returns ``blender``."""
    root = home / "root"
    for name, program in (("blender", "blender"),
                          ("xvfb-blender", "xvfb-run -a -s \"-screen 0 1280x800x24\" blender")):
        path = home / name
        path.write_text(WRAPPER.format(suite=SUITE, root=root, repo=ROOT, program=program))
        path.chmod(0o755)
    return home / "blender"


@contextlib.contextmanager
def _only_one_at_a_time(home: Path):
    """Hold an exclusive lock on ``home``/lock: a second provision (``make test``
    starts one in the background, and the tests' fixture calls it) waits for the
    first and then finds the chroot made."""
    home.mkdir(parents=True, exist_ok=True)
    with open(home / "lock", "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def provision(home: Path = HOME, log=print) -> Path:
    """Make the chroot once (about a minute, 1.4 GB) and return the wrapper's path.

    Safe to call from several processes at once: they take turns, and only the
    first makes the chroot."""
    with _only_one_at_a_time(home):
        return _provision(home, log)


def _provision(home: Path, log) -> Path:
    root = home / "root"
    stamp = home / "ready"
    if stamp.exists() and stamp.read_text().strip() == STAMP:
        return write_wrappers(home)
    if sys.platform != "linux" or os.geteuid() != 0:
        raise ProvisionError("needs root on Linux (debootstrap, chroot, unshare); "
                             "set GLOSSY_BLENDER to a Blender 4.2+ executable instead",
                             unprivileged=True)
    if shutil.which("debootstrap") is None:
        log("debian-blender: installing debootstrap")
        _run(["apt-get", "update", "-qq"])
        _run(["apt-get", "install", "-y", "-qq", "debootstrap"],
             env=dict(os.environ, DEBIAN_FRONTEND="noninteractive"))
    partial = home / "root.partial"
    shutil.rmtree(partial, ignore_errors=True)
    shutil.rmtree(root, ignore_errors=True)
    stamp.unlink(missing_ok=True)
    home.mkdir(parents=True, exist_ok=True)
    log(f"debian-blender: debootstrap {SUITE} into {partial}")
    mirror = _host_mirror()
    _run(["debootstrap", "--variant=minbase", SUITE, str(partial), *([mirror] if mirror else [])])
    log("debian-blender: installing Blender, Xvfb and Mesa")
    _chroot_apt(partial, "update", "-qq")
    last = None
    for version in BLENDER_VERSIONS:
        try:
            _chroot_apt(partial, "install", "-y", "-qq", "--no-install-recommends",
                        f"blender={version}", *PACKAGES)
            break
        except ProvisionError as error:
            last = error
    else:
        raise last
    # The downloaded packages and the archive's indexes are not needed to run
    # Blender: dropping them keeps the chroot about 0.45 GB smaller (CI's disk).
    _chroot_apt(partial, "clean")
    shutil.rmtree(partial / "var" / "lib" / "apt" / "lists", ignore_errors=True)
    partial.rename(root)
    wrapper = write_wrappers(home)
    check = subprocess.run([str(wrapper), "--version"], capture_output=True, text=True)
    if check.returncode != 0:
        message = (check.stdout + check.stderr).strip().splitlines()[-1:] or ["no output"]
        raise ProvisionError(f"the chroot's blender does not run: {message[0]}",
                             unprivileged=check.returncode == 97)
    stamp.write_text(STAMP + "\n")
    log("debian-blender: " + check.stdout.splitlines()[0])
    return wrapper


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=["provision"])
    parser.add_argument("--if-possible", action="store_true",
                        help="do nothing (exit 0) when GLOSSY_BLENDER is set or not root")
    args = parser.parse_args()
    if args.if_possible:
        if os.environ.get("GLOSSY_BLENDER"):
            print(f"debian-blender: using GLOSSY_BLENDER={os.environ['GLOSSY_BLENDER']}",
                  file=sys.stderr)
            return 0
        if sys.platform != "linux" or os.geteuid() != 0:
            print("debian-blender: not root; the blender-executable tests will be skipped "
                  "(set GLOSSY_BLENDER to run them)", file=sys.stderr)
            return 0
    try:
        print(provision(log=lambda line: print(line, file=sys.stderr)))
    except ProvisionError as error:
        print(f"error: {error}", file=sys.stderr)
        return 0 if args.if_possible and error.unprivileged else 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
