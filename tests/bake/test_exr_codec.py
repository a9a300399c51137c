"""bake.exr_codec against the OpenEXR package: each reads what the other writes."""

import numpy as np
import OpenEXR
import pytest

from bake import exr, exr_codec
from bake.errors import BakeError


def _planes(rng, height=37, width=29):
    return {
        "R": (rng.random((height, width)) * 100).astype(np.float32),
        "G": rng.random((height, width)).astype(np.float32),
        "B": np.full((height, width), 1.0, np.float32),  # long runs: ZIP actually packs
        "slice.0.R": rng.standard_normal((height, width)).astype(np.float16),
        "a.layer.name.longer.than.31.characters.R": rng.random((height, width)).astype(
            np.float32),
    }


@pytest.mark.parametrize("compression", ["zip", "none"])
@pytest.mark.parametrize("height", [37, 301])  # 301: ZIP chunks deflated on two threads
def test_openexr_package_reads_codec_files_exactly(tmp_path, compression, height):
    planes = _planes(np.random.default_rng(1), height=height)
    path = tmp_path / "codec.exr"
    path.write_bytes(exr_codec.encode(planes, {"glossy": '{"k": 1}'}, compression))
    with OpenEXR.File(str(path), separate_channels=True) as handle:
        channels = handle.channels()
        assert handle.header()["glossy"] == '{"k": 1}'
        assert sorted(channels) == sorted(planes)
        for name, plane in planes.items():
            assert channels[name].pixels.dtype == plane.dtype
            np.testing.assert_array_equal(channels[name].pixels, plane)


@pytest.mark.parametrize("compression", ["ZIP_COMPRESSION", "ZIPS_COMPRESSION",
                                         "RLE_COMPRESSION", "NO_COMPRESSION"])
def test_codec_reads_package_files_exactly(tmp_path, compression):
    rng = np.random.default_rng(2)
    image = rng.random((53, 41, 4)).astype(np.float32)
    image[10:20] = 0.5  # runs for RLE
    path = tmp_path / "package.exr"
    header = {"compression": getattr(OpenEXR, compression), "type": OpenEXR.scanlineimage,
              "glossy": "{}"}
    OpenEXR.File(header, {"RGBA": image}).write(str(path))
    decoded_header, planes = exr_codec.decode(path.read_bytes())
    assert decoded_header["glossy"] == "{}"
    assert decoded_header["dataWindow"] == (0, 0, 40, 52)
    np.testing.assert_array_equal(np.stack([planes[c] for c in "RGBA"], -1), image)


def test_exr_module_round_trips_through_either_backend(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    layers = {"": rng.random((8, 16, 3)).astype(np.float32),
              "slice.1": rng.random((8, 16, 4)).astype(np.float32),
              "mask": rng.random((8, 16, 1)).astype(np.float32)}
    meta = {"layout": "latlong", "n": 3}
    for writer, reader in (("numpy", "openexr"), ("openexr", "numpy"), ("numpy", "numpy")):
        monkeypatch.setenv("GLOSSY_EXR_BACKEND", writer)
        path = exr.write(tmp_path / f"{writer}.exr", layers, meta)
        monkeypatch.setenv("GLOSSY_EXR_BACKEND", reader)
        got, got_meta = exr.read(path, layers=True)
        assert got_meta == meta
        assert sorted(got) == sorted(layers), (writer, reader)
        for name, array in layers.items():
            np.testing.assert_array_equal(got[name], array, err_msg=f"{writer}->{reader}")


def test_codec_refuses_what_it_cannot_read(tmp_path, hdri_dir, monkeypatch):
    data = exr_codec.encode({"Y": np.ones((20, 20), np.float32)})
    with pytest.raises(exr_codec.ExrCodecError, match="magic"):
        exr_codec.decode(b"P6\n" + data)
    for cut in (10, len(data) // 2, len(data) - 3):
        with pytest.raises(exr_codec.ExrCodecError):
            exr_codec.decode(data[:cut])
    # forest.exr is DWAB-compressed: one clear message naming what would read it.
    monkeypatch.setenv("GLOSSY_EXR_BACKEND", "numpy")
    with pytest.raises(BakeError, match="needs the OpenEXR package"):
        exr.read(hdri_dir / "forest.exr")
    with pytest.raises(BakeError, match="multi-part"):
        exr.write_parts(tmp_path / "parts.exr", {"a": np.ones((2, 2, 3))})
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("backend", ["openexr", "numpy"])
def test_read_meta_is_the_header_read_without_the_pixels(tmp_path, monkeypatch, backend):
    """exr.read_meta gives what exr.read gives as metadata, through either backend,
    without decoding pixels (attach reads only this before Blender loads the
    image); a file without Glossy metadata gives {}."""
    monkeypatch.setenv("GLOSSY_EXR_BACKEND", backend)
    meta = {"mode": "atlas3d", "slices": 4, "mu": [0.1, 0.5]}
    image = np.random.default_rng(5).random((300, 40, 3)).astype(np.float32)
    path = exr.write(tmp_path / "meta.exr", image, meta)
    assert exr.read_meta(path) == exr.read(path)[1] == meta
    decoded = []
    monkeypatch.setattr(exr_codec, "decode", lambda *a, **k: decoded.append(1))
    assert exr.read_meta(path) == meta and decoded == []
    plain = exr.write(tmp_path / "plain.exr", image)
    assert exr.read_meta(plain) == {}
