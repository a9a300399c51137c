"""The hybrid of the 3D map and runtime regular sampling, weighted by measured error.

The radially symmetric 3D map (bake.prefilter) is accurate near normal
incidence and breaks at grazing views, where the true lobe is no longer
radially symmetric about the reflected direction; the regular-sampling
estimator (bake.sampling) follows the true lobe at every view but carries
the pattern's quadrature error where the map is exact. Each pixel blends the
two:

    L = (1 - w) L_map + w L_regular,

with w per bin of view elevation mu = n.v and per roughness, *measured* on
Blender's bundled HDRIs by ``benchmarks/hybrid.py`` (which writes
``hybrid_errors.json`` beside this module; nothing here is tuned by hand):
each bin's w is the least-squares blend of the two estimates against the
brute-force integral,

    w = sum (m - t)(m - r) / sum (m - r)^2   (clamped to [0, 1]),

over the bin's pixels of every HDRI, each HDRI's squares divided by its
mean squared truth in the bin (relative errors, pooled). Unlike an
inverse-variance weight it accounts for the two errors being correlated
(both limited by the probe, e.g. roughness 0.1 under a tiny sun). The table
also records each method's relative RMS error per bin. Between bins and
roughness values w is interpolated linearly (mu at the bins' centres,
roughness on its grid; clamped outside).
"""

import json
from pathlib import Path

import numpy as np

from .errors import BakeError

__all__ = ["ErrorTable", "load_table", "blend_weight", "weight_curve", "blend_curve",
           "TABLE_PATH"]

TABLE_PATH = Path(__file__).with_name("hybrid_errors.json")


class ErrorTable:
    """Measured relative errors ``map`` and ``regular``, (R, B) each, over
    roughness values ``roughness`` (R,) and mu bins ``edges`` (B + 1,)."""

    def __init__(self, roughness, edges, map_error, regular_error, weight, meta=None):
        self.roughness = np.asarray(roughness, dtype=np.float64)
        self.edges = np.asarray(edges, dtype=np.float64)
        self.map = np.asarray(map_error, dtype=np.float64)
        self.regular = np.asarray(regular_error, dtype=np.float64)
        self.weight = np.asarray(weight, dtype=np.float64)
        self.meta = dict(meta or {})
        shape = (len(self.roughness), len(self.edges) - 1)
        if any(a.shape != shape for a in (self.map, self.regular, self.weight)):
            raise BakeError(f"hybrid error table: errors and weights must be {shape}")

    def to_json(self) -> dict:
        return {"roughness": self.roughness.tolist(), "mu_edges": self.edges.tolist(),
                "map": self.map.tolist(), "regular": self.regular.tolist(),
                "weight": self.weight.tolist(), "meta": self.meta}

    @classmethod
    def from_json(cls, data) -> "ErrorTable":
        return cls(data["roughness"], data["mu_edges"], data["map"], data["regular"],
                   data["weight"], data.get("meta"))

    def interpolate(self, table, mu, roughness):
        """A (R, B) table interpolated at mu (...) and a scalar roughness."""
        mu = np.clip(np.asarray(mu, dtype=np.float64), 0.0, 1.0)
        centres = 0.5 * (self.edges[:-1] + self.edges[1:])
        along_r = np.array([np.interp(roughness, self.roughness, table[:, b])
                            for b in range(table.shape[1])])
        return np.interp(mu, centres, along_r)


def load_table(path=None) -> ErrorTable:
    """The measured table (``hybrid_errors.json`` by default)."""
    path = Path(path or TABLE_PATH)
    try:
        return ErrorTable.from_json(json.loads(path.read_text()))
    except FileNotFoundError:
        raise BakeError(f"no hybrid error table at {path} (run benchmarks/hybrid.py "
                        "--write)") from None


def blend_weight(mu, roughness, table=None):
    """w (...) of the regular estimate at view elevations mu = n.v (...) for a
    material of the given (isotropic GGX) roughness."""
    table = table or load_table()
    return np.clip(table.interpolate(table.weight, mu, roughness), 0.0, 1.0)


def weight_curve(roughness, table=None):
    """(centres (B,), weights (B,)): the regular estimate's weight at the mu bins'
    centres for one roughness, the knots of the piecewise-linear w(mu) a
    material carries (the Hybrid's shader nodes evaluate it with
    :func:`blend_curve`'s arithmetic)."""
    table = table or load_table()
    centres = 0.5 * (table.edges[:-1] + table.edges[1:])
    weights = np.clip(table.interpolate(table.weight, centres, roughness), 0.0, 1.0)
    return centres, weights


def blend_curve(mu, centres, weights):
    """w (...) at mu (...) from the knots: w_0 + sum_i (w_{i+1} - w_i) t_i with
    t_i = clamp((mu - c_i) / (c_{i+1} - c_i), 0, 1), i.e. np.interp with the
    ends held, written as the shader nodes compute it."""
    mu = np.asarray(mu, dtype=np.float64)
    value = np.full(mu.shape, float(weights[0]))
    for i in range(len(centres) - 1):
        t = np.clip((mu - centres[i]) / (centres[i + 1] - centres[i]), 0.0, 1.0)
        value = value + (float(weights[i + 1]) - float(weights[i])) * t
    return value
