"""Reflected radiance through spherical harmonics (Cabral, Max & Springmeyer 1987, sections 7-8).

The radiance a surface point reflects towards the viewer is the integral of
the environment L(i) against the lobe h(i) = f_r(i, v) max(0, n . i). Both are
expanded in real spherical harmonics to ``order`` M (bake.sh), so the integral
is the dot product of their coefficient vectors (Parseval: only the lobe's
band-limited part matters, so the result converges as M grows with no
ringing of the environment itself).

Section 7's frame: the view frame V, with the view v along z and the normal
in the xz plane at angle alpha from v, n_V = (sin alpha, 0, cos alpha). For an
isotropic BRDF the lobe there depends on alpha only; its coefficients
a_lm(alpha) are tabulated at K tilts alpha_j (equal steps on [0, pi/2], the
last a quarter step inside the horizon) and interpolated by a C1
Catmull-Rom spline in alpha (end tangents by one-sided differences). They come
(:func:`lobe_coefficients`) from quadrature of f_r cos for any library BRDF,
or (:func:`facet_coefficients`, section 8 / eq. 7) directly from a bump
surface's facets: each facet seen from v reflects the environment from its
mirror direction i_f with weight A_f (n_f . v) F x (unmasked and unshadowed
fraction) / (A cos alpha), so a_lm = sum over facets of weight x Y_lm(i_f).

Shading a pixel (normal n, view v): its view frame (z = v, x along n's part
normal to v) is a rotation R to world space, and the radiance is
c . D(R) a(alpha) with c the environment's world coefficients (bake.sh
rotate_many, exact). For one view shared by many pixels (a distant camera)
eq. 8 does it once per view: with the environment rotated into a fixed view
frame, c_V, the radiance at a normal of tilt alpha and azimuth beta about v is
the Fourier series sum over m of g_m(alpha) cos(m beta) + h_m(alpha) sin(m beta),
g_m(alpha_j) = sum over l of a_lm(alpha_j) c_V,lm and h_m(alpha_j) = sum over l of
a_lm(alpha_j) c_V,l,-m: K x (2M + 1) numbers per view, then per pixel a spline
in alpha and a Fourier sum in beta.

Back-facing views (n . v < 0) are shaded as grazing (alpha = pi/2), as every
other baked map does. Isotropic BRDFs only (the lobe must depend on alpha
alone); a bump table is averaged over the view's azimuth.
"""

import math

import numpy as np

from . import sh
from .errors import BakeError

__all__ = ["ALPHAS", "alpha_nodes", "lobe_coefficients", "facet_coefficients",
           "catmull_rom", "view_frames", "SHReflection"]

#: Tilts alpha_j tabulated by default.
ALPHAS = 33


def alpha_nodes(count=ALPHAS) -> np.ndarray:
    """(K,) tilts where the lobe is evaluated: equal steps on [0, pi/2], the last
    a quarter step inside the horizon (where cos alpha > 0)."""
    step = (np.pi / 2) / (count - 1)
    alphas = np.arange(count) * step
    alphas[-1] -= step / 4
    return alphas


def lobe_coefficients(model, order, alphas=ALPHAS, resolution=None) -> np.ndarray:
    """(K, N, 3) coefficients a_lm(alpha_j) of h(i) = f_r(i, v) max(0, n . i) in the
    view frame, for an isotropic library BRDF, by Gauss-Legendre x uniform
    quadrature of ``resolution`` (default max(8 order, 128): the lobe is not
    band-limited, so the rule must resolve it, not just the harmonics)."""
    if not getattr(model, "isotropic", True):
        raise BakeError(f"{model.spec}: the spherical-harmonic path needs an isotropic BRDF")
    resolution = int(resolution or max(8 * order, 128))
    d, w = sh.quadrature(resolution)
    y = sh.basis(d, order)
    out = np.empty((alphas, sh.count(order), 3))
    for j, alpha in enumerate(alpha_nodes(alphas)):
        s, c = math.sin(alpha), math.cos(alpha)
        # Surface frame inside V: normal (s, 0, c), tangent (c, 0, -s), bitangent y.
        wi = np.stack([d[:, 0] * c - d[:, 2] * s, d[:, 1], d[:, 0] * s + d[:, 2] * c], -1)
        wo = np.array([-s, 0.0, c])
        value = model.f(wi, np.broadcast_to(wo, wi.shape)) * np.clip(wi[:, 2], 0, None)[:, None]
        out[j] = y.T @ (value * w[:, None])
    return out


