"""Kautz & McCool 2000, section 3: radially symmetric lobes per view elevation.

For an isotropic BRDF, each of K *slices* fixes the view elevation theta_o
(nodes uniform in mu = cos theta_o = n.r_v, the third coordinate of the 3D
map) and looks at the slice s(w_i) = f(w_i, w_o) cos(theta_i) as a function
of the incoming direction, in the local frame with w_o at azimuth 0:

1. the centre: KM 2000 take the peak, the maximum of s in the plane of
   incidence (refined to 1e-6 rad); since stop 72 the first lobe's centre is
   the direction between that peak and the slice's centroid whose radially
   symmetric lobe is nearest the slice (:func:`_best_centre`; ``centre="peak"``
   keeps the paper's). For rough lobes the horizon clips the slice far on
   the normal's side of its peak, and a lobe about the peak puts that mass
   in the wrong place: GGX 0.8's one-lobe error over the sphere, RMS over 16
   slices, 0.43 about the peak and 0.26 about the best centre; GGX 0.95 0.36
   and 0.07; a Principled dielectric (roughness 0.5) 0.60 and 0.40; GGX
   0.05-0.3 keep their peak. Its *offset* is the angle from the mirror
   direction r_v to the centre, positive towards the horizon (negative
   towards the normal; a Lambertian slice is centred on the normal, offset
   -theta_o);
2. profile curves: s along 16 great circles through the centre, as functions
   of the angle gamma from it (gamma = pi t^2 on 256 nodes, dense near 0);
3. the radially symmetric lobe: the mean of the profiles (KM 2000 "mean
   profile"); in greedy multi-lobe fits every lobe but the last uses the
   *minimum* profile, so the lobe stays under the slice, and is subtracted
   before the next peak is sought in the residual;
4. energy: every lobe shape is normalized to unit integral over the sphere;
   its RGB weights come from a non-negative least-squares fit to the slice
   constrained to sum to the slice's directional albedo rho(theta_o)
   (hemispherical reflectivity), so the lobes reflect exactly that energy.

Lobes of a multi-lobe fit are clustered into coherent sequences across
slices by their offsets (the permutation that moves offsets least from the
previous slice), so lobe j of every slice is filtered into map sequence j.

The 2D mode keeps one lobe shape (that of the normal-incidence slice) and a
weight k(theta_o) per slice (KM 2000's single 2D lobe).

Each slice records the cosine-weighted RMS error of the fitted BRDF against
the true one over 4096 cosine-distributed directions (Kautz & McCool 1999,
section 5.2), absolute and relative to the RMS of the BRDF.
"""

import copy
import functools
import hashlib
import itertools
import json
from dataclasses import asdict, dataclass, field

import numpy as np

from . import __version__
from .brdf import BRDF, parse
from .brdf.base import hammersley
from .brdf.vectors import around_axis
from .errors import BakeError
from .progress import report

__all__ = ["Fit", "SliceFit", "LobeFit", "fit", "slice_nodes", "GAMMA"]

FORMAT_VERSION = 1
MU_MIN = 0.02
PROFILE_AZIMUTHS = 16
GAMMA = np.pi * np.linspace(0.0, 1.0, 256) ** 2
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
MAX_SLICES = 256
MAX_LOBES = 4
#: Where a slice's (first) lobe is centred: "best", between the peak and the centroid
#: (:func:`_best_centre`), or "peak", Kautz & McCool's.
CENTRE_RULES = ("best", "peak")


@dataclass
class LobeFit:
    """One radially symmetric lobe: centre offset (rad), RGB weight, unit-integral profile."""

    offset: float
    weight: list
    profile: list

    def shape(self, cos_gamma):
        """Lobe shape (1/sr, unit integral) at cos(angle from the lobe centre)."""
        gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
        return np.interp(gamma, GAMMA, np.asarray(self.profile))


