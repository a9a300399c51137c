"""bake.exr: round trips, Blender's DWAB files, metadata, atomic writes, bad input."""

import os

import numpy as np
import OpenEXR
import pytest

from bake import exr
from bake.errors import BakeError


def _distinct(shape, channels, seed=0):
    rng = np.random.default_rng(seed)
    image = rng.uniform(0.0, 100.0, size=(*shape, channels)).astype(np.float32)
    image[..., 0] += 1000.0  # channels stay distinguishable: order errors show
    return image


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_round_trip_is_bit_exact(tmp_path, channels):
    image = _distinct((7, 11), channels)
    path = exr.write(tmp_path / "a.exr", image, {"layout": "latlong", "k": [1, 2]})
    back, meta = exr.read(path)
    assert back.dtype == np.float32 and back.shape == image.shape
    np.testing.assert_array_equal(back, image)
    assert meta == {"layout": "latlong", "k": [1, 2]}


def test_layers_round_trip_with_their_names(tmp_path):
    layers = {"slice.0": _distinct((5, 10), 3, 1), "slice.1": _distinct((5, 10), 3, 2),
              "lobe1.slice.0": _distinct((5, 10), 3, 3)}
    exr.write(tmp_path / "l.exr", layers)
    back, meta = exr.read(tmp_path / "l.exr")
    assert meta == {} and set(back) == set(layers)
    for name, image in layers.items():
        np.testing.assert_array_equal(back[name], image)
    # Channel names follow the <layer>.<R|G|B> convention other tools expect.
    with OpenEXR.File(str(tmp_path / "l.exr"), separate_channels=True) as handle:
        assert "slice.1.G" in handle.channels()


def test_single_named_layer_can_be_read_as_dict(tmp_path):
    exr.write(tmp_path / "s.exr", {"slice.0": _distinct((3, 6), 3)})
    back, _ = exr.read(tmp_path / "s.exr", layers=True)
    assert list(back) == ["slice.0"]


def test_half_precision_write(tmp_path):
    image = _distinct((4, 4), 3)
    exr.write(tmp_path / "h.exr", image, half=True)
    back, _ = exr.read(tmp_path / "h.exr")
    np.testing.assert_allclose(back, image, rtol=2**-10)  # half has a 10-bit mantissa


def test_reads_blenders_dwab_hdri(hdri_dir):
    header = exr.read_header(hdri_dir / "forest.exr")
    assert header["compression"] == OpenEXR.DWAB_COMPRESSION
    image, meta = exr.read(hdri_dir / "forest.exr")
    assert image.shape == (512, 1024, 3) and image.dtype == np.float32
    # DWAB is lossy: it leaves tiny negative values around dark texels.
    assert np.isfinite(image).all() and image.min() > -0.01 and image.max() > 10.0
    assert meta == {}


def test_missing_directory_and_non_exr_inputs(tmp_path):
    with pytest.raises(BakeError, match="no such file"):
        exr.read(tmp_path / "missing.exr")
    with pytest.raises(BakeError, match="is a directory"):
        exr.read(tmp_path)
    text = tmp_path / "text.exr"
    text.write_text("not an image\n")
    with pytest.raises(BakeError, match="not an OpenEXR file"):
        exr.read(text)
    empty = tmp_path / "empty.exr"
    empty.write_bytes(b"")
    with pytest.raises(BakeError, match="not an OpenEXR file"):
        exr.read(empty)


@pytest.mark.parametrize("fraction", [0.3, 0.7, 0.95])
def test_truncated_files_are_rejected(tmp_path, hdri_dir, fraction):
    small = exr.write(tmp_path / "zip.exr", _distinct((64, 64), 3))
    for source in (hdri_dir / "forest.exr", small):
        data = source.read_bytes()
        cut = tmp_path / f"cut_{source.name}"
        cut.write_bytes(data[: int(len(data) * fraction)])
        with pytest.raises(BakeError, match="truncated or corrupt"):
            exr.read(cut)


def _write_raw(path, image):
    channels = {name: np.ascontiguousarray(image[..., i]) for i, name in enumerate("RGB")}
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 channels).write(str(path))


def test_nonfinite_input_errors_or_is_sanitized(tmp_path):
    image = _distinct((4, 5), 3)
    image[0, 0, 0] = np.nan
    image[1, 1, 1] = np.inf
    image[2, 2, 2] = -np.inf
    _write_raw(tmp_path / "nan.exr", image)
    with pytest.raises(BakeError, match="3 values are NaN or infinite"):
        exr.read(tmp_path / "nan.exr")
    with pytest.warns(RuntimeWarning, match="replaced 3"):
        clean, _ = exr.read(tmp_path / "nan.exr", nonfinite="sanitize")
    finite = np.isfinite(image)
    assert np.isfinite(clean).all()
    np.testing.assert_array_equal(clean[finite], image[finite])
    assert clean[0, 0, 0] == 0.0 and clean[2, 2, 2] == 0.0
    assert clean[1, 1, 1] == image[finite].max()  # the layer's largest finite value


def test_failed_writes_leave_no_file_and_keep_the_old_one(tmp_path):
    target = tmp_path / "keep.exr"
    exr.write(target, _distinct((4, 4), 3, 5))
    before = target.read_bytes()
    bad = _distinct((4, 4), 3)
    bad[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        exr.write(target, bad)
    with pytest.raises(ValueError, match="C in 1, 3, 4"):
        exr.write(target, np.zeros((4, 4, 2), np.float32))
    with pytest.raises(BakeError, match="does not exist"):
        exr.write(tmp_path / "no" / "such" / "dir.exr", _distinct((4, 4), 3))
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["keep.exr"]


def test_write_is_atomic_when_the_library_fails(tmp_path, monkeypatch):
    target = tmp_path / "atomic.exr"
    exr.write(target, _distinct((4, 4), 3, 7))
    before = target.read_bytes()

    class Exploding:
        def __init__(self, *args):
            pass

        def write(self, path):
            with open(path, "wb") as handle:
                handle.write(b"\x76\x2f\x31\x01 half")  # a partial file, then failure
            raise RuntimeError("disk full")

    monkeypatch.setattr(OpenEXR, "File", Exploding)
    with pytest.raises(BakeError, match="disk full"):
        exr.write(target, _distinct((4, 4), 3))
    assert target.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["atomic.exr"]