def facet_coefficients(surface, order, alphas=17, azimuths=4) -> np.ndarray:
    """(K, N, 3) a_lm(alpha_j) straight from a bump surface's reflected beams (eq. 7,
    section 8): for a view v at tilt alpha (and ``azimuths`` azimuths, averaged),
    the beams surface.scatter(v) returns are the facets' mirror directions i_f
    and their weights x A cos alpha (shadowing and masking are symmetric in l
    and v), so a_lm = sum_f weight_f Y_lm(i_f in the view frame). Grey (the
    facets' Fresnel factor is one number), repeated in three channels. Two
    threads (NumPy releases the GIL in the large array operations)."""
    from concurrent.futures import ThreadPoolExecutor

    def one(task):
        alpha, phi = task
        s, c = math.sin(alpha), math.cos(alpha)
        v = np.array([s * math.cos(phi), s * math.sin(phi), c])
        directions, power = surface.scatter(v)
        # View frame: z = v, x along the normal's part normal to v.
        x = np.array([0.0, 0.0, 1.0]) - c * v
        x = x / np.linalg.norm(x) if s > 1e-9 else np.array([math.cos(phi), math.sin(phi), 0.0])
        frame = np.stack([x, np.cross(v, x), v])
        return (power / (surface.area * c)) @ sh.basis(directions @ frame.T, order) / azimuths

    tasks = [(alpha, 2 * np.pi * (k + 0.5) / azimuths)
             for alpha in alpha_nodes(alphas) for k in range(azimuths)]
    with ThreadPoolExecutor(max_workers=2) as pool:
        parts = np.array(list(pool.map(one, tasks))).reshape(alphas, azimuths, -1)
    return np.repeat(parts.sum(1)[..., None], 3, -1)


def catmull_rom(table, alpha) -> np.ndarray:
    """(P, ...) C1 Catmull-Rom interpolation of table (K, ...) at alpha (P,) in
    [0, pi/2] over K equally spaced nodes (one-sided end tangents)."""
    table = np.asarray(table, dtype=np.float64)
    count = table.shape[0]
    x = np.clip(np.asarray(alpha, dtype=np.float64) / (np.pi / 2) * (count - 1), 0, count - 1)
    i = np.minimum(np.floor(x).astype(np.intp), count - 2)
    t = (x - i).reshape(-1, *([1] * (table.ndim - 1)))
    p0, p1, p2, p3 = (table[np.clip(i + o, 0, count - 1)] for o in (-1, 0, 1, 2))
    m1 = np.where((i == 0).reshape(t.shape), p2 - p1, 0.5 * (p2 - p0))
    m2 = np.where((i == count - 2).reshape(t.shape), p2 - p1, 0.5 * (p3 - p1))
    t2, t3 = t * t, t * t * t
    return ((2 * t3 - 3 * t2 + 1) * p1 + (t3 - 2 * t2 + t) * m1 + (-2 * t3 + 3 * t2) * p2
            + (t3 - t2) * m2)


def view_frames(normal, view):
    """(alpha (P,), rotations (P, 3, 3)) of unit normals and views (P, 3): the columns
    of each rotation are the view frame's x (the normal's part normal to v), y
    and z = v in world coordinates; alpha = angle(n, v) clamped to [0, pi/2]."""
    n = np.asarray(normal, dtype=np.float64)
    v = np.asarray(view, dtype=np.float64)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    mu = np.sum(n * v, -1)
    x = n - mu[:, None] * v
    length = np.linalg.norm(x, axis=-1)
    # n along v: any x normal to v (the lobe is then symmetric about v).
    fallback = np.cross(v, np.where(np.abs(v[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]]))
    x = np.where(length[:, None] > 1e-9, x / np.maximum(length, 1e-300)[:, None],
                 fallback / np.linalg.norm(fallback, axis=-1, keepdims=True))
    alpha = np.arccos(np.clip(mu, 0.0, 1.0))
    return alpha, np.stack([x, np.cross(v, x), v], -1)


