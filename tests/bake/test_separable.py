"""Separable BRDF approximations (bake.separable, Kautz & McCool 1999), against
closed forms: BRDFs separable by construction, the exact truncated SVD of
NumPy on a small matrix, and the paper's findings on which parameterization
suits which BRDF."""

import numpy as np
import pytest

from bake import brdf, separable
from bake.brdf.base import BRDF
from bake.errors import BakeError


class _IncidentTimesView(BRDF):
    """a(wi) b(wo): exactly separable in the incident/view parameterization."""

    name = "test-incident-view"

    def _f(self, wi, wo):
        a = (1.5 + wi[..., 0]) * (1.0 + wi[..., 2] ** 2)
        b = (2.0 + wo[..., 1]) * (0.5 + wo[..., 2])
        return (a * b)[..., None] * np.array([1.0, 0.5, 0.25])


class _HalfTimesDifference(BRDF):
    """a(h) b(d): exactly separable in the half/difference parameterization."""

    name = "test-half-difference"

    def _f(self, wi, wo):
        h = wi + wo
        h = h / np.linalg.norm(h, axis=-1, keepdims=True)
        d = separable._rotate_to_pole(wi, h)
        a = 0.2 + h[..., 2] ** 4 + 0.3 * h[..., 0]
        b = 1.0 + 0.5 * d[..., 0] ** 2 + 0.25 * d[..., 2]
        return (a * b)[..., None] * np.array([0.9, 0.6, 0.3])


def _inside_texel_pairs(fac, step_u=5, step_v=3):
    """Pairs at texel centres that are not on the clamped rim (exactly representable)."""
    grid = fac.grid
    n = fac.size
    radius = np.hypot(*np.meshgrid(separable._texel_centres(n), separable._texel_centres(n),
                                   indexing="ij")).ravel()
    inside = np.flatnonzero(radius < 1.0 - 1.0 / n)
    u, v = grid.u[inside[::step_u]], grid.v[inside[::step_v]]
    wi, wo = grid.pairs(u, v)
    keep = (wi[..., 2] > 1e-3) & (wo[..., 2] > 1e-3)
    return wi[keep], wo[keep]


@pytest.mark.parametrize("model, parameterization", [
    (_IncidentTimesView(), "incident-view"), (_HalfTimesDifference(), "half-difference")])
@pytest.mark.parametrize("method", ["svd", "nd"])
@pytest.mark.parametrize("kind", ["xy", "parabolic"])
def test_an_exactly_separable_brdf_is_recovered_by_one_term(model, parameterization, method,
                                                            kind):
    fac = separable.factorize(model, parameterization, method, 1, 16, kind)
    wi, wo = _inside_texel_pairs(fac)
    truth, approx = model.f(wi, wo), fac.evaluate(wi, wo)
    assert np.abs(approx - truth).max() <= 1e-6 * np.abs(truth).max()


def test_the_randomized_svd_matches_numpy_s_truncated_svd():
    """Eckart-Young: the k-term error of the matrix equals the tail of its singular
    values; the randomized solver reaches it (to 1e-4) without a full SVD."""
    model = brdf.parse("ggx:roughness=0.5")
    matrix = separable.matrix_for(model, "incident-view", 8)
    full = matrix._kept[1].astype(np.float64)  # green channel, 64 x 64
    sigma = np.linalg.svd(full, compute_uv=False)
    for terms in (1, 3, 5):
        fac = separable.factorize(model, "incident-view", "svd", terms, 8, matrix=matrix)
        g = fac.g[..., 1].reshape(terms, -1) * fac.scale_g[:, 1:2]
        h = fac.h[..., 1].reshape(terms, -1) * fac.scale_h[:, 1:2]
        error = np.linalg.norm(full - g.T @ h)
        best = np.sqrt(np.sum(sigma[terms:] ** 2))
        assert error == pytest.approx(best, rel=1e-4, abs=1e-6 * sigma[0])


