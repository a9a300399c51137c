"""Compare EEVEE renders of attached Glossy materials with bake.atlas.shade.

Reads what tests/blender/scripts/_acceptance_scene.render_views wrote
(lookup/normals/ids EXRs and views.json) and evaluates the NumPy twin of the
node lookup at each pixel's rendered shading normal and the orthographic
camera's view vector, in this (pytest) process.
"""

import json
from pathlib import Path

import numpy as np

from bake import atlas, exr
from bake.brdf import fresnel


def lookup_errors(workdir) -> dict:
    """{object: {pixels, median, p95, max}} of |rendered - predicted| / max(predicted, 1e-3)."""
    workdir = Path(workdir)
    views = json.loads((workdir / "views.json").read_text())
    radiance, normals, ids = (exr.read(workdir / f"{name}.exr")[0][..., :3].astype(np.float64)
                              for name in ("lookup", "normals", "ids"))
    normals = normals * 2.0 - 1.0
    view = np.array(views["view"])
    out = {}
    for index, (name, maps) in enumerate(views["atlases"].items()):
        mask = (ids[..., index] > 0.99) & (ids[..., 1 - index] < 0.01)
        mask &= np.abs(np.linalg.norm(normals, axis=-1) - 1.0) < 0.01
        n = normals[mask]
        predicted = atlas.shade(*exr.read(maps["glossy"]), n, view)
        if maps["diffuse"]:
            diffuse = atlas.shade(*exr.read(maps["diffuse"]), n, view)
            unit = n / np.linalg.norm(n, axis=-1, keepdims=True)
            f = fresnel.dielectric(unit @ view, maps["fresnel_ior"])[:, None]
            predicted = fresnel.blend(f, predicted, diffuse)  # Heidrich 3.1.1
        relative = np.abs(radiance[mask] - predicted) / np.maximum(np.abs(predicted), 1e-3)
        out[name] = {"pixels": int(mask.sum()), "median": float(np.median(relative)),
                     "p95": float(np.percentile(relative, 95)), "max": float(relative.max()),
                     "diffuse": bool(maps["diffuse"])}
    return out


def assert_matches_shade(workdir):
    """EEVEE writes half floats (relative rounding <= 4.9e-4) for both the
    radiance and the normal it is compared at; normals off by that much move
    the lookup by ~1e-3 rad: a few 1e-3 on these maps. Edge pixels where the
    normal varies quickly within the pixel make the tail."""
    errors = lookup_errors(workdir)
    assert set(errors) == {"Sphere", "Torus"}
    assert errors["Sphere"]["diffuse"] and not errors["Torus"]["diffuse"]
    for name, result in errors.items():
        assert result["pixels"] > 500, (name, result)
        assert result["median"] < 3e-3, (name, result)
        assert result["p95"] < 2e-2, (name, result)
        assert result["max"] < 5e-2, (name, result)
    return errors
