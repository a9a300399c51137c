"""``python -m bake convert`` / ``mip`` as a user runs them."""

import os
import subprocess
import sys

import numpy as np
import pytest

from bake import exr
from tests.conftest import ROOT


def run_bake(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bake", *map(str, args)], cwd=cwd or ROOT,
                          env=env, capture_output=True, text=True, timeout=300)


def test_convert_writes_a_map_with_its_parameters(hdri_dir, tmp_path, forest):
    out = tmp_path / "forest_cube.exr"
    result = run_bake("convert", hdri_dir / "forest.exr", "--to", "cube", "--size", "256",
                      "-o", out)
    assert result.returncode == 0, result.stderr
    assert f"wrote {out}" in result.stdout
    # 1024 x 512 -> 6 x 256^2 is large enough for a progress line.
    assert "%]" in result.stderr and "resampling" in result.stderr
    image, meta = exr.read(out)
    assert image.shape == (256, 1536, 3)
    assert meta["layout"] == "cube" and meta["size"] == 256 and meta["source"] == "forest.exr"
    assert meta["source_layout"] == "latlong" and "glTF" in meta["convention"]
    from bake.envmap import convert
    np.testing.assert_array_equal(image, convert(forest, "latlong", "cube", 256))

    # The layout is read back from the metadata: paraboloid and lat-long share a shape.
    par = tmp_path / "p.exr"
    assert run_bake("convert", out, "--to", "paraboloid", "--size", "32", "-o", par,
                    "-q").returncode == 0
    back = tmp_path / "l.exr"
    result = run_bake("convert", par, "--to", "latlong", "--size", "16", "-o", back, "-q")
    assert result.returncode == 0 and exr.read(back)[1]["source_layout"] == "paraboloid"


def test_mip_writes_every_level(tmp_path):
    cube = tmp_path / "c.exr"
    exr.write(cube, np.ones((16, 96, 3), np.float32), {"layout": "cube"})
    result = run_bake("mip", cube, "--filter", "gauss6", "-o", tmp_path / "p.exr")
    assert result.returncode == 0, result.stderr
    sizes = [exr.read(tmp_path / f"p.mip{k}.exr")[0].shape[0] for k in range(5)]
    assert sizes == [16, 8, 4, 2, 1]


def _bad_inputs(tmp_path, hdri_dir):
    text = tmp_path / "notes.exr"
    text.write_text("this is text\n")
    truncated = tmp_path / "cut.exr"
    truncated.write_bytes((hdri_dir / "forest.exr").read_bytes()[:200_000])
    forest = hdri_dir / "forest.exr"
    return {
        "missing": ([tmp_path / "nope.exr", "--to", "cube", "--size", "8"], "no such file"),
        "text": ([text, "--to", "cube", "--size", "8"], "not an OpenEXR file"),
        "truncated": ([truncated, "--to", "cube", "--size", "8"], "truncated or corrupt"),
        "size0": ([forest, "--to", "cube", "--size", "0"], "size must be"),
        "huge": ([forest, "--to", "cube", "--size", "1000000"], "too large"),
        "target": ([forest, "--to", "octahedral", "--size", "8"], "invalid choice"),
        "notint": ([forest, "--to", "cube", "--size", "big"], "invalid int value"),
    }


@pytest.mark.parametrize("case", ["missing", "text", "truncated", "size0", "huge", "target",
                                  "notint"])
def test_bad_input_gives_one_line_and_no_file(tmp_path, hdri_dir, case):
    args, message = _bad_inputs(tmp_path, hdri_dir)[case]
    out = tmp_path / "out.exr"
    result = run_bake("convert", *args, "-o", out)
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert message in lines[0] and "Traceback" not in result.stderr
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if "partial" in p.name]


def test_failed_run_keeps_an_existing_output(tmp_path, hdri_dir):
    out = tmp_path / "keep.exr"
    exr.write(out, np.ones((4, 8, 3), np.float32))
    before = out.read_bytes()
    result = run_bake("convert", hdri_dir / "forest.exr", "--to", "cube", "--size", "0", "-o", out)
    assert result.returncode == 2 and out.read_bytes() == before


def test_nan_input_is_refused_unless_sanitized(tmp_path):
    import OpenEXR

    image = np.ones((8, 16, 3), np.float32)
    image[2, 3, 1] = np.nan
    path = tmp_path / "nan.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {c: np.ascontiguousarray(image[..., i]) for i, c in enumerate("RGB")}
                 ).write(str(path))
    out = tmp_path / "o.exr"
    result = run_bake("convert", path, "--to", "cube", "--size", "4", "-o", out)
    assert result.returncode == 2 and "NaN" in result.stderr and not out.exists()
    result = run_bake("convert", path, "--to", "cube", "--size", "4", "-o", out, "--sanitize")
    assert result.returncode == 0 and "warning: " in result.stderr and out.exists()