@pytest.mark.parametrize("parameterization", ["incident-view", "elevation-azimuth"])
def test_svd_error_does_not_grow_with_terms(parameterization):
    """Measured as the paper does (cosine-weighted outgoing radiance, continuous
    lookups) for GGX 0.5 at 32^2. The 1e-3 allowance covers the bilinear lookup
    between texel centres, where the SVD's optimality does not hold."""
    model = brdf.parse("ggx:roughness=0.5")
    fac = separable.factorize(model, parameterization, "svd", 5, 32)
    pairs = separable.stratified_pairs(60)
    errors = [separable.error(fac, model, pairs, k) for k in range(1, 6)]
    assert all(b <= a + 1e-3 for a, b in zip(errors, errors[1:], strict=False)), errors
    assert errors[-1] < errors[0]


def test_the_weighted_fit_ignores_pairs_below_the_horizon():
    """In the half-vector parameterizations, (h, d) pairs that put wi or wo below
    the horizon are no BRDF value. Fitting only the others recovers a BRDF
    separable in (h, d) exactly; a plain SVD of the zero-filled matrix does not."""
    model = _HalfTimesDifference()
    matrix = separable.matrix_for(model, "half-difference", 16)
    weighted = separable.factorize(model, "half-difference", "svd", 1, 16, matrix=matrix)
    g, h = separable._svd(matrix, 1, None)  # the zero-filled matrix, unweighted
    plain = separable.Factorization(model.spec, "half-difference", "svd", 16, "xy", g, h)
    wi, wo = _inside_texel_pairs(weighted)
    truth = model.f(wi, wo)
    assert np.abs(weighted.evaluate(wi, wo) - truth).max() <= 1e-6 * np.abs(truth).max()
    assert np.abs(plain.evaluate(wi, wo) - truth).max() > 0.1 * np.abs(truth).max()


def test_nd_streams_in_memory_linear_in_its_output(monkeypatch):
    """A matrix too large to keep is evaluated again per pass, block by block, and
    gives the same factors as the kept matrix."""
    model = brdf.parse("ward:ax=0.2,ay=0.1,ks=0.5")
    kept = separable.factorize(model, "gram-schmidt", "nd", 2, 16)
    monkeypatch.setattr(separable, "MATRIX_BYTES", 0)
    matrix = separable.matrix_for(model, "gram-schmidt", 16)
    assert matrix._kept is None
    streamed = separable.factorize(model, "gram-schmidt", "nd", 2, 16, matrix=matrix)
    assert matrix.evaluations % (16 * 16) ** 2 == 0 and matrix.evaluations > (16 * 16) ** 2
    np.testing.assert_allclose(streamed.g, kept.g, atol=1e-6)
    np.testing.assert_allclose(streamed.h, kept.h, atol=1e-6)


@pytest.mark.parametrize("parameterization", ["half-difference", "gram-schmidt"])
def test_the_one_term_nd_on_the_fill_equals_the_nd_of_the_filled_matrix(parameterization):
    """The matrix-vector shortcut (no filled copy) against the general ND run on the
    filled blocks; only float32 rounding of the fill may differ."""
    model = brdf.parse("ggx:roughness=0.4,anisotropy=0.5")
    matrix = separable.matrix_for(model, parameterization, 16)
    g, h = separable._nd(matrix, 1, 2.0, None)
    g, h = separable._als(matrix, g, h, 10, separable.ALS_TOLERANCE, None, double_round=False)
    fast = separable._nd_one_term_filled(matrix, (g, h), None)
    assert fast is not None
    general = separable._nd(separable._Filled(matrix, (g, h)), 1, 2.0, None)
    product = [np.einsum("cu,cv->cuv", a[..., 0], b[..., 0]) for a, b in (fast, general)]
    scale = np.abs(product[1]).max()
    assert np.abs(product[0] - product[1]).max() <= 1e-5 * scale


