"""Real spherical harmonics to any order: basis, exact quadrature, projection,
rotation, and irradiance (the order-2 path of Ramamoorthi & Hanrahan).

Convention: real, orthonormal on the unit sphere, no Condon-Shortley phase,
coefficient index l^2 + l + m (l = 0..order, m = -l..l), with z the polar axis
and phi = atan2(y, x):

    Y_l0 = Q_l0(cos theta),  Y_lm = sqrt(2) Q_lm cos(m phi),  Y_l,-m = sqrt(2) Q_lm sin(m phi)

(m > 0), Q_lm the normalized associated Legendre functions, computed by the
stable three-term recurrences in l with the normalization folded in (no
factorials, fine to order several hundred):

    Q_00 = 1 / sqrt(4 pi),  Q_mm = sqrt((2m + 1) / (2m)) sin(theta) Q_m-1,m-1,
    Q_m+1,m = sqrt(2m + 3) cos(theta) Q_mm,
    Q_lm = a_lm (cos(theta) Q_l-1,m - b_lm Q_l-2,m),
    a_lm = sqrt((4l^2 - 1) / (l^2 - m^2)),  b_lm = sqrt(((l-1)^2 - m^2) / (4 (l-1)^2 - 1)).

Order 2 gives the 9 familiar polynomials (0.282095, 0.488603 y, ...).

Rotations act on functions: the coefficients of g(d) = f(R^-1 d) are D(R) c,
band by band, with D^l_mm' = integral of Y_lm(R e) Y_lm'(e) over the sphere,
computed exactly by the quadrature below (Gauss-Legendre in cos(theta) times a
uniform rule in phi, exact for every polynomial of degree <= 2 order on the
sphere). D(R1 R2) = D(R1) D(R2). For many rotations at once
(:func:`rotate_many`) R is written as Rz(A) Ry(B) Rz(C) and Ry(B) as
Rx(-90) Rz(B) Rx(90): z rotations mix each (m, -m) pair by cos/sin(m angle)
and the two fixed D(Rx(+-90)) are computed once per order.
"""

import math

import numpy as np

from .envmap import get_layout
from .zonal import gauss_legendre

__all__ = ["count", "index", "basis", "quadrature", "project", "project_function",
           "evaluate", "rotation_matrix", "rotation_blocks", "rotate", "rotate_z",
           "rotate_many", "irradiance"]

_A = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)


def count(order: int) -> int:
    """Coefficients of an expansion to ``order``: (order + 1)^2."""
    return (int(order) + 1) ** 2


def index(l: int, m: int) -> int:  # noqa: E741  (the standard name of the band)
    """Position of Y_lm in a coefficient vector."""
    return l * l + l + m


def _legendre(z, s, order):
    """{(l, m): Q_lm} for m >= 0, arrays shaped like z (cos theta) and s (sin theta)."""
    q = {(0, 0): np.full_like(z, 1.0 / math.sqrt(4 * math.pi))}
    for m in range(order + 1):
        if m > 0:
            q[m, m] = math.sqrt((2 * m + 1) / (2 * m)) * s * q[m - 1, m - 1]
        if m + 1 <= order:
            q[m + 1, m] = math.sqrt(2 * m + 3) * z * q[m, m]
        for l in range(m + 2, order + 1):  # noqa: E741
            a = math.sqrt((4 * l * l - 1) / (l * l - m * m))
            b = math.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
            q[l, m] = a * (z * q[l - 1, m] - b * q[l - 2, m])
    return q


