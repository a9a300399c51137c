"""Runtime regular sampling as shader nodes will perform it: the baked constants
and the NumPy twin of the per-pixel arithmetic (issue 11, item 4's contract).

bake.sampling's estimator needs, per pixel, the BRDF's directional albedo and
a MIP pyramid with a level-of-detail lookup; shader nodes have neither. This
module fixes what a material carries instead, in one texture and its metadata,
and :func:`shade` is exactly the arithmetic the node groups will do:

The texture (``pack``): bake.sampling_atlas's level stack (the probe's
pre-blurred lat-long levels, each at its own size, one below the other: its
"mip" layout, W + 3 texels wide) and below it a block of rows whose texels
(row ``table_row`` + l, column 1 + k) hold the directional albedo
rho(mu_k, phi_l) (RGB) at mu_k = m + (1 - m) k / (M - 1) (m = MIN_COS) and
phi_l = (pi / 2) l / (P - 1) of the view's azimuth in the lobe frame folded
into [0, pi / 2] (the GGX lobe is symmetric under both mirror axes); P = 1 for
isotropic lobes. With probe lights (below), the next P rows hold the lights'
scale rho / A_ss on the same grid. The same block holds the pattern, one
sample per texel (p1, p2, prob_j as RGB) from atlas row ``sample_row`` (meta),
column 1 + j mod W, row + j div W, so that the nodes read sample j in a loop
(a repeat zone whose shader compiles once, whatever the sample count) rather
than unrolled. After one empty row, the probe lights (below) follow from
row ``light_row``, LIGHT_TEXELS texels each (:func:`light_texels`: the
direction rounded to a half float, the irradiance, the widened alphas, and
what the rounding left of the direction), read by the nodes in a loop too.
The direction is split so that a half-float atlas (the bake writes one
whenever its values fit) keeps it to about 1e-7 rad: whole, a half float
moves it by up to 5e-4 rad, which moved the runtime estimate by 1.5% (relative
RMS, night.exr, GGX 0.1) and 8% (GGX 0.05) on a 48 px sphere. The block has
as many rows as it needs (``meta["atlas_rows"]`` is the atlas's).

Atlases packed before stop 75 hold every level at the base's size and the
table in one more slice of H + 2 rows (no ``meta["level_layout"]``,
``table_row`` or ``atlas_rows``: :func:`table_row`, :func:`atlas_rows`); there a
stack too small for four texels per light kept three, the direction whole
(``meta["light_texels"]`` 3), and an atlas packed before stop 58 has no
``meta["light_texels"]`` and three texels per light. Their readers take them so.

Probe lights (``pack(..., lights=)``, bake.probe_lights): the level stack is
then of the probe without its small bright lights (and the tiles of its wide
bright regions), and each light (world direction l, irradiance E, RMS
radius r; ``meta["lights"]``, and in the atlas as the nodes read it) is added
exactly: (rho / A_ss)(wo) D_B(h) G2(l, wo) / (4 wo_z) E, with h the half
vector, A_ss the untinted single-scattering albedo (:func:`single_scatter_albedo`)
and D_B GGX's D with its slopes widened by the light's extent
(:func:`widened_d`): the light's directions, an RMS angle r about l, move
the half vector by LIGHT_WIDENING r within the plane of l and wo and by
LIGHT_WIDENING r / (wo.h) across it (h = (l + wo) / |l + wo| and
|l + wo| = 2 wo.h), Gaussian widths added in quadrature to the lobe's
alphas. Near normal incidence both are r / 2 (0.5 from half-vector geometry,
measured better than 0.707 on GGX 0.1 with 128^2-face probes); at grazing
views the highlight of a small lamp spreads across the plane of incidence by
1 / (wo.h), which an isotropic widening missed (night.exr at GGX 0.2, sphere
sub-pixels at n.v 0.04-0.06: 213 / 5.1 / 0.53 against the HDRI's integral
110 / 14.4 / 1.56; with the view-dependent widening 101 / 15.1 / 1.46). For
Cycles' GGX this is f cos E itself; a Fresnel term and multiple scattering
enter as their average over the lobe, through rho.

The constants (metadata): the lobe (``ax``, ``ay``, ``angle``), the density
threshold ``xi0``, the MIP ``bias`` and, per sample j, its point (p1, p2) on
the unit disk of Heitz's visible-normal sampler and the probability ``prob_j``
its pattern cell holds. Isotropic lobes use the paper's regular pattern
(bake.sampling's ``vndf`` warp, GGX's default; ``pattern`` "regular").
Anisotropic lobes use a ``stretched`` lattice (:func:`stretched_pattern`),
turned per pixel onto the direction in which the disk-to-lobe map stretches
most (:func:`_stretch_angle`). This departs from the paper, which keeps its
isotropic pattern and filters each sample's elongated footprint with the GPU's
anisotropic filtering (eqs. 14-16). Shader nodes have one isotropic lookup per
tap, and an elongated footprint read that way leaves gaps along the lobe.
Measured against the brute-force integral with 14 samples, GGX 0.3 with
anisotropy 0.8, a 64^2-face probe, and a head-on sphere:
- night.exr: 0.44 with the regular pattern, 0.18 with the stretched one;
- city.exr: 0.51 and 0.39;
- sunset.exr: 0.115 and 0.089.

Per pixel (world normal n, view v, tangent t; float32 in the nodes):
    frame x = t orthogonalised against n, y = n x x, turned by ``angle``;
    wo = (v.x, v.y, max(v.n, 1e-3)) normalised (the silhouette's grazing
    normals read the horizon rather than nothing);
    per sample: h_j = VNDF(wo, R p_j) (R the stretched pattern's turn, else 1),
    wi_j = 2 (wo.h_j) h_j - wo,
    w_j = prob_j G2(wi_j, wo) (= f cos Omega_j up to the factor G1(wo) and the
    tint, which cancel in the normalisation), 0 where wi_j,z <= 0,
    Omega_j = prob_j 4 wo_z / (G1(wo) D(h_j)),
    level_j = clamp(1/2 log2(Omega_j / Omega_t(wi_j)) + bias, 0, L - 1) with the
    lat-long texel solid angle Omega_t (bake.sampling_atlas), read between
    the two stored levels around it;
    w_j = 0 where w_j < xi0 max_k w_k;
    L(wo) = rho(wo) sum_j w_j L_j / sum_j w_j (eq. 18: a constant environment
    is returned as its radiance times the albedo, to the table's bilinear
    interpolation), plus the probe lights' term (above).

Cycles' Beckmann lobe (``kind`` "beckmann" in the meta) is sampled through the
same GGX visible normals of its alphas, each sample weighed for the Beckmann
lobe it estimates: w_j = prob_j G2_B(wi_j, wo) D_B(h_j) / D_GGX(h_j) (f cos
over the GGX sample's density, up to G1_GGX(wo), which the normalisation
cancels; :func:`proposal_ratio`), with Cycles' rational Beckmann Lambda in
G2_B. GGX's tails are heavier than Beckmann's, so the ratio is at most 1 and
no sample's weight blows up. The footprints (Omega_j) stay the GGX samples'
own, rho and A_ss are Beckmann's, and the lights' term uses Beckmann's D and
Lambdas. Measured on a smooth sky with 61 samples at n.v >= 0.3: 1.6% from
the brute-force integral, against 3.1% with the samples weighed as GGX
(tests/bake/test_sampling_runtime.py).

The tint and a Fresnel term (Principled metallic) enter through rho only: the
weights are scalar. That is the one difference from bake.sampling's
render_regular besides the texture's lat-long levels and the tabulated albedo.
"""

