"""bake.reference.render against the per-pixel loop and against closed forms."""

import subprocess
import sys

import numpy as np
import pytest

from bake import brdf, envmap, exr, reference
from tests.conftest import ROOT
from tools.bpy_wheel import studio_lights

LUM = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def probes():
    out = {}
    for name in ("sunset.exr", "night.exr"):
        image, _ = exr.read(studio_lights() / name)
        out[name] = envmap.convert(image[..., :3], "latlong", "cube", 32)
    return out


def _pixels(count=120, seed=0):
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(count, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    v = n + rng.normal(size=(count, 3)) * 0.7  # includes grazing views
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    return n, v


def _relative_rms(a, b):
    return float(np.sqrt(np.sum(((a - b) @ LUM) ** 2) / np.sum((b @ LUM) ** 2)))


@pytest.mark.parametrize("spec", ["ggx:roughness=0.3", "ggx:roughness=0.1", "lambert",
                                  "ward:alpha=0.2", "phong:n=1000",
                                  "lafortune:cx=-0.8,cy=-0.8,cz=0.9,n=30"])
def test_adaptive_render_matches_the_per_pixel_loop(probes, spec):
    model = brdf.parse(spec)
    normals, views = _pixels()
    for probe in probes.values():
        exact = reference.reflected_radiance(model, probe, "cube", normals, views)
        fast = reference.render(model, probe, "cube", normals, views)
        # The default budget (5e-4 of a pixel's total per block, Richardson-
        # corrected) measured 1e-5..4e-4 over sunset and night; 1e-3 is a
        # tenth of the smallest method error the validation reports.
        assert _relative_rms(fast, exact) < 1e-3, spec
        every = reference.render(model, probe, "cube", normals[:20], views[:20], tolerance=0)
        np.testing.assert_allclose(every, exact[:20], rtol=1e-9, atol=1e-12)


def test_white_furnace_gives_the_albedo(probes):
    """A uniform environment L = 1 reflects the directional albedo (computed by
    bake.brdf's own MIS integration, a different quadrature)."""
    probe = np.ones((32, 192, 3))
    normals, views = _pixels(40, seed=3)
    views = np.where(np.sum(normals * views, axis=1, keepdims=True) > 0.05, views, normals)
    for spec in ("lambert", "ggx:roughness=0.4"):
        model = brdf.parse(spec)
        found = reference.render(model, probe, "cube", normals, views)
        cos_o = np.clip(np.sum(normals * views, axis=1), 0.0, 1.0)
        wo = np.stack([np.sqrt(1 - cos_o**2), 0 * cos_o, cos_o], axis=1)
        expected = model.albedo(wo)
        # The cube's 6 x 32^2 texels integrate a smooth lobe to ~0.3%.
        np.testing.assert_allclose(found, expected, rtol=6e-3, err_msg=spec)


def test_latlong_probes_and_odd_sizes(probes):
    model = brdf.parse("ggx:roughness=0.35")
    normals, views = _pixels(30, seed=5)
    image, _ = exr.read(studio_lights() / "forest.exr")
    for layout, size in (("latlong", 24), ("cube", 15)):
        probe = envmap.convert(image[..., :3], "latlong", layout, size)
        exact = reference.reflected_radiance(model, probe, layout, normals, views)
        fast = reference.render(model, probe, layout, normals, views)
        assert _relative_rms(fast, exact) < 1e-3, layout


def test_sphere_buffers_are_a_sphere_seen_through_pixel_centres():
    normals, views, mask = reference.sphere_buffers(200, distance=6.0, lens=90.0)
    assert np.allclose(np.linalg.norm(normals[mask], axis=1), 1.0)
    assert np.all(np.sum(normals[mask] * views[mask], axis=1) > -1e-9)
    # The sphere's silhouette: a cone of half-angle asin(1/6); on the 36 mm / 90 mm
    # sensor it is a disc of radius tan(asin(1/6)) / 0.2 of the half-width.
    radius = np.tan(np.arcsin(1 / 6)) / 0.2 * 100
    assert mask.sum() == pytest.approx(np.pi * radius**2, rel=0.01)
    centre = normals[100, 100]
    assert centre[1] < -0.99  # faces the camera at -Y


def test_command_line_reference(tmp_path, probes):
    probe_path = tmp_path / "probe.exr"
    exr.write(probe_path, probes["sunset.exr"].astype(np.float32), {"layout": "cube"})
    out = tmp_path / "ref.exr"
    run = subprocess.run([sys.executable, "-m", "bake", "reference", str(probe_path), "--brdf",
                          "ward:alpha=0.15", "--sphere", "24", "--reconstruction", "texels",
                          "-q", "-o", str(out)],
                         cwd=ROOT, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    image, meta = exr.read(out)
    assert meta["reconstruction"] == "texels"
    normals, views, mask = reference.sphere_buffers(24)
    np.testing.assert_array_equal(image[..., 3] > 0, mask)
    exact = reference.reflected_radiance(brdf.parse("ward:alpha=0.15"), probes["sunset.exr"],
                                         "cube", normals[mask], views[mask])
    assert _relative_rms(image[mask, :3].astype(np.float64), exact) < 1e-3
    assert meta["brdf"].startswith("ward")
    # Buffers from an EXR: normal + position + camera give the same image.
    positions = np.where(mask[..., None], normals, 0.0)  # the unit sphere's points
    buffers = tmp_path / "passes.exr"
    exr.write(buffers, {"ViewLayer.Normal": np.where(mask[..., None], normals, 0).astype(
        np.float32), "ViewLayer.Position": positions.astype(np.float32)})
    out2 = tmp_path / "ref2.exr"
    run = subprocess.run([sys.executable, "-m", "bake", "reference", str(probe_path), "--brdf",
                          "ward:alpha=0.15", "--buffers", str(buffers), "--camera", "0,-6,0",
                          "--reconstruction", "texels", "-q", "-o", str(out2)], cwd=ROOT,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    np.testing.assert_allclose(exr.read(out2)[0], image, rtol=1e-4, atol=1e-6)
    bad = subprocess.run([sys.executable, "-m", "bake", "reference", str(probe_path), "--brdf",
                          "nosuch", "--sphere", "8", "-o", str(tmp_path / "bad.exr")],
                         cwd=ROOT, capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad.exr").exists()


def test_a_line_shaped_lobe_is_refined_along_its_length():
    """Cycles' anisotropy 0.8 at roughness 0.3 is 25 times narrower across than
    along (alpha 0.018 by 0.45). The adaptive sum must find it against the exact
    sum over every texel (tolerance 0): its width is taken across the narrow axis
    and the seeds along the whole lobe force refinement. Measured on these bright
    spots: 0.09% (city and night HDRIs, 64^2 faces: 0.7% and 0.2%; before the
    narrow-axis width this test failed, and the HDRIs gave 4.7% and 6.8%);
    1.5% allowed."""
    from bake import sampling

    env = sampling.spots_environment(32, 3)
    normals, views, mask = reference.sphere_buffers(20)
    model = brdf.parse("ggx:roughness=0.3,anisotropy=0.8")
    adaptive = reference.render(model, env, "cube", normals[mask], views[mask])
    exact = reference.render(model, env, "cube", normals[mask], views[mask], tolerance=0)
    lum = np.array([0.2126, 0.7152, 0.0722])
    difference = (adaptive - exact) @ lum
    assert np.sqrt(np.mean(difference ** 2) / np.mean((exact @ lum) ** 2)) < 0.015


def _bilinear_truth(model, probe, factor, normals, views):
    """The per-pixel loop over the probe's bilinear reconstruction ``factor`` times finer."""
    fine = envmap.convert(probe, "cube", "cube", probe.shape[0] * factor, samples=1)
    return reference.reflected_radiance(model, fine, "cube", normals, views)


@pytest.mark.parametrize("spec", ["ggx:roughness=0.3", "ward:alpha=0.1"])
def test_the_bilinear_reconstruction_is_integrated_where_the_texel_sum_aliases(probes, spec):
    """A lobe a few texels wide sees the texel centres as a coarse, aliased
    quadrature of the probe's bilinear reconstruction (what a renderer samples).
    The truth here is the per-pixel loop over that reconstruction sampled 16x
    finer per side (night.exr, 32 px faces: 3.6 deg texels against 9 deg
    median lobe widths; the 8x and 16x loops agree to 1.5e-4), twice as fine as
    the factor chosen. ``reconstruction="bilinear"`` must come within 0.3% of
    it (measured below 0.1%; the 16-samples-a-width rule left 0.06-0.16% on
    the bundled HDRIs, benchmarks/reference_reconstruction.py), and the texel
    sum must be at least three times further off (measured 1.5-2.5%), so the
    option is what brings the reference to the integral."""
    model = brdf.parse(spec)
    probe = probes["night.exr"]
    normals, views = _pixels(30, seed=3)
    factor, why = reference.reconstruction_factor(model, probe.shape, "cube", normals, views)
    assert 2 <= factor <= 8 and "texels" in why
    truth = _bilinear_truth(model, probe, 16, normals, views)
    bilinear = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    texels = reference.render(model, probe, "cube", normals, views)
    error, aliased = _relative_rms(bilinear, truth), _relative_rms(texels, truth)
    assert error < 0.003, (factor, error, aliased)
    assert aliased > 3 * error, (factor, error, aliased)


def test_a_wide_lobe_keeps_the_texel_sum_and_the_factor_is_bounded(probes):
    """Where the lobe spans many texels the factor is 1 and the bilinear option is the
    texel sum itself (nothing more is computed); a probe too large for a finer
    grid within MAX_RECONSTRUCTION_TEXELS keeps its own grid and says so; an
    unknown reconstruction is refused."""
    model = brdf.parse("ggx:roughness=0.8")
    normals, views = _pixels(40)
    probe = probes["sunset.exr"]
    assert reference.reconstruction_factor(model, probe.shape, "cube", normals, views)[0] == 1
    np.testing.assert_array_equal(
        reference.render(model, probe, "cube", normals, views, reconstruction="bilinear"),
        reference.render(model, probe, "cube", normals, views))
    big = (2048, 6 * 2048)
    factor, why = reference.reconstruction_factor(brdf.parse("ggx:roughness=0.05"), big, "cube",
                                                  normals, views)
    assert factor == 1 and "memory bound" in why
    with pytest.raises(ValueError, match="reconstruction"):
        reference.render(model, probe, "cube", normals, views, reconstruction="cubic")


def _smooth_probe(face=32):
    """A cube probe of a smooth, coloured environment (exp of low-order terms in the
    direction): its bilinear reconstruction is nearly linear across a texel."""
    d = envmap.get_layout("cube").texel_directions((face, 6 * face))
    return np.exp(np.stack([1.5 * d[..., 0] + 0.5 * d[..., 1] * d[..., 2],
                            0.8 * d[..., 2] - d[..., 1], np.sin(2.0 * d[..., 0])], axis=-1))


@pytest.mark.parametrize("spec", ["ggx:roughness=0.01", "ggx:roughness=0.03",
                                  "principled:metallic=1,roughness=0.01"])
def test_a_near_mirror_lobe_sees_the_reconstruction_at_its_mirror_direction(spec, monkeypatch):
    """A lobe hundreds of times narrower than a texel (Principled Roughness 0.01,
    what Glossy reads a Roughness of 0 as: GGX alpha 1e-4) integrates the probe's
    bilinear reconstruction to its value at the mirror direction times the
    BRDF's albedo, to second order in the lobe's width: the independent truth
    (a smooth probe, 32 px faces: 2.8 deg texels against lobes of 0.004-0.1
    deg). The bilinear option must come within 0.1% of it (measured 1.4e-4 to
    2.2e-4: the lobes' cores are integrated by their own samples). The grid
    alone at the factor chosen (the cores switched off, what the reference did
    before) is 157-191% off, a lobe falling between sub-texel centres; asserted
    at least 20 times further off."""
    model = brdf.parse(spec)
    probe = _smooth_probe()
    normals, views = _pixels(200, seed=5)
    mirror = 2.0 * np.sum(normals * views, axis=1, keepdims=True) * normals - views
    frames = reference._frames(normals, None, (0.3, 0.5, 0.8))
    wo_local = np.einsum("pij,pj->pi", frames, views)
    truth = envmap.get_layout("cube").sampler(probe.astype(np.float32))(mirror) \
        * model.albedo(wo_local)
    cored = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    monkeypatch.setattr(reference, "CORE_STEPS", 0)
    grid = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    error, before = _relative_rms(cored, truth), _relative_rms(grid, truth)
    print(f"\n{spec}: cores sampled {error:.2e}, grid alone {before:.3f}")
    assert error < 1e-3
    assert before > 20 * error


def test_a_lobe_narrower_than_the_grid_matches_the_grid_that_resolves_it(probes, monkeypatch):
    """Where memory or a grazing view leaves the grid coarser than a lobe, the cores
    sampled must agree with a grid that resolves the lobe: night.exr at 32 px
    faces (3.6 deg texels, lamps a texel wide), GGX 0.2 (4.1 deg median lobe),
    the reference held to the probe's own grid (factor 1) against the texel sum
    over the reconstruction 16x finer (18 steps a lobe width; the default
    tolerance). Measured: 0.42% with the cores sampled, 48% for the grid alone.
    The 1% bound is four times the worst case of the sample count's sweep
    (CORE_SAMPLES: 0.03-0.25% at 2048 samples over 1-8x grids, two HDRIs)."""
    model = brdf.parse("ggx:roughness=0.2")
    probe = probes["night.exr"]
    normals, views = _pixels(150, seed=1)
    truth = reference.render(model, reference._bilinear_grid(probe, envmap.get_layout("cube"),
                                                             16), "cube", normals, views)
    monkeypatch.setattr(reference, "reconstruction_factor", lambda *a, **k: (1, "held"))
    cored = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    monkeypatch.setattr(reference, "CORE_STEPS", 0)
    grid = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    error, before = _relative_rms(cored, truth), _relative_rms(grid, truth)
    print(f"\ncores sampled {error:.4f}, grid alone {before:.4f}")
    assert error < 0.01
    assert before > 10 * error


def test_a_narrow_lobe_mixed_with_a_diffuse_one_is_the_sum_of_their_references(probes):
    """A dielectric's near-mirror specular part beside its diffuse part (one model,
    one sampler whose samples are a third diffuse): its reference must be the sum
    of the two parts' references, each integrated alone (the specular one by its
    core's samples, checked above; the diffuse one by the grid), within 0.1%
    (measured 3.3e-4): the core is found through the mixture, and the diffuse
    part within it is integrated by the cap's uniform samples as much as by
    the mixture's own."""
    specular, diffuse = "ggx:roughness=0.02", "lambert:color=0.6/0.5/0.4"
    probe = probes["sunset.exr"]
    normals, views = _pixels(150, seed=2)

    def ref(spec):
        return reference.render(brdf.parse(spec), probe, "cube", normals, views,
                                reconstruction="bilinear")

    together = ref(f"sum({specular}; {diffuse})")
    apart = ref(specular) + ref(diffuse)
    error = _relative_rms(together, apart)
    print(f"\nsum against parts {error:.2e}")
    assert error < 1e-3


def _importance_sampled(model, probe, normals, views, samples, seed):
    """An independent estimate of the same integral: per pixel, the mean of
    L(wi) f cos / pdf over ``samples`` stratified, jittered draws of the BRDF's own
    sampler (bake.brdf's ``sample``), L the probe's bilinear reconstruction
    (bake.envmap's cube sampler). Unbiased; its noise falls as 1 / sqrt(samples)."""
    lookup = envmap.get_layout("cube").sampler(probe)
    frames = reference._frames(normals, None, None)
    wo = np.einsum("nij,nj->ni", frames, views)
    side = int(np.sqrt(samples))
    grid = (np.stack(np.meshgrid(np.arange(side), np.arange(side), indexing="ij"), -1)
            .reshape(-1, 2) + 0.5) / side
    rng = np.random.default_rng(seed)
    out = np.zeros((len(normals), 3))
    for start in range(0, len(normals), 32):
        rows = slice(start, start + 32)
        count = len(wo[rows])
        u = (grid[None] + (rng.random((count, 1, 2)) - 0.5) / side) % 1.0
        w = np.broadcast_to(wo[rows][:, None, :], u.shape[:2] + (3,))
        wi, pdf = model.sample(w, u)
        cos = np.clip(wi[..., 2], 0.0, None)
        good = (pdf > 0) & (cos > 0) & np.all(np.isfinite(wi), -1)
        weight = np.where(good[..., None], model.f(wi, w) * cos[..., None]
                          / np.where(good, pdf, 1.0)[..., None], 0.0)
        world = np.einsum("nij,nsi->nsj", frames[rows], np.where(good[..., None], wi, 0.0))
        world[~good] = (0.0, 0.0, 1.0)
        out[rows] = np.mean(weight * lookup(world.reshape(-1, 3)).reshape(count, -1, 3), 1)
    return out


@pytest.mark.slow
@pytest.mark.parametrize("spec", ["ggx:roughness=0.1",
                                  "principled:base_color=0,metallic=0,roughness=0.05,diffuse=0"])
def test_the_bilinear_reference_equals_an_importance_sampled_integral(probes, spec):
    """The integral the map benchmarks and tests/bake/test_resolution.py measure against,
    for lobes narrower than the probe's texels (GGX 0.1 on a 32-px probe of sunset.exr,
    where the sun is a few texels; a dielectric near-mirror, whose Fresnel puts most of
    the reflection at grazing views), against an estimate by another route: the
    BRDF's own importance sampling of the same bilinear reconstruction. Two seeds of
    4096 samples agree to 0.57% / 0.23% (measured), and render is 0.35% / 0.20% from
    the first: within 1% plus that noise. The texel sum over a 3x reconstruction, the
    benchmarks' truth until stop 55, is 4.7% / 91% from it here (it fails this test)."""
    model = brdf.parse(spec)
    normals, views, mask = reference.sphere_buffers(20)
    normals, views = normals[mask], views[mask]
    probe = probes["sunset.exr"]
    truth = reference.render(model, probe, "cube", normals, views, reconstruction="bilinear")
    first = _importance_sampled(model, probe, normals, views, 4096, 1)
    second = _importance_sampled(model, probe, normals, views, 4096, 2)
    noise = _relative_rms(first, second)
    assert noise < 0.01
    assert _relative_rms(truth, first) < 0.01 + noise