def basis(d, order: int = 2) -> np.ndarray:
    """Real SH basis (..., (order + 1)^2) at unit directions d (..., 3)."""
    d = np.asarray(d, dtype=np.float64)
    x, y, z = d[..., 0], d[..., 1], np.clip(d[..., 2], -1.0, 1.0)
    s = np.sqrt(np.clip(x * x + y * y, 0.0, None))
    q = _legendre(z, s, order)
    phi = np.arctan2(y, x)
    out = np.empty((*z.shape, count(order)))
    for m in range(order + 1):
        if m == 0:
            for l in range(order + 1):  # noqa: E741
                out[..., index(l, 0)] = q[l, 0]
            continue
        c, sn = math.sqrt(2) * np.cos(m * phi), math.sqrt(2) * np.sin(m * phi)
        for l in range(m, order + 1):  # noqa: E741
            out[..., index(l, m)] = q[l, m] * c
            out[..., index(l, -m)] = q[l, m] * sn
    return out


def quadrature(order: int):
    """Directions (Q, 3) and weights (Q,) integrating exactly every polynomial of
    degree <= 2 order over the sphere (order + 1 Gauss-Legendre nodes in cos(theta),
    2 order + 1 equal steps in phi): products of two band-limited functions."""
    z, w = gauss_legendre(order + 1)
    count_phi = 2 * order + 1
    phi = 2 * np.pi * np.arange(count_phi) / count_phi
    s = np.sqrt(1.0 - z * z)
    d = np.stack([s[:, None] * np.cos(phi)[None], s[:, None] * np.sin(phi)[None],
                  np.repeat(z[:, None], count_phi, 1)], -1).reshape(-1, 3)
    return d, np.repeat(w * (2 * np.pi / count_phi), count_phi)


def project_function(function, order: int, resolution: int | None = None) -> np.ndarray:
    """Coefficients (N, ...) of ``function`` (directions (Q, 3) -> (Q, ...)) by the
    quadrature of ``resolution`` (default ``order``: exact when the function's own
    band limit is at most ``order``; give more for a function that is not band-limited)."""
    d, w = quadrature(max(int(resolution or order), int(order)))
    values = np.asarray(function(d), dtype=np.float64)
    y = basis(d, order)
    return np.einsum("qk,q,q...->k...", y, w, values)


def project(image, layout, order: int = 2) -> np.ndarray:
    """Coefficients (N, C) of an environment map in any layout: sum over texels of
    L Y omega (solid-angle weighted; a texel sum, so exact only to the map's own
    sampling)."""
    layout = get_layout(layout)
    image = layout.check_image(image)
    shape = image.shape[:2]
    omega = layout.solid_angles(shape)
    directions = layout.texel_directions(shape)
    out = np.zeros((count(order), image.shape[2]))
    for row in range(0, shape[0], 64):  # bounded memory at high orders
        y = basis(directions[row:row + 64], order)
        out += np.einsum("hwk,hw,hwc->kc", y, omega[row:row + 64],
                         image[row:row + 64].astype(np.float64))
    return out


def evaluate(coefficients, d, order: int | None = None) -> np.ndarray:
    """The expansion (N, ...) at directions d (..., 3): (..., ...)."""
    coefficients = np.asarray(coefficients, dtype=np.float64)
    order = int(round(math.sqrt(coefficients.shape[0]))) - 1 if order is None else order
    return np.tensordot(basis(d, order), coefficients, axes=(-1, 0))


def rotation_blocks(rotation, order: int) -> list:
    """[D^l (2l+1, 2l+1) for l = 0..order] of the 3 x 3 rotation matrix ``rotation``,
    D^l_mm' = integral Y_lm(R e) Y_lm'(e) de by exact quadrature."""
    rotation = np.asarray(rotation, dtype=np.float64)
    d, w = quadrature(order)
    y = basis(d, order)
    y_rotated = basis(d @ rotation.T, order)
    blocks = []
    for l in range(order + 1):  # noqa: E741
        band = slice(l * l, (l + 1) ** 2)
        blocks.append(np.einsum("q,qa,qb->ab", w, y_rotated[:, band], y[:, band]))
    return blocks