class SHReflection:
    """Environment coefficients (N, 3) and lobe coefficients (K, N, 3) of one BRDF."""

    def __init__(self, environment, lobe):
        self.environment = np.asarray(environment, dtype=np.float64)
        self.lobe = np.asarray(lobe, dtype=np.float64)
        self.order = int(round(math.sqrt(self.environment.shape[0]))) - 1
        if sh.count(self.order) != self.environment.shape[0] or \
                self.lobe.shape[1] != self.environment.shape[0]:
            raise BakeError(f"SH map: environment {self.environment.shape} and lobe "
                            f"{self.lobe.shape} do not match")

    def shade(self, normal, view, chunk=8192) -> np.ndarray:
        """Radiance (..., 3) at world normals and views (..., 3): eq. 8 when every
        pixel has the same view, else one exact rotation per pixel."""
        normal, view = np.broadcast_arrays(np.asarray(normal, dtype=np.float64),
                                           np.asarray(view, dtype=np.float64))
        shape = normal.shape[:-1]
        n, v = normal.reshape(-1, 3), view.reshape(-1, 3)
        if len(v) and np.ptp(v, axis=0).max() < 1e-12:
            return self.shade_one_view(n, v[0]).reshape(*shape, 3)
        out = np.empty((len(n), 3))
        grey = np.array_equal(self.lobe[..., 0], self.lobe[..., 1]) and \
            np.array_equal(self.lobe[..., 0], self.lobe[..., 2])
        for start in range(0, len(n), chunk):
            alpha, rotation = view_frames(n[start:start + chunk], v[start:start + chunk])
            lobes = catmull_rom(self.lobe, alpha)  # (P, N, 3)
            for channel in range(1 if grey else 3):
                world = sh.rotate_many(lobes[..., channel], rotation, self.order)
                if grey:
                    out[start:start + chunk] = world @ self.environment
                else:
                    out[start:start + chunk, channel] = world @ self.environment[:, channel]
        return out.reshape(*shape, 3)

    def fourier(self, view):
        """Eq. 8 for one view: (frame (3, 3) with columns x, y, z = v, and the
        Fourier table (K, 2M + 1, 3): g_0, g_1, h_1, g_2, h_2, ... at each alpha_j)."""
        v = np.asarray(view, dtype=np.float64)
        v = v / np.linalg.norm(v)
        x = np.cross([0.0, 1.0, 0.0] if abs(v[1]) < 0.9 else [1.0, 0.0, 0.0], v)
        x /= np.linalg.norm(x)
        frame = np.stack([x, np.cross(v, x), v], -1)
        local = sh.rotate(self.environment, frame.T, self.order)  # c_V: L(frame d_V)
        table = np.zeros((self.lobe.shape[0], 2 * self.order + 1, 3))
        for m in range(self.order + 1):
            bands = range(m, self.order + 1)
            cos_terms = [sh.index(l, m) for l in bands]
            table[:, 2 * m - (m > 0)] = np.einsum("knc,nc->kc", self.lobe[:, cos_terms],
                                                   local[cos_terms])
            if m:
                sin_terms = [sh.index(l, -m) for l in bands]
                table[:, 2 * m] = np.einsum("knc,nc->kc", self.lobe[:, cos_terms],
                                            local[sin_terms])
        return frame, table

    def shade_one_view(self, normal, view) -> np.ndarray:
        """Radiance (P, 3) at normals (P, 3) all seen from one view (3,) by eq. 8."""
        frame, table = self.fourier(view)
        n = np.asarray(normal, dtype=np.float64)
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        local = n @ frame
        alpha = np.arccos(np.clip(local[:, 2], 0.0, 1.0))
        beta = np.arctan2(local[:, 1], local[:, 0])
        series = catmull_rom(table, alpha)  # (P, 2M + 1, 3)
        out = series[:, 0].copy()
        for m in range(1, self.order + 1):
            out += series[:, 2 * m - 1] * np.cos(m * beta)[:, None]
            out += series[:, 2 * m] * np.sin(m * beta)[:, None]
        return out