@pytest.mark.parametrize("kind", ["xy", "parabolic"])
def test_hemisphere_maps_round_trip_at_texel_centres(kind):
    size = 16
    directions = separable.hemisphere_directions(size, kind)
    col, row = separable.hemisphere_coords(directions, size, kind)
    radius = np.hypot(*np.meshgrid(separable._texel_centres(size),
                                   separable._texel_centres(size), indexing="ij"))
    inside = radius < 1.0 - 1.0 / size
    rows, cols = np.indices((size, size))
    np.testing.assert_allclose(col[inside], cols[inside], atol=1e-9)
    np.testing.assert_allclose(row[inside], rows[inside], atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=-1), 1.0, atol=1e-12)
    assert directions[0, size // 2, 1] > 0.9  # row 0 is +y


def test_the_paper_s_findings_on_parameterizations():
    """Kautz & McCool 1999: half-vector parameterizations suit near-specular BRDFs
    (the anisotropic Ward of their Figure 10); a velvet-like BRDF, which follows
    the incident and view elevations, is best in a parameterization without the
    half vector (here elevation/azimuth; the paper found incident/view)."""
    pairs = separable.stratified_pairs(60)

    def errors(spec):
        out = {}
        for param in separable.PARAMETERIZATIONS:
            matrix = separable.matrix_for(spec, param, 32)
            out[param] = min(separable.error(separable.factorize(spec, param, method, 1, 32,
                                                                 matrix=matrix), spec, pairs)
                             for method in separable.METHODS)
        return out

    ward = errors("ward:ax=0.21,ay=0.048,ks=0.3,kd=1/0/0")
    assert min(ward["half-difference"], ward["gram-schmidt"]) < \
        0.6 * min(ward["incident-view"], ward["elevation-azimuth"]), ward
    velvet = errors("velvet:sigma=0.4,ks=0.8")
    assert min(velvet["incident-view"], velvet["elevation-azimuth"]) < \
        0.9 * min(velvet["half-difference"], velvet["gram-schmidt"]), velvet


@pytest.mark.parametrize("arguments, says", [
    ({"size": 2}, "texture size"), ({"size": 512}, "texture size"), ({"terms": 0}, "terms"),
    ({"terms": 17}, "terms"), ({"parameterization": "polar"}, "parameterization"),
    ({"kind": "sphere"}, "hemisphere map"), ({"method": "pca"}, "method"), ({"p": 0.0}, "p-norm")])
def test_absurd_arguments_are_refused_before_any_work(arguments, says):
    class Exploding(BRDF):
        name = "exploding"

        def _f(self, wi, wo):
            raise AssertionError("evaluated")

    with pytest.raises(BakeError, match=says):
        separable.factorize(Exploding(), **arguments)


def test_the_command_line_writes_factors_and_the_report(tmp_path):
    from bake import exr
    from tests.bake.test_cli import run_bake

    out = tmp_path / "f.exr"
    result = run_bake("factorize", "--brdf", "ward:ax=0.2,ay=0.1,ks=0.5,kd=0.2", "--size", "16",
                      "--terms", "2", "--param", "gram-schmidt", "--method", "nd", "-q",
                      "-o", out)
    assert result.returncode == 0, result.stderr
    layers, meta = exr.read(out, layers=True)
    assert sorted(layers) == ["g0", "g1", "h0", "h1"]
    assert meta["parameterization"] == "gram-schmidt" and meta["terms"] == 2
    # Round trip: the textures and scales in the file rebuild the same factorization.
    # The fit runs in float32 products (sgemm) whose summation order follows the
    # BLAS threads of each process: the two runs agree to a few float32 ulps of
    # the factors' unit scale (1.8e-6 measured on one machine), not bit for bit.
    again = separable.factorize("ward:ax=0.2,ay=0.1,ks=0.5,kd=0.2", "gram-schmidt", "nd", 2, 16)
    np.testing.assert_allclose(layers["g1"], again.g[1], atol=1e-5)
    np.testing.assert_allclose(meta["scale_h"], again.scale_h, rtol=1e-5)

    result = run_bake("factorize", "--brdf", "ggx:roughness=0.5", "--report", "--sizes", "8,16",
                      "--terms", "2", "--strata", "20", "--plots", tmp_path / "fig", "-q")
    assert result.returncode == 0, result.stderr
    table = [line for line in result.stdout.splitlines() if line.split()[:1] and
             line.split()[0] in separable.PARAMETERIZATIONS]
    assert len(table) == 4 * len(separable.METHODS) * 2  # parameterizations x methods x sizes
    assert "best at 16^2" in result.stdout
    assert (tmp_path / "fig_terms.png").stat().st_size > 1000
    assert (tmp_path / "fig_sizes.png").stat().st_size > 1000

    for args, says in ((["--size", "1024"], "texture size"), (["--terms", "0"], "terms"),
                       (["--report", "--strata", "1"], "--strata"), ([], "-o OUT.exr")):
        result = run_bake("factorize", "--brdf", "ggx:roughness=0.5", *args,
                          *(["-o", tmp_path / "x.exr"] if args[:1] == ["--size"] or
                            args[:1] == ["--terms"] else []), "-q")
        assert result.returncode == 2 and says in result.stderr, result.stderr
        assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "x.exr").exists()