import numpy as np

from . import brdf, probe_lights
from .brdf.microfacet import (
    beckmann_lambda_cycles,
    ggx_d,
    ggx_lambda,
    sample_ggx_vndf,
)
from .envmap import get_layout
from .errors import BakeError
from .probe_maps import probe_maps
from .sampling import DEFAULTS, lobe_of, pattern_for_budget
from .sampling_atlas import (
    AtlasProbe,
    is_stack_height,
    level_count,
    level_lookup,
    pack_levels,
    stack_rows_below,
)

__all__ = ["pack", "shade", "mip_bias_for", "check", "probe_widths", "samples_of", "MODE",
           "ALBEDO_MU", "ALBEDO_PHI", "stack_height", "MIN_STACK_ROWS",
           "ALONE_CAP_FACTOR", "ALONE_MAX_ROWS", "near_mirror", "finest_level",
           "stack_reason", "table_row", "atlas_rows"]

MODE = "atlas_runtime"
#: Lobes the nodes sample: GGX's visible normals, and Beckmann's through them (its
#: own distribution weighs each GGX sample; see the module doc).
KINDS = ("ggx", "beckmann")
#: Albedo table size: M values of mu = n.v, P of the folded view azimuth.
ALBEDO_MU = 32
ALBEDO_PHI = 9
#: Floor of wo_z in the lobe frame (see the module doc).
MIN_COS = 1e-3
#: Directional-albedo integration samples per table entry (bake.brdf's MIS).
ALBEDO_SAMPLES = 1024
#: Visible-normal samples per entry of the lights' single-scattering albedo.
LIGHT_ALBEDO_SAMPLES = 4096
#: Atlas texels per probe light (light_texels): the direction's half-float part, the
#: irradiance, the widened alphas and spread, the direction's remainder.
LIGHT_TEXELS = 4
#: Texels per light of an atlas without ``meta["light_texels"]`` (packed before stop 58).
LIGHT_TEXELS_BEFORE = 3
#: A light of RMS angular radius r widens the lobe's alphas by LIGHT_WIDENING r in
#: quadrature within the plane of incidence, by LIGHT_WIDENING r / (wo.h) across it
#: (half-vector displacement is half the light's over wo.h; :func:`widened_d`).
LIGHT_WIDENING = 0.5
#: The MIP bias of the level lookups by lobe width: (alpha, bias) at two alphas,
#: linear in log alpha between and constant beyond (:func:`mip_bias_for`).
BIAS_BY_ALPHA = ((0.09, 0.0), (0.36, -1.0))
#: Smallest level stack (rows) that holds the albedo table: ALBEDO_MU columns
#: (a slice is twice as wide as it is high) and, for an anisotropic lobe with
#: probe lights, 2 ALBEDO_PHI + 3 rows.
MIN_STACK_ROWS = 16
#: Under Auto, a near-mirror lobe's stack that is its bake's only texture (Runtime
#: Sampling, not the Hybrid's second one) may have up to ALONE_CAP_FACTOR times Max
#: Map Size's rows, at most ALONE_MAX_ROWS (:func:`stack_height`, :func:`near_mirror`).
ALONE_CAP_FACTOR = 2
#: Chosen when every level was stored at the base's size (1024 rows packed 11 x 1026 =
#: 11286 rows, within the GPU's 16384; 1536 would have packed 16918). Since stop 75's
#: "mip" layout a 1024-row stack is about 2070 rows by 2051 texels, so the GPU allows
#: more; larger stacks were not measured.
ALONE_MAX_ROWS = 1024


def _lobe_directions(mu, phi):
    mu, phi = np.broadcast_arrays(mu, phi)
    sin = np.sqrt(np.clip(1.0 - mu * mu, 0.0, None))
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), mu], -1)


def near_mirror(lobe) -> bool:
    """Whether a bake.sampling.Lobe is narrower, along its narrower axis, than the
    Hybrid's tables reach (bake.hybrid.near_mirror_alpha of its kind): the lobes
    whose Runtime Sampling stack may pass Max Map Size (:func:`stack_height`'s
    ``alone``). At GGX 0.1, the tables' first row, 512 rows instead of 384 moved
    Runtime Sampling in EEVEE against Cycles by 0 to +0.2 point (city / forest
    / interior / night / sunrise / sunset 2.2 / 3.1 / 3.5 / 4.0 / 0.4 / 2.7%
    against stop 73's 2.2 / 2.9 / 3.4 / 3.9 / 0.4 / 2.7%), so the rows stay
    bounded there; at 0.05 they lowered it on every HDRI measured."""
    from .hybrid import near_mirror_alpha

    return min(lobe.mx, lobe.my) < near_mirror_alpha(lobe.kind)


