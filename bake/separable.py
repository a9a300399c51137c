"""Separable BRDF approximations (Kautz & McCool 1999): f ~ sum_k g_k(u) h_k(v).

A 4D BRDF is written as a matrix M[u, v] by choosing a *parameterization*
(a pair of 2D parameters, each sampled on an n x n texture), and M is
factored into a few pairs of 2D textures:

- ``incident-view``: u = wi, v = wo, each on a hemisphere map;
- ``elevation-azimuth``: u = (theta_i, theta_o), v = (phi_i, phi_o), on
  [0, pi/2]^2 and [0, 2 pi)^2 grids (row = first angle, column = second);
- ``half-difference`` (Rusinkiewicz): u = h = normalize(wi + wo), v = d, wi
  in the frame that takes h to the pole (rotate by -phi_h about z, then by
  -theta_h about y), each on a hemisphere map;
- ``gram-schmidt`` (the paper's eq. 4): u = h, v = wo in the frame
  z' = h, x' = normalize(x - (x.h) h) (the tangent made orthogonal to h),
  y' = z' x x'.

Hemisphere maps (section 5.3) take a unit vector (x, y, z >= 0) to texture
coordinates s = (X + 1) / 2 along columns and t = (1 - Y) / 2 along rows
(row 0 at +y), where (X, Y) = (x, y) (``xy``: orthographic projection) or
(x, y) / (1 + z) (``parabolic``). Texels outside the unit disc hold the
value at the rim direction they project to (so bilinear lookups near the rim
stay continuous). All frames are the BRDF's local frame (z = normal, x =
tangent); f is f_r without the cosine, RGB channels factored independently.

Decompositions (section 4):

- truncated SVD: the N leading singular triplets by randomized subspace
  iteration on row blocks of M (Halko, Martinsson & Tropp 2011), never a
  full SVD of M; g_k = sqrt(s_k) u_k, h_k = sqrt(s_k) v_k;
- normalized decomposition (ND): h(v) = ||M[:, v]||_p (column p-norms),
  g(u) = mean over v of M[u, v] / h(v) (columns with h = 0 skipped); later
  terms are the ND of the residual M - sum of earlier terms, with each signed
  residual column turned to agree with the strongest one. Passes over row
  blocks only: memory linear in the textures, as the paper states.

The matrix is evaluated in row blocks and kept only while it fits
``MATRIX_BYTES``; larger ones are re-evaluated per pass. In the half-vector
parameterizations some (u, v) pairs put wi or wo below the horizon: those
entries are no BRDF value: the SVD is then the weighted rank-N least squares
over the valid entries (alternating least squares), the ND decomposes the
matrix with them filled by that fit, so an exactly separable BRDF is
recovered exactly and the fit spends nothing on pairs no shader looks up.

Each stored factor is normalized to a largest magnitude of 1 with its
scale in the metadata: f = sum_k scale_g[k] scale_h[k] G_k(u) H_k(v).
"""

import math
import os
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .brdf import parse
from .errors import BakeError
from .progress import report

__all__ = ["PARAMETERIZATIONS", "MAPS", "METHODS", "Factorization", "factorize",
           "check_arguments", "matrix_for",
           "hemisphere_directions", "hemisphere_coords", "stratified_pairs", "error", "pack",
           "atlas_lookup"]

PARAMETERIZATIONS = ("incident-view", "elevation-azimuth", "half-difference", "gram-schmidt")
MAPS = ("xy", "parabolic")
METHODS = ("svd", "nd", "sampled")
SIZE_RANGE = (4, 256)
TERMS_RANGE = (1, 16)
#: A sampled matrix is kept in memory up to this size (bytes, float32 RGB).
MATRIX_BYTES = 512 << 20
#: Weighted least squares over the valid entries (half-vector parameterizations):
#: at most this many rounds, stopping when the reconstruction moves less.
ALS_ROUNDS = 24
ALS_TOLERANCE = 1e-7
#: Rounds of the (rank-N, float32) fit that fills those entries before an ND,
#: started from the ND of the zero-filled matrix (5 or 7 rounds leave an exactly
#: separable BRDF above the 1e-6 of the module's tests; 10 meet it).
ND_FILL_ROUNDS = 10


# --- hemisphere maps ----------------------------------------------------------------
def _texel_centres(size):
    return (np.arange(size) + 0.5) / size * 2.0 - 1.0


def hemisphere_directions(size: int, kind: str = "xy") -> np.ndarray:
    """(size, size, 3) unit vectors at texel centres of a hemisphere map (row 0 at +y).

    Centres beyond half a texel inside the disc's edge (and every texel outside
    it) take the direction at that radius along their own azimuth: the map is
    sampled where its texels represent the hemisphere, not at z = 0 where f
    grows without bound (GGX's 1 / (cos theta_i cos theta_o)), and bilinear
    lookups near the rim stay continuous."""
    X = _texel_centres(size)[None, :].repeat(size, 0)
    Y = -_texel_centres(size)[:, None].repeat(size, 1)
    r = np.hypot(X, Y)
    rim = 1.0 - 1.0 / size  # half a texel inside the disc's edge
    scale = np.where(r > rim, rim / np.maximum(r, 1e-30), 1.0)
    X, Y, r = X * scale, Y * scale, np.minimum(r, rim)
    if kind == "xy":
        z = np.sqrt(np.clip(1.0 - r * r, 0.0, None))
        v = np.stack([X, Y, z], -1)
    elif kind == "parabolic":  # (X, Y) = (x, y) / (1 + z)
        z = (1.0 - r * r) / (1.0 + r * r)
        v = np.stack([X * (1.0 + z), Y * (1.0 + z), z], -1)
    else:
        raise BakeError(f"unknown hemisphere map {kind!r} (use xy or parabolic)")
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def hemisphere_coords(vectors, size: int, kind: str = "xy"):
    """Continuous (column, row) texel coordinates of unit vectors (..., 3), z >= 0,
    on a size x size hemisphere map (texel centres at integers)."""
    v = np.asarray(vectors, dtype=np.float64)
    if kind == "xy":
        X, Y = v[..., 0], v[..., 1]
    else:
        denominator = 1.0 + np.maximum(v[..., 2], 0.0)
        X, Y = v[..., 0] / denominator, v[..., 1] / denominator
    return (X + 1.0) / 2.0 * size - 0.5, (1.0 - Y) / 2.0 * size - 0.5


def _bilinear(texture, col, row, wrap_cols=False, wrap_rows=False):
    """Bilinear lookup of texture (H, W, C) at continuous texel coordinates."""
    height, width = texture.shape[:2]
    c0, r0 = np.floor(col).astype(int), np.floor(row).astype(int)
    fc, fr = (col - c0)[..., None], (row - r0)[..., None]

    def index(i, n, wrap):
        return np.mod(i, n) if wrap else np.clip(i, 0, n - 1)

    c0w, c1w = index(c0, width, wrap_cols), index(c0 + 1, width, wrap_cols)
    r0w, r1w = index(r0, height, wrap_rows), index(r0 + 1, height, wrap_rows)
    top = texture[r0w, c0w] * (1 - fc) + texture[r0w, c1w] * fc
    bottom = texture[r1w, c0w] * (1 - fc) + texture[r1w, c1w] * fc
    return top * (1 - fr) + bottom * fr