@dataclass
class SliceFit:
    """The lobes of one view elevation (mu = cos theta_o = n.r_v)."""

    mu: float
    albedo: list
    lobes: list = field(default_factory=list)
    rms_error: float = 0.0
    relative_rms_error: float = 0.0


@dataclass
class Fit:
    """A serializable lobe fit of one BRDF (Kautz & McCool 2000)."""

    spec: str
    spec_hash: str
    mode: str
    slices: list
    lobes: int
    version: str = __version__
    format: int = FORMAT_VERSION

    @property
    def mus(self):
        return np.array([s.mu for s in self.slices])

    def to_dict(self) -> dict:
        data = asdict(self)
        data["gamma"] = GAMMA.tolist()
        return data

    def to_json(self) -> str:
        return json.dumps(self.to_dict())

    def save(self, path):
        from pathlib import Path

        from . import outputs

        text = self.to_json()
        return outputs.atomic_write(path, lambda target: Path(target).write_text(text))

    @classmethod
    def from_dict(cls, data: dict) -> "Fit":
        if data.get("format") != FORMAT_VERSION:
            raise BakeError(f"unsupported lobe-fit format {data.get('format')!r}")
        if not np.allclose(data.get("gamma", GAMMA), GAMMA):
            raise BakeError("lobe fit was made with a different gamma grid")
        slices = [SliceFit(mu=s["mu"], albedo=s["albedo"],
                           lobes=[LobeFit(**lobe) for lobe in s["lobes"]],
                           rms_error=s["rms_error"], relative_rms_error=s["relative_rms_error"])
                  for s in data["slices"]]
        return cls(spec=data["spec"], spec_hash=data["spec_hash"], mode=data["mode"],
                   slices=slices, lobes=data["lobes"], version=data.get("version", ""))

    @classmethod
    def load(cls, path) -> "Fit":
        from pathlib import Path

        try:
            return cls.from_dict(json.loads(Path(path).read_text()))
        except (OSError, ValueError, KeyError, TypeError) as error:
            raise BakeError(f"{path}: not a lobe fit ({error})") from error

    def evaluate(self, k: int, wi):
        """Fitted f cos(theta_i) (RGB) of slice k at local directions wi (..., 3)."""
        s = self.slices[k]
        wo = _view(s.mu)
        total = 0.0
        for lobe in s.lobes:
            centre = _centre(wo, lobe.offset)
            total = total + lobe.shape(np.asarray(wi) @ centre)[..., None] * np.asarray(lobe.weight)
        return total


def slice_nodes(count: int) -> np.ndarray:
    """mu = cos(theta_o) of the K slices: k / (K - 1), the first raised to MU_MIN."""
    mus = np.linspace(0.0, 1.0, count)
    mus[0] = MU_MIN
    return mus


def _view(mu):
    return np.array([np.sqrt(max(1.0 - mu * mu, 0.0)), 0.0, mu])


def _centre(wo, offset):
    """Mirror direction of wo turned by ``offset`` towards the horizon, in the x-z plane."""
    theta_r = np.arctan2(wo[0], wo[2])  # mirror sits at signed elevation -theta_r
    t = -theta_r - offset
    return np.array([np.sin(t), 0.0, np.cos(t)])


def _slice_luminance(model, wo, wi):
    return (model.f(wi, np.broadcast_to(wo, np.shape(wi))) @ LUMINANCE) * np.clip(
        np.asarray(wi)[..., 2], 0.0, None)


def _peak(function, wo):
    """Signed elevation t* maximizing function on the incidence plane (x-z).

    A 4001-point scan brackets the maximum within one cell; three rounds of
    65-point scans then each shrink the bracket 32-fold (to about 2e-8 rad),
    vectorized: 4 calls of ``function`` instead of a golden-section loop's 80.
    """
    def plane(t):
        return function(np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], -1))

    t = np.linspace(-np.pi / 2, np.pi / 2, 4001)
    values = plane(t)
    best = int(np.argmax(values))
    peak = float(values.max())
    low, high = t[max(best - 1, 0)], t[min(best + 1, t.size - 1)]
    for _ in range(3):
        grid = np.linspace(low, high, 65)
        scan = plane(grid)
        best = int(np.argmax(scan))
        peak = max(peak, float(scan[best]))
        low, high = grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)]
    return 0.5 * (low + high), peak