def stack_height(probe_shape, layout, fixed=None, cap=None,
                 names=("Map Size", "Max Map Size"), alone=False, content_shape=None) -> tuple:
    """(rows, why) of the level stack :func:`pack` makes from a probe of
    ``probe_shape`` (H, W) in ``layout``: ``fixed`` rows when given, else the
    probe's own detail (a lat-long twice a cube face's rows, or the rows of a
    lat-long or other map) capped by ``cap``; rounded down to a power of two or
    three times one (bake.sampling_atlas.stack_rows_below: the level chain halves
    it exactly); without ``fixed``, at least MIN_STACK_ROWS.

    Before stop 73 the rows were rounded down to a power of two: the default Max
    Map Size of 384 gave a 256-row stack, and a near-mirror lobe lost detail the
    map beside it kept (GGX 0.05 in courtyard.exr from a 328 px probe, against
    the world's brute-force integral in NumPy: runtime sampling 4.1% at 256 rows,
    2.3% at 384, benchmarks/stack_rows.py).
    ``names``: what ``why`` calls the fixed size and the cap (Blender's fields,
    or the command line's options). ``content_shape``: the (H, W) of the
    coarsest level of the probe's box pyramid that stands for its content
    (bake.probe_content.of_probe); when smaller than the probe, the stack's
    own detail is that level's (a smooth probe's finer levels hold nothing the
    lookups would miss: the level differs from the probe by at most
    bake.probe_content.TOLERANCE of its mean, RMS).

    ``alone``: the stack is the bake's only texture (Runtime Sampling; not the
    Hybrid's, whose weights were measured with stacks capped at the map's
    bound) and its lobe a near-mirror (:func:`near_mirror`). Its cap is then
    ALONE_CAP_FACTOR times ``cap`` (768 rows at the default Max Map Size of 384),
    at most ALONE_MAX_ROWS: Max Map Size bounds the prefiltered map because
    filtering costs grow with its rows' square, while a stack is the probe
    box-reduced (its packing grows with its texels: 0.8 s at 384 rows and 1.3 s
    at 512 from courtyard's 328 px probe, cold), and a stack of 2N rows has a
    third of the texels of a twelve-slice 3D map of N. There the rows were the
    limit: in EEVEE against Cycles (courtyard.exr, 328 px probe, 19 samples)
    Beckmann 0.05 measured 6.1% at 384 rows and 4.5% at 512 (the probe's 656
    rows of detail, rounded down), GGX 0.05 4.3% and 2.9%; careful native EEVEE
    12.0% and 9.6%."""
    smoother = content_shape is not None and int(content_shape[0]) < int(probe_shape[0])
    detail = content_shape if smoother else probe_shape
    natural = 2 * int(detail[0]) if layout == "cube" else int(detail[0])
    if alone and fixed is None and cap is not None:
        cap = min(ALONE_CAP_FACTOR * int(cap), ALONE_MAX_ROWS)
        names = (names[0], f"{ALONE_CAP_FACTOR} x {names[1]} (the stack is the only "
                           f"texture), at most {ALONE_MAX_ROWS}")
    if fixed is not None:
        wanted, why = int(fixed), f"set by {names[0]}"
    elif cap is not None and natural > cap:
        wanted, why = int(cap), f"the probe's {natural} capped by {names[1]}"
    elif smoother:
        wanted, why = natural, (f"the probe's content, no more detailed than a "
                                f"{int(detail[0])} px {layout}")
    else:
        wanted, why = natural, "the probe's own detail"
    rows = stack_rows_below(wanted)
    if rows < wanted:
        why += f", rounded down to {rows} from {wanted} (the level chain halves it)"
    if fixed is None and rows < MIN_STACK_ROWS:
        rows, why = MIN_STACK_ROWS, f"{why}, raised to {MIN_STACK_ROWS}, the least that " \
                                    f"holds the albedo table"
    return rows, why


def finest_level(ax, ay, prob, height, bias) -> int:
    """The finest level (0 the stack's base of ``height`` lat-long rows) that any
    lookup of :func:`shade` (and the nodes) can read for a lobe of alphas ``ax``,
    ``ay``, pattern cell probabilities ``prob`` (S,) and MIP ``bias``: the floor of
    a lower bound of level_j = 1/2 log2(Omega_j / Omega_t) + bias over every
    sample, view and direction, at least 0.

    Omega_j = prob_j 4 wo_z / (G1(wo) D(h_j)) (the GGX proposal's, for Beckmann
    too) is at least min(prob) times min over wo of 4 wo_z (1 + Lambda(wo)),
    which is 2 (z + sqrt(z^2 + a^2 (1 - z^2))) at wo_z = z along an azimuth
    where the projected alpha is a (ax <= a <= ay), evaluated on z in
    [MIN_COS, 1] at the smaller alpha (it grows with a), over GGX's largest D,
    1 / (pi ax ay) at h = n. Omega_t, the lat-long texel's solid angle, is at
    most (pi / H)(2 pi / W) (at the equator). The bound is reached only at the
    silhouette (wo_z = MIN_COS, where G1 is smallest) by the smallest cell at
    the lobe's peak: GGX 0.6 (alpha 0.36, bias -1, 19 samples) never reads
    finer than level 2 of a 256-row stack, GGX 1 than level 4, GGX 0.3 reads
    level 0."""
    ax, ay = float(ax), float(ay)
    low = min(ax, ay)
    z = np.linspace(MIN_COS / np.sqrt(1.0 + MIN_COS ** 2), 1.0, 4097)
    least_view = float(np.min(2.0 * (z + np.sqrt(z * z + low * low * (1.0 - z * z)))))
    omega = float(np.min(prob)) * least_view * np.pi * ax * ay
    texel = (np.pi / height) * (2.0 * np.pi / (2 * height))
    bound = 0.5 * np.log2(omega / texel) + float(bias)
    return max(0, int(np.floor(bound - 1e-3)))  # the margin: float32 in the nodes


def stack_reason(meta, why) -> str:
    """The panel's and the command line's words for a runtime texture's level stack
    (``meta`` from :func:`pack`; ``why``: :func:`stack_height`'s reason)."""
    rows, first = int(meta["slice_height"]), int(meta.get("first_level", 0))
    text = f"{len(meta['prob'])} samples over {meta['levels']} levels of {rows} rows ({why}"
    if first:
        text += (f"; the lobe reads no level finer than {first} of "
                 f"{int(meta['stack_rows'])} rows, so the stack starts there")
    return text + ")"


def check(spec, budget=19):
    """The lobe and pattern ``pack`` would use for BRDF ``spec`` and a sample
    budget, without the work: (bake.sampling.Lobe, bake.sampling.Pattern), or
    BakeError (a BRDF with no GGX or Cycles' Beckmann lobe, a budget no pattern
    gives)."""
    model = brdf.parse(spec)
    nodes_sample = ("runtime sampling in shader nodes samples GGX lobes (ggx, "
                    "principled_metallic, ggx_multiscatter, principled without a coat) and "
                    "Cycles' Beckmann")
    try:
        lobe = lobe_of(model)
    except BakeError:  # bake.sampling's message names NumPy's samplers, more than the nodes'
        raise BakeError(f"{nodes_sample}; there is no sampler for {model.spec}") from None
    if lobe.kind not in KINDS or (lobe.kind == "beckmann" and model.name != "beckmann"):
        raise BakeError(f"{nodes_sample}, not {model.spec} (its {lobe.kind} lobe)")
    return lobe, pattern_for_budget(budget, lobe.anisotropic)