@pytest.mark.parametrize("parameterization", separable.PARAMETERIZATIONS)
@pytest.mark.parametrize("kind", ["xy", "parabolic"])
@pytest.mark.parametrize("method, size_h", [("svd", 12), ("sampled", 6)])
def test_the_packed_atlas_reads_back_the_factors_exactly(parameterization, kind, method,
                                                         size_h):
    """What a shader reads from the padded atlas (clamped coordinates, one ring
    of edge or wrapped texels) is Factorization.evaluate's bilinear lookup."""
    fac = separable.factorize("ggx:roughness=0.5,anisotropy=0.5", parameterization, method, 2,
                              12, kind, size_h=size_h)
    image, meta = separable.pack(fac)
    assert image.shape == (14 + size_h + 2, 2 * 14, 3)
    assert (meta["tile_g"], meta["tile_h"]) == (14, size_h + 2)
    wi, wo = separable.stratified_pairs(400)
    expected = fac.evaluate(wi, wo)
    got = separable.atlas_lookup(image, meta, wi, wo)
    assert np.abs(got - expected).max() <= 1e-6 * np.abs(expected).max()  # float32 scales


def test_a_factorization_that_overflows_is_a_clear_error():
    class Huge(BRDF):
        name = "test-huge"

        def _f(self, wi, wo):
            return np.full(wi.shape, 1e300)

    with pytest.raises(BakeError, match="did not converge"):
        separable.factorize(Huge(), "incident-view", "svd", 1, 8)


@pytest.mark.parametrize("size_h", [8, 16])
def test_the_sampled_fit_recovers_a_separable_brdf_with_h_of_its_own_size(size_h):
    """a(h) b(d) is rank one: the sampled fit (rows against a sub-grid of the
    columns and back) reproduces it at texel centres of g (16^2) and h."""
    model = _HalfTimesDifference()
    fac = separable.factorize(model, "half-difference", "sampled", 1, 16, size_h=size_h)
    assert fac.g.shape == (1, 16, 16, 3) and fac.h.shape == (1, size_h, size_h, 3)

    def inside(n):  # texel centres not on the clamped rim
        centres = separable._texel_centres(n)
        radius = np.hypot(*np.meshgrid(centres, centres, indexing="ij")).ravel()
        return np.flatnonzero(radius < 1.0 - 1.0 / n)

    wi, wo = fac.grid.pairs(fac.grid.u[inside(16)[::3]], fac.grid.v[inside(size_h)])
    keep = (wi[..., 2] > 1e-3) & (wo[..., 2] > 1e-3)
    truth, approx = model.f(wi[keep], wo[keep]), fac.evaluate(wi[keep], wo[keep])
    assert np.abs(approx - truth).max() <= 1e-5 * np.abs(truth).max()