def _profiles(function, centre):
    """Slice values along PROFILE_AZIMUTHS great circles from the centre: (G, M)."""
    psi = 2.0 * np.pi * np.arange(PROFILE_AZIMUTHS) / PROFILE_AZIMUTHS
    d = around_axis(np.broadcast_to(centre, (GAMMA.size, PROFILE_AZIMUTHS, 3)),
                    np.cos(GAMMA)[:, None], psi[None, :])
    return function(d)


def _integral(profile):
    """2 pi * integral of profile(gamma) sin(gamma) d gamma, exact for the piecewise-
    linear interpolation of the profile on GAMMA (as lookups evaluate it)."""
    p = np.asarray(profile, dtype=np.float64)
    g0, g1 = GAMMA[:-1], GAMMA[1:]
    slope = (p[1:] - p[:-1]) / (g1 - g0)
    intercept = p[:-1] - slope * g0

    def antiderivative(g):  # of (intercept + slope g) sin g
        return -intercept * np.cos(g) + slope * (np.sin(g) - g * np.cos(g))

    return float(2.0 * np.pi * np.sum(antiderivative(g1) - antiderivative(g0)))


def _unit(profile):
    total = _integral(profile)
    if not total > 0:
        return None
    return np.asarray(profile) / total


@functools.lru_cache(maxsize=4)
def _error_samples(n=4096):
    """(n, 3) cosine-distributed Hammersley directions (the same for every slice;
    read-only)."""
    u = hammersley(n)
    r = np.sqrt(u[:, 0])
    phi = 2.0 * np.pi * u[:, 1]
    samples = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u[:, 0])], -1)
    samples.flags.writeable = False
    return samples


