"""bake.sampling_runtime: the constants and NumPy twin of the runtime-sampling
nodes, against bake.sampling's estimator, the BRDF's own albedo, a frame
rotation and an EXR round trip."""

import numpy as np
import pytest

from bake import brdf, exr, sampling, sampling_runtime
from bake.errors import BakeError
from bake.sampling_atlas import AtlasProbe

ISOTROPIC = "ggx:roughness=0.3"
ANISOTROPIC = "ggx:roughness=0.3,anisotropy=0.8,rotation=0.1"


def _pixels(count=1500, seed=1):
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    v = rng.normal(size=(count, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    v = np.where((np.sum(n * v, axis=1) < 0)[:, None], -v, v)
    keep = np.sum(n * v, axis=1) > 0.05
    n, v = n[keep], v[keep]
    t = np.cross(n, (0.2, 0.3, 0.9))
    return n, v, t / np.linalg.norm(t, axis=1, keepdims=True)


def _luminance(x):
    return x @ np.array([0.2126, 0.7152, 0.0722])


@pytest.mark.parametrize("spec", [ISOTROPIC, ANISOTROPIC])
def test_the_twin_is_bake_sampling_estimator_on_the_same_levels(spec):
    """Same pattern, warp, threshold and levels; the twin differs only by the
    tabulated albedo (32 x 9 bilinear entries of a 1024-sample integral) and
    the wo_z floor at the rim: measured 0.2% / 0.4% relative RMS; 1% allowed."""
    env = sampling.spots_environment(32)
    n, v, t = _pixels()
    atlas, meta = sampling_runtime.pack(env, spec)
    twin = sampling_runtime.shade(atlas, meta, n, v, t)
    estimator = sampling.render_regular(brdf.parse(spec), env, n, v, tangents=t,
                                        mip=AtlasProbe(atlas, meta))
    error = np.sqrt(np.mean((_luminance(twin) - _luminance(estimator)) ** 2))
    assert error / np.mean(_luminance(estimator)) < 0.01
    assert len(meta["disk"]) == (19 if spec == ISOTROPIC else 14)


@pytest.mark.parametrize("spec", [ISOTROPIC, ANISOTROPIC, "principled_metallic:roughness=0.4"])
def test_a_constant_environment_returns_the_albedo(spec):
    """Eq. 18: a constant environment L comes back as rho(wo) L; the table holds rho
    on a 32 x 9 grid, so its bilinear interpolation is the only error: measured
    under 0.5% at 99% of the views, at most 1.7% at grazing views of the
    anisotropic lobe, whose albedo turns fastest with azimuth there (allowed:
    1% and 2.5%)."""
    env = np.full((16, 96, 3), 2.0, np.float32)
    n, v, t = _pixels(800)
    atlas, meta = sampling_runtime.pack(env, spec)
    out = sampling_runtime.shade(atlas, meta, n, v, t)
    model = brdf.parse(spec)
    from bake.reference import _frames
    frames = _frames(n, t, None)
    wo = np.einsum("bij,bj->bi", frames, v)
    truth = 2.0 * model.albedo(wo, samples=4096)
    relative = np.abs(out - truth) / truth
    assert np.percentile(relative, 99) < 0.01
    assert relative.max() < 0.025


def test_turning_the_tangent_is_turning_the_lobe():
    """rotation = 0.25 turn with tangent t equals rotation 0 with the tangent turned
    a quarter turn about n (y = n x t): the frame convention of Cycles' closures."""
    env = sampling.spots_environment(16)
    n, v, t = _pixels(600)
    turned = sampling_runtime.pack(env, "ggx:roughness=0.4,anisotropy=0.7,rotation=0.25")
    plain = sampling_runtime.pack(env, "ggx:roughness=0.4,anisotropy=0.7")
    a = sampling_runtime.shade(*turned, n, v, t)
    b = sampling_runtime.shade(*plain, n, v, np.cross(n, t))
    np.testing.assert_allclose(a, b, rtol=2e-3, atol=1e-6)
    # and the lobe does turn: without the turned tangent the result differs
    c = sampling_runtime.shade(*plain, n, v, t)
    assert np.max(np.abs(_luminance(a) - _luminance(c)) / _luminance(a)) > 0.1


def test_the_atlas_survives_an_exr_round_trip(tmp_path):
    env = sampling.spots_environment(16)
    atlas, meta = sampling_runtime.pack(env, ANISOTROPIC)
    exr.write(tmp_path / "r.exr", atlas, meta)
    back, back_meta = exr.read(tmp_path / "r.exr")
    n, v, t = _pixels(300)
    np.testing.assert_allclose(sampling_runtime.shade(back[..., :3], back_meta, n, v, t),
                               sampling_runtime.shade(atlas, meta, n, v, t), rtol=1e-6)


def test_bad_input_is_refused():
    env = sampling.spots_environment(8)
    with pytest.raises(BakeError, match="GGX"):
        sampling_runtime.pack(env, "beckmann:roughness=0.3")
    with pytest.raises(BakeError, match="no sampler"):
        sampling_runtime.pack(env, "ward:alpha=0.2")
    with pytest.raises(BakeError, match="beyond the largest pattern"):
        sampling_runtime.pack(env, ISOTROPIC, budget=10000)
    with pytest.raises(BakeError, match="not a runtime"):
        sampling_runtime.shade(np.zeros((8, 8, 3)), {"mode": "atlas3d"}, np.eye(3), np.eye(3))