def test_the_command_line_writes_factors_of_two_sizes(tmp_path):
    from bake import exr
    from tests.bake.test_cli import run_bake

    out = tmp_path / "f.exr"
    result = run_bake("factorize", "--brdf", "ggx:roughness=0.3,anisotropy=0.8", "--size", "32",
                      "--size-h", "8", "--terms", "2", "--method", "sampled", "-q", "-o", out)
    assert result.returncode == 0, result.stderr
    parts, meta = exr.read_parts(out)
    assert {k: v.shape[:2] for k, v in parts.items()} == {
        "g0": (32, 32), "g1": (32, 32), "h0": (8, 8), "h1": (8, 8)}
    assert meta["size_h"] == 8 and meta["method"] == "sampled"


# --- isotropic BRDFs: one row of M per radius of g's map ----------------------------
@pytest.mark.parametrize("spec", ["principled:metallic=1,roughness=0.1",
                                  "principled:roughness=0.4,base_color=0.8/0.3/0.1",
                                  "ggx:roughness=0.3"])
def test_an_isotropic_brdf_gives_the_slab_of_the_direct_evaluation(spec):
    """Rows of one radius (any azimuth of the half vector) hold the same values: the
    compact slab, expanded, is the slab evaluated row by row, to the rounding of
    the rotation (1e-9 of the largest value)."""
    model = brdf.parse(spec)
    grid = separable._Grid("half-difference", 64, "xy", 16)
    rows = np.arange(len(grid.u))
    cols = separable._sub_grid(16, 8)
    values, valid, inverse, representatives = separable._slab(model, grid, rows, cols)
    assert len(representatives) < len(rows) / 4  # 64^2 texels: 528 radii (and the rim)
    direct, direct_valid = separable._slab_direct(model, grid, rows, cols)
    np.testing.assert_array_equal(valid[inverse], direct_valid)
    np.testing.assert_allclose(values[:, inverse], direct, rtol=0,
                               atol=1e-9 * np.abs(direct).max())


def test_an_isotropic_fit_is_the_direct_fit_from_fewer_evaluations(monkeypatch):
    """The sampled fit of Principled metal 0.15 (g 128^2, h 16^2, 2 terms) from
    the compact slabs equals the fit from every row, within float32 summation
    order (1e-4 of the factors' scale), from under a quarter of the BRDF
    evaluations."""
    evaluated = []
    direct_slab = separable._slab_direct

    def counting(model, grid, rows, cols, *args):
        evaluated.append(len(rows) * len(cols))
        return direct_slab(model, grid, rows, cols, *args)

    monkeypatch.setattr(separable, "_slab_direct", counting)
    spec = "principled:metallic=1,roughness=0.15"
    compact = separable.factorize(spec, "half-difference", "sampled", 2, 128, size_h=16)
    compact_count = sum(evaluated)
    evaluated.clear()
    monkeypatch.setattr(separable, "_shared_rows", lambda *args: None)
    direct = separable.factorize(spec, "half-difference", "sampled", 2, 128, size_h=16)
    assert compact_count < sum(evaluated) / 4
    for a, b in ((compact.g, direct.g), (compact.h, direct.h)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-4 * np.abs(b).max())
    np.testing.assert_allclose(compact.scale_g * compact.scale_h,
                               direct.scale_g * direct.scale_h, rtol=1e-4)


@pytest.mark.parametrize("spec", ["principled:metallic=1,roughness=0.3,anisotropy=0.8",
                                  "ggx:roughness=0.2,anisotropy=0.6,rotation=0.15",
                                  "ward:ax=0.2,ay=0.1,ks=0.5,kd=0.2"])
