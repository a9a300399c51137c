"""Runtime regular sampling of glossy BRDFs from a MIP-mapped cube probe.

The regular-sampling paper (Kurt et al. 2010 model, sections 4-7) evaluates
the reflection integral at render time with a small *regular* pattern of
samples of the BRDF lobe, each read from the probe's MIP level that matches
the solid angle it stands for. This module is that estimator in NumPy, the
twin of a GLSL (or node-group) lookup, and Colbert & Krivanek's filtered
importance sampling (GPU Gems 3, ch. 20) with the same budget for comparison.

The lobe plane
    A microfacet lobe (Beckmann: the Kurt model's lobes and Cycles'
    Beckmann; GGX; Ashikhmin-Shirley) is laid out in its *normalized slope
    plane*: a half vector h in the lobe's frame (x = the lobe's tangent,
    after the BRDF's own rotation) has slopes (-h_x/h_z, -h_y/h_z), and
    (x, y) = (slope_x / m_x, slope_y / m_y). The slope density of the lobe,
    D(h) h_z^4 m_x m_y, is then a function q of rho = |(x, y)| alone for
    Beckmann (exp(-rho^2) / pi) and GGX (1 / (pi (1 + rho^2)^2)); for
    Ashikhmin-Shirley, whose exponent varies with the azimuth, the density
    along the x and y axes is used and the wider one bounds the pattern.
    The Kurt sampler (eqs. 6, 7: phi_h = atan(m_y/m_x tan 2 pi u_2),
    theta_h = atan(sqrt(-ln u_1 / (cos^2 phi_h/m_x^2 + sin^2 phi_h/m_y^2))))
    maps (u_1, u_2) into this plane: it is the polar map rho = sqrt(-ln u_1)
    of the plane, and its pdf (eq. 10) is D(h) h_z / (4 wo.h), which is the
    library's ``model.pdf``.

The pattern (our reading of eqs. 11-13; the counts the paper quotes follow)
    - eq. 11: rho_max is where the slope density falls to xi_0 of its peak,
      q(rho_max) = xi_0 q(0) (Beckmann: sqrt(-ln xi_0); GGX:
      sqrt(xi_0^-1/2 - 1)), i.e. theta_max = atan(m rho_max);
    - eq. 12: two spacings for n_c circles: s1 = rho_max / (n_c - 1), circles
      at i s1 (a centre sample on the mirror direction, the last circle on
      the threshold contour), and s2 = rho_max / n_c, circles at (i + 1/2) s2
      (half-offset: annuli of width s2 that tile the disk exactly);
    - eq. 13: circle i holds n_i = n_0 r_i / s samples (n_0 = 6: hexagonal
      spacing; n_0 = 4: square) rounded up to an even count, so every
      pattern is symmetric under both mirror axes of an anisotropic lobe;
      odd circles are turned by half a step. n_c = 3 gives 1 + 6 + 12 = 19
      samples with s1 and 4 + 10 + 16 = 30 with s2 (n_0 = 6).
    - Anisotropic lobes take the half-offset circles (no sample sits on an
      axis of the ellipse alone); isotropic ones the pattern, s1 or s2,
      whose count is closest to the sample budget.
    - Samples whose weight (below) is under xi_0 of the strongest one are
      rejected: below the horizon at grazing views, or in the shadowed tail.

The estimator (eqs. 17, 18)
    Each sample stands for a cell of the pattern's disk: its circle's annulus
    (midway to the neighbouring circles) shared equally by the circle's
    samples, so the pdf is constant on each circle (eq. 18; the even counts
    make it differ slightly between circles). ``warp="slope"`` scales the
    disk to rho_max; ``warp="mass"`` puts disk radius r where the lobe's
    radial mass is (r / edge)^2 times the mass within rho_max (the pattern
    then follows the lobe's own sampler); ``warp="vndf"`` (GGX's default)
    puts the pattern on the disk of Heitz's visible-normal sampler, which holds
    all of the lobe's mass and follows the view. The
    density transform to incident directions (eq. 17) is
    d omega_i = m_x m_y h_z^3 4 (wo.h) d plane (d slope = d omega_h / h_z^3,
    d omega_i = 4 (wo.h) d omega_h), so sample j stands for the solid angle
    Omega_j = cell area in the plane x that Jacobian, weighs
    w_j = f(wi_j, wo) cos(theta_i,j) Omega_j, and

        L(wo) = C sum_j w_j L(wi_j),  C = rho(wo) / sum_j w_j,

    the constant of eq. 18 with rho(wo) the BRDF's directional albedo, so a
    constant environment is returned exactly (albedo times its radiance).

MIP levels (eqs. 14-16)
    Sample j's footprint is an ellipse of axes proportional to m_x and m_y
    and of solid angle Omega_j. The level is
    l_j = 1/2 log2(Omega_j / Omega_t(wi_j)) + ``bias``, where Omega_t(d) =
    (2 / n)^2 |d|_inf^3 is the solid angle of a level-0 texel of an n x n cube
    face at d (the cube map's distortion factor), read trilinearly between
    the two levels around l_j. ``footprint="minor"`` takes the ellipse's
    minor axis instead of its area (sharper, aliasing along the major axis).

Filtered importance sampling (the comparison)
    N Hammersley points through the model's own sampler, pdf p; level
    max(1/2 log2(Omega_s / Omega_t) + 1, 0) with Omega_s = 1 / (N p);
    L = 1/N sum f cos L / p, as Colbert & Krivanek write it.
"""

