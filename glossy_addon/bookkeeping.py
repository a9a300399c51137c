"""Whether a material's bake is up to date, stale or missing."""

import hashlib
import json
from pathlib import Path


def bake_inputs_hash(material_settings, probe_path) -> str:
    """Hash of everything a bake depends on: the BRDF, the method, sizes and the probe file."""
    probe = Path(probe_path)
    try:
        stamp = probe.stat()
        probe_key = [str(probe), stamp.st_size, stamp.st_mtime_ns]
    except OSError:
        probe_key = [str(probe), None, None]
    key = {"spec": material_settings.brdf_spec(), "method": material_settings.method,
           "slices": material_settings.slices, "size": material_settings.map_size,
           "size_mode": material_settings.size_mode,
           "lobes": material_settings.lobes if material_settings.method == "3d" else 1,
           "diffuse": [round(c, 6) for c in material_settings.diffuse],
           "probe": probe_key}
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def bake_status(material_settings, probe_path) -> str:
    """``missing`` (no file), ``stale`` (inputs changed) or ``up to date``."""
    if not material_settings.bake_path or not Path(material_settings.bake_path).exists():
        return "missing"
    if any(material_settings.diffuse) and not (
            material_settings.diffuse_path and Path(material_settings.diffuse_path).exists()):
        return "missing"
    if material_settings.bake_hash != bake_inputs_hash(material_settings, probe_path):
        return "stale"
    return "up to date"
