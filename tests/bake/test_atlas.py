"""The node-group atlas: packing and its NumPy lookup equal BakedMap.shade."""

import numpy as np
import pytest

from bake import atlas, envmap, prefilter
from bake.errors import BakeError


def test_atlas_lookup_equals_the_baked_map(forest):
    probe = envmap.convert(forest, "latlong", "cube", 24)
    baked = prefilter.prefilter(probe, "ggx:roughness=0.4", "3d", 16, slices=5)
    image, meta = atlas.pack(baked)
    assert image.shape == (5 * 18, 35, 3)
    np.testing.assert_allclose(image[np.arange(5) * 18, 34, 0], meta["offsets"])
    # Padding: pole rows are ring means, edge columns wrap.
    np.testing.assert_allclose(image[0, 5], baked.layers["slice.0"][0].mean(0), rtol=1e-6)
    np.testing.assert_array_equal(image[1:17, 0], baked.layers["slice.0"][:, -1])
    rng = np.random.default_rng(4)
    n = rng.normal(size=(500, 3))
    v = n + rng.normal(scale=0.8, size=(500, 3))
    np.testing.assert_allclose(atlas.shade(image, meta, n, v), baked.shade(n, v), rtol=1e-5,
                               atol=1e-6)


def test_multi_lobe_atlas_equals_the_baked_map(forest):
    probe = envmap.convert(forest, "latlong", "cube", 16)
    baked = prefilter.prefilter(probe, "sum(lambert:color=0.4; ggx:roughness=0.3)", "3d", 8,
                                slices=3, lobes_count=2)
    image, meta = atlas.pack(baked)
    assert image.shape == (2 * 3 * 10, 19, 3) and meta["lobes"] == 2
    rng = np.random.default_rng(8)
    n = rng.normal(size=(300, 3))
    v = n + rng.normal(scale=0.7, size=(300, 3))
    np.testing.assert_allclose(atlas.shade(image, meta, n, v), baked.shade(n, v), rtol=1e-5,
                               atol=1e-6)
    with pytest.raises(BakeError, match="3D maps and 2D maps"):
        atlas.pack(prefilter.prefilter(probe, "lambert", "irradiance", 8))


def test_irradiance_atlas_equals_the_irradiance_map(forest):
    probe = envmap.convert(forest, "latlong", "cube", 16)
    baked = prefilter.prefilter(probe, "lambert:color=0.5/0.4/0.3", "irradiance", 16)
    image, meta = atlas.pack_irradiance(baked)
    assert image.shape == (18, 35, 3) and meta["mode"] == "atlas_irradiance"
    rng = np.random.default_rng(6)
    n = rng.normal(size=(300, 3))
    v = n + rng.normal(scale=0.7, size=(300, 3))
    np.testing.assert_allclose(atlas.shade(image, meta, n, v), baked.shade(n, v), rtol=1e-5,
                               atol=1e-6)


def test_2d_atlas_equals_the_2d_map(forest):
    probe = envmap.convert(forest, "latlong", "cube", 16)
    baked = prefilter.prefilter(probe, "ward:alpha=0.15", "2d", 16, slices=6)
    image, meta = atlas.pack(baked)
    assert image.shape == (18, 36, 3) and meta["mode"] == "atlas2d"
    np.testing.assert_allclose(image[:6, 34, 0], meta["offsets"])
    np.testing.assert_allclose(image[:6, 35], meta["k"])
    rng = np.random.default_rng(7)
    n = rng.normal(size=(300, 3))
    v = n + rng.normal(scale=0.7, size=(300, 3))
    np.testing.assert_allclose(atlas.shade(image, meta, n, v), baked.shade(n, v), rtol=1e-5,
                               atol=1e-6)


def test_split_sum_atlas_follows_the_split_sum_map(forest):
    """The node form of split-sum: levels blended at the material's roughness, DFG as k(mu)."""
    probe = envmap.convert(forest, "latlong", "cube", 32)
    baked = prefilter.prefilter(probe, "ggx:roughness=0.5", "split-sum", 32)
    image, meta = atlas.pack_split_sum(baked)
    assert meta["mode"] == "atlas2d" and meta["slices"] == 33
    rng = np.random.default_rng(9)
    n = rng.normal(size=(400, 3))
    v = n + rng.normal(scale=0.7, size=(400, 3))
    approx, exact = atlas.shade(image, meta, n, v), baked.shade(n, v)
    # Differences: the levels resampled to lat-long (2x the face size) and the
    # DFG interpolated linearly over 33 nodes in mu instead of bilinearly in a
    # 32 x 32 table: both well under 2%.
    relative = np.abs(approx - exact) / np.maximum(exact, 1e-3)
    assert np.median(relative) < 0.005 and np.percentile(relative, 95) < 0.02