from dataclasses import dataclass

import numpy as np

from .brdf.base import hammersley
from .envmap import get_layout
from .envmap.mip import pyramid as mip_pyramid
from .errors import BakeError
from .progress import report

__all__ = ["Lobe", "Pattern", "lobe_of", "pattern", "pattern_for_budget", "threshold_radius",
           "MipProbe", "render_regular", "render_fis", "spots_environment", "N0_CHOICES",
           "DEFAULT_XI0"]

N0_CHOICES = (6, 4)
#: The paper's density threshold, the default of the pattern counts.
DEFAULT_XI0 = 0.1
#: Per distribution: (warp, xi_0, MIP bias) of the renderer's defaults, measured
#: by benchmarks/sampling.py (tiny bright spots, brute force as truth): the
#: Gaussian Beckmann lobe does best laid out uniformly in the slope plane at the
#: paper's xi_0; GGX's heavy tails (32% of its mass lies beyond the xi_0 = 0.1
#: radius) need the pattern spread by mass: on the disk of its visible-normal
#: sampler (all of the mass, view-dependent; isotropic GGX 0.3: 0.09-0.14
#: against 0.10-0.20 by the slope-plane mass warp at xi_0 = 0.001, bias 0.5).
DEFAULTS = {"beckmann": ("slope", 0.1, 0.0), "ggx": ("vndf", 0.001, 0.0),
            "ashikhmin_shirley": ("slope", 0.1, 0.0)}
WARPS = ("slope", "mass", "vndf")
#: Largest number of circles a pattern may have (a budget beyond is refused).
MAX_CIRCLES = 12
#: Pixels per vectorized batch (bounds memory: batch x samples x a few floats).
BATCH = 4096