def _fit_slice(model, mu, lobes, mode_shape=None, centre_rule="best"):
    """Fit one slice with up to ``lobes`` lobes: returns a SliceFit.

    Lobe 1 is the single-lobe fit (mean profile about the slice's peak). Each
    further lobe is found greedily in the residual (the slice minus the
    current fit, clipped at 0): its peak in the plane of incidence, and the
    *minimum* of its profiles there, so it adds what the fit lacks along the
    profile that lacks least and never overshoots along the others. After
    every addition all weights are refitted (non-negative least squares), so
    the fit error (:func:`sphere_error`) cannot grow as lobes are added, under
    the constraint that the lobes integrate to the directional albedo (per
    channel). Until stop 55 the weights were fitted on the 4096 cosine-
    distributed error samples, which a narrow lobe falls between: a coated
    metal's second lobe (a near-mirror spike) took 0.39 of its red, and its map
    went from 7.8% to 27.6% from the converged integral with two lobes.
    """
    wo = _view(mu)
    albedo = model.albedo(wo)
    if not np.all(np.isfinite(albedo)) or albedo.max() <= 0:
        raise BakeError(f"{model.spec}: the BRDF reflects nothing at cos(theta_o) = {mu:.3g}")
    samples = _error_samples()
    target = model.f(samples, np.broadcast_to(wo, samples.shape))

    def slice_fn(wi):
        return _slice_luminance(model, wo, wi)

    shapes, offsets = [], []
    weights = np.zeros((0, 3))
    for index in range(lobes):
        if index == 0:
            residual = slice_fn
        else:
            def residual(wi, shapes=tuple(shapes), offsets=tuple(offsets),
                         w=weights @ LUMINANCE):
                fitted = sum(wj * np.interp(np.arccos(np.clip(np.asarray(wi) @ _centre(wo, o),
                                                              -1, 1)), GAMMA, shp)
                             for wj, shp, o in zip(w, shapes, offsets, strict=True))
                return np.clip(slice_fn(wi) - fitted, 0.0, None)
        t_star, peak = _peak(residual, wo)
        if index and peak <= 1e-6 * _peak(slice_fn, wo)[1]:
            break
        profiles = None
        if index == 0 and mode_shape is None and centre_rule == "best":
            t_star, profiles = _best_centre(residual, t_star,
                                            float(np.asarray(albedo) @ LUMINANCE))
        centre = np.array([np.sin(t_star), 0.0, np.cos(t_star)])
        offset = float(-np.arctan2(wo[0], wo[2]) - t_star)
        if mode_shape is not None:
            shape = mode_shape
        else:
            if profiles is None:
                profiles = np.clip(_profiles(residual, centre), 0.0, None)
            shape = _unit(profiles.mean(axis=1) if index == 0 else profiles.min(axis=1))
        if shape is None:
            if index == 0:
                raise BakeError(f"{model.spec}: no lobe found at cos(theta_o) = {mu:.3g}")
            break
        shapes.append(shape)
        offsets.append(offset)
        if index == 0:  # one lobe: its weight is the albedo
            weights = np.asarray(albedo, dtype=np.float64)[None, :]
            grid = _polar_grid(centre)
            upper = grid[0][:, 2] > 0.0
            grid_target = np.zeros((len(grid[0]), 3))
            grid_target[upper] = model.f(grid[0][upper], np.broadcast_to(
                wo, grid[0][upper].shape)) * grid[0][upper, 2:3]
            continue
        basis = np.stack([np.interp(np.arccos(np.clip(grid[0] @ _centre(wo, o), -1, 1)),
                                    GAMMA, shp) for shp, o in zip(shapes, offsets, strict=True)],
                         -1) * grid[1][:, None]
        # Least squares of the slice s = f cos over the whole sphere (zero below
        # the horizon) on the polar grid about the first lobe, which resolves
        # lobes far narrower than the error samples' spacing; non-negative,
        # summing to the albedo.
        weights = np.stack([_weights_summing_to(basis, grid_target[:, c] * grid[1],
                                                albedo[c]) for c in range(3)], -1)
    fitted = [LobeFit(offset=o, weight=w.tolist(), profile=s.tolist())
              for o, w, s in zip(offsets, weights, shapes, strict=True)]
    result = SliceFit(mu=float(mu), albedo=albedo.tolist(), lobes=fitted)
    _measure(result, target @ LUMINANCE, wo, samples)
    return result


#: Azimuths of the quadrature that judges candidate lobe centres (:func:`_best_centre`):
#: about the slice's peak, fine enough to resolve a specular peak seen from a centre
#: far on the normal's side (16 azimuths, the profiles', put a Principled dielectric's
#: integral of s^2 over the sphere 50% apart from two centres).
JUDGE_AZIMUTHS = 32