# --- parameterizations ------------------------------------------------------------
def _pole_angles(h):
    """(cos phi, sin phi, cos theta, sin theta) of unit vectors h (..., 3), without
    trigonometric calls; phi = 0 where h is the pole (atan2(0, 0))."""
    cos_t = np.clip(h[..., 2], -1.0, 1.0)
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    radius = np.hypot(h[..., 0], h[..., 1])
    safe = np.where(radius > 1e-300, radius, 1.0)
    cos_p = np.where(radius > 1e-300, h[..., 0] / safe, 1.0)
    sin_p = np.where(radius > 1e-300, h[..., 1] / safe, 0.0)
    return cos_p, sin_p, cos_t, sin_t


def _rotate_to_pole(v, h):
    """v (..., 3) in the frame taking h to +z (Rusinkiewicz: -phi_h about z, -theta_h about y)."""
    cos_p, sin_p, cos_t, sin_t = _pole_angles(h)
    x = cos_p * v[..., 0] + sin_p * v[..., 1]
    y = -sin_p * v[..., 0] + cos_p * v[..., 1]
    z = v[..., 2]
    return np.stack([cos_t * x - sin_t * z, y, sin_t * x + cos_t * z], -1)


def _rotate_from_pole(d, h):
    """Inverse of :func:`_rotate_to_pole`."""
    cos_p, sin_p, cos_t, sin_t = _pole_angles(h)
    x = cos_t * d[..., 0] + sin_t * d[..., 2]
    z = -sin_t * d[..., 0] + cos_t * d[..., 2]
    y = d[..., 1]
    return np.stack([cos_p * x - sin_p * y, sin_p * x + cos_p * y, z], -1)


def _gram_schmidt_frame(h):
    """(x', y', z') of the paper's eq. 4 at half vectors h (..., 3)."""
    tangent = np.zeros_like(h)
    tangent[..., 0] = 1.0
    x = tangent - np.sum(tangent * h, -1, keepdims=True) * h
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    fallback = np.zeros_like(h)
    fallback[..., 1] = 1.0  # h along x (never above the horizon's interior): use y
    x = np.where(norm > 1e-9, x / np.maximum(norm, 1e-30), fallback)
    y = np.cross(h, x)
    return x, y, h


def _reflect_about(v, h):
    return 2.0 * np.sum(v * h, -1, keepdims=True) * h - v


class _Grid:
    """The two sampled parameters of one parameterization: u on a size x size
    texture (g), v on a size_h x size_h one (h; default the same size)."""

    def __init__(self, name, size, kind, size_h=None):
        if name not in PARAMETERIZATIONS:
            raise BakeError(f"unknown parameterization {name!r} (use one of: "
                            f"{', '.join(PARAMETERIZATIONS)})")
        size_h = size if size_h is None else size_h
        self.name, self.size, self.size_h, self.kind = name, size, size_h, kind
        if name == "elevation-azimuth":
            theta = (np.arange(size) + 0.5) / size * (np.pi / 2)
            phi = (np.arange(size_h) + 0.5) / size_h * (2 * np.pi)
            self.u = np.stack(np.meshgrid(theta, theta, indexing="ij"), -1).reshape(-1, 2)
            self.v = np.stack(np.meshgrid(phi, phi, indexing="ij"), -1).reshape(-1, 2)
        else:
            self.u = hemisphere_directions(size, kind).reshape(-1, 3)
            self.v = hemisphere_directions(size_h, kind).reshape(-1, 3)

    def radius_keys(self):
        """(size^2,) int64: a^2 + b^2 for the u texel at column j and row i, a =
        2 j + 1 - size and b = 2 i + 1 - size (its centre's radius times size,
        squared), capped at the rim's (size - 1)^2 as hemisphere_directions caps
        the radius: texels of one key have the same direction up to a rotation
        about the pole, exactly (one key: one elevation)."""
        offsets = 2 * np.arange(self.size, dtype=np.int64) + 1 - self.size
        squares = offsets[:, None] ** 2 + offsets[None, :] ** 2
        return np.minimum(squares, (self.size - 1) ** 2).ravel()

    def pairs(self, u, v):
        """(wi, wo) for every (u row, v column): (len(u), len(v), 3) each."""
        if self.name == "incident-view":
            wi = np.broadcast_to(u[:, None, :], (len(u), len(v), 3))
            wo = np.broadcast_to(v[None, :, :], (len(u), len(v), 3))
            return wi, wo
        if self.name == "elevation-azimuth":
            ti, to = u[:, None, 0], u[:, None, 1]
            pi, po = v[None, :, 0], v[None, :, 1]
            wi = np.stack(np.broadcast_arrays(np.sin(ti) * np.cos(pi), np.sin(ti) * np.sin(pi),
                                              np.cos(ti) + 0 * pi), -1)
            wo = np.stack(np.broadcast_arrays(np.sin(to) * np.cos(po), np.sin(to) * np.sin(po),
                                              np.cos(to) + 0 * po), -1)
            return wi, wo
        h = np.broadcast_to(u[:, None, :], (len(u), len(v), 3))
        second = np.broadcast_to(v[None, :, :], (len(u), len(v), 3))
        if self.name == "half-difference":
            wi = _rotate_from_pole(second, h)
            return wi, _reflect_about(wi, h)
        x, y, z = _gram_schmidt_frame(h)
        wo = second[..., :1] * x + second[..., 1:2] * y + second[..., 2:] * z
        return _reflect_about(wo, h), wo

    def coords(self, wi, wo):
        """Continuous texel coordinates ((col, row) of u, (col, row) of v) of pairs."""
        n, m = self.size, self.size_h
        if self.name == "incident-view":
            return hemisphere_coords(wi, n, self.kind), hemisphere_coords(wo, m, self.kind)
        if self.name == "elevation-azimuth":
            ti = np.arccos(np.clip(wi[..., 2], -1, 1))
            to = np.arccos(np.clip(wo[..., 2], -1, 1))
            pi = np.mod(np.arctan2(wi[..., 1], wi[..., 0]), 2 * np.pi)
            po = np.mod(np.arctan2(wo[..., 1], wo[..., 0]), 2 * np.pi)
            theta = n / (np.pi / 2)
            phi = m / (2 * np.pi)
            return (to * theta - 0.5, ti * theta - 0.5), (po * phi - 0.5, pi * phi - 0.5)
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        if self.name == "half-difference":
            second = _rotate_to_pole(wi, h)
        else:
            x, y, z = _gram_schmidt_frame(h)
            second = np.stack([np.sum(wo * x, -1), np.sum(wo * y, -1), np.sum(wo * z, -1)], -1)
        return hemisphere_coords(h, n, self.kind), hemisphere_coords(second, m, self.kind)