@dataclass(frozen=True)
class Lobe:
    """A microfacet lobe in the normalized slope plane: distribution ``kind``
    (beckmann, ggx, ashikhmin_shirley), slope widths ``mx``, ``my`` along the
    lobe's tangent and bitangent, ``angle`` (radians) of the lobe's tangent
    about the normal from the frame's x axis."""

    kind: str
    mx: float
    my: float
    angle: float = 0.0

    @property
    def anisotropic(self) -> bool:
        return not np.isclose(self.mx, self.my, rtol=1e-6)

    def density(self, x, y):
        """Slope density relative to its peak, q(x, y) / q(0, 0), in the plane."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        r2 = x * x + y * y
        if self.kind == "beckmann":
            return np.exp(-r2)
        if self.kind == "ggx":
            return 1.0 / (1.0 + r2) ** 2
        # Ashikhmin-Shirley: D ~ h_z^(n(phi)), slopes t: h_z = 1 / sqrt(1 + t^2)
        nx, ny = 2.0 / self.mx**2 - 2.0, 2.0 / self.my**2 - 2.0
        sx, sy = x * self.mx, y * self.my
        t2 = sx * sx + sy * sy
        with np.errstate(divide="ignore", invalid="ignore"):
            exponent = np.where(t2 > 0, (nx * sx * sx + ny * sy * sy) / np.where(t2 > 0, t2, 1),
                                0.5 * (nx + ny))
        return (1.0 + t2) ** (-(exponent + 4.0) / 2.0)


def threshold_radius(lobe: Lobe, xi0: float) -> float:
    """rho_max of eq. 11: the plane radius where the slope density falls to xi0 of
    its peak (along the wider axis for a lobe that is not radially symmetric)."""
    if not 0.0 < xi0 < 1.0:
        raise BakeError(f"the density threshold xi_0 must lie in (0, 1), not {xi0!r}")
    if lobe.kind == "beckmann":
        return float(np.sqrt(-np.log(xi0)))
    if lobe.kind == "ggx":
        return float(np.sqrt(xi0 ** -0.5 - 1.0))
    radius = 0.0
    for direction in ((1.0, 0.0), (0.0, 1.0)):
        low, high = 0.0, 64.0
        for _ in range(80):
            mid = 0.5 * (low + high)
            if lobe.density(mid * direction[0], mid * direction[1]) > xi0:
                low = mid
            else:
                high = mid
        radius = max(radius, low)
    return radius


@dataclass(frozen=True)
class Pattern:
    """Sample positions (N, 2) in the unit disk of the plane (multiply by rho_max),
    the circles' radii and counts, the spacing (``s1`` or ``s2``) and n_0."""

    points: np.ndarray
    radii: tuple
    counts: tuple
    spacing: str
    n0: int
    #: (N,) area of the unit-disk cell each sample stands for: its circle's annulus
    #: (midway to the neighbouring circles) shared equally by the circle's samples
    cells: np.ndarray = None
    #: outer radius of the cells' union (1 for s2; (n_c - 1/2) s1 for s1)
    edge: float = 1.0

    def __len__(self):
        return len(self.points)


def pattern(circles: int, spacing: str = "s1", n0: int = 6) -> Pattern:
    """The regular pattern of eqs. 12-13 on the unit disk (see the module doc)."""
    if n0 not in N0_CHOICES:
        raise BakeError(f"n_0 must be one of {N0_CHOICES}, not {n0!r}")
    if int(circles) != circles or not 1 <= circles <= MAX_CIRCLES:
        raise BakeError(f"a pattern has 1 to {MAX_CIRCLES} circles, not {circles!r}")
    if spacing == "s1":
        if circles == 1:
            radii_s = [0.0]
            step = 1.0
        else:
            step = 1.0 / (circles - 1)
            radii_s = [float(i) for i in range(circles)]
    elif spacing == "s2":
        step = 1.0 / circles
        radii_s = [i + 0.5 for i in range(circles)]
    else:
        raise BakeError(f"spacing must be 's1' or 's2', not {spacing!r}")
    points, counts, cells = [], [], []
    for i, r in enumerate(radii_s):
        annulus = np.pi * step * step * (max(r + 0.5, 0.0) ** 2 - max(r - 0.5, 0.0) ** 2)
        if r == 0.0:
            points.append((0.0, 0.0))
            counts.append(1)
            cells.append(annulus)
            continue
        count = int(2 * np.ceil(n0 * r / 2.0 - 1e-9))
        offset = np.pi / count if i % 2 else 0.0
        phi = offset + 2.0 * np.pi * np.arange(count) / count
        points.extend(zip(r * step * np.cos(phi), r * step * np.sin(phi), strict=True))
        counts.append(count)
        cells.extend([annulus / count] * count)
    edge = (radii_s[-1] + 0.5) * step
    return Pattern(np.asarray(points), tuple(r * step for r in radii_s), tuple(counts),
                   spacing, n0, np.asarray(cells), edge)


