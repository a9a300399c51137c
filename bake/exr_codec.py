"""A pure NumPy + zlib codec for single-part scanline OpenEXR files.

Why: a Blender that links OpenEXR as a shared library (Linux distributions'
builds, Debian's 4.3 with OpenEXR 3.1) makes the OpenEXR wheel's C core
functions bind to Blender's older copy, and writing fails ("Unable to set long
name support flag"); loading the wheel with RTLD_DEEPBIND instead crashes
against Blender's jemalloc. ``bake.exr`` uses this codec for Glossy's own
files in such a process. Files it writes are ordinary OpenEXR 2 files
(tests/bake/test_exr_codec.py reads them with the OpenEXR package and reads the
package's files with this codec).

Scope, following the OpenEXR file layout document: version 2, single part,
scanline; compression NONE, RLE, ZIPS and ZIP (reading), NONE and ZIP
(writing); pixel types UINT, HALF and FLOAT; any attribute is kept as its raw
bytes, and ``string``, ``int``, ``float``, ``box2i``, ``v2f``, ``compression``,
``lineOrder`` and ``chlist`` are decoded. Tiled, deep and multi-part files,
and PIZ/PXR24/B44/DWA compression, raise :class:`ExrCodecError`.

Channels are returned and given as 2D (H, W) arrays keyed by full channel name
(``R``, ``slice.0.G``, ...); row 0 is the top of the data window.
"""

import os
import struct
import zlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

MAGIC = b"\x76\x2f\x31\x01"
COMPRESSION = {"none": 0, "rle": 1, "zips": 2, "zip": 3}
_LINES_PER_CHUNK = {0: 1, 1: 1, 2: 1, 3: 16}
_PIXEL_DTYPES = {0: np.dtype("<u4"), 1: np.dtype("<f2"), 2: np.dtype("<f4")}
_TILED, _LONG_NAMES, _DEEP, _MULTIPART = 0x200, 0x400, 0x800, 0x1000


class ExrCodecError(ValueError):
    """The bytes are not an EXR this codec reads (or are truncated)."""


class ExrCodecUnsupported(ExrCodecError):
    """A valid EXR that uses a feature outside this codec's scope."""


# --- header -------------------------------------------------------------------

def _read_cstring(data: bytes, offset: int) -> tuple[str, int]:
    end = data.find(b"\0", offset)
    if end < 0:
        raise ExrCodecError("truncated header (unterminated name)")
    return data[offset:end].decode("latin-1"), end + 1


def _decode_chlist(raw: bytes) -> list[tuple[str, int, int, int]]:
    """[(name, pixel type, x sampling, y sampling)] in file order."""
    channels, offset = [], 0
    while offset < len(raw) and raw[offset] != 0:
        name, offset = _read_cstring(raw, offset)
        if offset + 16 > len(raw):
            raise ExrCodecError("truncated channel list")
        pixel_type, _, xs, ys = struct.unpack_from("<iB3xii", raw, offset)
        offset += 16
        channels.append((name, pixel_type, xs, ys))
    return channels


def _decode_value(kind: str, raw: bytes):
    try:
        if kind == "string":
            return raw.decode("utf-8", "replace")
        if kind == "int":
            return struct.unpack("<i", raw)[0]
        if kind == "float":
            return struct.unpack("<f", raw)[0]
        if kind == "box2i":
            return tuple(struct.unpack("<4i", raw))
        if kind == "v2f":
            return tuple(struct.unpack("<2f", raw))
        if kind in ("compression", "lineOrder"):
            return raw[0]
        if kind == "chlist":
            return _decode_chlist(raw)
    except struct.error as error:
        raise ExrCodecError(f"bad {kind} attribute ({error})") from error
    return raw


