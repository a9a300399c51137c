"""Viewing aids: tonemapping and a dependency-free PNG writer, for people only.

Nothing here feeds back into a bake: radiance stays linear and unclamped in
every EXR. These helpers make contact sheets a person can look at.
"""

import struct
import zlib
from pathlib import Path

import numpy as np

from . import outputs

__all__ = ["tonemap", "write_png", "contact_sheet", "upscale"]


def tonemap(image: np.ndarray, exposure: float | None = None) -> np.ndarray:
    """Linear radiance (H, W, 3) -> sRGB-encoded uint8 (H, W, 3).

    ``exposure`` scales radiance first (default: maps the median luminance
    to 0.18); then Reinhard's L / (1 + L) per channel and the sRGB curve.
    """
    image = np.asarray(image, dtype=np.float64)[..., :3]
    if exposure is None:
        luminance = image @ np.array([0.2126, 0.7152, 0.0722])
        median = float(np.median(luminance[luminance > 0])) if np.any(luminance > 0) else 1.0
        exposure = 0.18 / max(median, 1e-8)
    x = np.clip(image * exposure, 0.0, None)
    x = x / (1.0 + x)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return np.clip(np.round(srgb * 255.0), 0, 255).astype(np.uint8)


def write_png(path, pixels: np.ndarray) -> Path:
    """Write uint8 (H, W, 3) pixels as an 8-bit RGB PNG, atomically."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise ValueError(f"pixels must have shape (H, W, 3), got {pixels.shape}")
    height, width = pixels.shape[:2]
    raw = np.concatenate([np.zeros((height, 1), np.uint8), pixels.reshape(height, -1)], axis=1)

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    data = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header)
            + chunk(b"IDAT", zlib.compress(raw.tobytes(), 6)) + chunk(b"IEND", b""))
    return outputs.atomic_write(path, lambda target: Path(target).write_bytes(data))


def upscale(image: np.ndarray, factor: int) -> np.ndarray:
    """Nearest-neighbour enlargement by an integer factor (texels stay visible)."""
    return np.repeat(np.repeat(image, factor, axis=0), factor, axis=1)


def contact_sheet(rows, gap: int = 8, background: int = 24) -> np.ndarray:
    """Arrange uint8 images row by row: ``rows`` is a list of lists of (H, W, 3)."""
    heights = [max(img.shape[0] for img in row) for row in rows]
    widths = [sum(img.shape[1] for img in row) + gap * (len(row) - 1) for row in rows]
    sheet = np.full((sum(heights) + gap * (len(rows) + 1), max(widths) + 2 * gap, 3),
                    background, np.uint8)
    top = gap
    for row, height in zip(rows, heights, strict=True):
        left = gap
        for img in row:
            sheet[top:top + img.shape[0], left:left + img.shape[1]] = img
            left += img.shape[1] + gap
        top += height + gap
    return sheet
