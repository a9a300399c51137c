"""bake.hybrid: the measured table, and the hybrid against the brute-force integral on
environments the table was not measured on."""

import json

import numpy as np
import pytest

from bake import brdf, hybrid, prefilter, probe_lights, reference, sampling, sampling_runtime
from bake.envmap import get_layout
from bake.errors import BakeError

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


@pytest.mark.parametrize("kind", hybrid.KINDS)
def test_the_committed_table_is_whole_and_its_weights_interpolate_back(kind):
    """GGX's table and Beckmann's (benchmarks/hybrid.py --brdf beckmann)."""
    table = hybrid.load_table(kind=kind)
    assert table.meta["brdf"].startswith(kind)
    budgets, roughness, bins = len(table.budgets), len(table.roughness), len(table.edges) - 1
    assert table.weight.shape == table.regular.shape == (budgets, roughness, bins)
    assert table.map.shape == (roughness, bins)
    assert list(table.budgets) == [19, 61, 127]
    assert np.all((table.weight >= 0) & (table.weight <= 1))
    assert np.all(table.map > 0) and np.all(table.regular > 0)
    assert len(table.meta["hdris"]) >= 8  # measured on every bundled HDRI
    centres = 0.5 * (table.edges[:-1] + table.edges[1:])
    for s, budget in enumerate(table.budgets):
        for i, r in enumerate(table.roughness):
            np.testing.assert_allclose(hybrid.blend_weight(centres, r, table, budget),
                                       table.weight[s, i], atol=1e-12)
    # Between budgets: linear in log2(samples); outside them: the nearest budget.
    t = (np.log2(40) - np.log2(19)) / (np.log2(61) - np.log2(19))
    between = (1 - t) * table.weight[0, 2] + t * table.weight[1, 2]
    np.testing.assert_allclose(hybrid.blend_weight(centres, table.roughness[2], table, 40),
                               np.clip(between, 0, 1), atol=1e-12)
    np.testing.assert_allclose(hybrid.blend_weight(centres, table.roughness[2], table, 400),
                               table.weight[-1, 2], atol=1e-12)
    # With more samples the regular estimate is more accurate: pooled over the
    # table's roughness values and bins its error falls from 19 to 127 samples.
    pooled = np.sqrt(np.mean(table.regular ** 2, axis=(1, 2)))
    assert pooled[-1] < pooled[0], pooled


def test_the_node_curve_is_the_tables_interpolation():
    """blend_curve (the shader nodes' arithmetic over a material's knots) equals
    blend_weight at every mu, inside the bins and past the end centres, for
    roughness values and sample counts between the table's."""
    table = hybrid.load_table()
    mu = np.linspace(-0.2, 1.0, 241)
    for roughness in (0.1, 0.17, 0.3, 0.44, 0.6):
        for samples in (19, 30, 127):
            centres, weights = hybrid.weight_curve(roughness, table, samples)
            np.testing.assert_allclose(hybrid.blend_curve(mu, centres, weights),
                                       hybrid.blend_weight(mu, roughness, table, samples),
                                       atol=1e-12)



def _blend_data(seed=0, count=4000):
    rng = np.random.default_rng(seed)
    mu = rng.random(count)
    baked = rng.normal(1.0, 0.3, count)
    regular = baked + rng.normal(0.0, 0.2, count)
    return rng, mu, baked, regular


