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
    from ..bake.errors import BakeError

    try:
        spec = material_settings.brdf_spec()
    except BakeError as error:  # From Material with an unreadable tree: never up to date
        spec = f"unreadable: {error}"
    method = material_settings.method_used()
    key = {"spec": spec, "method": method,
           "slices": material_settings.slices, "size": material_settings.map_size,
           "size_mode": material_settings.size_mode,
           "lobes": (material_settings.lobes
                     if method in ("3d", "hybrid") else 1),
           "diffuse": [round(c, 6) for c in material_settings.diffuse_colour()],
           "lamps": ([material_settings.lamp_parameterization, material_settings.lamp_size,
                      material_settings.lamp_size_h, material_settings.lamp_method,
                      material_settings.lamp_terms]
                     if material_settings.lamps and material_settings.lamp_path else None),
           "probe": probe_key}
    if method in ("runtime", "hybrid"):
        key["samples"] = material_settings.samples
        # The lights' layout in the runtime texture changed with tiles (version 2).
        key["probe_lights"] = [material_settings.probe_lights, 2]
    elif method == "3d" and material_settings.model == "MATERIAL" and \
            material_settings.method == "auto":
        # The knots' maps take the probe lights out (bake.knot_lights, version 1).
        key["knot_lights"] = [material_settings.probe_lights, 1]
    if material_settings.model == "MATERIAL" and not spec.startswith("unreadable"):
        from .material_source import parts  # the read spec, weights and images

        found = parts(material_settings.id_data)
        key["material"] = [found.full_spec, found.derived.digest()]
    return hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]


def stamp(path) -> str:
    """``size:mtime_ns`` of a file as it is now ('' if it does not exist)."""
    try:
        status = Path(path).stat()
    except OSError:
        return ""
    return f"{status.st_size}:{status.st_mtime_ns}"


def stamps(text: str) -> dict:
    """{absolute path: stamp} recorded in a ``*_stamp`` JSON property."""
    try:
        values = json.loads(text or "{}")
    except ValueError:
        return {}
    return values if isinstance(values, dict) else {}


def bake_status(material_settings, probe_path) -> str:
    from ..bake.errors import BakeError

    """``missing`` (no file), ``damaged`` (a baked file is not as Glossy wrote it:
    truncated, rewritten or replaced, judged by its recorded size and time),
    ``stale`` (inputs changed) or ``up to date``."""
    settings = material_settings
    env_expected = bool(settings.bake_path) or not settings.lamp_path  # lamps-only: no map
    if env_expected and not (settings.bake_path and Path(settings.bake_path).exists()):
        return "missing"
    if settings.lamp_path and not Path(settings.lamp_path).exists():
        return "missing"
    if settings.runtime_path and not Path(settings.runtime_path).exists():
        return "missing"
    try:
        diffuse = any(material_settings.diffuse_colour())
    except BakeError:
        return "stale"
    if diffuse and not (
            material_settings.diffuse_path and Path(material_settings.diffuse_path).exists()):
        return "missing"
    for path, written in stamps(material_settings.bake_stamp).items():
        if path in (settings.bake_path, settings.diffuse_path, settings.lamp_path,
                    settings.runtime_path) and \
                stamp(path) != written:
            return "damaged"
    if material_settings.bake_hash != bake_inputs_hash(material_settings, probe_path):
        return "stale"
    return "up to date"
