"""Build the installable extension zip with Blender's own builder and validator.

Downloads the pinned OpenEXR wheels that blender_manifest.toml lists into
wheels/ (once), then runs ``blender_ext.py validate`` and ``build`` from the
bpy wheel (plain Python, no Blender needed). Prints the zip's path.

    python tools/build_extension.py [--output-dir build]
"""

import argparse
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tools.bpy_wheel import BpyWheelMissing, blender_ext_script  # noqa: E402


def fetch_wheels(manifest: dict) -> None:
    for entry in manifest.get("wheels", []):
        wheel = (ROOT / entry).resolve()
        if wheel.exists():
            continue
        name = wheel.name
        parts = name[:-4].split("-")
        distribution, version, python_tag, platform = parts[0], parts[1], parts[2], parts[4]
        wheel.parent.mkdir(parents=True, exist_ok=True)
        command = [
            sys.executable, "-m", "pip", "download", "--quiet", "--disable-pip-version-check",
            "--no-deps", "--only-binary=:all:", "--platform", platform,
            "--python-version", python_tag[2:], "--dest", str(wheel.parent),
            f"{distribution}=={version}",
        ]
        subprocess.run(command, check=True)
        if not wheel.exists():
            sys.exit(f"error: pip did not produce {name}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", default=str(ROOT / "build"))
    args = parser.parse_args()
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    fetch_wheels(manifest)
    try:
        script = blender_ext_script()
    except BpyWheelMissing as error:
        sys.exit(f"error: {error}")
    output_dir = Path(args.output_dir)
    output_dir.mkdir(parents=True, exist_ok=True)
    subprocess.run([sys.executable, str(script), "validate", str(ROOT)], check=True)
    zip_path = output_dir / f"{manifest['id']}-{manifest['version']}.zip"
    if zip_path.exists():
        zip_path.unlink()
    subprocess.run(
        [sys.executable, str(script), "build", "--source-dir", str(ROOT),
         "--output-filepath", str(zip_path)],
        check=True,
    )
    subprocess.run([sys.executable, str(script), "validate", str(zip_path)], check=True)
    print(zip_path)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except subprocess.CalledProcessError as error:
        sys.exit(f"error: {' '.join(map(str, error.cmd[:3]))} ... failed (exit {error.returncode})")