def test_the_curve_fit_is_the_squared_error_of_the_curve_the_nodes_evaluate():
    """curve_normal_equations' quadratic form is the weighted squared error of the
    blend through blend_curve (the nodes' w(mu)) for any knot values, and a truth
    that is such a blend gives back its knots (bounded_least_squares)."""
    rng, mu, baked, regular = _blend_data()
    centres = np.array([0.05, 0.15, 0.275, 0.425, 0.6, 0.85])
    knots = np.array([0.7, 0.5, 1.0, 0.9, 0.4, 0.0])
    truth = baked + hybrid.blend_curve(mu, centres, knots) * (regular - baked)
    scale = rng.uniform(0.5, 2.0, mu.shape)
    gram, rhs = hybrid.curve_normal_equations(mu, baked, regular, truth, scale, centres)
    constant = np.sum(scale * (truth - baked) ** 2)
    for w in (knots, rng.random(6), np.zeros(6)):
        blend = baked + hybrid.blend_curve(mu, centres, w) * (regular - baked)
        np.testing.assert_allclose(w @ gram @ w - 2 * rhs @ w + constant,
                                   np.sum(scale * (blend - truth) ** 2), rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(hybrid.bounded_least_squares(gram, rhs), knots, atol=1e-9)


def test_bounded_least_squares_meets_the_optimality_conditions_at_the_bounds():
    """Where the unconstrained optimum leaves [0, 1] the result satisfies the
    Karush-Kuhn-Tucker conditions (an independent criterion of the minimum of a
    convex problem): zero gradient on the free knots, pointing out of the box on
    the knots held at 0 or 1; and no random point of the box does better."""
    rng, mu, baked, regular = _blend_data(1)
    centres = np.array([0.1, 0.3, 0.5, 0.7, 0.9])
    unbounded = np.array([-0.6, 0.3, 1.7, 0.8, 1.2])
    truth = baked + hybrid.blend_curve(mu, centres, unbounded) * (regular - baked) \
        + rng.normal(0.0, 0.05, mu.shape)
    gram, rhs = hybrid.curve_normal_equations(mu, baked, regular, truth, 1.0, centres)
    w = hybrid.bounded_least_squares(gram, rhs)
    assert np.all((w >= 0) & (w <= 1))
    assert w[0] == 0.0 and w[2] == 1.0  # the unconstrained optimum is out of the box there
    gradient = 2.0 * (gram @ w - rhs)
    tolerance = 1e-8 * np.abs(rhs).max()
    free = (w > 0) & (w < 1)
    assert np.all(np.abs(gradient[free]) < tolerance), gradient
    assert np.all(gradient[w == 0] > -tolerance) and np.all(gradient[w == 1] < tolerance)
    cost = w @ gram @ w - 2 * rhs @ w
    for other in rng.random((2000, 5)):
        assert other @ gram @ other - 2 * rhs @ other >= cost - 1e-9 * abs(cost)
    with pytest.raises(BakeError, match="K <= 10"):
        hybrid.bounded_least_squares(np.eye(11), np.zeros(11))


def test_a_table_of_one_budget_still_reads(tmp_path):
    """A table written before the budget axis (weights (R, B), meta budget 19)."""
    table = hybrid.load_table()
    old = {"roughness": table.roughness.tolist(), "mu_edges": table.edges.tolist(),
           "map": table.map.tolist(), "regular": table.regular[0].tolist(),
           "weight": table.weight[0].tolist(), "meta": {"budget": 19}}
    path = tmp_path / "old.json"
    path.write_text(json.dumps(old))
    read = hybrid.load_table(path)
    assert list(read.budgets) == [19]
    centres, weights = hybrid.weight_curve(0.3, read, samples=127)
    np.testing.assert_allclose(weights, hybrid.weight_curve(0.3, table, samples=19)[1])


def test_a_missing_table_is_one_clear_error(tmp_path):
    with pytest.raises(BakeError, match="benchmarks/hybrid.py"):
        hybrid.load_table(tmp_path / "nothing.json")
    with pytest.raises(BakeError, match="no hybrid table for a ward lobe"):
        hybrid.load_table(kind="ward")


def _environments():
    cube = get_layout("cube")
    directions = cube.texel_directions(cube.shape(32))
    sun = np.array([0.6, 0.0, 0.8])
    sky = 0.2 + np.clip(directions[..., 2], 0, None)[..., None] * np.array([1.0, 2.0, 3.0]) + \
        50.0 * (directions @ sun > 0.995)[..., None]
    return [sampling.spots_environment(32, 3), sampling.spots_environment(32, 7),
            sky.astype(np.float32)]


def test_the_hybrid_beats_both_methods_on_environments_it_was_not_measured_on():
    """Three synthetic environments (two of tiny bright spots, a sky with a small
    sun), GGX roughness 0.2-0.6, a 32^2 sphere, the regular estimate as the
    Runtime Sampling nodes compute it (bake.sampling_runtime's twin, 64-row
    level stack): the hybrid's relative RMS error against the brute-force
    integral, pooled over the 12 cases (root mean square), is below the 3D
    map's and below regular sampling's. Both parts are made as the bake makes
    them with Probe Lights on (the default; the table is measured so): from
    the residual probe, each with the lights' exact term (small lights and
    tiles, at the lowest threshold that fits: extract_for). Measured with 19
    samples: 0.0133 against 0.0324 (map) and 0.0146 (regular), a margin of
    9% on the closer one (stop 42, when a light's extent widened its
    highlight alike in every direction: 0.0161, 0.0335 and 0.0172; with the
    threshold ladder of stop 34, whose rungs
    were an octave apart, fewer lights were taken: 0.0624 against 0.0679 and
    0.0647; without Probe Lights, and the table measured without them, 0.125
    against 0.190 and 0.141); per case the hybrid is not always the best,
    which is what the pooled figure allows. With 127 samples: 0.0118 against
    0.0123 (regular); the weights measured for 19 samples give 0.0119 here
    (stop 42: 0.0149, 0.0154, 0.0151; stop 34: 0.0609, 0.0611, 0.0610), so the table's
    sample axis is held to within 2% of them on these environments (on the
    bundled HDRIs, leave one out, it puts the hybrid below both methods in
    29 of 40 cases at 127 samples against 21 with the weights for 19:
    benchmarks/hybrid.py)."""
    normals, views, mask = reference.sphere_buffers(32)
    normals, views = normals[mask], views[mask]
    mu = np.clip(np.sum(normals * views, axis=-1), 0.0, 1.0)
    squares = {key: [] for key in ("map", "regular", "hybrid", "regular 127", "hybrid 127",
                                   "hybrid 127 as 19")}

    def add(key, estimate, truth):
        squares[key].append(np.mean((estimate - truth) ** 2) / np.mean(truth ** 2))

    for env in _environments():
        for roughness in (0.2, 0.3, 0.45, 0.6):
            spec = f"ggx:roughness={roughness}"
            model = brdf.parse(spec)
            truth = reference.render(model, env, "cube", normals, views) @ LUMINANCE
            # As the bake makes them (Probe Lights on): both parts from the residual,
            # the lights' exact term added to each.
            residual, lights = probe_lights.extract_for(env, "cube", roughness ** 2)
            atlas, meta = sampling_runtime.pack(residual, spec, layout="cube", height=64,
                                                lights=lights)
            light_term = sampling_runtime.shade(atlas, meta, normals, views) - \
                sampling_runtime.shade(atlas, {**meta, "lights": []}, normals, views)
            baked = (prefilter.prefilter(residual, spec, "3d", "auto").shade(normals, views)
                     + light_term) @ LUMINANCE
            add("map", baked, truth)
            for budget, suffix in ((19, ""), (127, " 127")):
                atlas, meta = sampling_runtime.pack(residual, spec, layout="cube",
                                                    budget=budget, height=64, lights=lights)
                regular = sampling_runtime.shade(atlas, meta, normals, views) @ LUMINANCE
                add("regular" + suffix, regular, truth)
                weight = hybrid.blend_weight(mu, roughness, samples=budget)
                add("hybrid" + suffix, (1.0 - weight) * baked + weight * regular, truth)
                if budget != 19:
                    weight = hybrid.blend_weight(mu, roughness, samples=19)
                    add("hybrid 127 as 19", (1.0 - weight) * baked + weight * regular, truth)
    pooled = {key: float(np.sqrt(np.mean(value))) for key, value in squares.items()}
    assert pooled["hybrid"] < pooled["map"] and pooled["hybrid"] < pooled["regular"], pooled
    assert pooled["hybrid 127"] < min(pooled["map"], pooled["regular 127"]), pooled
    assert pooled["hybrid 127"] < 1.02 * pooled["hybrid 127 as 19"], pooled


def test_a_principled_bsdf_without_a_coat_takes_the_hybrid_too():
    """The Principled BSDF's glossy layers without a coat are one GGX lobe whose
    Fresnel terms and multiscatter energy runtime sampling carries in its albedo
    table only (bake.sampling.lobe_of). The Hybrid, weighted by the GGX table at
    the lobe's roughness, is still below the 3D map and below regular sampling,
    pooled over a dielectric and a coloured metal at roughness 0.3 and 0.5 on
    the synthetic environments (19 samples, 32^2 sphere). Measured: 0.159 against
    0.240 (map) and 0.177 (regular), a margin of 10% on the closer one.
    On the bundled HDRIs (64 px probe) the dielectric at 0.3 measured 0.22
    against the map's 0.51 in night.exr, 0.28 against 0.43 in studio.exr."""
    normals, views, mask = reference.sphere_buffers(32)
    normals, views = normals[mask], views[mask]
    mu = np.clip(np.sum(normals * views, axis=-1), 0.0, 1.0)
    squares = {key: [] for key in ("map", "regular", "hybrid")}
    for env in _environments():
        for roughness in (0.3, 0.5):
            for material in ("metallic=0", "metallic=1,base_color=0.9/0.6/0.3"):
                spec = f"principled:roughness={roughness},{material},diffuse=0"
                model = brdf.parse(spec)
                truth = reference.render(model, env, "cube", normals, views) @ LUMINANCE
                baked = prefilter.prefilter(env, spec, "3d", "auto").shade(normals, views) \
                    @ LUMINANCE
                atlas, meta = sampling_runtime.pack(env, spec, layout="cube", budget=19,
                                                    height=64)
                regular = sampling_runtime.shade(atlas, meta, normals, views) @ LUMINANCE
                weight = hybrid.blend_weight(mu, roughness, samples=19)
                for key, estimate in (("map", baked), ("regular", regular),
                                      ("hybrid", (1.0 - weight) * baked + weight * regular)):
                    squares[key].append(np.mean((estimate - truth) ** 2) / np.mean(truth ** 2))
    pooled = {key: float(np.sqrt(np.mean(value))) for key, value in squares.items()}
    print(pooled)
    assert pooled["hybrid"] < pooled["map"] and pooled["hybrid"] < pooled["regular"], pooled
    with pytest.raises(BakeError, match="no sampler"):  # a coat is a second lobe
        sampling_runtime.pack(_environments()[0], "principled:roughness=0.3,coat_weight=1")