def _best_centre(function, t_peak, albedo, scan=4, refine=2):
    """(t, profiles): the signed elevation t of the single lobe's centre in the plane
    of incidence, and the slice's profiles about it (:func:`_profiles`, (G, M)),
    chosen between the slice's peak ``t_peak`` and its centroid (the direction of
    the integral of s(w) w over the sphere) as the centre whose radially symmetric
    lobe (the mean profile, scaled to integrate to ``albedo``, the slice's
    luminance albedo) is nearest the slice ``function`` in L2 over the sphere, on a
    quadrature about the peak of GAMMA x JUDGE_AZIMUTHS directions (the slice
    evaluated once; each candidate's lobe interpolated there).

    ``scan`` centres evenly from the peak to the centroid, then ``refine`` rounds
    that try the best one's two neighbours at half the previous step. The peak is always a
    candidate, so the lobe is never further from the slice than the peak-centred
    one (Kautz & McCool's, kept by ``centre="peak"``). Where peak and centroid
    are within 2 mrad (narrow or symmetric lobes) the peak is kept unsearched."""
    step = np.gradient(GAMMA)
    peak_centre = np.array([np.sin(t_peak), 0.0, np.cos(t_peak)])
    psi = 2.0 * np.pi * np.arange(JUDGE_AZIMUTHS) / JUDGE_AZIMUTHS
    directions = around_axis(np.broadcast_to(peak_centre, (GAMMA.size, JUDGE_AZIMUTHS, 3)),
                             np.cos(GAMMA)[:, None], psi[None, :])
    omega = (np.sin(GAMMA) * step * (2.0 * np.pi / JUDGE_AZIMUTHS))[:, None]
    values = np.clip(function(directions), 0.0, None)
    mass = np.einsum("gm,gmc->c", omega * values, directions)
    t_centroid = float(np.arctan2(mass[0], mass[2]))

    def profiles_at(t):
        centre = np.array([np.sin(t), 0.0, np.cos(t)])
        return np.clip(_profiles(function, centre), 0.0, None)

    if not np.isfinite(t_centroid) or abs(t_centroid - t_peak) < 2e-3:
        return t_peak, profiles_at(t_peak)
    tried = {}

    def consider(t):
        t = float(t)
        if t in tried or not abs(t) < np.pi / 2:
            return
        profiles = profiles_at(t)
        mean = profiles.mean(axis=1)
        total = _integral(mean)
        if not total > 0:
            return
        centre = np.array([np.sin(t), 0.0, np.cos(t)])
        lobe = np.interp(np.arccos(np.clip(directions @ centre, -1.0, 1.0)), GAMMA,
                         mean * (albedo / total))
        tried[t] = (float(np.sum(omega * (lobe - values) ** 2)), profiles)

    grid = np.linspace(t_peak, t_centroid, scan)
    for t in grid:
        consider(t)
    if not tried:
        return t_peak, profiles_at(t_peak)
    best = min(tried, key=lambda t: tried[t][0])
    half = abs(grid[1] - grid[0])
    for _ in range(refine):
        half *= 0.5
        consider(best - half)
        consider(best + half)
        best = min(tried, key=lambda t: tried[t][0])
    return best, tried[best][1]


def _polar_grid(centre):
    """(directions (G M, 3), sqrt of their solid angles (G M,)) on GAMMA x
    PROFILE_AZIMUTHS about ``centre`` (the profiles' grid): a quadrature of the whole
    sphere, dense near the centre (the trapezoid rule in gamma with sin gamma)."""
    psi = 2.0 * np.pi * np.arange(PROFILE_AZIMUTHS) / PROFILE_AZIMUTHS
    directions = around_axis(np.broadcast_to(centre, (GAMMA.size, PROFILE_AZIMUTHS, 3)),
                             np.cos(GAMMA)[:, None], psi[None, :])
    step = np.gradient(GAMMA)
    omega = np.sin(GAMMA) * step * (2.0 * np.pi / PROFILE_AZIMUTHS)
    return directions.reshape(-1, 3), np.sqrt(np.repeat(omega, PROFILE_AZIMUTHS))


def sphere_error(model, slice_fit) -> float:
    """Relative L2 error (over the whole sphere, per solid angle, RGB summed) of a
    slice's fitted lobes against the slice s = f cos (zero below the horizon), on the
    polar grid about its heaviest lobe (:func:`_polar_grid`; the first fitted, which
    the weights were fitted about, unless the clustering of :func:`fit` reordered
    the lobes or a later lobe outweighs it): the error multi-lobe weights minimise.
    Unlike the reported KM 1999 error (4096 cosine-distributed directions) it
    resolves lobes narrower than those directions' spacing."""
    wo = _view(slice_fit.mu)
    first = max(slice_fit.lobes, key=lambda lobe: float(np.asarray(lobe.weight) @ LUMINANCE))
    directions, root = _polar_grid(_centre(wo, first.offset))
    upper = directions[:, 2] > 0.0
    target = np.zeros((len(directions), 3))
    target[upper] = model.f(directions[upper], np.broadcast_to(
        wo, directions[upper].shape)) * directions[upper, 2:3]
    approx = sum(lobe.shape(directions @ _centre(wo, lobe.offset))[:, None]
                 * np.asarray(lobe.weight)[None, :] for lobe in slice_fit.lobes)
    return float(np.sqrt(np.sum(((approx - target) * root[:, None]) ** 2)
                         / np.sum((target * root[:, None]) ** 2)))