def read_header(data: bytes) -> tuple[dict, int]:
    """Decoded attributes of a single-part scanline file and the offset just
    past the header."""
    if len(data) < 8 or data[:4] != MAGIC:
        raise ExrCodecError("not an OpenEXR file (wrong magic number)")
    version = struct.unpack_from("<I", data, 4)[0]
    if version & 0xFF != 2:
        raise ExrCodecError(f"unsupported OpenEXR version {version & 0xFF}")
    if version & (_TILED | _DEEP | _MULTIPART):
        raise ExrCodecUnsupported("tiled, deep and multi-part files need the OpenEXR package")
    header, offset = {}, 8
    while True:
        if offset >= len(data):
            raise ExrCodecError("truncated header")
        if data[offset] == 0:
            return header, offset + 1
        name, offset = _read_cstring(data, offset)
        kind, offset = _read_cstring(data, offset)
        if offset + 4 > len(data):
            raise ExrCodecError("truncated header")
        size = struct.unpack_from("<i", data, offset)[0]
        offset += 4
        if size < 0 or offset + size > len(data):
            raise ExrCodecError(f"truncated header (attribute {name!r})")
        header[name] = _decode_value(kind, data[offset:offset + size])
        offset += size


def _attribute(name: str, kind: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


# --- ZIP / RLE byte transforms (OpenEXR's predictor and interleave) -------------

def _unpredict_deinterleave(buffer: np.ndarray) -> bytes:
    """Undo the predictor (each byte stored as its difference to the previous
    + 128) and the split into even and odd bytes."""
    if buffer.size == 0:
        return b""
    deltas = buffer.copy()
    deltas[1:] -= np.uint8(128)  # uint8 arithmetic wraps modulo 256, as the format does
    raw = np.cumsum(deltas, dtype=np.uint8)
    out = np.empty_like(raw)
    half = (raw.size + 1) // 2
    out[0::2] = raw[:half]
    out[1::2] = raw[half:]
    return out.tobytes()


def _interleave_predict(data: bytes) -> bytes:
    raw = np.frombuffer(data, np.uint8)
    split = np.concatenate([raw[0::2], raw[1::2]])
    predicted = split.copy()
    # (d_i - d_(i-1) + 128) mod 256, which uint8 arithmetic wraps to by itself.
    np.subtract(split[1:], split[:-1], out=predicted[1:])
    predicted[1:] += np.uint8(128)
    return predicted.tobytes()


def _rle_decode(data: bytes, expected: int) -> np.ndarray:
    out = bytearray()
    offset = 0
    while offset < len(data) and len(out) < expected:
        count = struct.unpack_from("b", data, offset)[0]
        offset += 1
        if count < 0:
            out += data[offset:offset - count]
            offset -= count
        else:
            out += data[offset:offset + 1] * (count + 1)
            offset += 1
    if len(out) != expected:
        raise ExrCodecError("corrupt RLE chunk")
    return np.frombuffer(bytes(out), np.uint8)


# --- pixels --------------------------------------------------------------------

def _line_dtype(channels, width: int) -> np.dtype:
    fields = []
    for name, pixel_type, xs, ys in channels:
        if (xs, ys) != (1, 1):
            raise ExrCodecUnsupported(f"channel {name!r} is subsampled; not supported")
        if pixel_type not in _PIXEL_DTYPES:
            raise ExrCodecError(f"channel {name!r} has unknown pixel type {pixel_type}")
        fields.append((name, _PIXEL_DTYPES[pixel_type], (width,)))
    return np.dtype(fields)


def decode(data: bytes) -> tuple[dict, dict]:
    """(header, {channel name: (H, W) array of uint32/float16/float32})."""
    header, offset = read_header(data)
    try:
        channels = header["channels"]
        x0, y0, x1, y1 = header["dataWindow"]
        compression = header["compression"]
    except KeyError as error:
        raise ExrCodecError(f"header lacks the required attribute {error}") from error
    if compression not in _LINES_PER_CHUNK:
        raise ExrCodecUnsupported(f"compression type {compression} needs the OpenEXR package")
    width, height = x1 - x0 + 1, y1 - y0 + 1
    if width < 1 or height < 1:
        raise ExrCodecError("empty data window")
    line = _line_dtype(channels, width)
    per_chunk = _LINES_PER_CHUNK[compression]
    chunks = -(-height // per_chunk)
    if offset + 8 * chunks > len(data):
        raise ExrCodecError("truncated offset table")
    table = np.frombuffer(data, "<u8", count=chunks, offset=offset)
    lines = np.zeros(height, dtype=line)
    for start in table:
        start = int(start)
        if start + 8 > len(data):
            raise ExrCodecError("truncated file (chunk past the end)")
        y, size = struct.unpack_from("<ii", data, start)
        first = y - y0
        count = min(per_chunk, height - first)
        if first < 0 or count < 1 or start + 8 + size > len(data):
            raise ExrCodecError("truncated or corrupt chunk")
        payload = data[start + 8:start + 8 + size]
        expected = count * line.itemsize
        if size == expected or compression == 0:
            raw = payload
        elif compression == 1:
            raw = _unpredict_deinterleave(_rle_decode(payload, expected))
        else:
            try:
                unpacked = zlib.decompress(payload)
            except zlib.error as error:
                raise ExrCodecError(f"corrupt ZIP chunk ({error})") from error
            raw = _unpredict_deinterleave(np.frombuffer(unpacked, np.uint8))
        if len(raw) != expected:
            raise ExrCodecError("corrupt chunk (wrong uncompressed size)")
        lines[first:first + count] = np.frombuffer(raw, dtype=line, count=count)
    return header, {name: lines[name] for name, _, _, _ in channels}


def encode(planes: dict, attributes: dict | None = None, compression: str = "zip") -> bytes:
    """Bytes of a scanline OpenEXR file holding ``planes`` ({name: (H, W)
    float16 or float32}, all the same size) and extra ``string`` attributes."""
    if not planes:
        raise ValueError("nothing to encode")
    names = sorted(planes)  # the channel list is sorted by name
    arrays = [np.ascontiguousarray(planes[name]) for name in names]
    height, width = arrays[0].shape
    types = []
    for name, array in zip(names, arrays, strict=True):
        if array.shape != (height, width):
            raise ValueError(f"channel {name!r} has shape {array.shape}, not {(height, width)}")
        if array.dtype == np.float16:
            types.append(1)
        elif array.dtype == np.float32:
            types.append(2)
        else:
            raise ValueError(f"channel {name!r}: float16 or float32 only, not {array.dtype}")
    code = COMPRESSION[compression]
    chlist = b"".join(name.encode() + b"\0" + struct.pack("<iB3xii", kind, 0, 1, 1)
                      for name, kind in zip(names, types, strict=True)) + b"\0"
    window = struct.pack("<4i", 0, 0, width - 1, height - 1)
    long_names = any(len(name) > 31 for name in [*names, *(attributes or {})])
    header = [
        _attribute("channels", "chlist", chlist),
        _attribute("compression", "compression", bytes([code])),
        _attribute("dataWindow", "box2i", window),
        _attribute("displayWindow", "box2i", window),
        _attribute("lineOrder", "lineOrder", b"\0"),
        _attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        _attribute("screenWindowCenter", "v2f", struct.pack("<2f", 0.0, 0.0)),
        _attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
    ]
    for name, value in (attributes or {}).items():
        header.append(_attribute(name, "string", str(value).encode("utf-8")))
    version = 2 | (_LONG_NAMES if long_names else 0)
    head = MAGIC + struct.pack("<I", version) + b"".join(header) + b"\0"
    line = np.dtype([(name, array.dtype.newbyteorder("<"), (width,))
                     for name, array in zip(names, arrays, strict=True)])
    per_chunk = _LINES_PER_CHUNK[code]

    def chunk(first):
        count = min(per_chunk, height - first)
        records = np.empty(count, dtype=line)
        for name, array in zip(names, arrays, strict=True):
            records[name] = array[first:first + count]
        raw = records.tobytes()
        if code == 3:
            packed = zlib.compress(_interleave_predict(raw), 4)  # OpenEXR's default level
            if len(packed) < len(raw):
                raw = packed
        return struct.pack("<ii", first, len(raw)) + raw

    firsts = range(0, height, per_chunk)
    if code == 3 and height > 8 * per_chunk:
        # zlib releases the GIL while it deflates: two threads use both cores (the
        # bytes are the same, chunk by chunk, in the same order).
        with ThreadPoolExecutor(max_workers=min(2, os.cpu_count() or 1)) as pool:
            chunks = list(pool.map(chunk, firsts))
    else:
        chunks = [chunk(first) for first in firsts]
    offsets, position = [], len(head) + 8 * len(chunks)
    for chunk in chunks:
        offsets.append(position)
        position += len(chunk)
    return head + np.asarray(offsets, "<u8").tobytes() + b"".join(chunks)
