"""Float OpenEXR files through the ``OpenEXR`` package (3.x bindings).

Images are linear float32 arrays of shape (H, W, C), row 0 at the top, as
OpenEXR stores them. C is 1 (channel ``Y``), 3 (``R, G, B``) or 4 (``R, G, B,
A``). A file may hold several layers: channels ``<layer>.R``, ``<layer>.G``,
... (Blender's and Glossy's convention, e.g. ``slice.3.R``); they are read and
written as a dict ``{layer: array}`` where ``""`` is the unnamed layer.

Metadata is a JSON-serialisable dict stored in the header attribute
``glossy`` (a string), so every baked file carries its parameters.

Writes are atomic: the file is written beside the target under a temporary
name and renamed over it, so an interrupted write never leaves a half file.
Any compression OpenEXR supports is read (Blender's bundled HDRIs are DWAB);
files are written with ZIP compression, which every EXR reader handles.

Inside a Linux process that holds its own shared OpenEXR library (Blender),
single-part scanline files go through the NumPy codec bake.exr_codec instead
of the package (see :func:`backend`).
"""

import contextlib
import json
import os
import warnings
from pathlib import Path

import numpy as np

from . import exr_codec, outputs
from .errors import BakeError

__all__ = ["read", "write", "read_header", "read_meta", "read_parts", "write_parts", "EXR_MAGIC",
           "META_ATTRIBUTE"]

EXR_MAGIC = b"\x76\x2f\x31\x01"
META_ATTRIBUTE = "glossy"
_CHANNELS_BY_COUNT = {1: ("Y",), 3: ("R", "G", "B"), 4: ("R", "G", "B", "A")}


def _openexr_core_loaded() -> bool:
    """True when this process already holds a shared OpenEXR C library (a
    Blender on Linux: official builds ship libOpenEXRCore, distributions link
    the system one)."""
    try:
        with open("/proc/self/maps") as maps:
            return any("libOpenEXRCore" in line for line in maps)
    except OSError:  # not Linux: no flat symbol namespace, nothing to clash
        return False


def backend() -> str:
    """Which EXR implementation this process uses: ``"openexr"`` (the OpenEXR
    package) or ``"numpy"`` (bake.exr_codec).

    On Linux, inside a process that already holds a shared libOpenEXRCore
    (Blender), the package's C core functions would bind to that copy: with
    Debian's Blender 4.3 (OpenEXR 3.1) writing fails, and RTLD_DEEPBIND crashes
    against Blender's jemalloc. There Glossy's own scanline files go through
    the NumPy codec; a file outside the codec's scope (a DWAB HDRI) is still
    handed to the package for reading. GLOSSY_EXR_BACKEND=openexr|numpy
    overrides the choice (``numpy``: no fallback).
    """
    forced = os.environ.get("GLOSSY_EXR_BACKEND", "")
    if forced in ("openexr", "numpy"):
        return forced
    return "numpy" if _openexr_core_loaded() else "openexr"


def _need_openexr_package(what: str) -> None:
    if backend() == "numpy":
        raise BakeError(f"{what} need the OpenEXR package, which cannot be used inside "
                        "this Blender (it links its own OpenEXR); use the command line")


def _import_openexr():
    try:
        import OpenEXR
    except ImportError as error:  # pragma: no cover - depends on the install
        raise BakeError(
            "the OpenEXR Python package is missing (pip install OpenEXR==3.4.17)"
        ) from error
    return OpenEXR


@contextlib.contextmanager
def _quiet_native():
    """Silence the C library's own prints on fds 1 and 2 (errors become exceptions)."""
    saved = []
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
    except OSError:  # pragma: no cover
        yield
        return
    try:
        for fd in (1, 2):
            try:
                saved.append((fd, os.dup(fd)))
                os.dup2(devnull, fd)
            except OSError:  # pragma: no cover - fd not open (embedded use)
                pass
        yield
    finally:
        for fd, copy in saved:
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