def pattern_for_budget(budget: int, anisotropic: bool, n0: int = 6) -> Pattern:
    """The pattern whose sample count is closest to ``budget`` (ties: the smaller);
    half-offset circles (s2) for anisotropic lobes, s1 or s2 for isotropic ones."""
    if int(budget) != budget or budget < 1:
        raise BakeError(f"the sample budget must be a whole number >= 1, not {budget!r}")
    spacings = ("s2",) if anisotropic else ("s1", "s2")
    candidates = [pattern(c, s, n0) for s in spacings for c in range(1, MAX_CIRCLES + 1)]
    largest = max(len(p) for p in candidates)
    if budget > largest:
        raise BakeError(f"a sample budget of {budget} is beyond the largest pattern "
                        f"({largest} samples, {MAX_CIRCLES} circles)")
    return min(candidates, key=lambda p: (abs(len(p) - budget), len(p)))


def lobe_of(model) -> Lobe:
    """The sampled lobe of a library BRDF: Cycles' GGX, Beckmann and
    Ashikhmin-Shirley (with their anisotropy and rotation), the Principled
    metallic GGX, the Principled BSDF without a coat (its metal and dielectric
    specular share one GGX lobe; their Fresnel terms and the multiscatter
    energy scale it), and the Kurt model (its strongest lobe). BakeError
    otherwise (a coat adds a second lobe of its own roughness)."""
    name = getattr(model, "name", "")
    if name in ("ggx", "principled_metallic", "ggx_multiscatter") or \
            name == "principled" and model.coat == 0.0:
        return Lobe("ggx", model.ax, model.ay, model.angle)
    if name == "beckmann":
        return Lobe("beckmann", model.ax, model.ay, model.angle)
    if name == "ashikhmin_shirley":
        return Lobe("ashikhmin_shirley", model.ax, model.ay, model.angle)
    if name == "kurt":
        count = model._lobe_count()
        strongest = max(range(count), key=lambda k: float(np.mean(model._lobe(k)[0])))
        _, mx, my, _, _ = model._lobe(strongest)
        return Lobe("beckmann", float(mx), float(my), 0.0)
    raise BakeError(f"runtime sampling has no sampler for {getattr(model, 'spec', model)!r} "
                    "(use ggx, beckmann, ashikhmin_shirley, principled_metallic or kurt)")


# --- the probe's MIP pyramid -----------------------------------------------------------
class MipProbe:
    """A cube probe's MIP pyramid (bake.envmap.mip, ``filter`` box or gauss4/6),
    read trilinearly at a fractional level per direction."""

    def __init__(self, probe, layout="cube", filter="box"):
        layout_obj = get_layout(layout)
        if layout_obj.name != "cube":
            probe = _to_cube(probe, layout_obj)
        self.levels = mip_pyramid(probe, "cube", filter)
        self.face = self.levels[0].shape[0]
        self._samplers = [get_layout("cube").sampler(level) for level in self.levels]

    def texel_solid_angle(self, directions):
        """Solid angle of a level-0 texel at unit directions (...): (2/n)^2 |d|_inf^3."""
        return (2.0 / self.face) ** 2 * np.max(np.abs(directions), axis=-1) ** 3

    def lookup(self, directions, level):
        """(..., 3) radiance at unit directions (..., 3) and fractional levels (...)."""
        level = np.clip(level, 0.0, len(self.levels) - 1)
        low = np.floor(level).astype(int)
        frac = level - low
        out = np.zeros(directions.shape[:-1] + (3,))
        for index, sampler in enumerate(self._samplers):
            weight = np.where(low == index, 1.0 - frac, 0.0) + \
                np.where(low + 1 == index, frac, 0.0)
            used = weight > 0
            if np.any(used):
                out[used] += weight[used][:, None] * sampler(directions[used])[..., :3]
        return out


