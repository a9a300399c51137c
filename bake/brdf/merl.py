"""The MERL measured-BRDF binary format (Matusik et al. 2003).

File: three little-endian int32 dimensions (n_theta_h, n_theta_d, n_phi_d),
normally (90, 90, 180), then 3 * n doubles: the red, green and blue planes,
each n values in (theta_h, theta_d, phi_d) order, stored scaled: red by
1500, green by 1500 / 1.15, blue by 1500 / 1.66. Negative values mark
missing measurements (read as 0).

Lookup as in MERL's reference code: theta_h index = floor(sqrt(theta_h / (pi/2))
* n_theta_h), theta_d index = floor(theta_d / (pi/2) * n_theta_d), phi_d index
= floor(phi_d / pi * n_phi_d) with phi_d folded into [0, pi) by reciprocity.

The header is checked before anything is allocated: each dimension must be
in [1, 1024], the total at most 2^24 values, and the file size must match.
"""

import struct
from pathlib import Path

import numpy as np

from .base import BRDF
from .params import SpecError
from .vectors import normalize

__all__ = ["MerlBRDF", "read", "write", "SCALE", "half_diff"]

SCALE = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
MAX_DIM = 1024
MAX_VALUES = 1 << 24


def half_diff(wi, wo):
    """Rusinkiewicz coordinates (theta_h, phi_h, theta_d, phi_d) of direction pairs."""
    h = normalize(np.asarray(wi) + np.asarray(wo))
    theta_h = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
    phi_h = np.arctan2(h[..., 1], h[..., 0])
    wi = np.asarray(wi, dtype=np.float64)
    c, s = np.cos(-phi_h), np.sin(-phi_h)
    x = c * wi[..., 0] - s * wi[..., 1]
    y = s * wi[..., 0] + c * wi[..., 1]
    z = wi[..., 2]
    ct, st = np.cos(-theta_h), np.sin(-theta_h)
    dx = ct * x + st * z
    dz = -st * x + ct * z
    theta_d = np.arccos(np.clip(dz, -1.0, 1.0))
    phi_d = np.arctan2(y, dx)
    return theta_h, phi_h, theta_d, phi_d


def read(path) -> np.ndarray:
    """Values (n_theta_h, n_theta_d, n_phi_d, 3) of a MERL .binary file (unscaled f_r)."""
    path = Path(path)
    if not path.is_file():
        raise SpecError(f"merl: {path}: no such file")
    size = path.stat().st_size
    with open(path, "rb") as handle:
        header = handle.read(12)
        if len(header) < 12:
            raise SpecError(f"merl: {path}: too short for a MERL header")
        dims = struct.unpack("<3i", header)
        if any(not 1 <= d <= MAX_DIM for d in dims):
            raise SpecError(f"merl: {path}: implausible dimensions {dims}")
        count = dims[0] * dims[1] * dims[2]
        if count > MAX_VALUES:
            raise SpecError(f"merl: {path}: {count} values per channel is too many")
        expected = 12 + 3 * count * 8
        if size != expected:
            raise SpecError(f"merl: {path}: {size} bytes, expected {expected} for {dims}")
        data = np.frombuffer(handle.read(), dtype="<f8", count=3 * count)
    planes = data.reshape(3, *dims).transpose(1, 2, 3, 0) * SCALE
    return np.clip(planes, 0.0, None)


def write(path, values) -> Path:
    """Write values (n_theta_h, n_theta_d, n_phi_d, 3) as a MERL .binary file."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 4 or values.shape[3] != 3:
        raise ValueError(f"values must be (n_theta_h, n_theta_d, n_phi_d, 3), got {values.shape}")
    path = Path(path)
    planes = (values / SCALE).transpose(3, 0, 1, 2)
    with open(path, "wb") as handle:
        handle.write(struct.pack("<3i", *values.shape[:3]))
        handle.write(planes.astype("<f8").tobytes())
    return path


class MerlBRDF(BRDF):
    """A measured isotropic BRDF in MERL's format (nearest lookup, as MERL's code)."""

    name = "merl"
    PARAMS = ()

    def __init__(self, values, source="array"):
        self.values = np.asarray(values, dtype=np.float64)
        self.source = str(source)
        self.params = {}

    @classmethod
    def load(cls, path):
        return cls(read(path), source=path)

    @property
    def spec(self):
        return f"merl:file={self.source}"

    def _f(self, wi, wo):
        nh, nd, npd = self.values.shape[:3]
        theta_h, _, theta_d, phi_d = half_diff(wi, wo)
        phi_d = np.where(phi_d < 0, phi_d + np.pi, phi_d)
        ih = np.clip(np.floor(np.sqrt(np.clip(theta_h / (np.pi / 2), 0, 1)) * nh), 0, nh - 1)
        idd = np.clip(np.floor(theta_d / (np.pi / 2) * nd), 0, nd - 1)
        ip = np.clip(np.floor(phi_d / np.pi * npd), 0, npd - 1)
        return self.values[ih.astype(np.intp), idd.astype(np.intp), ip.astype(np.intp)]