def _check_readable(path: Path) -> None:
    if not path.exists():
        raise BakeError(f"{path}: no such file")
    if path.is_dir():
        raise BakeError(f"{path}: is a directory, not an EXR file")
    try:
        with open(path, "rb") as handle:
            magic = handle.read(4)
    except OSError as error:
        raise BakeError(f"{path}: cannot be read ({error.strerror})") from error
    if magic != EXR_MAGIC:
        raise BakeError(f"{path}: not an OpenEXR file (wrong magic number)")


def _decode_with_codec(path: Path):
    """(header, {channel: (H, W)}) through bake.exr_codec, or raise BakeError."""
    try:
        return exr_codec.decode(path.read_bytes())
    except exr_codec.ExrCodecError as error:
        raise BakeError(f"{path}: truncated, corrupt or unsupported OpenEXR file "
                        f"({error})") from error


def _group_planes(planes: dict) -> dict:
    """{layer: (H, W, C)} from full channel names, as the OpenEXR package groups
    them: R, G, B, A (those present, in that order) or one channel per layer."""
    groups = {}
    for name, plane in planes.items():
        layer, _, channel = name.rpartition(".")
        groups.setdefault(layer, {})[channel] = plane
    layers = {}
    for layer, channels in groups.items():
        if set(channels) <= {"R", "G", "B", "A"}:
            order = [c for c in "RGBA" if c in channels]
        elif len(channels) == 1:
            order = list(channels)
        else:
            for channel in sorted(channels):
                layers[f"{layer}.{channel}" if layer else channel] = (
                    channels[channel][:, :, None].astype(np.float32))
            continue
        layers[layer] = np.stack([channels[c] for c in order], axis=-1).astype(np.float32)
    return layers


def _open_layers(path: Path):
    """Return (header dict, {layer: float32 (H, W, C)}) or raise BakeError."""
    if backend() == "numpy":
        try:
            header, planes = _decode_with_codec(path)
            return header, _group_planes(planes)
        except BakeError as error:
            # Glossy never writes such files; a script may still read one (a DWAB
            # HDRI): try the package unless the codec was asked for explicitly.
            if not isinstance(error.__cause__, exr_codec.ExrCodecUnsupported) or \
                    os.environ.get("GLOSSY_EXR_BACKEND") == "numpy":
                raise
    OpenEXR = _import_openexr()
    try:
        with _quiet_native(), OpenEXR.File(str(path)) as exr_file:
            header = dict(exr_file.header())
            channels = {name: np.asarray(ch.pixels) for name, ch in exr_file.channels().items()}
    except (RuntimeError, ValueError, OSError, TypeError) as error:
        raise BakeError(f"{path}: truncated or corrupt OpenEXR file ({error})") from error
    layers, loose = {}, {}
    for key, pixels in channels.items():
        if pixels.dtype.kind not in "fu":
            raise BakeError(f"{path}: channel group {key!r} has unsupported type {pixels.dtype}")
        array = pixels.astype(np.float32, copy=False)
        if array.ndim == 2:
            # A lone channel the package did not group (R and G without B): kept
            # by its full name and regrouped below, never overwritten by another.
            loose[key] = array
            continue
        layers[_layer_name(key)] = array
    layers.update(_group_planes(loose))
    if not layers:
        raise BakeError(f"{path}: the file holds no image channels")
    return header, layers


def _layer_name(key: str) -> str:
    """Layer of a channel group key: 'RGB' -> '', 'slice.0' -> 'slice.0'."""
    if key in ("RGB", "RGBA", "Y", "R", "G", "B", "A"):
        return ""
    for suffix in (".RGBA", ".RGB", ".Y"):
        if key.endswith(suffix):
            return key[: -len(suffix)]
    return key


def _decode_meta(header: dict, path: Path) -> dict:
    raw = header.get(META_ATTRIBUTE)
    if raw is None:
        return {}
    if isinstance(raw, bytes):
        raw = raw.decode("utf-8", "replace")
    try:
        meta = json.loads(raw)
    except (TypeError, json.JSONDecodeError) as error:
        raise BakeError(f"{path}: header attribute '{META_ATTRIBUTE}' is not valid JSON") from error
    if not isinstance(meta, dict):
        raise BakeError(f"{path}: header attribute '{META_ATTRIBUTE}' is not a JSON object")
    return meta


