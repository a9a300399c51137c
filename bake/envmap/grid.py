"""Texel grids shared by all parameterizations: bilinear taps and clipped integrals.

Index conventions: a *face stack* is an array (F, h, w, C) holding the image's
faces (one face for lat-long and sphere maps, two halves for the dual
paraboloid, six faces for the cube). Continuous texel coordinates put texel
centres at integers within a face; image coordinates (x, y) run over
[0, W] x [0, H] of the whole image with texel (row i, col j) spanning
[j, j + 1] x [i, i + 1] and y growing downwards (row 0 at the top).
"""

import functools

import numpy as np

__all__ = ["bilinear", "gauss_legendre", "disk_clipped_integral", "gather_padded"]


def bilinear(stack: np.ndarray, face, px, py) -> np.ndarray:
    """Bilinear interpolation in a face stack.

    stack: (F, h, w, C). face: integer array (...). px, py: float arrays (...)
    in the face's index space (texel centres at integers), clamped to
    [0, w - 1] x [0, h - 1]. Returns (..., C) with stack's dtype promoted to
    float32 or wider.
    """
    n_faces, height, width, channels = stack.shape
    px = np.clip(px, 0.0, width - 1.0)
    py = np.clip(py, 0.0, height - 1.0)
    x0 = np.minimum(px.astype(np.intp), max(width - 2, 0))
    y0 = np.minimum(py.astype(np.intp), max(height - 2, 0))
    fx = (px - x0).astype(stack.dtype)[..., None]
    fy = (py - y0).astype(stack.dtype)[..., None]
    step_x = 1 if width > 1 else 0
    step_y = width if height > 1 else 0
    flat = stack.reshape(-1, channels)
    base = (np.asarray(face, dtype=np.intp) * height + y0) * width + x0
    top = flat[base] * (1 - fx) + flat[base + step_x] * fx
    bottom = flat[base + step_y] * (1 - fx) + flat[base + step_y + step_x] * fx
    return top * (1 - fy) + bottom * fy


def gather_padded(stack: np.ndarray, pad_index: np.ndarray, fill_corners: bool) -> np.ndarray:
    """Build a padded face stack from a pad index map.

    stack: (F, h, w, C). pad_index: (F, h + 2b, w + 2b) flat texel indices into
    stack.reshape(-1, C), or -1 where the padded position is no real texel (the
    corners of a cube face's border). With ``fill_corners`` those get the mean
    of the corner texel and its two border neighbours (three faces meet there),
    which keeps bilinear lookups continuous at cube vertices; otherwise 0.
    """
    channels = stack.shape[-1]
    flat = stack.reshape(-1, channels)
    missing = pad_index < 0
    padded = flat[np.where(missing, 0, pad_index)]
    if missing.any():
        padded[missing] = 0
        if fill_corners:
            padded = _fill_corners(padded, missing)
    return padded


def _fill_corners(padded: np.ndarray, missing: np.ndarray) -> np.ndarray:
    """Fill missing padded positions from the nearest row/column neighbours (border 1)."""
    faces, rows, cols = np.nonzero(missing)
    # Step from the corner towards the face interior along each axis.
    dr = np.where(rows == 0, 1, -1)
    dc = np.where(cols == 0, 1, -1)
    row_neighbour = padded[faces, rows + dr, cols]
    col_neighbour = padded[faces, rows, cols + dc]
    diagonal = padded[faces, rows + dr, cols + dc]
    padded[faces, rows, cols] = (row_neighbour + col_neighbour + diagonal) / 3.0
    return padded


@functools.lru_cache(maxsize=32)
def gauss_legendre(n: int):
    """Nodes and weights (n,) each, read-only, of n-point Gauss-Legendre quadrature on
    [0, 1] (cached: numpy's leggauss solves an eigenvalue problem each call)."""
    nodes, weights = np.polynomial.legendre.leggauss(n)
    nodes, weights = 0.5 * (nodes + 1.0), 0.5 * weights
    nodes.flags.writeable = weights.flags.writeable = False
    return nodes, weights


def disk_clipped_integral(edges: np.ndarray, inner, order: int = 12) -> np.ndarray:
    """Integrals of a density over every grid cell intersected with the unit disk.

    edges: (N + 1,) increasing cell edges, shared by both axes, within [-1, 1].
    inner(x, y0, y1): the exact integral of the density over y in [y0, y1] at
    abscissa x (arrays, broadcasting). Returns (N, N) with result[i, j] the
    integral over x in [edges[j], edges[j+1]], y in [edges[i], edges[i+1]]
    (y ascending with i), restricted to x^2 + y^2 <= 1.

    Cells wholly inside the disk use ``order``-point Gauss-Legendre in x.
    Cells cut by the circle are split at the points where the circle crosses
    their edges and integrated in beta with x = sin(beta), which removes the
    square-root behaviour of the circle, so every piece is smooth.
    """
    edges = np.asarray(edges, dtype=np.float64)
    n = edges.size - 1
    x0, x1 = edges[None, :-1], edges[None, 1:]
    y0, y1 = edges[:-1, None], edges[1:, None]
    near = np.minimum(np.abs(x0), np.abs(x1)) * ((x0 > 0) | (x1 < 0))
    near_y = np.minimum(np.abs(y0), np.abs(y1)) * ((y0 > 0) | (y1 < 0))
    far_x = np.maximum(np.abs(x0), np.abs(x1))
    far_y = np.maximum(np.abs(y0), np.abs(y1))
    inside = (far_x**2 + far_y**2) <= 1.0
    outside = (near**2 + near_y**2) >= 1.0
    result = np.zeros((n, n))
    t, w = gauss_legendre(order)

    rows, cols = np.nonzero(np.broadcast_to(inside, (n, n)))
    if rows.size:
        a, b = edges[cols], edges[cols + 1]
        xs = a[:, None] + (b - a)[:, None] * t
        vals = inner(xs, edges[rows][:, None], edges[rows + 1][:, None])
        result[rows, cols] = (vals * w).sum(axis=1) * (b - a)

    rows, cols = np.nonzero(~np.broadcast_to(inside | outside, (n, n)))
    if rows.size:
        a, b = edges[cols], edges[cols + 1]
        lo, hi = edges[rows], edges[rows + 1]
        crossings = [np.sqrt(np.clip(1.0 - v**2, 0.0, None)) for v in (lo, hi)]
        points = np.stack([a, b, crossings[0], -crossings[0], crossings[1], -crossings[1]], 1)
        points = np.sort(np.clip(points, a[:, None], b[:, None]), axis=1)
        beta = np.arcsin(np.clip(points, -1.0, 1.0))
        total = np.zeros(rows.size)
        for piece in range(points.shape[1] - 1):
            b0, b1 = beta[:, piece], beta[:, piece + 1]
            betas = b0[:, None] + (b1 - b0)[:, None] * t
            xs = np.sin(betas)
            half = np.sqrt(np.clip(1.0 - xs**2, 0.0, None))
            ya = np.clip(lo[:, None], -half, half)
            yb = np.clip(hi[:, None], -half, half)
            vals = np.where(yb > ya, inner(xs, ya, yb), 0.0) * np.cos(betas)
            total += (vals * w).sum(axis=1) * (b1 - b0)
        result[rows, cols] = total
    return result