# --- the matrix, in row blocks ------------------------------------------------------
class _Matrix:
    """M[c, u, v] = f(wi, wo)[c] of a parameterization, evaluated in row blocks
    (channel first, so every product is a batched BLAS matrix product)."""

    def __init__(self, model, grid, block_bytes=64 << 20):
        self.model, self.grid = model, grid
        self.rows, self.cols = len(grid.u), len(grid.v)
        self.block = max(1, int(block_bytes // (self.cols * 3 * 8 * 4)))
        self._kept = self._valid = None
        self.evaluations = 0
        if self.rows * self.cols * 3 * 4 <= MATRIX_BYTES:
            self._kept = np.concatenate([b for _, b in self._evaluate_blocks()], axis=1)
            self._valid = np.concatenate([v for _, v in self._evaluate_blocks(False)], axis=0)

    def _evaluate_blocks(self, with_values=True):
        for start in range(0, self.rows, self.block):
            stop = min(start + self.block, self.rows)
            wi, wo = self.grid.pairs(self.grid.u[start:stop], self.grid.v)
            valid = (wi[..., 2] > 0) & (wo[..., 2] > 0)
            if not with_values:
                yield start, valid
                continue
            self.evaluations += wi.shape[0] * wi.shape[1]
            values = self.model.f(wi, wo).astype(np.float32)
            yield start, np.ascontiguousarray(np.moveaxis(values, -1, 0))

    def blocks(self):
        """Yield (first row, (3, rows, cols) float32 block)."""
        if self._kept is not None:
            for start in range(0, self.rows, self.block):
                yield start, self._kept[:, start:start + self.block]
        else:
            yield from self._evaluate_blocks()

    def valid_blocks(self):
        """Yield (first row, (rows, cols) bool): pairs with wi and wo above the horizon
        (the others are no BRDF value at all: half-vector parameterizations reach
        below the horizon)."""
        if self._valid is not None:
            for start in range(0, self.rows, self.block):
                yield start, self._valid[start:start + self.block]
        else:
            yield from self._evaluate_blocks(with_values=False)

    @property
    def complete(self) -> bool:
        """True when every entry is a valid pair (incident-view, elevation-azimuth)."""
        return self.grid.name in ("incident-view", "elevation-azimuth")


class _Filled:
    """The matrix with its invalid entries filled by a reconstruction g h^T
    (EM-style imputation: an exactly separable BRDF stays exactly separable)."""

    def __init__(self, matrix, fill):
        self.matrix, self.fill = matrix, fill
        self.rows, self.cols = matrix.rows, matrix.cols
        self._kept = None
        if matrix._kept is not None:  # kept in memory: fill once, not on every pass
            self._kept = np.concatenate([b for _, b in self._filled_blocks()], axis=1)

    def blocks(self):
        if self._kept is None:
            yield from self._filled_blocks()
            return
        for start in range(0, self.rows, self.matrix.block):
            yield start, self._kept[:, start:start + self.matrix.block]

    def _filled_blocks(self):
        for (start, block), (_, valid) in zip(self.matrix.blocks(), self.matrix.valid_blocks(),
                                              strict=True):
            if self.fill is None or valid.all():
                yield start, block
                continue
            g, h = self.fill
            guess = g[:, start:start + block.shape[1]].astype(np.float32) @ \
                h.transpose(0, 2, 1).astype(np.float32)  # sgemm, like the matrix itself
            yield start, np.where(valid[None], block, guess)


# --- decompositions ------------------------------------------------------------------
def _residual(block, start, g, h):
    """block (3, r, cols) minus the earlier terms g (3, rows, K) h (3, cols, K) on its rows."""
    if not g.shape[2]:
        return block
    return block - g[:, start:start + block.shape[1]] @ h.transpose(0, 2, 1)


def _nd(matrix, terms, p, progress):
    """Normalized decomposition, sequentially on the residual; three passes over row
    blocks per term (column norms and the strongest column; each column's sign
    against it; the mean normalized column), so memory stays linear in the textures.
    Signs matter from the second term on (a residual is signed): each column is
    turned to agree with the strongest one, so a signed rank-1 residual a b^T is
    recovered exactly."""
    g = np.zeros((3, matrix.rows, 0))
    h = np.zeros((3, matrix.cols, 0))
    channels = np.arange(3)
    def residual(block, start):
        # The first term works on the float32 matrix itself (sums in float64).
        return block if not g.shape[2] else _residual(block.astype(np.float64), start, g, h)

    for k in range(terms):
        norms = np.zeros((3, matrix.cols))
        lowest = np.inf
        for start, block in matrix.blocks():
            r = residual(block, start)
            norms += np.sum(r * r if p == 2 else np.abs(r) ** p, axis=1, dtype=np.float64)
            lowest = min(lowest, float(r.min()))
        column = norms ** (1.0 / p)
        if lowest >= 0.0:  # no negative entry: every column agrees with every other
            sign = np.ones((3, matrix.cols))
        else:
            strongest = np.argmax(column, axis=1)
            reference = np.zeros((3, matrix.rows))
            dots = np.zeros((3, matrix.cols))
            for start, block in matrix.blocks():
                r = residual(block, start)
                reference[:, start:start + r.shape[1]] = r[channels, :, strongest]
            for start, block in matrix.blocks():
                r = residual(block, start)
                dots += np.einsum("cu,cuv->cv", reference[:, start:start + r.shape[1]], r)
            sign = np.where(dots < 0, -1.0, 1.0)
        usable = column > 1e-12 * max(float(column.max()), 1e-300)
        safe = np.where(usable, column, 1.0) * sign
        row = np.zeros((3, matrix.rows))
        inverse = np.where(usable, 1.0 / safe, 0.0)
        for start, block in matrix.blocks():
            r = residual(block, start)
            row[:, start:start + r.shape[1]] = np.einsum(
                "cuv,cv->cu", r, inverse.astype(r.dtype), dtype=np.float64) / \
                np.maximum(usable.sum(1), 1)[:, None]
        g = np.concatenate([g, row[..., None]], axis=2)
        h = np.concatenate([h, np.where(usable, safe, 0.0)[..., None]], axis=2)
        report(progress, (k + 1) / terms, f"ND term {k + 1}/{terms}")
    return g, h


def _nd_one_term_filled(matrix, fill, progress):
    """The ND's one term (p = 2) of the matrix with its invalid entries filled by a
    non-negative rank-one fill g h^T, without forming the filled matrix: with W the
    valid mask and M zero where W is, the filled matrix is M + (1 - W) o g h^T, so

        ||column v||^2 = sum_u M_uv^2 + h_v^2 (sum_u g_u^2 - (W^T g^2)_v)
        row u          = (M s)_u + g_u (sum_v h_v s_v - (W (h o s))_u),  s = 1 / ||column||

    two streamed passes of matrix-vector products. None when the fill or the
    matrix has a negative entry (the general ND then runs on the filled blocks)."""
    g, h = (f[..., 0] for f in fill)  # (3, rows), (3, cols)
    if g.min() < 0.0 or h.min() < 0.0:
        return None
    squares = np.zeros((3, matrix.cols))
    masked_g2 = np.zeros((matrix.cols, 3))
    lowest = np.inf
    g2 = (g * g).T.astype(np.float32)  # (rows, 3)
    for (start, block), (_, valid) in zip(matrix.blocks(), matrix.valid_blocks(), strict=True):
        squares += np.sum(np.square(block, dtype=np.float64), axis=1)
        masked_g2 += valid.T.astype(np.float32) @ g2[start:start + block.shape[1]]
        lowest = min(lowest, float(block.min()))
    if lowest < 0.0:
        return None
    norms = squares + h * h * np.maximum((g * g).sum(axis=1)[:, None] - masked_g2.T, 0.0)
    column = np.sqrt(norms)
    usable = column > 1e-12 * max(float(column.max()), 1e-300)
    inverse = np.where(usable, 1.0 / np.where(usable, column, 1.0), 0.0)
    weighted_h = (h * inverse).T.astype(np.float32)  # (cols, 3)
    row = np.zeros((3, matrix.rows))
    for (start, block), (_, valid) in zip(matrix.blocks(), matrix.valid_blocks(), strict=True):
        rows = slice(start, start + block.shape[1])
        observed = np.einsum("cuv,cv->cu", block, inverse.astype(np.float32),
                             dtype=np.float64)
        filled = (h * inverse).sum(axis=1)[:, None] - (valid.astype(np.float32) @ weighted_h).T
        row[:, rows] = observed + g[:, rows] * filled
    row /= np.maximum(usable.sum(1), 1)[:, None]
    report(progress, 1.0, "ND term 1/1")
    return row[..., None], np.where(usable, column, 0.0)[..., None]


def _svd(matrix, terms, progress, iterations=4, oversample=8, seed=0):
    """Randomized subspace iteration per channel: (g, h) of the leading terms,
    (3, rows, K) and (3, cols, K)."""
    rng = np.random.default_rng(seed)
    width = min(terms + oversample, matrix.rows, matrix.cols)
    g = np.zeros((3, matrix.rows, terms))
    h = np.zeros((3, matrix.cols, terms))

    def times(right):  # M right: (3, rows, width); float32 products (sgemm), float64 sums
        right32 = right.astype(np.float32)
        out = np.zeros((3, matrix.rows, right.shape[2]))
        for start, block in matrix.blocks():
            out[:, start:start + block.shape[1]] = block @ right32
        return out

    def transposed_times(left, dtype=np.float32):  # M^T left: (3, cols, width)
        left_cast = left.astype(dtype)
        out = np.zeros((3, matrix.cols, left.shape[2]))
        for start, block in matrix.blocks():
            out += block.astype(dtype, copy=False).transpose(0, 2, 1) @ \
                left_cast[:, start:start + block.shape[1]]
        return out

    def orthonormal(a):
        return np.stack([np.linalg.qr(a[c])[0] for c in range(3)])

    q = orthonormal(times(rng.standard_normal((3, matrix.cols, width))))
    for step in range(iterations):
        q = orthonormal(times(orthonormal(transposed_times(q))))
        report(progress, (step + 1) / (iterations + 1), f"SVD subspace iteration {step + 1}")
    b = transposed_times(q, np.float64)  # (3, cols, width) = (Q^T M)^T, in full precision
    for c in range(3):
        small_u, sigma, vt = np.linalg.svd(b[c].T, full_matrices=False)
        if not np.all(np.isfinite(sigma)):
            raise BakeError("the SVD did not converge (non-finite values in the BRDF?)")
        u = q[c] @ small_u
        for k in range(min(terms, len(sigma))):
            root = math.sqrt(max(float(sigma[k]), 0.0))
            sign = -1.0 if u[:, k].sum() < 0 else 1.0
            g[c, :, k] = sign * root * u[:, k]
            h[c, :, k] = sign * root * vt[k]
    report(progress, 1.0, f"SVD: {terms} term(s)")
    return g, h


# --- the result --------------------------------------------------------------------
class Factorization:
    """Factor textures and how to look them up.

    ``g``: (K, n, n, 3), ``h``: (K, m, m, 3) float32 (n = size, m = size_h), each
    normalized to a largest magnitude of 1; ``scale_g``, ``scale_h``: (K, 3)
    scales; f ~ sum_k scale_g scale_h g_k h_k.
    """

    def __init__(self, spec, parameterization, method, size, kind, g, h, p=2.0, size_h=None):
        size_h = size if size_h is None else size_h
        self.spec, self.parameterization, self.method = spec, parameterization, method
        self.size, self.size_h, self.kind, self.p = size, size_h, kind, p
        g = np.transpose(np.asarray(g), (2, 1, 0)).reshape(-1, size, size, 3)
        h = np.transpose(np.asarray(h), (2, 1, 0)).reshape(-1, size_h, size_h, 3)
        self.scale_g = np.maximum(np.abs(g).max(axis=(1, 2)), 1e-30)
        self.scale_h = np.maximum(np.abs(h).max(axis=(1, 2)), 1e-30)
        self.g = (g / self.scale_g[:, None, None]).astype(np.float32)
        self.h = (h / self.scale_h[:, None, None]).astype(np.float32)
        self.grid = _Grid(parameterization, size, kind, size_h)

    @property
    def terms(self):
        return len(self.g)

    def evaluate(self, wi, wo, terms=None):
        """Reconstructed f (..., 3) at pairs, by bilinear lookups (first ``terms``)."""
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        (uc, ur), (vc, vr) = self.grid.coords(wi, wo)
        wrap = self.parameterization == "elevation-azimuth"
        total = np.zeros(np.broadcast_shapes(wi.shape, wo.shape))
        for k in range(terms or self.terms):
            a = _bilinear(self.g[k], uc, ur)
            b = _bilinear(self.h[k], vc, vr, wrap_cols=wrap, wrap_rows=wrap)
            total += a * b * (self.scale_g[k] * self.scale_h[k])
        above = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        return np.where(above[..., None], total, 0.0)

    def meta(self) -> dict:
        return {"generator": "glossy-bake separable", "kind": "separable", "spec": self.spec,
                "parameterization": self.parameterization, "method": self.method,
                "terms": self.terms, "size": self.size, "size_h": self.size_h,
                "map": self.kind, "p": self.p,
                "scale_g": self.scale_g.tolist(), "scale_h": self.scale_h.tolist(),
                "convention": __doc__.split("\n\n")[2].replace("\n", " ")}

    def layers(self) -> dict:
        out = {}
        for k in range(self.terms):
            out[f"g{k}"] = self.g[k]
            out[f"h{k}"] = self.h[k]
        return out


def check_arguments(size, terms, parameterization, kind, method, p, size_h=None):
    """Raise BakeError for an argument outside what factorize takes (before any work)."""
    low, high = SIZE_RANGE
    for value in (size, size if size_h is None else size_h):
        if not isinstance(value, (int, np.integer)) or not low <= value <= high:
            raise BakeError(f"texture size must be a whole number in [{low}, {high}], "
                            f"not {value!r}")
    low, high = TERMS_RANGE
    if not isinstance(terms, (int, np.integer)) or not low <= terms <= high:
        raise BakeError(f"terms must be a whole number in [{low}, {high}], not {terms!r}")
    if parameterization not in PARAMETERIZATIONS:
        raise BakeError(f"unknown parameterization {parameterization!r} (use one of: "
                        f"{', '.join(PARAMETERIZATIONS)})")
    if kind not in MAPS:
        raise BakeError(f"unknown hemisphere map {kind!r} (use xy or parabolic)")
    if method not in METHODS:
        raise BakeError(f"unknown method {method!r} (use one of: {', '.join(METHODS)})")
    if not 0.5 <= p <= 16:
        raise BakeError(f"the ND's p-norm must be in [0.5, 16], not {p}")


def factorize(brdf, parameterization="half-difference", method="svd", terms=1, size=32,
              kind="xy", p=2.0, progress=None, matrix=None, size_h=None) -> Factorization:
    """Factor a BRDF (spec or model) into ``terms`` pairs of textures: g on
    size x size texels, h on size_h x size_h (default: size).

    Arguments are checked before any evaluation (BakeError). ``matrix``: a
    sampled matrix to reuse (the report factors one matrix several ways).
    ``method="sampled"`` never forms the whole matrix (see :func:`_sampled_als`).
    """
    check_arguments(size, terms, parameterization, kind, method, p, size_h)
    model = parse(brdf)
    grid = _Grid(parameterization, size, kind, size_h)
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            if method == "sampled":
                g, h = _sampled_als(model, grid, terms, progress)
            else:
                if matrix is None:
                    matrix = _Matrix(model, grid)
                g, h = _decompose(matrix, method, terms, p, progress)
    except np.linalg.LinAlgError as error:
        raise BakeError(f"the factorization of {model.spec} did not converge ({error})") \
            from None
    if not (np.all(np.isfinite(g)) and np.all(np.isfinite(h))):
        raise BakeError(f"the factorization of {model.spec} did not converge (non-finite "
                        f"factors: the BRDF has infinite or NaN values in the "
                        f"{parameterization} parameterization)")
    return Factorization(model.spec, parameterization, method, size, kind, g, h, p,
                         grid.size_h)


def _product_norm(g, h):
    """||g h^T||_F over channels from K x K Gram matrices (no rows x cols product)."""
    return math.sqrt(max(float(np.sum((g.transpose(0, 2, 1) @ g) * (h.transpose(0, 2, 1) @ h))),
                         0.0))


#: Ridge of the weighted least squares with several terms, relative to the mean
#: diagonal of the normal equations. With missing entries, terms can trade
#: values in texels that few valid pairs constrain, which bilinear lookups then
#: mix into their neighbours (measured: Ward, Figure 10, 32^2, gram-schmidt: 2-5
#: terms gave 1.7-6.6 relative error unregularized, about 0.26 with 1e-2). One
#: term has no such freedom and is fitted without a ridge (exact for a
#: separable BRDF).
ALS_RIDGE = 1e-2


def _ridge(normal):
    """(3, n, 1, 1) ridge for normal equations (3, n, K, K)."""
    diagonal = np.trace(normal, axis1=2, axis2=3) / normal.shape[-1]
    strength = ALS_RIDGE if normal.shape[-1] > 1 else 1e-12
    return strength * diagonal.mean(axis=1)[:, None, None, None] + 1e-300


def _als(matrix, g, h, rounds, tolerance, progress, double_round=True):
    """Weighted rank-K least squares over the valid entries only (alternating least
    squares from (g, h)): the truncated SVD of a matrix with missing entries.
    The rounds use float32 products; ``double_round`` adds one in float64."""
    terms = g.shape[2]
    eye = np.eye(terms)
    kept_weights = None
    if matrix._kept is not None:  # in memory anyway: cast the mask once, not every pass
        kept_weights = [valid.astype(np.float32) for _, valid in matrix.valid_blocks()]

    def weight_blocks(dtype):
        if kept_weights is None:
            return (valid.astype(dtype) for _, valid in matrix.valid_blocks())
        return (w.astype(dtype, copy=False) for w in kept_weights)

    for round_ in range(rounds + int(double_round)):
        # float32 products (sgemm) while converging, one last round in float64
        final = round_ == rounds
        dtype = np.float64 if final else np.float32
        previous = (g.copy(), h.copy())
        for side in ("g", "h"):
            other = h if side == "g" else g
            # (n, 3 K^2): one product reads the mask once for all three channels
            outer = np.moveaxis((other[..., :, None] * other[..., None, :]).reshape(
                3, -1, terms * terms), 0, 1).reshape(-1, 3 * terms * terms).astype(dtype)
            h_cast = h.astype(dtype)
            if side == "h":
                normal = np.zeros((matrix.cols, 3 * terms * terms))
                right = np.zeros((3, matrix.cols, terms))
            for (start, block), weight in zip(matrix.blocks(), weight_blocks(dtype),
                                              strict=True):
                observed = block.astype(dtype, copy=False)  # f is 0 where a pair is not valid
                if side == "g":
                    rows = slice(start, start + block.shape[1])
                    a = np.moveaxis((weight @ outer).reshape(-1, 3, terms, terms), 1, 0
                                    ).astype(np.float64)
                    rhs = (observed @ h_cast).astype(np.float64)
                    ridge = _ridge(a)
                    system = (a + ridge * eye).reshape(-1, terms, terms)
                    g[:, rows] = _solve_small(system, rhs.reshape(-1, terms)).reshape(
                        rhs.shape)
                else:
                    rows = slice(start, start + block.shape[1])
                    g_cast = g[:, rows].astype(dtype)
                    normal += weight.T @ outer[rows]
                    right += observed.transpose(0, 2, 1) @ g_cast
            if side == "h":
                a = np.moveaxis(normal.reshape(matrix.cols, 3, terms, terms), 1, 0)
                ridge = _ridge(a)
                h = _solve_small((a + ridge * eye).reshape(-1, terms, terms),
                                 right.reshape(-1, terms)).reshape(right.shape)
        both_g = np.concatenate([g, previous[0]], axis=2)
        both_h = np.concatenate([h, -previous[1]], axis=2)
        change = _product_norm(both_g, both_h) / max(_product_norm(g, h), 1e-300)
        report(progress, min(1.0, (round_ + 1) / rounds),
               f"weighted least squares round {round_ + 1}")
        if final:
            break
        if change < tolerance:
            if not double_round:
                break
            rounds = round_ + 1  # converged in float32: the float64 round is next
    return _as_svd(g, h)


def _as_svd(g, h):
    """The same product g h^T as SVD-ordered terms g_k = sqrt(s_k) u_k, h_k = sqrt(s_k) v_k."""
    out_g, out_h = np.zeros_like(g), np.zeros_like(h)
    for c in range(3):
        qg, rg = np.linalg.qr(g[c])
        qh, rh = np.linalg.qr(h[c])
        u, sigma, vt = np.linalg.svd(rg @ rh.T)
        root = np.sqrt(np.maximum(sigma, 0.0))
        left, right = qg @ u * root, qh @ vt.T * root
        signs = np.where(left.sum(axis=0) < 0, -1.0, 1.0)
        out_g[c], out_h[c] = left * signs, right * signs
    return out_g, out_h


def _decompose(matrix, method, terms, p, progress):
    """(g, h) of the matrix. Where some entries are no valid pair (below the
    horizon, half-vector parameterizations), the SVD becomes the weighted rank-K
    least squares over the valid entries (alternating least squares from the SVD
    of the zero-filled matrix), and the ND decomposes the matrix with those
    entries filled by that reconstruction."""
    if matrix.complete:
        if method == "svd":
            return _svd(matrix, terms, progress)
        return _nd(matrix, terms, p, progress)
    # The ND's fill only starts from the ND of the zero-filled matrix (two passes).
    g, h = _svd(matrix, terms, None) if method == "svd" else _nd(matrix, terms, p, None)
    rounds = ALS_ROUNDS if method == "svd" else ND_FILL_ROUNDS
    g, h = _als(matrix, g, h, rounds, ALS_TOLERANCE, None if method == "nd" else progress,
                double_round=method == "svd")
    if method == "svd":
        return g, h
    if terms == 1 and p == 2:
        one = _nd_one_term_filled(matrix, (g, h), progress)
        if one is not None:
            return one
    return _nd(_Filled(matrix, (g, h)), terms, p, progress)


#: The sampled fit: g's rows are fitted against a SAMPLED_GRID x SAMPLED_GRID
#: sub-grid of h's texels, h's columns against one of g's texels, for
#: SAMPLED_ROUNDS alternations (measured on GGX 0.3 and anisotropic GGX
#: 0.3/0.8, g 256^2, h 32^2, 2 terms: 8 x 8 and 64 x 64 sub-grids are within
#: 0.2 points of image error of 16 x 16 and 128 x 128; see the module's tests).
SAMPLED_GRID = (64, 8)
SAMPLED_ROUNDS = 8


def _sub_grid(size, count):
    """Flat indices of a count x count regular sub-grid of a size x size texture
    (every texel when count >= size): one texel in each stratum of ``size //
    count`` texels, at its centre rounded up in the texture's first half and
    mirrored in its second, so the sub-grid is its own mirror image across
    both axes and its own half turn. A symmetric BRDF's equal rows then fall
    within it (:func:`_shared_rows`: an isotropic BRDF's 64^2 sub-grid of a
    256^2 g map holds 414 radii, an anisotropic lobe's half of its rows)."""
    stride = max(1, size // count)
    axis = np.arange(stride // 2, size, stride)
    first = axis[2 * axis <= size - 1]
    axis = np.union1d(first, size - 1 - first)
    return (axis[:, None] * size + axis[None, :]).ravel()


#: Groups of rows whose second member _shared_rows evaluates to check that
#: the model has the symmetry it is assumed to have.
SHARED_ROW_CHECKS = 64


def _shared_rows(model, grid, rows, cols):
    """(representative rows, inverse) where rows of M repeat by a symmetry of
    the model, else None.

    In the half-difference parameterization wi = Rz(phi_h) Ry(theta_h) d and
    wo is wi reflected about h, so every pair of a row at azimuth phi_h is the
    phi_h = 0 pair rotated about the normal by phi_h:

    - an isotropic BRDF (and the horizon test) gives the same value: rows whose
      texels lie at one radius of g's map (:meth:`_Grid.radius_keys`, exact
      integers) are equal (256^2 g texels: 8256 radii);
    - any other BRDF that a half turn about the normal leaves unchanged (every
      elliptical anisotropic lobe: GGX, Beckmann, Ashikhmin-Shirley, Ward,
      Principled, whatever their rotation) gives equal rows at h and at its
      half-turn partner (-h_x, -h_y, h_z), the texel mirrored through the map's
      centre: half the rows (and :func:`_mirrored_rows` halves them again for a
      lobe aligned with the tangent).

    Each group is evaluated once, at its first member: M[rows] =
    M[representatives][inverse] up to the rounding of the rotation (tests
    compare it with the direct evaluation). The symmetry is checked, not
    assumed from the model's ``isotropic`` flag alone: a second member of
    SHARED_ROW_CHECKS groups is evaluated too (at ``cols``), and any mismatch
    beyond rounding (a tabulated anisotropic BRDF, a model that only claims
    isotropy) evaluates every row."""
    if grid.name != "half-difference":
        return None
    rows = np.asarray(rows)
    if getattr(model, "isotropic", False):
        keys = grid.radius_keys()
    else:
        texels = np.arange(grid.size * grid.size)
        keys = np.minimum(texels, texels[::-1])  # a texel and its half-turn partner
    _, first, inverse = np.unique(keys[rows], return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    if len(first) == len(rows):
        return None
    last = np.zeros(len(first), np.int64)
    last[inverse] = np.arange(len(rows))  # the last member of each group
    shared = np.flatnonzero(last != first)
    picked = shared[np.linspace(0, len(shared) - 1, min(SHARED_ROW_CHECKS, len(shared)))
                    .astype(np.int64)]
    once = _slab_direct(model, grid, rows[first[picked]], cols)
    again = _slab_direct(model, grid, rows[last[picked]], cols)
    if not (np.array_equal(once[1], again[1]) and
            np.allclose(once[0], again[0], rtol=1e-6, atol=1e-9 * np.abs(once[0]).max())):
        return None
    return rows[first], inverse


def _slab(model, grid, rows, cols, pairs_per_block=1 << 19):
    """The slab M[c, rows, cols] in compact form: (values (3, U, len(cols)) float32,
    valid (U, len(cols)) float32, inverse (len(rows),) int, representatives (U,)
    int) with M[:, rows] = values[:, inverse], row ``representatives[u]`` of the
    grid standing for every row of group u. Rows that a symmetry of the model
    repeats are evaluated once (:func:`_shared_rows`); otherwise U = len(rows),
    inverse is the identity and representatives are ``rows``."""
    shared = _shared_rows(model, grid, rows, cols)
    if shared is None:
        shared = np.asarray(rows), np.arange(len(rows))
    representatives, inverse = shared
    mirrored = _mirrored_rows(model, grid, representatives, cols)
    if mirrored is None:
        values, valid = _slab_direct(model, grid, representatives, cols, pairs_per_block)
        return values, valid, inverse, representatives
    evaluated, source, flipped, permutation = mirrored
    values, valid = _slab_direct(model, grid, representatives[evaluated], cols,
                                 pairs_per_block)
    values, valid = values[:, source], valid[source]
    values[:, flipped] = values[:, flipped][:, :, permutation]
    valid[flipped] = valid[flipped][:, permutation]
    return values, valid, inverse, representatives


def _mirrored_rows(model, grid, representatives, cols):
    """(evaluated, source, flipped, permutation) where an anisotropic lobe is also
    its own mirror image across the tangent's axes, else None.

    A lobe aligned with the tangent frame (rotation 0 or a quarter turn: Blender's
    default) is unchanged when x -> -x (or y -> -y) for both directions. The row
    of the half vector mirrored so, (-h_x, h_y, h_z), is then the row of h with
    d -> (d_x, -d_y, d_z): the same values, h's columns permuted (the d map's
    rows flipped; ``cols``, a symmetric sub-grid or every texel, is closed under
    it). Of the half-turn groups ``representatives`` (:func:`_shared_rows`),
    one of each mirror pair is evaluated (``evaluated``, indices into
    ``representatives``); row u of the slab is row ``source[u]`` of those, with
    its columns permuted by ``permutation`` where ``flipped``. Checked like
    :func:`_shared_rows` on SHARED_ROW_CHECKS pairs (a lobe turned by any other
    angle fails and keeps its half-turn groups)."""
    if grid.name != "half-difference" or getattr(model, "isotropic", False):
        return None
    n, m = grid.size, grid.size_h
    cols = np.asarray(cols)
    position = np.full(m * m, -1)
    position[cols] = np.arange(len(cols))
    permutation = position[(m - 1 - cols // m) * m + cols % m]
    if np.any(permutation < 0):
        return None
    reps = np.asarray(representatives)
    groups = np.minimum(reps, n * n - 1 - reps)  # half-turn groups' keys
    mirror = (reps // n) * n + (n - 1 - reps % n)  # (-h_x, h_y): the map's columns flipped
    order = np.argsort(groups)
    found = np.searchsorted(groups[order], np.minimum(mirror, n * n - 1 - mirror))
    found = np.minimum(found, len(reps) - 1)
    partner = order[found]
    if np.any(groups[partner] != np.minimum(mirror, n * n - 1 - mirror)):
        return None  # the rows are not closed under the mirror
    own = np.arange(len(reps))
    kept = partner >= own  # evaluate the first of each pair (and self-mirrored rows)
    if np.all(kept):
        return None
    flipped = ~kept
    picked = np.flatnonzero(flipped)
    picked = picked[np.linspace(0, len(picked) - 1, min(SHARED_ROW_CHECKS, len(picked)))
                    .astype(np.int64)]
    once = _slab_direct(model, grid, reps[partner[picked]], cols)
    again = _slab_direct(model, grid, reps[picked], cols)
    if not (np.array_equal(once[1][:, permutation], again[1]) and
            np.allclose(once[0][:, :, permutation], again[0], rtol=1e-6,
                        atol=1e-9 * np.abs(once[0]).max())):
        return None
    evaluated = np.flatnonzero(kept)
    index = np.full(len(reps), -1)
    index[evaluated] = np.arange(len(evaluated))
    source = np.where(kept, index, index[partner])
    return evaluated, source, flipped, permutation


def _slab_direct(model, grid, rows, cols, pairs_per_block=1 << 19):
    """(M[c, rows, cols] float32, valid (rows, cols) float32) with every row
    evaluated, in row blocks of about ``pairs_per_block`` pairs, on every core
    (NumPy releases the GIL in its loops)."""
    values = np.empty((3, len(rows), len(cols)), np.float32)
    valid = np.empty((len(rows), len(cols)), np.float32)
    block = max(1, pairs_per_block // len(cols))

    def evaluate(start):
        stop = min(start + block, len(rows))
        wi, wo = grid.pairs(grid.u[rows[start:stop]], grid.v[cols])
        valid[start:stop] = (wi[..., 2] > 0) & (wo[..., 2] > 0)
        values[:, start:stop] = np.moveaxis(model.f(wi, wo), -1, 0)

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        list(pool.map(evaluate, range(0, len(rows), block)))
    return values, valid


def _weighted_rows(weighted, weights, factors, ridge):
    """Per channel and row x, argmin over a (K) of sum_c w (M[x, c] - a . F[c])^2
    (+ ridge): weighted = w M (3, X, C) float32 (the caller forms it once for
    every round), weights (X, C) float32, factors (3, C, K) -> (3, X, K). The
    normal matrices of the three channels come from one product with the
    weights (one pass over them, not three)."""
    channels, count, terms = factors.shape
    f = factors.astype(np.float32)
    outer = (f[:, :, :, None] * f[:, :, None, :]).reshape(channels, count, terms * terms)
    outer = np.ascontiguousarray(outer.transpose(1, 0, 2)).reshape(count, -1)
    normals = (weights @ outer).reshape(-1, channels, terms, terms).astype(np.float64)
    out = np.empty((channels, weighted.shape[1], terms), np.float64)
    for channel in range(channels):
        normal = normals[:, channel]
        right = (weighted[channel] @ f[channel]).astype(np.float64)
        scale = np.trace(normal, axis1=1, axis2=2)[:, None, None] / terms
        normal = normal + (ridge * scale + 1e-30) * np.eye(terms)
        out[channel] = _solve_small(normal, right)
    return out


def _solve_small(normal, right):
    """Batched solve of (X, K, K) systems; K = 1 and 2 in closed form (LAPACK's
    per-matrix overhead dominates for millions of tiny systems)."""
    if normal.shape[-1] == 1:
        return right / normal[:, 0]
    if normal.shape[-1] == 2:
        a, b, c, d = normal[:, 0, 0], normal[:, 0, 1], normal[:, 1, 0], normal[:, 1, 1]
        det = a * d - b * c
        det = np.where(np.abs(det) > 1e-300, det, 1e-300)
        return np.stack([(d * right[:, 0] - b * right[:, 1]) / det,
                         (a * right[:, 1] - c * right[:, 0]) / det], -1)
    return np.linalg.solve(normal, right[..., None])[..., 0]


def _sampled_als(model, grid, terms, progress):
    """(g (3, rows, K), h (3, cols, K)): weighted rank-K least squares from two
    slabs of the matrix, never the whole of it.

    g and h may differ in size: a narrow lobe needs a fine g (the half vector
    carries D(h)) while h stays smooth. h is fitted to every column from the
    rows R of a regular sub-grid of g's texels, g to every row from the columns
    C of a sub-grid of h's texels, alternately (SAMPLED_ROUNDS), so the BRDF is
    evaluated |R| cols + rows |C| times instead of rows x cols (g 256^2 and h
    32^2: 8.4 million instead of 67 million; rows that a symmetry repeats
    once, :func:`_shared_rows` and :func:`_mirrored_rows`: 0.68 million for an
    isotropic BRDF, 4.2 million for an anisotropic lobe, 2.1 million for one
    aligned with the tangent). Pairs below the horizon weigh
    nothing; h starts as the column RMS over R (the ND's h for p = 2), later
    terms from small fixed pseudo-random columns; ALS_RIDGE for K > 1.
    """
    rows = _sub_grid(grid.size, SAMPLED_GRID[0])
    cols = _sub_grid(grid.size_h, SAMPLED_GRID[1])
    every_row = np.arange(len(grid.u))
    every_col = np.arange(len(grid.v))
    report(progress, 0.0, f"sampling {len(rows)} x {len(grid.v)} and "
                          f"{len(grid.u)} x {len(cols)} BRDF values")
    # Compact slabs (_slab): rows that a symmetry repeats are held once. A
    # group's rows share one g row (their least-squares problems are the same),
    # and in h's fit a group counts as many times as it has rows.
    across, across_valid, across_groups, across_rows = _slab(model, grid, rows, every_col)
    down, down_valid, down_groups, _ = _slab(model, grid, every_row, cols)  # M[:, C]
    across_valid = across_valid * np.bincount(across_groups,
                                              minlength=len(across_rows))[:, None]
    report(progress, 0.3, "sampled")
    power = np.einsum("crk,rk->ck", across.astype(np.float64) ** 2, across_valid)
    count = np.maximum(across_valid.sum(0), 1.0)
    h = np.zeros((3, len(grid.v), terms))
    h[:, :, 0] = np.sqrt(power / count)
    rng = np.random.default_rng(0)
    for k in range(1, terms):
        h[:, :, k] = 0.1 * rng.standard_normal((3, len(grid.v))) * h[:, :, 0].mean(1,
                                                                                   keepdims=True)
    ridge = ALS_RIDGE if terms > 1 else 0.0
    across_valid_t = np.ascontiguousarray(across_valid.T)
    across_t = across_valid_t * across.transpose(0, 2, 1)  # w M, h's rows first
    down = down_valid * down  # w M: the same in every round
    across_in_down = down_groups[across_rows]  # each across group's row of the compact g
    for round_ in range(SAMPLED_ROUNDS):
        g = _weighted_rows(down, down_valid, h[:, cols], ridge)
        h = _weighted_rows(across_t, across_valid_t, g[:, across_in_down], ridge)
        report(progress, 0.3 + 0.7 * (round_ + 1) / SAMPLED_ROUNDS,
               f"sampled fit round {round_ + 1}/{SAMPLED_ROUNDS}")
    g = _weighted_rows(down, down_valid, h[:, cols], ridge)
    return g[:, down_groups], h


# --- error analysis (section 5.2) ---------------------------------------------------
def stratified_pairs(per_hemisphere=90, seed=1):
    """(wi, wo) (N^2, 3) each: N jittered strata of (cos theta, phi) on each
    hemisphere (cos theta uniform: equal solid angle), every wi with every wo."""
    rng = np.random.default_rng(seed)
    rows = int(math.sqrt(per_hemisphere))
    cols = per_hemisphere // rows
    count = rows * cols

    def strata():
        i, j = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
        mu = (i.ravel() + rng.random(count)) / rows
        phi = (j.ravel() + rng.random(count)) / cols * 2 * np.pi
        s = np.sqrt(1 - mu * mu)
        return np.stack([s * np.cos(phi), s * np.sin(phi), np.maximum(mu, 1e-6)], -1)

    wi, wo = strata(), strata()
    return (np.repeat(wi, count, axis=0), np.tile(wo, (count, 1)))


def error(factorization, model, pairs=None, terms=None) -> float:
    """Relative cosine-weighted RMS error of outgoing radiance: sqrt(sum over pairs
    of |(f_rec - f) cos theta_i|^2 / sum |f cos theta_i|^2), RGB summed."""
    model = parse(model)
    wi, wo = pairs if pairs is not None else stratified_pairs()
    truth = model.f(wi, wo) * wi[:, 2:3]
    approx = factorization.evaluate(wi, wo, terms) * wi[:, 2:3]
    return float(np.sqrt(np.sum((approx - truth) ** 2) / max(np.sum(truth ** 2), 1e-300)))


def matrix_for(brdf, parameterization, size, kind="xy"):
    """The sampled matrix of a parameterization (to factor it several ways)."""
    check_arguments(size, 1, parameterization, kind, "svd", 2.0)
    return _Matrix(parse(brdf), _Grid(parameterization, size, kind))


# --- one texture for shaders ----------------------------------------------------------
def pack(factorization, levels=None):
    """The factors as one padded atlas for GPU lookups: (image, meta).

    image: (n + 2 + m + 2, K max(n + 2, m + 2), 3) float32, first row at the
    top (n = size of g, m = size_h of h). Term k's g_k tile has its top-left
    texel at (row 1, column k (n + 2) + 1), h_k's at (row h_row + 1, column
    k (m + 2) + 1); each tile is ringed by one texel repeating its edge
    (wrapped instead for the azimuth axes of ``elevation-azimuth``), so
    bilinear filtering at continuous texel coordinates clamped to
    [-0.5, size - 0.5] reads exactly :meth:`Factorization.evaluate`'s values.
    ``levels``: a bake.lamp_spread.Levels (lamps of any size) adds a second g
    band of n + 2 rows holding its cap levels side by side
    (bake.lamp_spread.level_layout), each tile ringed alike; h_row is then
    2 (n + 2), else n + 2. Tiles hold the normalized factors; ``meta["scale"]``
    is the (K, 3) product scale_g scale_h per term; ``meta["tile_g"]``,
    ``meta["tile_h"]`` the padded tile sizes, ``meta["h_row"]`` the h band's
    first row, ``meta["levels"]``, ``meta["first_radius"]`` (rad), ``meta["per_octave"]`` and
    ``meta["spread_scale"]`` the cap levels (0 levels: none).
    """
    from .lamp_spread import level_layout

    f = factorization
    count = f.terms
    tile_g, tile_h = f.size + 2, f.size_h + 2
    level_count = levels.count if levels is not None else 0
    h_row = tile_g * (2 if level_count else 1)
    width = count * max(tile_g, tile_h)
    if level_count:
        last_side, last_column, _ = level_layout(f.size, count, level_count, count - 1,
                                                 levels.per_octave)
        width = max(width, last_column + last_side + 2)
    image = np.zeros((h_row + tile_h, width, 3), np.float32)
    wrap = f.parameterization == "elevation-azimuth"
    for k in range(count):
        image[:tile_g, k * tile_g:(k + 1) * tile_g] = np.pad(
            f.g[k], ((1, 1), (1, 1), (0, 0)), mode="edge")
        image[h_row:, k * tile_h:(k + 1) * tile_h] = np.pad(
            f.h[k], ((1, 1), (1, 1), (0, 0)), mode="wrap" if wrap else "edge")
        for j in range(1, level_count + 1):
            side, column, row = level_layout(f.size, count, j, k, levels.per_octave)
            image[row:row + side + 2, column:column + side + 2] = np.pad(
                levels.maps[j - 1][k], ((1, 1), (1, 1), (0, 0)), mode="edge")
    meta = f.meta()
    meta.update({"layout": "separable-atlas", "tile_g": tile_g, "tile_h": tile_h,
                 "h_row": h_row, "atlas_width": width, "levels": level_count,
                 "per_octave": levels.per_octave if level_count else 1,
                 "first_radius": float(levels.radii[0]) if level_count else 0.0,
                 "spread_scale": float(levels.scale) if level_count else 0.0,
                 "scale": (f.scale_g * f.scale_h).tolist()})
    return image, meta


def atlas_lookup(image, meta, wi, wo, terms=None, spread=None):
    """Reconstructed f (..., 3) from a packed atlas, as a shader reads it:
    bilinear taps at clamped texel coordinates inside each padded tile.
    ``spread``: the lamp's angular radius (rad, broadcast with wi[..., 0]) for
    an atlas with cap levels (bake.lamp_spread): g is then the mean over a cap
    of radius spread x meta["spread_scale"], blended from two levels exactly
    as the material's nodes blend them; None or an atlas without levels: f at
    (wi, wo)."""
    from .lamp_spread import level_layout, level_weights

    n, m = int(meta["size"]), int(meta.get("size_h", meta["size"]))
    grid = _Grid(meta["parameterization"], n, meta["map"], m)
    tile_g, tile_h = int(meta["tile_g"]), int(meta["tile_h"])
    h_row = int(meta.get("h_row", tile_g))
    count = int(meta.get("levels", 0))
    per_octave = int(meta.get("per_octave", 1))
    (uc, ur), (vc, vr) = grid.coords(np.asarray(wi, np.float64), np.asarray(wo, np.float64))
    uc, ur = np.clip(uc, -0.5, n - 0.5), np.clip(ur, -0.5, n - 0.5)
    scale = np.asarray(meta["scale"])
    terms = terms or int(meta["terms"])
    if spread is not None and count:
        rho = np.broadcast_to(np.asarray(spread, np.float64) * float(meta["spread_scale"]),
                              uc.shape)
        level_a, level_b, weight_a, weight_b = level_weights(
            rho, float(meta["first_radius"]), count, per_octave)

    def g_at(k, level):
        """g_k at each pixel's level (an array of whole numbers)."""
        out = np.zeros(uc.shape + (3,))
        for j in np.unique(level).astype(int):
            where = level == j
            side, column, row = level_layout(n, int(meta["terms"]), j, k, per_octave)
            col = (uc[where] + 0.5) * side / n - 0.5
            rw = (ur[where] + 0.5) * side / n - 0.5
            out[where] = _bilinear(image, np.clip(col, -0.5, side - 0.5) + 1 + column,
                                   np.clip(rw, -0.5, side - 0.5) + 1 + row)
        return out

    total = 0.0
    for k in range(terms):
        if spread is not None and count:
            g = g_at(k, level_a) * weight_a[..., None] + g_at(k, level_b) * weight_b[..., None]
        else:
            g = _bilinear(image, uc + 1 + k * tile_g, ur + 1)
        h = _bilinear(image, np.clip(vc, -0.5, m - 0.5) + 1 + k * tile_h,
                      np.clip(vr, -0.5, m - 0.5) + 1 + h_row)
        total = total + g * h * scale[k]
    above = (np.asarray(wi)[..., 2] > 0) & (np.asarray(wo)[..., 2] > 0)
    return np.where(above[..., None], total, 0.0)