def test_an_anisotropic_lobe_shares_rows_with_its_half_turn_partner(spec):
    """An elliptical lobe is unchanged by a half turn about the normal: the row of
    h and that of (-h_x, -h_y, h_z) are equal, half the rows are evaluated, and
    the expanded slab is the direct one to rounding."""
    model = brdf.parse(spec)
    assert not model.isotropic
    grid = separable._Grid("half-difference", 32, "xy", 8)
    rows = np.arange(len(grid.u))
    cols = separable._sub_grid(8, 8)
    values, valid, inverse, representatives = separable._slab(model, grid, rows, cols)
    assert len(representatives) == len(rows) // 2
    direct, direct_valid = separable._slab_direct(model, grid, rows, cols)
    np.testing.assert_array_equal(valid[inverse], direct_valid)
    np.testing.assert_allclose(values[:, inverse], direct, rtol=0,
                               atol=1e-9 * np.abs(direct).max())


@pytest.mark.parametrize("rotation, share", [(0.0, 4), (0.25, 4), (0.1, 2)])
def test_an_aligned_anisotropic_lobe_is_evaluated_on_a_quarter_of_its_rows(monkeypatch,
                                                                           rotation, share):
    """Principled anisotropic metal aligned with the tangent (rotation 0 or a
    quarter turn) is also its own mirror image: the mirrored half vector's row
    is the row with the d map's rows flipped, so a quarter of the rows are
    evaluated (half when turned 0.1); the slab, expanded, is the direct one."""
    model = brdf.parse(f"principled:metallic=1,roughness=0.3,anisotropy=0.8,rotation={rotation}")
    grid = separable._Grid("half-difference", 32, "xy", 16)
    evaluated = []
    direct_slab = separable._slab_direct

    def counting(model, grid, rows, cols, *args):
        evaluated.append(len(rows))
        return direct_slab(model, grid, rows, cols, *args)

    for rows, cols in ((np.arange(32 * 32), separable._sub_grid(16, 8)),
                       (separable._sub_grid(32, 16), np.arange(16 * 16))):
        monkeypatch.setattr(separable, "_slab_direct", counting)
        values, valid, inverse, _ = separable._slab(model, grid, rows, cols)
        monkeypatch.setattr(separable, "_slab_direct", direct_slab)
        assert evaluated[-1] == len(rows) // share  # the slab's own rows (checks before)
        direct, direct_valid = direct_slab(model, grid, rows, cols)
        np.testing.assert_array_equal(valid[inverse], direct_valid)
        np.testing.assert_allclose(values[:, inverse], direct, rtol=0,
                                   atol=1e-9 * np.abs(direct).max())


def test_a_table_without_the_symmetry_is_evaluated_row_by_row():
    """A tabulated anisotropic BRDF whose values change under a half turn: the
    check evaluates every row."""
    from bake.brdf.tabulated import AnisotropicTable

    thetas, phis = 6, 8
    rng = np.random.default_rng(4)
    table = AnisotropicTable(rng.uniform(0.1, 1.0, (thetas, phis, thetas, phis, 3)))
    grid = separable._Grid("half-difference", 16, "xy", 8)
    assert separable._shared_rows(table, grid, np.arange(len(grid.u)), np.arange(64)) is None


def test_a_brdf_that_only_claims_isotropy_is_evaluated_row_by_row():
    """a(h) b(d) with a term in h_x changes with the half vector's azimuth; it
    inherits BRDF.isotropic = True, and the check of _shared_rows catches it."""
    model = _HalfTimesDifference()
    assert model.isotropic
    grid = separable._Grid("half-difference", 32, "xy", 8)
    assert separable._shared_rows(model, grid, np.arange(len(grid.u)), np.arange(64)) is None
    assert separable._shared_rows(brdf.parse("ggx:roughness=0.3"), grid,
                                  np.arange(len(grid.u)), np.arange(64)) is not None