def test_brdf_command_describes_and_plots(tmp_path):
    plot = tmp_path / "ggx.png"
    result = run_bake("brdf", "ggx:roughness=0.4,anisotropy=0.3", "--plot", plot)
    assert result.returncode == 0, result.stderr
    assert "spec: ggx:roughness=0.4,anisotropy=0.3,rotation=0,color=1" in result.stdout
    assert "albedo at theta_o =  0.0 deg" in result.stdout
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and plot.stat().st_size > 10_000


@pytest.mark.parametrize(("spec", "message"), [
    ("ggx:roughness=3", "roughness=3 is out of range [0.01, 1]"),
    ("corduroy", "unknown BRDF 'corduroy'"),
    ("ward:alpha=0.1,shine=2", "unknown key 'shine'"),
])
def test_brdf_command_bad_spec_is_one_line(tmp_path, spec, message):
    plot = tmp_path / "p.png"
    result = run_bake("brdf", spec, "--plot", plot)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0]
    assert not plot.exists()


def test_fit_and_prefilter_commands(tmp_path, hdri_dir):
    fit = tmp_path / "fit.json"
    result = run_bake("fit", "--brdf", "ggx:roughness=0.4", "--slices", "4", "-o", fit, "-q")
    assert result.returncode == 0, result.stderr
    assert "relative RMS error" in result.stdout and fit.exists()
    out = tmp_path / "g3d.exr"
    result = run_bake("prefilter", hdri_dir / "forest.exr", "--brdf", "ggx:roughness=0.4",
                      "--size", "32", "--slices", "4", "-o", out)
    assert result.returncode == 0, result.stderr
    assert "%]" in result.stderr  # progress line
    from bake import prefilter

    baked = prefilter.load(out)
    assert baked.mode == "3d" and baked.meta["slices"] == 4 and baked.meta["source"] == "forest.exr"
    assert out.with_suffix(".json").exists()
    for mode in ("split-sum", "2d"):
        path = tmp_path / f"{mode}.exr"
        assert run_bake("prefilter", hdri_dir / "forest.exr", "--brdf", "ggx:roughness=0.4",
                        "--mode", mode, "--size", "16", "-o", path, "-q").returncode == 0
        assert prefilter.load(path).mode == mode
    irr = tmp_path / "irr.exr"
    assert run_bake("irradiance", hdri_dir / "forest.exr", "--size", "16", "-o", irr,
                    "--method", "sh", "-q").returncode == 0
    assert prefilter.load(irr).meta["method"] == "sh"


@pytest.mark.parametrize(("args", "message"), [
    (["--brdf", "lambert:color=0", "--size", "16"], "reflects nothing"),
    (["--brdf", "ggx:roughness=0.3", "--size", "16", "--slices", "1"], "slices must be"),
    (["--brdf", "ggx:roughness=0.3", "--size", "99999"], "size must be"),
    (["--brdf", "ggx:roughness=0.3", "--size", "16", "--mode", "split-sum", "--levels", "9"],
     "levels must be"),
    (["--brdf", "ggx:roughnes=0.3", "--size", "16"], "unknown key"),
    (["--brdf", "ggx:roughness=0.3", "--size", "big"], "must be a whole number or 'auto'"),
    (["--brdf", "ggx:roughness=0.3", "--mode", "split-sum"], "needs a face size"),
    (["--brdf", "ggx:roughness=0.3", "--size", "2048", "--slices", "256"], "GiB"),
])
def test_prefilter_bad_input_is_one_line_and_no_file(tmp_path, hdri_dir, args, message):
    out = tmp_path / "bad.exr"
    result = run_bake("prefilter", hdri_dir / "forest.exr", *args, "-o", out, "-q")
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2 and len(lines) == 1 and message in lines[0]
    assert not out.exists() and not out.with_suffix(".json").exists()


def test_prefilter_auto_size_is_the_default_and_says_why(tmp_path, hdri_dir):
    out = tmp_path / "auto.exr"
    result = run_bake("prefilter", hdri_dir / "forest.exr", "--brdf", "ggx:roughness=0.6",
                      "--slices", "4", "--max-size", "64", "-o", out, "-q")
    assert result.returncode == 0, result.stderr
    from bake import prefilter

    baked = prefilter.load(out)
    assert baked.meta["size"] <= 64 and baked.meta["size_reason"] in result.stdout
    assert baked.meta["size_reason"].startswith(f"{baked.meta['size']} rows")


def test_prefilter_refuses_a_nan_probe(tmp_path):
    import OpenEXR

    image = np.ones((8, 48, 3), np.float32)
    image[1, 2, 0] = np.nan
    path = tmp_path / "nan.exr"
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 {c: np.ascontiguousarray(image[..., i]) for i, c in enumerate("RGB")}
                 ).write(str(path))
    out = tmp_path / "o.exr"
    result = run_bake("prefilter", path, "--brdf", "ggx:roughness=0.3", "--size", "8", "-o", out)
    assert result.returncode == 2 and "NaN" in result.stderr and not out.exists()