def _to_cube(probe, layout_obj):
    from .envmap import convert

    size = max(8, int(2 ** np.round(np.log2(max(probe.shape[0] // 2, 8)))))
    return convert(probe, layout_obj.name, "cube", size)


# --- estimators ----------------------------------------------------------------------
def _frames(normals, tangents, tangent_hint):
    from .reference import _frames as reference_frames

    return reference_frames(normals, tangents, tangent_hint)


def _radial_cdf(lobe, rho):
    """Mass of the slope density within plane radius rho (radially symmetric kinds)."""
    rho = np.asarray(rho, dtype=np.float64)
    if lobe.kind == "beckmann":
        return -np.expm1(-rho * rho)
    if lobe.kind == "ggx":
        return rho * rho / (1.0 + rho * rho)
    raise BakeError("the mass warp needs a radially symmetric lobe (beckmann, ggx)")


def _inverse_radial_cdf(lobe, mass):
    mass = np.asarray(mass, dtype=np.float64)
    if lobe.kind == "beckmann":
        return np.sqrt(-np.log1p(-mass))
    return np.sqrt(mass / (1.0 - mass))


def _slope_density(lobe, rho):
    """Normalized slope density q (integrates to 1 over the plane)."""
    if lobe.kind == "beckmann":
        return np.exp(-rho * rho) / np.pi
    return 1.0 / (np.pi * (1.0 + rho * rho) ** 2)


def _plane_points(lobe, plan, rho_max, warp):
    """Pattern points (N, 2) in the normalized slope plane and the plane area (N,)
    each stands for. ``slope``: the unit disk scaled by rho_max. ``mass``: disk
    radius r goes where the lobe's radial mass is (r / edge)^2 M, M the mass within
    rho_max, so the disk's uniform density 1 / (pi edge^2) becomes q / M and a
    cell's area is scaled by M / (pi edge^2 q)."""
    if warp == "slope":
        return plan.points * rho_max, plan.cells * rho_max * rho_max
    mass = float(_radial_cdf(lobe, rho_max))
    r = np.hypot(plan.points[:, 0], plan.points[:, 1])
    rho = _inverse_radial_cdf(lobe, (r / plan.edge) ** 2 * mass)
    scale = np.where(r > 0, rho / np.where(r > 0, r, 1.0), 0.0)
    area = plan.cells * mass / (np.pi * plan.edge ** 2 * _slope_density(lobe, rho))
    return plan.points * scale[:, None], area


def _incident(lobe, points, wo):
    """Half vectors h (N, 3) of plane points (N, 2) in the local frame (after the
    lobe's rotation), wo.h (B, N), incident directions (B, N, 3) and the Jacobian
    d omega_i / d plane = m_x m_y h_z^3 4 (wo.h) (B, N) (eq. 17)."""
    cos_a, sin_a = np.cos(lobe.angle), np.sin(lobe.angle)
    h_lobe = np.stack([-lobe.mx * points[:, 0], -lobe.my * points[:, 1],
                       np.ones(len(points))], -1)
    h_lobe /= np.linalg.norm(h_lobe, axis=-1, keepdims=True)
    h = np.stack([cos_a * h_lobe[:, 0] - sin_a * h_lobe[:, 1],
                  sin_a * h_lobe[:, 0] + cos_a * h_lobe[:, 1], h_lobe[:, 2]], -1)
    wo_h = wo @ h.T
    wi = 2.0 * wo_h[..., None] * h - wo[..., None, :]
    jacobian = lobe.mx * lobe.my * h[:, 2] ** 3 * 4.0 * wo_h
    return h, wo_h, wi, jacobian


def _vndf_samples(model, plan, wo):
    """The pattern on the disk of Heitz's (2018) visible-normal sampler: disk point
    (r, phi) / edge is u = (r^2, phi / 2 pi) of ``model.sample``; a cell of disk
    area a holds probability a / (pi edge^2), so it stands for the solid angle
    a / (pi edge^2 p(wi)). Returns wi (B, N, 3), omega (B, N), valid (B, N)."""
    points = plan.points / plan.edge
    u = np.stack([np.clip(np.sum(points * points, axis=-1), 0.0, 1.0 - 1e-12),
                  np.mod(np.arctan2(points[:, 1], points[:, 0]), 2.0 * np.pi) / (2.0 * np.pi)],
                 -1)
    probability = plan.cells / (np.pi * plan.edge ** 2)
    wi, pdf = model.sample(wo[:, None, :], u[None])
    valid = (pdf > 0) & (wi[..., 2] > 0)
    omega = np.where(valid, probability[None] / np.where(valid, pdf, 1.0), 0.0)
    return wi, omega, valid


def _regular_batch(model, lobe, plan, rho_max, mip, frames, wo, xi0, bias, footprint,
                   warp="slope"):
    """Regular-sampling radiance of one batch: frames (B, 3, 3), wo (B, 3) local."""
    if warp == "vndf":
        wi, omega, valid = _vndf_samples(model, plan, wo)
    else:
        points, area = _plane_points(lobe, plan, rho_max, warp)
        _, wo_h, wi, jacobian = _incident(lobe, points, wo)
        omega = np.maximum(area[None] * jacobian, 0.0)  # (B, N) solid angle of each sample
        valid = wo_h > 0
    with np.errstate(invalid="ignore"):
        weight = model.f(wi, wo[:, None, :]) * np.clip(wi[..., 2:3], 0.0, None) * \
            omega[..., None]
    weight = np.where(valid[..., None] & np.isfinite(weight), weight, 0.0)
    luminance = weight @ np.array([0.2126, 0.7152, 0.0722])
    strongest = luminance.max(axis=1, keepdims=True)
    weight = np.where((luminance >= xi0 * strongest)[..., None] & (strongest > 0)[..., None],
                      weight, 0.0)
    world = np.einsum("bnk,bkj->bnj", wi, frames)  # local -> world (rows of frames)
    if footprint == "minor":
        omega = omega * min(lobe.mx, lobe.my) / np.sqrt(lobe.mx * lobe.my)
    with np.errstate(divide="ignore"):
        level = 0.5 * np.log2(np.maximum(omega, 1e-30) / mip.texel_solid_angle(world)) + bias
    radiance = mip.lookup(world.reshape(-1, 3), level.reshape(-1)).reshape(world.shape)
    total = weight.sum(axis=1)  # (B, 3)
    albedo = model.albedo(wo, samples=1024)
    scale = np.where(total > 0, albedo / np.where(total > 0, total, 1.0), 0.0)
    return np.sum(weight * radiance, axis=1) * scale


def _fis_batch(model, samples, mip, frames, wo, bias):
    u = hammersley(samples)
    wi, pdf = model.sample(wo[:, None, :], u[None])  # (B, S, 3), (B, S)
    with np.errstate(divide="ignore", invalid="ignore"):
        weight = model.f(wi, wo[:, None, :]) * np.clip(wi[..., 2:3], 0.0, None) / \
            (samples * pdf[..., None])
        omega = 1.0 / (samples * pdf)
    good = (pdf > 0) & (wi[..., 2] > 0)
    weight = np.where(good[..., None] & np.isfinite(weight), weight, 0.0)
    world = np.einsum("bnk,bkj->bnj", wi, frames)
    level = np.where(good, 0.5 * np.log2(np.where(good, omega, 1.0) /
                                         mip.texel_solid_angle(world)) + bias, 0.0)
    level = np.maximum(level, 0.0)
    radiance = mip.lookup(world.reshape(-1, 3), level.reshape(-1)).reshape(world.shape)
    return np.sum(weight * radiance, axis=1)


def _render(batch_function, normals, views, tangents, tangent_hint, progress, label):
    from .reference import pixel_arrays

    normals, views, tangents = pixel_arrays(normals, views, tangents)
    frames = _frames(normals, tangents, tangent_hint)
    wo = np.einsum("bij,bj->bi", frames, views)
    out = np.zeros((len(normals), 3))
    for start in range(0, len(normals), BATCH):
        stop = min(start + BATCH, len(normals))
        front = wo[start:stop, 2] > 0
        if np.any(front):
            index = np.arange(start, stop)[front]
            out[index] = batch_function(frames[index], wo[index])
        report(progress, stop / len(normals), f"{label}: {stop}/{len(normals)} pixels")
    return out


def render_regular(model, probe, normals, views, *, budget=19, xi0=None, n0=6,
                   layout="cube", filter="box", bias=None, footprint="area", warp=None,
                   tangents=None, tangent_hint=(0.3, 0.5, 0.8), mip=None, progress=None):
    """(N, 3) radiance of the regular-sampling estimator for world-space unit
    normals and views (surface to viewer), (N, 3) each; the probe (H, W, 3) in
    ``layout`` (cube strip by default) or a prepared :class:`MipProbe` ``mip``;
    tangents as bake.reference (anisotropic lobes). ``warp``: ``slope``
    (pattern uniform in the normalized slope plane out to rho_max) or ``mass``
    (pattern radius r placed where the lobe's radial mass is r^2 times the mass
    within rho_max: the pattern then follows the lobe's own sampler) or
    ``vndf`` (GGX: the pattern on the disk of the visible-normal sampler); ``warp``,
    ``xi0`` and ``bias`` default per distribution (DEFAULTS)."""
    lobe = lobe_of(model)
    default_warp, default_xi0, default_bias = DEFAULTS[lobe.kind]
    warp = default_warp if warp is None else warp
    xi0 = default_xi0 if xi0 is None else xi0
    bias = default_bias if bias is None else bias
    if warp not in WARPS:
        raise BakeError(f"warp must be one of {', '.join(WARPS)}, not {warp!r}")
    if warp == "mass" and lobe.kind == "ashikhmin_shirley":
        raise BakeError("the mass warp needs a radially symmetric lobe (beckmann, ggx)")
    if warp == "vndf" and lobe.kind != "ggx":
        raise BakeError("the vndf warp is GGX's visible-normal sampler (a GGX lobe only)")
    plan = pattern_for_budget(budget, lobe.anisotropic, n0)
    rho_max = threshold_radius(lobe, xi0)
    if footprint not in ("area", "minor"):
        raise BakeError(f"footprint must be 'area' or 'minor', not {footprint!r}")
    mip = mip or MipProbe(probe, layout, filter)
    return _render(lambda frames, wo: _regular_batch(model, lobe, plan, rho_max, mip, frames, wo,
                                                     xi0, bias, footprint, warp),
                   normals, views, tangents, tangent_hint, progress,
                   f"regular sampling ({len(plan)} samples)")


def render_fis(model, probe, normals, views, *, samples=19, layout="cube", filter="box",
               bias=1.0, tangents=None, tangent_hint=(0.3, 0.5, 0.8), mip=None, progress=None):
    """(N, 3) radiance of filtered importance sampling with ``samples`` samples
    (same arguments as :func:`render_regular`)."""
    if int(samples) != samples or samples < 1:
        raise BakeError(f"samples must be a whole number >= 1, not {samples!r}")
    mip = mip or MipProbe(probe, layout, filter)
    return _render(lambda frames, wo: _fis_batch(model, int(samples), mip, frames, wo, bias),
                   normals, views, tangents, tangent_hint, progress,
                   f"filtered importance sampling ({samples} samples)")


def spots_environment(size=32, seed=3):
    """A dim sky with eight tiny bright discs (radius 2-10 degrees, 30 to 3000 times
    the sky, placed by ``seed``), the kind of light of the paper's comparison:
    a cube strip (size, 6 size, 3) float32."""
    cube = get_layout("cube")
    directions = cube.texel_directions(cube.shape(size))
    env = 0.5 + 0.5 * np.clip(directions[..., 2], 0, None)[..., None] * np.array([0.6, 0.8, 1.0])
    rng = np.random.default_rng(seed)
    for _ in range(8):
        centre = rng.normal(size=3)
        centre /= np.linalg.norm(centre)
        radius = np.radians(rng.uniform(2.0, 10.0))
        env = env + np.where((directions @ centre > np.cos(radius))[..., None],
                             rng.choice([30.0, 300.0, 3000.0]), 0.0)
    return env.astype(np.float32)
