"""bake.hybrid: the measured table, and the hybrid against the brute-force integral on
environments the table was not measured on."""

import numpy as np
import pytest

from bake import brdf, hybrid, prefilter, reference, sampling
from bake.envmap import get_layout
from bake.errors import BakeError

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def test_the_committed_table_is_whole_and_its_weights_interpolate_back():
    table = hybrid.load_table()
    assert table.weight.shape == table.map.shape == table.regular.shape
    assert np.all((table.weight >= 0) & (table.weight <= 1))
    assert np.all(table.map > 0) and np.all(table.regular > 0)
    assert len(table.meta["hdris"]) >= 8  # measured on every bundled HDRI
    centres = 0.5 * (table.edges[:-1] + table.edges[1:])
    for i, roughness in enumerate(table.roughness):
        np.testing.assert_allclose(hybrid.blend_weight(centres, roughness, table),
                                   table.weight[i], atol=1e-12)


def test_the_node_curve_is_the_tables_interpolation():
    """blend_curve (the shader nodes' arithmetic over a material's knots) equals
    blend_weight at every mu, inside the bins and past the end centres, for
    roughness values between the table's."""
    table = hybrid.load_table()
    mu = np.linspace(-0.2, 1.0, 241)
    for roughness in (0.1, 0.17, 0.3, 0.44, 0.6):
        centres, weights = hybrid.weight_curve(roughness, table)
        np.testing.assert_allclose(hybrid.blend_curve(mu, centres, weights),
                                   hybrid.blend_weight(mu, roughness, table), atol=1e-12)


def test_a_missing_table_is_one_clear_error(tmp_path):
    with pytest.raises(BakeError, match="benchmarks/hybrid.py"):
        hybrid.load_table(tmp_path / "nothing.json")


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
    sun), GGX roughness 0.2-0.6, a 32^2 sphere: the hybrid's relative RMS error
    against the brute-force integral, pooled over the 12 cases (root mean
    square), is below the 3D map's and below regular sampling's. Measured:
    0.127 against 0.190 (map) and 0.149 (regular), a margin of 15% on the
    closer one; per case the hybrid is not always the best (7 of 12 at 40^2),
    which is what the pooled figure allows."""
    normals, views, mask = reference.sphere_buffers(32)
    normals, views = normals[mask], views[mask]
    mu = np.clip(np.sum(normals * views, axis=-1), 0.0, 1.0)
    squares = {"map": [], "regular": [], "hybrid": []}
    for env in _environments():
        mip = sampling.MipProbe(env)
        for roughness in (0.2, 0.3, 0.45, 0.6):
            spec = f"ggx:roughness={roughness}"
            model = brdf.parse(spec)
            truth = reference.render(model, env, "cube", normals, views) @ LUMINANCE
            baked = prefilter.prefilter(env, spec, "3d", "auto").shade(normals, views) @ LUMINANCE
            regular = sampling.render_regular(model, None, normals, views, budget=19,
                                              mip=mip) @ LUMINANCE
            weight = hybrid.blend_weight(mu, roughness)
            blended = (1.0 - weight) * baked + weight * regular
            for key, estimate in (("map", baked), ("regular", regular), ("hybrid", blended)):
                squares[key].append(np.mean((estimate - truth) ** 2) / np.mean(truth ** 2))
    pooled = {key: float(np.sqrt(np.mean(value))) for key, value in squares.items()}
    assert pooled["hybrid"] < pooled["map"] and pooled["hybrid"] < pooled["regular"], pooled