def _weights_summing_to(a, b, total):
    """min |a x - b| subject to x >= 0 and sum(x) = total (a few columns).

    Exhaustive over active sets (at most 2^4 - 1 for 4 lobes), each solved
    exactly through its KKT system: the fitted lobes integrate to ``total``
    (the directional albedo) while matching the slice as well as they can.
    A fit with one more lobe contains the previous optimum (weight 0), so its
    error can only fall.
    """
    columns = a.shape[1]
    gram = a.T @ a
    rhs = a.T @ b
    best, best_x = np.inf, None
    for mask in range(1, 1 << columns):
        keep = [j for j in range(columns) if mask >> j & 1]
        n = len(keep)
        system = np.zeros((n + 1, n + 1))
        system[:n, :n] = 2.0 * gram[np.ix_(keep, keep)]
        system[:n, n] = system[n, :n] = 1.0
        vector = np.concatenate([2.0 * rhs[keep], [total]])
        try:
            solution = np.linalg.solve(system, vector)
        except np.linalg.LinAlgError:
            solution = np.linalg.lstsq(system, vector, rcond=None)[0]
        x = solution[:n]
        if np.any(x < -1e-12):
            continue
        candidate = np.zeros(columns)
        candidate[keep] = np.clip(x, 0.0, None)
        residual = float(np.sum((a @ candidate - b) ** 2))
        if residual < best:
            best, best_x = residual, candidate
    if best_x is None:
        best_x = np.full(columns, total / columns)
    return best_x


def _measure(slice_fit, true_f, wo, samples):
    """Cosine-weighted RMS error of the fitted BRDF (KM 1999 sec. 5.2), in place.
    true_f: (N,) luminance of the true BRDF at ``samples`` (N, 3) for view ``wo``."""
    approx = 0.0
    for lobe in slice_fit.lobes:
        shape = lobe.shape(samples @ _centre(wo, lobe.offset))
        approx = approx + shape * float(np.asarray(lobe.weight) @ LUMINANCE)
    approx = approx / np.maximum(samples[:, 2], 1e-6)
    rms = float(np.sqrt(np.mean((approx - true_f) ** 2)))
    slice_fit.rms_error = rms
    slice_fit.relative_rms_error = rms / max(float(np.sqrt(np.mean(true_f**2))), 1e-300)


def _cluster(slices):
    """Reorder each slice's lobes to follow the previous slice's offsets (in place)."""
    for previous, current in itertools.pairwise(slices):
        if len(current.lobes) < 2:
            continue
        prev = [lobe.offset for lobe in previous.lobes]
        best = min(itertools.permutations(current.lobes),
                   key=lambda order: sum(abs(lobe.offset - prev[i]) if i < len(prev) else 0.0
                                         for i, lobe in enumerate(order)))
        current.lobes = list(best)


#: Fits made in this process, by (canonical spec, slices, lobes, mode): a fit is a
#: pure function of those, so materials re-baked in one session refit nothing. It
#: also holds, by the BRDF's shape (:func:`shape_key`), each fit with the colour it
#: was made for, from which a BRDF of the same shape in another colour is rescaled.
_CACHE: dict = {}
_CACHE_SIZE = 64
#: Fits computed and fits rescaled from another colour's, in this process.
computed = {"fitted": 0, "rescaled": 0}
#: Angles (rad) of the rings of fingerprint directions about each view's mirror
#: direction (:func:`shape_key`): a near-mirror lobe's peak, which cosine-distributed
#: directions fall between, is in the fingerprint too.
_RING_ANGLES = (1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3)
_RING_AZIMUTHS = 8
#: Largest deviation from one colour times one function (a fraction of the largest
#: value) for which a BRDF counts as a colour times a shape.
_RANK_ONE_TOLERANCE = 1e-9