def rotation_matrix(rotation, order: int) -> np.ndarray:
    """The block-diagonal (N, N) matrix of :func:`rotation_blocks`."""
    out = np.zeros((count(order), count(order)))
    for l, block in enumerate(rotation_blocks(rotation, order)):  # noqa: E741
        out[l * l:(l + 1) ** 2, l * l:(l + 1) ** 2] = block
    return out


def rotate(coefficients, rotation, order: int | None = None) -> np.ndarray:
    """Coefficients (N, ...) of f(R^-1 d) from those of f."""
    coefficients = np.asarray(coefficients, dtype=np.float64)
    order = int(round(math.sqrt(coefficients.shape[0]))) - 1 if order is None else order
    return np.tensordot(rotation_matrix(rotation, order), coefficients, axes=(1, 0))


def _m_of(order):
    return np.concatenate([np.arange(-l, l + 1) for l in range(order + 1)])  # noqa: E741


def rotate_z(coefficients, angle, order: int) -> np.ndarray:
    """Coefficients (P, N) of f(Rz(angle)^-1 d) for coefficients (P, N) and angles (P,):
    the pair (c_m, c_-m) becomes (c_m cos m a - c_-m sin m a, c_-m cos m a + c_m sin m a)."""
    m = _m_of(order)
    angle = np.asarray(angle, dtype=np.float64)[..., None]
    c, s = np.cos(np.abs(m) * angle), np.sin(np.abs(m) * angle)
    partner = coefficients[..., np.arange(len(m)) - 2 * m]  # index of (l, -m)
    sign = np.where(m > 0, -1.0, np.where(m < 0, 1.0, 0.0))
    return coefficients * c + sign * partner * s


_x90: dict = {}


def _x_quarter(order):
    if order not in _x90:
        quarter = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # Rx(90)
        _x90[order] = (rotation_blocks(quarter.T, order), rotation_blocks(quarter, order))
    return _x90[order]


def zyz_angles(rotation):
    """(A, B, C) with R = Rz(A) Ry(B) Rz(C) for rotations (P, 3, 3)."""
    r = np.asarray(rotation, dtype=np.float64)
    b = np.arccos(np.clip(r[..., 2, 2], -1.0, 1.0))
    s = np.sin(b)
    regular = s > 1e-12
    a = np.where(regular, np.arctan2(r[..., 1, 2], r[..., 0, 2]), 0.0)
    # B = 0: R = Rz(A + C); B = pi: R = Rz(A) diag(-1, 1, -1) Rz(C); either way A = 0.
    flip = np.where(r[..., 2, 2] > 0, 1.0, -1.0)
    c = np.where(regular, np.arctan2(r[..., 2, 1], -r[..., 2, 0]),
                 np.arctan2(r[..., 1, 0], flip * r[..., 0, 0]))
    return a, b, c


def _apply_blocks(blocks, coefficients):
    out = np.empty_like(coefficients)
    for l, block in enumerate(blocks):  # noqa: E741
        band = slice(l * l, (l + 1) ** 2)
        out[..., band] = coefficients[..., band] @ block.T
    return out


def rotate_many(coefficients, rotations, order: int) -> np.ndarray:
    """Coefficients (P, N) rotated each by its own rotation (P, 3, 3): row p becomes
    D(R_p) c_p. Exact (Euler angles, two fixed quarter turns about x)."""
    a, b, c = zyz_angles(rotations)
    minus, plus = _x_quarter(order)  # D(Rx(-90)), D(Rx(90))
    out = rotate_z(np.asarray(coefficients, dtype=np.float64), c, order)
    out = _apply_blocks(plus, out)
    out = rotate_z(out, b, order)
    out = _apply_blocks(minus, out)
    return rotate_z(out, a, order)


def irradiance(coefficients, normals):
    """Irradiance / pi (..., C) at unit normals from order-2 SH coefficients (9, C)."""
    return basis(np.asarray(normals, dtype=np.float64)) @ (coefficients * _A[:, None]) / np.pi