def probe_widths(spec, budget=19) -> list:
    """Widths (rad, as bake.resolution.lobe_half_width measures them) a probe must
    resolve for runtime sampling of BRDF ``spec`` (BakeError as :func:`check`).

    The sampled lobe's narrow axis at normal incidence
    (bake.resolution.ggx_half_width), and its narrower width at grazing views,
    where the reflected lobe is compressed in the plane of incidence: the
    widths of the 3D fit (bake.lobes, 16 slices) of the isotropic lobe of that
    narrow alpha, the same fit a Hybrid's map makes. GGX alpha 0.01 (roughness
    0.1): 0.66 degrees at normal incidence, 0.38 at its narrowest. Measured
    (benchmarks/runtime_validate.py, GGX 0.1, a 4096 x 2048 world with a sun of
    0.3 degrees radius): from the normal-incidence width alone Auto captured
    240 px faces and Runtime Sampling measured 9.1% against Cycles (native EEVEE
    7.7%); from these widths it captures what the Hybrid captures (1024 px
    faces, Max Probe Resolution) and measures 2.7%.
    """
    from . import lobes
    from .resolution import ggx_half_width, lobe_half_width

    lobe, _ = check(spec, budget)
    narrow = float(min(lobe.mx, lobe.my))
    widths = [ggx_half_width(narrow)]
    fit = lobes.fit(f"{lobe.kind}:alpha={narrow!r}", slices=16)
    widths += [lobe_half_width(lobes.GAMMA, part.profile)
               for piece in fit.slices for part in piece.lobes]
    return widths


def lobe_lambda(kind, w, ax, ay):
    """Smith Lambda of the sampled lobe's distribution at lobe-frame directions w
    (..., 3): GGX's, or Cycles' rational Beckmann one."""
    return ggx_lambda(w, ax, ay) if kind == "ggx" else beckmann_lambda_cycles(w, ax, ay)


def proposal_ratio(kind, h, ax, ay):
    """D(h) / D_GGX(h) (...) at lobe-frame half vectors h (..., 3): 1 for GGX; for
    Beckmann exp(-tau) (1 + tau)^2 with tau = (hx^2/ax^2 + hy^2/ay^2) / hz^2 (the
    importance weight of a GGX visible-normal sample for a Beckmann lobe of the
    same alphas, up to the factor G1_GGX(wo) that the normalisation cancels)."""
    if kind == "ggx":
        return np.ones(h.shape[:-1])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        tau = ((h[..., 0] / ax) ** 2 + (h[..., 1] / ay) ** 2) / (h[..., 2] ** 2)
        value = np.exp(-tau) * (1.0 + tau) ** 2
    return np.where(h[..., 2] > 0, np.nan_to_num(value), 0.0)


def stretched_pattern(count, aspect, resolution=512):
    """(points (N, 2), probabilities (N,)) of a lattice on the unit disk whose cells
    are ``aspect`` times as tall (y) as wide (x): R rows of equal height, each
    cut into strips of equal area, as many per row as its share of the disk's
    area (largest remainders; at least one), so that each cell holds about
    1 / count of the disk. Each point is its cell's centroid and its probability
    the cell's area over pi (a ``resolution``^2 grid integrates both).

    Used for anisotropic lobes, turned per pixel so that its dense axis lies
    along the direction in which the disk-to-lobe map stretches most (module
    doc): the cells then become about round on the sphere, which one isotropic
    MIP lookup per sample filters without gaps.
    """
    count = int(count)
    aspect = float(np.clip(aspect, 1.0, max(count, 1)))
    rows = max(1, int(round(2.0 / np.sqrt(np.pi * aspect / count))))
    g = (np.arange(resolution) + 0.5) / resolution * 2.0 - 1.0
    gx, gy = np.meshgrid(g, g)
    inside = gx * gx + gy * gy <= 1.0
    gx, gy = gx[inside], gy[inside]
    row = np.minimum(((gy + 1.0) * 0.5 * rows).astype(int), rows - 1)
    share = np.bincount(row, minlength=rows) / len(gx) * count
    per_row = np.maximum(np.floor(share).astype(int), 1)
    for index in np.argsort(-(share - np.floor(share))):
        if per_row.sum() >= count:
            break
        per_row[index] += 1
    points, probs = [], []
    for r in range(rows):
        xs, ys = gx[row == r], gy[row == r]
        columns, column, counts = np.unique(xs, return_inverse=True, return_counts=True)
        middle = (np.cumsum(counts) - 0.5 * counts) / len(xs)  # whole grid columns per
        cell = np.minimum((middle * per_row[r]).astype(int), per_row[r] - 1)[column]
        for k in range(per_row[r]):  # strip, by the column's middle: mirror-symmetric
            points.append((xs[cell == k].mean(), ys[cell == k].mean()))
            probs.append(np.count_nonzero(cell == k) / len(gx))
    return np.array(points), np.array(probs)