def _fingerprint_directions(wo):
    """(P, 3) incident directions at which :func:`shape_key` reads the slice of view
    ``wo``: 512 cosine-distributed ones and rings about the mirror direction."""
    mirror = np.array([-wo[0], wo[1], wo[2]])
    psi = 2.0 * np.pi * np.arange(_RING_AZIMUTHS) / _RING_AZIMUTHS
    rings = around_axis(np.broadcast_to(mirror, (len(_RING_ANGLES), _RING_AZIMUTHS, 3)),
                        np.cos(np.array(_RING_ANGLES))[:, None], psi[None, :]).reshape(-1, 3)
    return np.concatenate([_error_samples()[:512], mirror[None, :], rings])


def shape_key(model, slices):
    """(digest, colour) with model = colour x shape, or None where the BRDF is no
    single colour times one function.

    Everything :func:`fit` computes is a function of f(w_i, w_o) at the slices'
    views and of the directional albedo there, and is linear in a per-channel
    scale of f: a BRDF c (.) g (g grey: Cycles' Glossy BSDF in any Color, a
    Principled dielectric's specular part whatever its Base Color) has the fit of
    g with every lobe weight and albedo times c, the same lobe shapes and
    offsets and the same relative error. The digest hashes the luminance of f at
    fixed directions per view (:func:`_fingerprint_directions`) and the albedos,
    divided by their largest value and rounded to 9 digits; ``colour`` (3,) is
    what multiplies that normalised shape, per channel. Two BRDFs with one digest
    are equal up to a per-channel scale at 9 digits on 16,000 directions (and
    their albedos): BRDFs that differ only in a parameter show it there."""
    values = []
    for mu in slice_nodes(int(slices)):
        wo = _view(mu)
        wi = _fingerprint_directions(wo)
        values.append(np.asarray(model.f(wi, np.broadcast_to(wo, wi.shape)), dtype=np.float64))
        values.append(np.asarray(model.albedo(wo), dtype=np.float64)[None, :])
    table = np.concatenate(values)  # (P, 3)
    if not np.all(np.isfinite(table)):
        return None
    luminance = table @ LUMINANCE
    norm = float(luminance @ luminance)
    peak = float(np.abs(luminance).max())
    if not norm > 0.0 or not peak > 0.0:
        return None
    colour = (luminance @ table) / norm  # table = luminance x colour if rank one
    if np.abs(table - np.outer(luminance, colour)).max() > _RANK_ONE_TOLERANCE * \
            np.abs(table).max():
        return None
    shape = np.round(luminance / peak, 9) + 0.0  # -0.0 hashes as 0.0
    digest = hashlib.blake2b(shape.tobytes(), digest_size=16).hexdigest()
    return digest, colour * peak


def _rescaled(fitted, colour_from, colour_to, model):
    """A copy of ``fitted`` (the fit of a BRDF colour_from x g) for ``model`` =
    colour_to x g: weights and albedos times colour_to / colour_from per channel,
    the absolute error times the luminance's ratio. None where colour_from has a
    zero channel that colour_to has not."""
    colour_from, colour_to = np.asarray(colour_from), np.asarray(colour_to)
    if np.any((colour_from <= 0.0) & (colour_to > 0.0)) or np.any(colour_to < 0.0):
        return None
    ratio = np.where(colour_from > 0.0, colour_to / np.where(colour_from > 0.0, colour_from,
                                                              1.0), 0.0)
    brightness = float(colour_to @ LUMINANCE) / float(colour_from @ LUMINANCE)
    result = copy.deepcopy(fitted)
    result.spec, result.spec_hash = model.spec, model.spec_hash()
    for piece in result.slices:
        piece.albedo = (np.asarray(piece.albedo) * ratio).tolist()
        piece.rms_error *= brightness
        for lobe in piece.lobes:
            lobe.weight = (np.asarray(lobe.weight) * ratio).tolist()
    return result