def _handle_nonfinite(layers: dict, path: Path, nonfinite: str) -> None:
    bad = {name: int(np.count_nonzero(~np.isfinite(a))) for name, a in layers.items()}
    total = sum(bad.values())
    if total == 0:
        return
    if nonfinite == "error":
        raise BakeError(
            f"{path}: {total} values are NaN or infinite "
            "(use --sanitize / nonfinite='sanitize' to replace them)"
        )
    for name, array in layers.items():
        if bad[name]:
            finite = array[np.isfinite(array)]
            top = float(finite.max()) if finite.size else 0.0
            np.nan_to_num(array, copy=False, nan=0.0, posinf=max(top, 0.0), neginf=0.0)
    warnings.warn(
        f"{path}: replaced {total} NaN/infinite values (NaN and -inf by 0, +inf by the "
        "largest finite value of the layer)",
        RuntimeWarning,
        stacklevel=3,
    )


def read_meta(path) -> dict:
    """The ``glossy`` header attribute of an EXR as a dict ({} when absent), without
    decoding its pixels (BakeError for an unreadable file or a bad attribute)."""
    path = Path(path)
    return _decode_meta(read_header(path), path)


def read_header(path) -> dict:
    """The file's header attributes as a dict (OpenEXR binding values)."""
    path = Path(path)
    _check_readable(path)
    if backend() == "numpy":
        try:
            return exr_codec.read_header(path.read_bytes())[0]
        except exr_codec.ExrCodecError as error:
            raise BakeError(f"{path}: truncated, corrupt or unsupported OpenEXR file "
                            f"({error})") from error
    OpenEXR = _import_openexr()
    try:
        with _quiet_native(), OpenEXR.File(str(path), header_only=True) as exr_file:
            return dict(exr_file.header())
    except (RuntimeError, ValueError, OSError, TypeError) as error:
        raise BakeError(f"{path}: truncated or corrupt OpenEXR file ({error})") from error


def read(path, *, layers: bool = False, nonfinite: str = "error"):
    """Read a float EXR.

    Returns ``(image, meta)``: ``image`` is a float32 (H, W, C) array when the
    file holds one layer (unless ``layers=True``), otherwise a dict
    ``{layer_name: (H, W, C) array}`` with ``""`` for the unnamed layer.
    ``meta`` is the decoded ``glossy`` header attribute ({} if absent).

    ``nonfinite``: ``"error"`` (default) raises BakeError on NaN/inf texels;
    ``"sanitize"`` replaces NaN and -inf by 0 and +inf by the layer's largest
    finite value, with a RuntimeWarning.
    """
    if nonfinite not in ("error", "sanitize"):
        raise ValueError(f"nonfinite must be 'error' or 'sanitize', not {nonfinite!r}")
    path = Path(path)
    _check_readable(path)
    header, data = _open_layers(path)
    meta = _decode_meta(header, path)
    _handle_nonfinite(data, path, nonfinite)
    if not layers and len(data) == 1:
        return next(iter(data.values())), meta
    return data, meta


