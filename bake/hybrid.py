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
``hybrid_errors.json`` beside this module; nothing here is tuned by hand),
each roughness (GGX 0.1, 0.2, 0.3, 0.45, 0.6, 0.8 and 1; 0.8 and 1 since stop
72: until then a rougher lobe took 0.6's weights, and at 0.8 the Hybrid measured
above Runtime Sampling in EEVEE in three of eight HDRIs) and HDRI from a probe
of the face Auto captures for it
(``--face world``: bake.resolution.choose_probe_face's lobe rule, 200 px at
GGX 0.1 to 24 px at 0.8 and 1, raised for the HDRI's small lights by
bake.probe_detail: up to 328 px at GGX 0.1), so the weights judge the two
methods where the bake uses them (measured at 64 px for all, GGX 0.1 had w
near 0 from n.v 0 to 0.35: there the coarse probe limited regular sampling;
at the lobe rule's 200 px w was 0.6-0.9 below n.v 0.7, and at the faces the
HDRIs' lamps need it is 0.7-1.0):
the knots of w, its values w_k at the bins' centres (the piecewise-linear
w(mu) through them, held flat past the end centres, is what the nodes
evaluate: :func:`blend_curve`), are the least-squares blend of the two
estimates against the brute-force integral (the sum over the probe's texels),
both taken without
the probe lights' exact term, which the nodes add outside the blend (its own
error, against the sum over the lights' texels, is the same for every w, and
at grazing views under night.exr's lamps it was large enough to decide the
fit by chance), each pixel the mean
of 2 x 2 sub-pixels (``--supersample 2``: the footprint EEVEE's and Cycles'
anti-aliasing integrate; pixel centres alone alias highlights narrower than
a pixel, which put night.exr at 21% for every method at GGX 0.1 and moved
GGX 0.1's weights by up to 0.36), fitted as that very curve:

    minimise  sum_p s_p ((1 - w(mu_p)) m_p + w(mu_p) r_p - t_p)^2   over 0 <= w_k <= 1

(:func:`curve_normal_equations`, :func:`bounded_least_squares`) over the
pixels of every HDRI, s_p dividing each pixel's square by its HDRI's mean
squared truth in the pixel's bin (relative errors, pooled). Until stop 70
each bin had a constant of its own, w = sum (m - t)(m - r) / sum (m - r)^2
over the bin's pixels (clamped), which the curve then interpolated between
the centres: at GGX 0.1 its fall from 0.97 (n.v 0.35-0.5) to 0.42 (0.5-0.7)
let the map into the upper half of the 0.35-0.5 bin, where the map is the
worse estimate (``benchmarks/hybrid.py --fit bins`` fits as before). Leave
one out in NumPy the two fits are level (stop 70: pooled 2.656 / 2.649% at 19
samples, 2.431 / 2.436% at 61, 2.271 / 2.289% at 127, curve / bins; stop 72,
seven roughness values: 2.37 / 2.37%, 2.13 / 2.12%, 1.98 / 2.00%). Unlike an
inverse-variance weight it accounts for the two errors being correlated
(both limited by the probe, e.g. roughness 0.1 under a tiny sun). The table
also records each method's relative RMS error per bin. The regular
estimate's error falls as its sample count grows, so the table holds w and
its error per sample budget too (19, 61 and 127 samples): a Hybrid of 127
samples leans on the regular estimate where one of 19 must not. Between
bins, roughness values and budgets w is interpolated linearly (mu at the
bins' centres, roughness on its grid, the budget in log2; clamped outside).

Cycles' Beckmann lobe, which runtime sampling estimates through GGX's visible
normals (bake.sampling_runtime), has a table of its own,
``hybrid_errors_beckmann.json`` (``benchmarks/hybrid.py --brdf beckmann --fit bins
--face world --supersample 2 --write``, measured as GGX's since stop 44: 2 x 2
sub-pixels, the weights fitted on the residual probe, the lights' term of
stop 43): its runtime estimate carries the importance weights' extra
spread, so the map keeps the blend near normal incidence (with 19 samples w =
0-0.01 above n.v 0.7 for roughness 0.1-0.8 and 0.18 at 1, 0-0.16 at n.v
0.5-0.7, where GGX's table gives 0.14-0.79).
Leave one out it puts the Hybrid below both methods in 50 / 46 / 30 of 56
cases at 19 / 61 / 127 samples (stop 72: seven roughness values, the 3D map's
lobes about bake.lobes' best centre; stop 71's five, about the peak: 37 / 38
/ 23 of 40), above both in none. Its knots are the per-bin constants
(``--fit bins``; its meta has no "fit"), on evidence: measured again at stop
71 (13 minutes here, the map's lobes then about the peak),
the data fitted per bin give the committed knots to 0.01, and fitted as the
curve they do worse left one out (pooled 2.877% against 2.834% at 19
samples, the worst case 1.28x its better method alone against 1.10x; level
at 61 and 127 samples: 2.427 / 2.419%, 2.238 / 2.242%); at stop 72, on the
new map and seven roughness values, 2.46% against 2.42% at 19 samples,
2.11 / 2.10% at 61 and 1.93 / 1.93% at 127 (curve / bins).
"""

import functools
import json
from pathlib import Path

import numpy as np

from .errors import BakeError

__all__ = ["ErrorTable", "load_table", "near_mirror_alpha", "blend_weight", "weight_curve",
           "blend_curve", "curve_normal_equations", "bounded_least_squares", "shade", "TABLE_PATH",
           "table_path"]

TABLE_PATH = Path(__file__).with_name("hybrid_errors.json")
#: Lobe kinds (bake.sampling_runtime.KINDS) with a table of their own.
KINDS = ("ggx", "beckmann")


def table_path(kind="ggx") -> Path:
    """The committed table of a lobe kind: ``hybrid_errors.json`` for GGX (the first),
    ``hybrid_errors_<kind>.json`` for the others (benchmarks/hybrid.py --brdf)."""
    if kind not in KINDS:
        raise BakeError(f"no hybrid table for a {kind} lobe (tables: {', '.join(KINDS)})")
    return TABLE_PATH if kind == "ggx" else TABLE_PATH.with_name(f"hybrid_errors_{kind}.json")


class ErrorTable:
    """Measured relative errors and weights over sample budgets ``budgets`` (S,),
    roughness values ``roughness`` (R,) and mu bins ``edges`` (B + 1,): ``map``
    (R, B) (the 3D map has no budget), ``regular`` and ``weight`` (S, R, B).
    A table of one budget may give ``regular`` and ``weight`` as (R, B); its
    budget is then ``meta["budget"]`` (19 when absent)."""

    def __init__(self, roughness, edges, map_error, regular_error, weight, meta=None,
                 budgets=None):
        self.roughness = np.asarray(roughness, dtype=np.float64)
        self.edges = np.asarray(edges, dtype=np.float64)
        self.meta = dict(meta or {})
        self.map = np.asarray(map_error, dtype=np.float64)
        self.regular = np.asarray(regular_error, dtype=np.float64)
        self.weight = np.asarray(weight, dtype=np.float64)
        if self.weight.ndim == 2:
            self.regular, self.weight = self.regular[None], self.weight[None]
        if budgets is None:
            budgets = [self.meta.get("budget", 19)] if self.weight.shape[0] == 1 else []
        self.budgets = np.asarray(budgets, dtype=np.float64)
        shape = (len(self.roughness), len(self.edges) - 1)
        if self.map.shape != shape or any(a.shape != (len(self.budgets), *shape)
                                          for a in (self.regular, self.weight)):
            raise BakeError(f"hybrid error table: the map's errors must be {shape}, the "
                            f"regular estimate's errors and weights {len(self.budgets)} x "
                            f"{shape} (one per budget)")
        if np.any(np.diff(self.budgets) <= 0) or np.any(self.budgets < 1):
            raise BakeError("hybrid error table: budgets must be increasing sample counts")

    def to_json(self) -> dict:
        return {"budgets": self.budgets.tolist(), "roughness": self.roughness.tolist(),
                "mu_edges": self.edges.tolist(), "map": self.map.tolist(),
                "regular": self.regular.tolist(), "weight": self.weight.tolist(),
                "meta": self.meta}

    @classmethod
    def from_json(cls, data) -> "ErrorTable":
        return cls(data["roughness"], data["mu_edges"], data["map"], data["regular"],
                   data["weight"], data.get("meta"), data.get("budgets"))

    def at_budget(self, table, samples):
        """A (S, R, B) table interpolated at ``samples`` (linear in log2 of the
        budget, clamped to the measured ones): (R, B)."""
        table = np.asarray(table, dtype=np.float64)
        if table.ndim == 2:
            return table
        if len(self.budgets) == 1:
            return table[0]
        x = np.log2(np.clip(float(samples), self.budgets[0], self.budgets[-1]))
        logs = np.log2(self.budgets)
        i = int(np.clip(np.searchsorted(logs, x, side="right") - 1, 0, len(logs) - 2))
        t = (x - logs[i]) / (logs[i + 1] - logs[i])
        return (1.0 - t) * table[i] + t * table[i + 1]

    def interpolate(self, table, mu, roughness, samples=19):
        """A (R, B) or (S, R, B) table interpolated at mu (...), a scalar roughness
        and (for (S, R, B)) a sample count."""
        table = self.at_budget(table, samples)
        mu = np.clip(np.asarray(mu, dtype=np.float64), 0.0, 1.0)
        centres = 0.5 * (self.edges[:-1] + self.edges[1:])
        along_r = np.array([np.interp(roughness, self.roughness, table[:, b])
                            for b in range(table.shape[1])])
        return np.interp(mu, centres, along_r)


def load_table(path=None, kind="ggx") -> ErrorTable:
    """The measured table (``path``, else the lobe kind's: :func:`table_path`)."""
    path = Path(path or table_path(kind))
    try:
        return ErrorTable.from_json(json.loads(path.read_text()))
    except FileNotFoundError:
        raise BakeError(f"no hybrid error table at {path} (run benchmarks/hybrid.py "
                        "--write)") from None


@functools.lru_cache(maxsize=len(KINDS))
def near_mirror_alpha(kind="ggx") -> float:
    """The alpha of a GGX or Beckmann lobe (``kind``) below which the lobe is a
    near-mirror: the square of the lowest roughness the Hybrid's table of that
    kind measured (0.1 for both). Under it the table's weights would be 0.1's,
    taken beyond what they were measured for, so Auto bakes Runtime Sampling
    (glossy_addon.method_choice), whose level stack may then take more rows
    than Max Map Size (bake.sampling_runtime.stack_height)."""
    return float(load_table(kind=kind).roughness[0]) ** 2


def blend_weight(mu, roughness, table=None, samples=19, kind="ggx"):
    """w (...) of the regular estimate at view elevations mu = n.v (...) for a
    material of the given (isotropic GGX, or ``kind``) roughness sampled with
    ``samples`` samples per pixel."""
    table = table or load_table(kind=kind)
    return np.clip(table.interpolate(table.weight, mu, roughness, samples), 0.0, 1.0)


def weight_curve(roughness, table=None, samples=19, kind="ggx"):
    """(centres (B,), weights (B,)): the regular estimate's weight at the mu bins'
    centres for one roughness and sample count, the knots of the
    piecewise-linear w(mu) a material carries (the Hybrid's shader nodes
    evaluate it with :func:`blend_curve`'s arithmetic)."""
    table = table or load_table(kind=kind)
    centres = 0.5 * (table.edges[:-1] + table.edges[1:])
    weights = np.clip(table.interpolate(table.weight, centres, roughness, samples), 0.0, 1.0)
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



def curve_normal_equations(mu, baked, regular, truth, scale, centres):
    """The normal equations (G (K, K), c (K,)) of the blend's squared error as a
    function of the knot values w (K,) of :func:`blend_curve` at ``centres`` (K,):

        E(w) = sum_p s_p ((1 - w(mu_p)) m_p + w(mu_p) r_p - t_p)^2
             = w^T G w - 2 c^T w + const,

    with w(mu) = sum_k w_k phi_k(mu), phi_k the curve of knot values e_k (hat
    functions at the centres, the end ones held flat past the end centres),
    so that the fit is of the very curve the nodes evaluate, not of constants
    per bin. mu, baked (m), regular (r), truth (t), scale (s, each pixel's
    weight, e.g. 1 / its bin's mean squared truth): (N,) each. Normal
    equations of several sets of pixels add (pooled fits)."""
    mu = np.asarray(mu, dtype=np.float64)
    difference = np.asarray(regular, dtype=np.float64) - np.asarray(baked, dtype=np.float64)
    target = np.asarray(truth, dtype=np.float64) - np.asarray(baked, dtype=np.float64)
    scale = np.broadcast_to(np.asarray(scale, dtype=np.float64), mu.shape)
    basis = np.stack([blend_curve(mu, centres, np.eye(len(centres))[k])
                      for k in range(len(centres))], axis=-1) * difference[..., None]
    weighted = basis * scale[..., None]
    return weighted.T @ basis, weighted.T @ target


def bounded_least_squares(gram, rhs, lower=0.0, upper=1.0):
    """argmin over lower <= w <= upper of w^T G w - 2 c^T w (G (K, K) symmetric
    positive semi-definite, c (K,); K up to 10): every assignment of each
    variable to its lower bound, its upper bound or free is solved and the
    feasible one of least cost kept. The problem is convex, so its minimum is
    one of these (the Karush-Kuhn-Tucker point); a singular free block takes
    the least-norm solution."""
    gram = np.asarray(gram, dtype=np.float64)
    rhs = np.asarray(rhs, dtype=np.float64)
    count = len(rhs)
    if gram.shape != (count, count) or count > 10:
        raise BakeError(f"bounded_least_squares needs a K x K system with K <= 10, not "
                        f"{gram.shape}")
    best, best_cost = None, np.inf
    slack = 1e-12 * max(1.0, upper - lower)
    for code in range(3 ** count):
        state = [(code // 3 ** k) % 3 for k in range(count)]
        w = np.array([lower if s == 0 else upper for s in state], dtype=np.float64)
        free = np.array([s == 2 for s in state])
        if free.any():
            fixed = ~free
            block = gram[np.ix_(free, free)]
            right = rhs[free] - gram[np.ix_(free, fixed)] @ w[fixed]
            w[free] = np.linalg.lstsq(block, right, rcond=1e-12)[0]
            if np.any(w[free] < lower - slack) or np.any(w[free] > upper + slack):
                continue
        w = np.clip(w, lower, upper)
        cost = w @ gram @ w - 2.0 * rhs @ w
        if cost < best_cost - 1e-15 * max(1.0, abs(best_cost) if np.isfinite(best_cost) else 1):
            best, best_cost = w, cost
    return best


def shade(baked_map, atlas, meta, normals, views, tangents=None):
    """(N, 3) radiance the Hybrid's nodes compute for world-space unit normals and
    views (surface to viewer), (N, 3) each: (1 - w) (map + lights) + w runtime.

    baked_map: the 3D map of the probe without its lights (bake.prefilter.BakedMap);
    atlas, meta: the runtime texture of that residual probe with its lights
    (bake.sampling_runtime.pack), whose meta carries the w(mu) knots ``blend_mu``,
    ``blend_weight`` (:func:`weight_curve`); w is :func:`blend_curve` at mu = n.v.
    The lights' exact term is added to the map's part, so it stands outside the
    blend (glossy_addon.sampling_nodes.hybrid_value, glossy_addon.nodes). tangents:
    as bake.sampling_runtime.shade."""
    from .sampling_runtime import shade as runtime_shade

    normals = np.asarray(normals, dtype=np.float64)
    views = np.asarray(views, dtype=np.float64)
    if "blend_mu" not in meta:
        raise BakeError("the runtime texture has no Hybrid weights (blend_mu, blend_weight)")
    runtime = runtime_shade(atlas, meta, normals, views, tangents)
    lights = runtime - runtime_shade(atlas, {**meta, "lights": []}, normals, views, tangents) \
        if meta.get("lights") else 0.0
    mu = np.sum(normals * views, axis=-1) / np.maximum(
        np.linalg.norm(normals, axis=-1) * np.linalg.norm(views, axis=-1), 1e-30)
    weight = blend_curve(mu, meta["blend_mu"], meta["blend_weight"])[..., None]
    return (1.0 - weight) * (baked_map.shade(normals, views) + lights) + weight * runtime