def fit(model, slices: int = 16, lobes: int = 1, mode: str = "3d", progress=None,
        centre: str = "best") -> Fit:
    """Fit ``model`` (BRDF or spec) with ``lobes`` lobes at ``slices`` view elevations.

    mode: ``3d`` (a lobe shape per slice) or ``2d`` (one shared shape + k(theta_o)).
    centre: ``best`` (the first lobe between the slice's peak and centroid,
    :func:`_best_centre`) or ``peak`` (Kautz & McCool's, the fits before stop 72).
    Results are cached in-process (a copy is returned, so callers may change it).
    """
    model = parse(model) if not isinstance(model, BRDF) else model
    key = (model.spec, model.spec_hash(), slices, lobes, mode, centre)
    if key in _CACHE:
        report(progress, 1.0, "lobe fit (cached)")
        return copy.deepcopy(_CACHE[key])
    shaped = shape_key(model, slices) if model.isotropic and int(slices) == slices \
        and 2 <= slices <= MAX_SLICES else None
    shape = None if shaped is None else ("shape", shaped[0], slices, lobes, mode, centre)
    result = None
    if shape in _CACHE:
        fitted, colour = _CACHE[shape]
        result = _rescaled(fitted, colour, shaped[1], model)
        if result is not None:
            computed["rescaled"] += 1
            report(progress, 1.0, "lobe fit (another colour's, rescaled)")
    computed_here = result is None
    if computed_here:
        result = _fit(model, slices, lobes, mode, progress, centre)
        computed["fitted"] += 1
    entries = [(key, result)]
    if shape is not None and computed_here:  # a fresh fit (also where one colour's
        entries.append((shape, (result, shaped[1])))  # zero channel could not rescale)
    for store, value in entries:
        _CACHE.pop(store, None)
        if len(_CACHE) >= _CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[store] = copy.deepcopy(value)
    return result


def _fit(model, slices, lobes, mode, progress, centre="best"):
    if not model.isotropic:
        raise BakeError(f"{model.spec}: lobe fitting needs an isotropic BRDF")
    if mode not in ("3d", "2d"):
        raise BakeError(f"mode must be '3d' or '2d', not {mode!r}")
    if int(slices) != slices or not 2 <= slices <= MAX_SLICES:
        raise BakeError(f"slices must be a whole number in [2, {MAX_SLICES}], not {slices!r}")
    if int(lobes) != lobes or not 1 <= lobes <= MAX_LOBES:
        raise BakeError(f"lobes must be a whole number in [1, {MAX_LOBES}], not {lobes!r}")
    if centre not in CENTRE_RULES:
        raise BakeError(f"centre must be one of {', '.join(CENTRE_RULES)}, not {centre!r}")
    if mode == "2d" and lobes != 1:
        raise BakeError("the 2D mode has a single lobe (lobes=1)")
    mus = slice_nodes(int(slices))
    shared = None
    if mode == "2d":
        shared = np.asarray(_fit_slice(model, 1.0, 1).lobes[0].profile)
    fitted = []
    for index, mu in enumerate(mus):
        fitted.append(_fit_slice(model, mu, int(lobes), shared, centre))
        report(progress, (index + 1) / len(mus), f"fitted slice {index + 1}/{len(mus)}")
    _cluster(fitted)
    lobe_count = max(len(s.lobes) for s in fitted)
    return Fit(spec=model.spec, spec_hash=model.spec_hash(), mode=mode, slices=fitted,
               lobes=lobe_count)