def _channels_for(name: str, array) -> dict:
    array = np.asarray(array)
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in _CHANNELS_BY_COUNT:
        raise ValueError(
            f"layer {name!r}: image must have shape (H, W, C) with C in 1, 3, 4; got {array.shape}"
        )
    if array.shape[0] < 1 or array.shape[1] < 1:
        raise ValueError(f"layer {name!r}: empty image of shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"layer {name!r}: refusing to write NaN or infinite values")
    prefix = f"{name}." if name else ""
    return {
        prefix + channel: np.ascontiguousarray(array[:, :, index])
        for index, channel in enumerate(_CHANNELS_BY_COUNT[array.shape[2]])
    }


def write(path, image, meta: dict | None = None, *, half: bool = False) -> Path:
    """Write ``image`` ((H, W, C) array or {layer: array}) atomically to ``path``.

    ``meta`` (JSON-serialisable dict) goes to the ``glossy`` header attribute.
    ``half=True`` stores 16-bit floats; the default is 32-bit float.
    Returns the path written.
    """
    path = Path(path)
    layers = image if isinstance(image, dict) else {"": image}
    dtype = np.float16 if half else np.float32
    channels = {}
    shape = None
    for name, array in layers.items():
        array = np.asarray(array)
        if shape is None:
            shape = array.shape[:2]
        elif array.shape[:2] != shape:
            raise ValueError(f"layer {name!r} has size {array.shape[:2]}, expected {shape}")
        for key, plane in _channels_for(name, array).items():
            channels[key] = plane.astype(dtype)
    if not channels:
        raise ValueError("nothing to write: no layers given")
    if not path.parent.is_dir():
        raise BakeError(f"{path.parent}: output folder does not exist")
    text = None if meta is None else json.dumps(meta, sort_keys=True)
    if backend() == "numpy":
        data = exr_codec.encode(channels, None if text is None else {META_ATTRIBUTE: text})
        return _atomic_write(path, lambda target: Path(target).write_bytes(data))
    OpenEXR = _import_openexr()
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if text is not None:
        header[META_ATTRIBUTE] = text
    return _atomic_write(path, lambda target: OpenEXR.File(header, channels).write(target))


def _atomic_write(path: Path, write) -> Path:
    """Call write(temporary path) beside ``path``, then rename it over ``path``
    (bake.outputs.atomic_write; the C library's prints silenced).

    On any failure the temporary file is removed and ``path`` is untouched.
    """
    def quiet(target):
        with _quiet_native():
            write(target)

    return outputs.atomic_write(path, quiet)


def write_parts(path, parts: dict, meta: dict | None = None) -> Path:
    """Write a multi-part EXR atomically: ``parts`` maps part names to (H, W, C)
    arrays of any sizes (a MIP chain, a LUT). ``meta`` goes to every part's
    ``glossy`` attribute.
    """
    _need_openexr_package("multi-part files")
    OpenEXR = _import_openexr()
    path = Path(path)
    if not parts:
        raise ValueError("nothing to write: no parts given")
    if not path.parent.is_dir():
        raise BakeError(f"{path.parent}: output folder does not exist")
    exr_parts = []
    # Parts may differ in size (data window) but must share the display window.
    height = max(np.shape(a)[0] for a in parts.values())
    width = max(np.shape(a)[1] for a in parts.values())
    display = (np.array([0, 0], np.int32), np.array([width - 1, height - 1], np.int32))
    for name, array in parts.items():
        h, w = np.shape(array)[:2]
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "displayWindow": display,
                  "dataWindow": (np.array([0, 0], np.int32), np.array([w - 1, h - 1], np.int32))}
        if meta is not None:
            header[META_ATTRIBUTE] = json.dumps(meta, sort_keys=True)
        channels = {key: plane.astype(np.float32) for key, plane in
                    _channels_for("", array).items()}
        exr_parts.append(OpenEXR.Part(header, channels, name=str(name)))
    return _atomic_write(path, lambda target: OpenEXR.File(exr_parts).write(target))


def read_parts(path, *, nonfinite: str = "error"):
    """Read every part of an EXR: ({part name: (H, W, C) float32}, meta of part 0)."""
    _need_openexr_package("multi-part files")
    OpenEXR = _import_openexr()
    path = Path(path)
    _check_readable(path)
    parts, meta = {}, {}
    try:
        with _quiet_native(), OpenEXR.File(str(path)) as exr_file:
            for index, part in enumerate(exr_file.parts):
                layers = {_layer_name(k): np.asarray(c.pixels).astype(np.float32)
                          for k, c in part.channels.items()}
                image = layers.get("", next(iter(layers.values())))
                if image.ndim == 2:
                    image = image[:, :, None]
                parts[part.name() if callable(part.name) else part.name] = image
                if index == 0:
                    meta = _decode_meta(dict(part.header), path)
    except (RuntimeError, ValueError, OSError, TypeError) as error:
        raise BakeError(f"{path}: truncated or corrupt OpenEXR file ({error})") from error
    _handle_nonfinite(parts, path, nonfinite)
    return parts, meta