def single_scatter_albedo(wo, ax, ay, samples=LIGHT_ALBEDO_SAMPLES, kind="ggx"):
    """A_ss(wo) = integral of D G2 / (4 wo_z) over incident directions: the albedo of
    an untinted single-scattering GGX (or ``kind`` "beckmann") lobe (ax, ay) for
    lobe-frame views wo (..., 3), as E[G2 (D / D_GGX) / G1_GGX(wo)] over GGX's
    visible normals (Hammersley points; ~1e-3 accurate)."""
    from .brdf.base import hammersley

    wo = np.asarray(wo, dtype=np.float64)
    flat = wo.reshape(-1, 3)
    u = hammersley(samples)
    h = sample_ggx_vndf(flat[:, None, :], u[None], ax, ay)
    wo_h = np.sum(flat[:, None, :] * h, axis=-1)
    wi = 2.0 * wo_h[..., None] * h - flat[:, None, :]
    valid = (wi[..., 2] > 0) & (wo_h > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        g1_proposal = 1.0 + ggx_lambda(flat, ax, ay)[:, None]
        lambda_o = lobe_lambda(kind, flat, ax, ay)[:, None]
        ratio = g1_proposal / (1.0 + lobe_lambda(kind, wi, ax, ay) + lambda_o) \
            * proposal_ratio(kind, h, ax, ay)
    return np.mean(np.where(valid, ratio, 0.0), axis=1).reshape(wo.shape[:-1])


def mip_bias_for(ax, ay=None) -> float:
    """The default MIP bias of the level lookups for a GGX lobe of alphas ``ax``,
    ``ay``: 0 up to alpha 0.09 (GGX 0.3), -1 from alpha 0.36 (GGX 0.6), linear
    in log alpha between, of the geometric mean of the two alphas.

    Measured (19 samples, the probe lights taken as the bake takes them, 64^2-face
    probes, a 64^2-px sphere against the brute-force integral, root mean square
    over the eight bundled HDRIs; a one-off sweep, its figures in the README): the best
    bias moves down as the lobe widens. GGX 0.2: 0.112 at biases -1 / -0.5 / 0
    alike; GGX 0.3: 0.036 / 0.033 / 0.033 at -0.5 / -0.25 / 0; GGX 0.45: 0.040 /
    0.036 / 0.034 / 0.043 at -1 / -0.75 / -0.5 / 0; GGX 0.6: 0.029 / 0.028 /
    0.032 / 0.045 at -1.5 / -1 / -0.5 / 0; GGX 0.8: 0.029 at -1 against 0.032 at
    -1.5. Each pre-blurred level's Gaussian reaches past the texel whose solid
    angle the footprint rule matches, so a wide lobe's large cells read a level
    blurrier than their cells; narrow lobes' cells sit at the finest levels,
    where the clamp at level 0 leaves the bias little to do.

    Measured again on the stack of stop 75 (each level at its own size, a
    little sharper than the resampled levels the sweep above read;
    ``benchmarks/mip_bias.py``, a 48^2-px sphere, the default plus -0.75 to +0.5
    in steps of 0.25): the default is still the best of the six at GGX 0.2,
    0.3, 0.45, 0.6, 0.8 and 1 (0.080 / 0.022 / 0.018 / 0.027 / 0.028 / 0.028),
    the next best within 0.0001 at GGX 0.2 (+0.25) and 1 (-0.75)."""
    ay = ax if ay is None else ay
    (a0, b0), (a1, b1) = BIAS_BY_ALPHA
    mean = max(float(np.sqrt(ax * ay)), 1e-9)
    t = (np.log(mean) - np.log(a0)) / (np.log(a1) - np.log(a0))
    return float(b0 + (b1 - b0) * min(max(t, 0.0), 1.0))


def pack(probe, spec, layout="cube", budget=19, height=None, filter="gauss4", xi0=None,
         bias=None, pattern="auto", lights=()):
    """(atlas, meta) of a probe for runtime sampling of BRDF ``spec`` (module doc).

    probe (H, W, 3) in ``layout``; budget: samples per pixel (the pattern with the
    closest count); height: the level stack's lat-long rows (bake.sampling_atlas).
    The levels finer than the lobe's lookups can read (:func:`finest_level`) are
    left out: the texture then holds the stack from its level ``meta["first_level"]``,
    of height / 2^first_level rows (``meta["slice_height"]``; ``meta["stack_rows"]``
    is ``height``), and every lookup reads what it read in the whole stack, the
    lat-long texel's solid angle scaling the level by exactly first_level
    (bake.sampling_atlas.pack_levels). GGX 0.6 from a 256-row stack: 6 levels of 64
    rows instead of 8 of 256, about 1/15 of the texels.
    lights: bake.probe_lights.Light's taken out of ``probe`` (then the residual),
    shaded exactly by :func:`shade` and the nodes; kept in ``meta["lights"]``.
    bias: the lookups' MIP bias (None: :func:`mip_bias_for` the lobe).
    BakeError for a BRDF with no GGX or Cycles' Beckmann lobe (the nodes sample GGX's
    visible normals).
    """
    model = brdf.parse(spec)
    lobe, plan = check(spec, budget)
    xi0 = DEFAULTS["ggx"][1] if xi0 is None else float(xi0)
    bias = mip_bias_for(lobe.mx, lobe.my) if bias is None else float(bias)
    # The level stack depends on the probe alone: made once for all its materials.
    # A residual's (bake.probe_maps.residual_maps) conversion is its probe's, recomputed
    # near its lights only.
    if pattern == "auto":
        pattern = "stretched" if lobe.anisotropic else "regular"
    if pattern == "stretched":
        points, prob = stretched_pattern(len(plan), max(lobe.mx, lobe.my) /
                                         min(lobe.mx, lobe.my))
    else:
        points = plan.points / plan.edge
        prob = plan.cells / (np.pi * plan.edge ** 2)
    count_phi = ALBEDO_PHI if lobe.anisotropic else 1
    # The levels finer than any lookup reads are left out (finest_level), down to
    # MIN_STACK_ROWS (the albedo table's width).
    rows = height
    if rows is None:
        rows = 2 * int(np.asarray(probe).shape[0]) if get_layout(layout).name == "cube" \
            else int(np.asarray(probe).shape[0])
    first = 0
    if is_stack_height(rows):
        for trim in range(finest_level(lobe.mx, lobe.my, prob, rows, bias), 0, -1):
            if rows >> trim >= MIN_STACK_ROWS and trim < level_count(rows):
                first = trim
                break
    maps = probe_maps(probe, layout)
    levels, meta = maps.kept(
        ("runtime levels", height, filter, first), lambda: pack_levels(
            probe, layout, height, filter,
            base=maps.plain(height) if height is not None and layout in ("cube", "latlong")
            and not (layout == "latlong" and np.asarray(probe).shape[0] == height) else None,
            first=first))
    meta = dict(meta)
    height, width = meta["slice_height"], meta["slice_width"]
    if ALBEDO_MU > width:
        raise BakeError(f"the level stack ({height} rows) is too small for the albedo table")
    mu = MIN_COS + (1.0 - MIN_COS) * np.linspace(0.0, 1.0, ALBEDO_MU)  # wo_z >= MIN_COS
    phi = np.linspace(0.0, 0.5 * np.pi, count_phi) if count_phi > 1 else np.zeros(1)
    wo_lobe = _lobe_directions(mu[None, :], phi[:, None])  # (P, M, 3) in the lobe frame
    cos_a, sin_a = np.cos(lobe.angle), np.sin(lobe.angle)
    wo_model = np.stack([cos_a * wo_lobe[..., 0] - sin_a * wo_lobe[..., 1],
                         sin_a * wo_lobe[..., 0] + cos_a * wo_lobe[..., 1], wo_lobe[..., 2]], -1)
    table = model.albedo(wo_model, samples=ALBEDO_SAMPLES).astype(np.float32)  # (P, M, 3)
    # The table block below the levels, as wide as the atlas: one empty row, rho (P
    # rows from column 1), the lights' scale rho / A_ss (light_radiance) in the P
    # rows after it (with lights), one empty, the samples, one empty, the lights at
    # LIGHT_TEXELS texels each (light_texels), and one empty row.
    light_rows = count_phi if lights else 0
    first_sample = count_phi + light_rows + 2
    sample_rows = -(-len(prob) // width)
    light_first = first_sample + sample_rows + 1
    block_rows = (light_first + -(-LIGHT_TEXELS * len(lights) // width) if lights
                  else first_sample + sample_rows) + 1
    block = np.zeros((block_rows, levels.shape[1], 3), np.float32)
    block[1:1 + count_phi, 1:1 + ALBEDO_MU] = table
    if light_rows:
        ratio = table / np.maximum(single_scatter_albedo(
            wo_lobe, lobe.mx, lobe.my, kind=lobe.kind), 1e-6)[..., None].astype(np.float32)
        block[1 + count_phi:1 + 2 * count_phi, 1:1 + ALBEDO_MU] = ratio
    for j, ((p1, p2), q) in enumerate(zip(points, prob, strict=True)):
        block[first_sample + j // width, 1 + j % width] = (p1, p2, q)
    for j, texels in enumerate(light_texels(lights, lobe.mx, lobe.my)):
        for c, value in enumerate(texels):
            t = LIGHT_TEXELS * j + c
            block[light_first + t // width, 1 + t % width] = value
    atlas = np.concatenate([levels, block], axis=0)
    below = int(meta["atlas_rows"])  # the levels' rows
    meta.update({
        "mode": MODE, "levels": meta["slices"], "slices": meta["slices"] + 1,
        "mu": [0.0] * (meta["slices"] + 1), "offsets": [0.0] * (meta["slices"] + 1),
        "spec": model.spec, "kind": lobe.kind, "ax": float(lobe.mx), "ay": float(lobe.my),
        "angle": float(lobe.angle), "xi0": xi0, "bias": bias, "budget": int(budget),
        "spacing": plan.spacing, "circles": len(plan.radii),
        "disk": points.tolist(), "prob": prob.tolist(), "pattern": pattern,
        "table_row": below + 1, "sample_row": below + first_sample,
        "light_row": below + light_first, "atlas_rows": int(atlas.shape[0]),
        "albedo_mu": ALBEDO_MU, "albedo_phi": count_phi, "min_cos": MIN_COS,
        "light_texels": LIGHT_TEXELS, "lights": [light.to_json() for light in lights]})
    return atlas, meta


def table_row(meta) -> int:
    """The atlas row of the albedo table's first entry (rho at phi 0): below the
    levels ("mip" layout), or row 1 of the last slice (an atlas packed before stop 75,
    every level H + 2 rows)."""
    if "table_row" in meta:
        return int(meta["table_row"])
    return int(meta["levels"]) * (int(meta["slice_height"]) + 2) + 1


def atlas_rows(meta) -> int:
    """The rows of a runtime or level atlas (``meta["atlas_rows"]``, or the slices of
    H + 2 rows an atlas packed before stop 75 has)."""
    return int(meta.get("atlas_rows") or int(meta["slices"]) * (int(meta["slice_height"]) + 2))


def _albedo(atlas, meta, wo, table=0):
    """rho (B, 3) from the table at lobe-frame views wo (B, 3), bilinear as the nodes;
    ``table`` 1: the lights' scale rho / A_ss (the rows after rho's)."""
    count_mu, count_phi = int(meta["albedo_mu"]), int(meta["albedo_phi"])
    base = table_row(meta) + table * count_phi
    x = np.clip((wo[:, 2] - MIN_COS) / (1.0 - MIN_COS), 0.0, 1.0) * (count_mu - 1)
    x0 = np.minimum(np.floor(x), count_mu - 2)
    fx = (x - x0)[:, None]
    if count_phi > 1:
        phi = np.arctan2(np.abs(wo[:, 1]), np.abs(wo[:, 0]))
        y = np.clip(phi / (0.5 * np.pi), 0.0, 1.0) * (count_phi - 1)
        y0 = np.minimum(np.floor(y), count_phi - 2)
    else:
        y = y0 = np.zeros_like(x)
    fy = (y - y0)[:, None]
    x0, y0 = x0.astype(int) + 1, y0.astype(int) + base
    y1 = y0 + (1 if count_phi > 1 else 0)
    top = atlas[y0, x0] * (1 - fx) + atlas[y0, x0 + 1] * fx
    bottom = atlas[y1, x0] * (1 - fx) + atlas[y1, x0 + 1] * fx
    return top * (1 - fy) + bottom * fy


def light_texels(lights, ax, ay):
    """Per light its LIGHT_TEXELS texels (RGB each) as the atlas holds them: the
    world direction rounded to a half float, the irradiance, (bx, by, spread)
    with the alphas widened by the light's extent (light_radiance;
    bake.probe_lights.Light.extent: its spread without its texels' own extent,
    which the spread here is), and the direction less its rounded part (the
    module doc: both survive a half-float atlas, their sum the direction)."""
    rows = []
    for light in lights:
        data = light.to_json() if hasattr(light, "to_json") else light
        spread = probe_lights.Light.from_json(data).extent
        widen = (LIGHT_WIDENING * spread) ** 2
        direction = np.asarray(data["direction"], np.float64)
        rounded = direction.astype(np.float16).astype(np.float64)
        rows.append((tuple(rounded), tuple(data["irradiance"]),
                     (float(np.sqrt(ax * ax + widen)), float(np.sqrt(ay * ay + widen)), spread),
                     tuple(direction - rounded)))
    return rows


def lights_of(atlas, meta):
    """(directions (N, 3), irradiances (N, 3), widened alphas (N, 2), spreads (N,)
    (RMS angular radius, rad)) of the probe lights as the nodes read them: from
    the atlas's light texels (module doc)."""
    count = len(meta.get("lights") or [])
    if not count:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0)
    width = int(meta["slice_width"])
    per = int(meta.get("light_texels", LIGHT_TEXELS_BEFORE))
    t = np.arange(per * count)
    texels = np.asarray(atlas)[int(meta["light_row"]) + t // width, 1 + t % width, :3]
    texels = texels.astype(np.float64).reshape(count, per, 3)
    # Rounded part plus remainder, summed in float32 as the nodes sum them.
    direction = texels[:, 0] if per < 4 else \
        (texels[:, 0].astype(np.float32) + texels[:, 3].astype(np.float32)).astype(np.float64)
    return direction, texels[:, 1], texels[:, 2, :2], texels[:, 2, 2]


def samples_of(atlas, meta):
    """(points (S, 2), probabilities (S,)) as the nodes read them: from the atlas's
    sample texels (module doc), not from the metadata's lists."""
    width = int(meta["slice_width"])
    j = np.arange(len(meta["prob"]))
    texels = np.asarray(atlas)[int(meta["sample_row"]) + j // width, 1 + j % width, :3]
    return texels[:, :2].astype(np.float64), texels[:, 2].astype(np.float64)


def _stretch_angle(wo, ax, ay):
    """(B,) angle in the VNDF disk (T1, T2 axes, before the p2 warp by s) of the
    direction the disk-to-half-vector map stretches most, for lobe-frame views
    wo (B, 3): the principal axis of M = ax^2 a a^T + ay^2 b b^T with
    a = (T1_x, s T2_x), b = (T1_y, s T2_y) (the rows of the map's Jacobian at the
    disk's centre, up to the common normalisation). The stretched pattern's
    x axis is turned onto it."""
    v = wo * np.array([ax, ay, 1.0])
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    lensq = v[:, 0] ** 2 + v[:, 1] ** 2
    inv = 1.0 / np.sqrt(np.maximum(lensq, 1e-30))
    t1 = np.stack([np.where(lensq > 0, -v[:, 1] * inv, 1.0),
                   np.where(lensq > 0, v[:, 0] * inv, 0.0), np.zeros(len(v))], -1)
    t2 = np.cross(v, t1)
    s = 0.5 * (1.0 + v[:, 2])
    a1, a2 = ax * t1[:, 0], ax * s * t2[:, 0]
    b1, b2 = ay * t1[:, 1], ay * s * t2[:, 1]
    m11, m22, m12 = a1 * a1 + b1 * b1, a2 * a2 + b2 * b2, a1 * a2 + b1 * b2
    return 0.5 * np.arctan2(2.0 * m12, m11 - m22)


def _footprints(wo, disk, turn, prob, omega, ax, ay, wi):
    """Per sample, the long axis (B, S, 3, lobe frame, unit) and the long and short
    extents (B, S) rad of its footprint: a square pattern cell of area pi prob_j
    on the VNDF disk, carried to incident directions by the map's Jacobian
    (finite differences along the pattern's two axes), scaled to solid angle
    omega_j."""
    eps = 1e-4
    side = np.sqrt(np.pi * prob)[None, :]
    axes = []
    for quarter in (0.0, 0.5 * np.pi):
        step = np.stack(np.broadcast_arrays(np.cos(turn + quarter), np.sin(turn + quarter)), -1)
        moved = disk[None] + eps * step
        u = np.stack(np.broadcast_arrays(
            np.sum(moved * moved, axis=-1),
            np.mod(np.arctan2(moved[..., 1], moved[..., 0]) + turn, 2.0 * np.pi) /
            (2.0 * np.pi)), -1)
        h = sample_ggx_vndf(wo[:, None, :], u, ax, ay)
        other = 2.0 * np.sum(wo[:, None, :] * h, axis=-1)[..., None] * h - wo[:, None, :]
        axes.append((other - wi) / eps * side[..., None])
    lengths = [np.linalg.norm(axis, axis=-1) for axis in axes]
    first_longer = lengths[0] >= lengths[1]
    long_axis = np.where(first_longer[..., None], axes[0], axes[1])
    long_axis /= np.maximum(np.linalg.norm(long_axis, axis=-1, keepdims=True), 1e-30)
    longest = np.maximum(lengths[0], lengths[1])
    shortest = np.maximum(np.minimum(lengths[0], lengths[1]), 1e-12)
    scale = np.sqrt(omega / np.maximum(longest * shortest, 1e-30))
    return long_axis, longest * scale, shortest * scale


def shade(atlas, meta, normals, views, tangents=None, tangent_hint=(0.3, 0.5, 0.8), taps=1,
          spread=None, levels_read=None):
    """(N, 3) radiance the runtime-sampling nodes compute for world-space unit
    normals, views (surface to viewer) and tangents (N, 3) each (tangents None:
    bake.reference's hint frame).

    ``taps`` > 1 is not what the nodes do yet: each sample's elongated footprint
    is read as GPU anisotropic filtering would (the paper's eqs. 14-16), with
    T = min(taps, round(long / short extent)) lookups spread along its long
    axis, each at the level of solid angle omega_j / T, and averaged. Measured
    (benchmarks/runtime_accuracy.py --taps): on GGX 0.3 with anisotropy 0.8 and
    14 samples, taps=4 cuts the error against the brute-force integral by
    1.2-2.1x on every bundled HDRI; on isotropic GGX 0.3 it helps at 19 samples
    where lights are small (night 0.29 -> 0.20, studio 0.17 -> 0.12; sunset and
    interior up to 9% worse) and costs up to 1.4x at 127 samples, where the
    footprints are small and nearly round. Not settled: for the stretched
    pattern :func:`_footprints` takes each cell as square and turns its
    finite-difference steps by the pattern's turn once more than the samples
    (the figures above were measured so); turning them once only measured
    worse (14 samples, 128 px probe, 4 lookups: night 0.145 -> 0.270), and
    with 52 or more samples the taps cost more than they gain, so the
    footprint model is not yet one to carry into the nodes.

    ``spread`` and ``levels_read``: lists to which the weighted spread of the
    samples' luminance (B,) about their mean, and the levels the valid samples
    compute before the clamp to the stack (1-D, this stack's levels), are
    appended (for measurements and tests)."""
    from .reference import _frames, pixel_arrays

    if meta.get("mode") != MODE:
        raise BakeError(f"not a runtime-sampling atlas (mode {meta.get('mode')!r})")
    normals, views, tangents = pixel_arrays(normals, views, tangents)
    # Unit length as the nodes make them (decoded render passes are off by ~1e-3).
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    views = views / np.linalg.norm(views, axis=1, keepdims=True)
    atlas = np.asarray(atlas, dtype=np.float64)
    frames = _frames(normals, tangents, tangent_hint)
    angle = float(meta["angle"])
    x = np.cos(angle) * frames[:, 0] + np.sin(angle) * frames[:, 1]
    y = np.cross(frames[:, 2], x)
    frames = np.stack([x, y, frames[:, 2]], axis=1)
    wo = np.einsum("bij,bj->bi", frames, views)
    wo[:, 2] = np.maximum(wo[:, 2], MIN_COS)
    wo /= np.linalg.norm(wo, axis=1, keepdims=True)
    ax, ay = float(meta["ax"]), float(meta["ay"])
    disk, prob = samples_of(atlas, meta)
    turn = np.zeros((len(wo), 1))
    if meta.get("pattern") == "stretched":
        turn = _stretch_angle(wo, ax, ay)[:, None]
    u = np.stack(np.broadcast_arrays(
        np.sum(disk * disk, axis=1)[None],
        np.mod(np.arctan2(disk[:, 1], disk[:, 0])[None] + turn, 2.0 * np.pi) / (2.0 * np.pi)),
        -1)
    h = sample_ggx_vndf(wo[:, None, :], u, ax, ay)  # (B, S, 3)
    wo_h = np.sum(wo[:, None, :] * h, axis=-1)
    wi = 2.0 * wo_h[..., None] * h - wo[:, None, :]
    valid = (wi[..., 2] > 0) & (wo_h > 0)
    kind = meta.get("kind", "ggx")
    with np.errstate(divide="ignore", invalid="ignore"):
        g1 = 1.0 / (1.0 + ggx_lambda(wo, ax, ay))  # (B,) the GGX proposal's
        g2 = 1.0 / (1.0 + lobe_lambda(kind, wi, ax, ay)
                    + lobe_lambda(kind, wo, ax, ay)[:, None])
        omega = prob[None] * 4.0 * wo[:, 2:3] / (g1[:, None] * ggx_d(h, ax, ay))
    weight = np.where(valid, prob[None] * g2 * proposal_ratio(kind, h, ax, ay), 0.0)
    weight = np.where(weight >= float(meta["xi0"]) * weight.max(axis=1, keepdims=True),
                      weight, 0.0)
    world = np.einsum("bnk,bkj->bnj", np.where(valid[..., None], wi, wo[:, None, :]), frames)
    probe = AtlasProbe(atlas, meta)
    if int(taps) <= 1:
        count, along, long_world = np.ones(omega.shape), np.zeros(omega.shape), None
    else:
        long_axis, longest, shortest = _footprints(wo, disk, turn, prob, omega, ax, ay, wi)
        count = np.clip(np.round(longest / shortest), 1, int(taps))
        along = longest
        long_world = np.einsum("bnk,bkj->bnj", long_axis, frames)
    radiance = 0.0
    for tap in range(int(count.max())):
        direction = world
        if long_world is not None:
            offset = ((tap + 0.5) / count - 0.5) * along
            direction = world + offset[..., None] * long_world
            direction = direction / np.linalg.norm(direction, axis=-1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            level = 0.5 * np.log2(np.where(valid, omega / count, 1.0) /
                                  probe.texel_solid_angle(direction)) + float(meta["bias"])
        if levels_read is not None:
            levels_read.append(level[valid & (tap < count)])
        level = np.clip(np.where(valid, level, 0.0), 0.0, probe.count - 1)
        low = np.floor(level).astype(int)
        high = np.minimum(low + 1, probe.count - 1)
        frac = (level - low)[..., None]
        value = (level_lookup(atlas, meta, low, direction) * (1.0 - frac)
                 + level_lookup(atlas, meta, high, direction) * frac)
        radiance = radiance + np.where((tap < count)[..., None], value / count[..., None], 0.0)
    total = weight.sum(axis=1, keepdims=True)
    mean = np.sum(weight[..., None] * radiance, axis=1) / np.where(total > 0, total, 1.0)
    if spread is not None:
        luminance = radiance @ np.array([0.2126, 0.7152, 0.0722])
        centre = mean @ np.array([0.2126, 0.7152, 0.0722])
        second = np.sum(weight * (luminance - centre[:, None]) ** 2, axis=1) / np.where(
            total[:, 0] > 0, total[:, 0], 1.0)
        spread.append(np.sqrt(second) / np.maximum(centre, 1e-30))
    result = np.where(total > 0, mean, 0.0) * _albedo(atlas, meta, wo)
    if meta.get("lights"):
        result = result + light_radiance(atlas, meta, frames, wo)
    return result


def widened_d(kind, h, wi, wo, bx, by, spread):
    """D (B,) of the lobe (``kind`` "ggx" or "beckmann") averaged over a light of RMS
    angular radius ``spread`` (rad) about the lobe-frame direction wi (B, 3), seen
    from wo (B, 3), at the half vectors h (B, 3) of wi and wo.

    The light's directions move h by LIGHT_WIDENING spread within the plane of wi
    and wo (already in the widened alphas bx, by: light_texels) and by that over
    c = max(wo.h, MIN_COS) across it, along q = the tangent-plane part of
    wi x wo (normalised; none where wi x wo has none). Gaussian widths add, so
    the slopes' covariance is S = diag(bx^2, by^2) + e q q^T with
    e = (LIGHT_WIDENING spread)^2 (1 / c^2 - 1), and with t = hz^2 + (Syy hx^2
    - 2 Sxy hx hy + Sxx hy^2) / det S:
        GGX       D = 1 / (pi sqrt(det S) t^2),
        Beckmann  D = exp(1 - t / hz^2) / (pi sqrt(det S) hz^4),
    which for e = 0 are the lobe's D at alphas (bx, by); 0 where hz <= 0."""
    cos_d = np.maximum(np.sum(wo * h, axis=1), MIN_COS)
    extra = (LIGHT_WIDENING * spread) ** 2 * (1.0 / (cos_d * cos_d) - 1.0)
    across = np.cross(wi, wo)[:, :2]
    length = np.linalg.norm(across, axis=1, keepdims=True)
    q = np.where(length > 0, across / np.where(length > 0, length, 1.0), 0.0)
    sxx = bx * bx + extra * q[:, 0] ** 2
    syy = by * by + extra * q[:, 1] ** 2
    sxy = extra * q[:, 0] * q[:, 1]
    det = sxx * syy - sxy * sxy
    hx, hy, hz = h[:, 0], h[:, 1], h[:, 2]
    t = hz * hz + (syy * hx * hx - 2.0 * sxy * hx * hy + sxx * hy * hy) / det
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        if kind == "ggx":
            d = 1.0 / (np.pi * np.sqrt(det) * t * t)
        else:
            hz2 = np.maximum(hz * hz, 1e-12)
            d = np.exp(1.0 - t / hz2) / (np.pi * np.sqrt(det) * hz2 * hz2)
    return np.where(hz > 0, np.nan_to_num(d), 0.0)


def light_radiance(atlas, meta, frames, wo):
    """(B, 3) radiance from the probe's lights (meta["lights"], bake.probe_lights):
    sum over lights of (rho / A_ss)(wo) D(h) G2(l, wo) / (4 wo_z) E, with l the
    light's direction in the lobe frame (frames (B, 3, 3) rows x, y, n), h the half
    vector and wo the lobe-frame view (z floored as for the samples); zero where
    l is below the surface. D is averaged over the light's extent
    (:func:`widened_d`). Exact f cos E for a point light of an untinted
    single-scattering GGX lobe; a tint, Fresnel and multiple scattering enter
    through rho / A_ss, their average over the lobe (exact for a tint)."""
    directions, irradiances, widened, spreads = lights_of(atlas, meta)
    total = light_sum(directions, irradiances, widened[:, 0], widened[:, 1], spreads, frames,
                      wo, float(meta["ax"]), float(meta["ay"]), meta.get("kind", "ggx"))
    return total * _albedo(atlas, meta, wo, table=1)


def light_sum(directions, irradiances, bx, by, spreads, frames, wo, ax, ay, kind="ggx"):
    """(B, 3) sum over lights of D_B(h) G2(l, wo) / (4 wo_z) E: :func:`light_radiance`
    before its scale rho / A_ss. directions, irradiances (N, 3) (world); the widened
    alphas bx, by (N,) or (N, B) per pixel; spreads (N,) (rad); frames (B, 3, 3);
    wo (B, 3) (lobe frame); the lobe's alphas ax, ay: floats or (B,) per pixel
    (bake.knot_lights: a roughness texture)."""
    total = np.zeros((len(wo), 3))
    lambda_o = lobe_lambda(kind, wo, ax, ay)
    for direction, irradiance, bx_l, by_l, spread in zip(directions, irradiances, bx, by,
                                                         spreads, strict=True):
        wi = frames @ direction  # (B, 3); unit to float32 rounding, as the nodes take it
        h = wi + wo
        h /= np.maximum(np.linalg.norm(h, axis=1, keepdims=True), 1e-30)
        valid = (wi[:, 2] > 0) & (np.sum(wo * h, axis=1) > 0)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            value = widened_d(kind, h, wi, wo, bx_l, by_l, spread) / (4.0 * wo[:, 2] * (
                1.0 + lambda_o + lobe_lambda(kind, wi, ax, ay)))
        total += np.where(valid, value, 0.0)[:, None] * irradiance
    return total
