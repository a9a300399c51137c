"""Regularly sampled BRDF tables with multilinear interpolation.

- :class:`IsotropicTable`: values (Ni, No, Np, 3) at theta_i, theta_o on
  [0, pi/2] (inclusive, Ni and No nodes) and phi_d = |phi_i - phi_o| folded to
  [0, pi] (Np nodes, inclusive).
- :class:`AnisotropicTable`: values (Ni, Pi, No, Po, 3) at theta_i, phi_i,
  theta_o, phi_o; theta on [0, pi/2] inclusive, phi periodic on [0, 2 pi) with
  Pi / Po nodes at k 2 pi / P.

Both behave as any analytic model (cosine-hemisphere sampling). Tables are
built from any model (``from_model``) or loaded from ``.npz`` files with a
``values`` array (spec ``table:file=PATH``).
"""

from pathlib import Path

import numpy as np

from .base import BRDF, register
from .params import Param, SpecError

__all__ = ["IsotropicTable", "AnisotropicTable", "load_table"]

MAX_TABLE_VALUES = 1 << 28


def _linear_index(coordinate, nodes, periodic=False):
    """(i0, i1, t) for linear interpolation on nodes 0..nodes-1 at real ``coordinate``."""
    if periodic:
        base = np.floor(coordinate)
        t = coordinate - base
        i0 = np.mod(base.astype(np.intp), nodes)
        return i0, np.mod(i0 + 1, nodes), t
    coordinate = np.clip(coordinate, 0.0, nodes - 1.0)
    i0 = np.minimum(np.floor(coordinate).astype(np.intp), max(nodes - 2, 0))
    t = coordinate - i0
    return i0, np.minimum(i0 + 1, nodes - 1), t


def _multilinear(values, indices):
    """Interpolate values (..dims.., 3) with per-axis (i0, i1, t) tuples."""
    dims = len(indices)
    out = 0.0
    for corner in range(1 << dims):
        weight = 1.0
        index = []
        for axis, (i0, i1, t) in enumerate(indices):
            upper = (corner >> axis) & 1
            index.append(i1 if upper else i0)
            weight = weight * (t if upper else 1.0 - t)
        out = out + np.asarray(weight)[..., None] * values[tuple(index)]
    return out


def _angles(w):
    theta = np.arccos(np.clip(w[..., 2], -1.0, 1.0))
    phi = np.arctan2(w[..., 1], w[..., 0])
    return theta, phi


class _Table(BRDF):
    PARAMS = (Param("file", None, 0, 0, "path of a .npz table"),)

    def __init__(self, values, source="array"):
        values = np.asarray(values, dtype=np.float64)
        self._check(values)
        self.values = np.clip(values, 0.0, None)
        self.source = str(source)
        self.params = {}

    @property
    def spec(self):
        return f"table:file={self.source}"

    def spec_hash(self):
        import hashlib

        return hashlib.sha256(self.values.tobytes()).hexdigest()[:16]


@register
class IsotropicTable(_Table):
    """Isotropic table over (theta_i, theta_o, phi_d); reciprocal if the data are."""

    name = "table"

    @staticmethod
    def _check(values):
        if values.ndim != 4 or values.shape[-1] != 3 or min(values.shape[:3]) < 2:
            raise SpecError(f"isotropic table must be (Ni, No, Np, 3) with sizes >= 2, got "
                            f"{values.shape}")

    @classmethod
    def from_model(cls, model, shape=(32, 32, 33)):
        ni, no, npd = shape
        ti = np.linspace(0, np.pi / 2, ni)[:, None, None]
        to = np.linspace(0, np.pi / 2, no)[None, :, None]
        pd = np.linspace(0, np.pi, npd)[None, None, :]
        ti, to, pd = np.broadcast_arrays(ti, to, pd)
        eps = 1e-6  # nodes on the horizon evaluate just above it
        ti_c = np.minimum(ti, np.pi / 2 - eps)
        to_c = np.minimum(to, np.pi / 2 - eps)
        wi = np.stack([np.sin(ti_c) * np.cos(pd), np.sin(ti_c) * np.sin(pd), np.cos(ti_c)], -1)
        wo = np.stack([np.sin(to_c), np.zeros_like(to_c), np.cos(to_c)], -1)
        return cls(model.f(wi, wo), source=f"<{model.spec} {ni}x{no}x{npd}>")

    def _f(self, wi, wo):
        ni, no, npd = self.values.shape[:3]
        theta_i, phi_i = _angles(wi)
        theta_o, phi_o = _angles(wo)
        phi_d = np.abs(np.mod(phi_i - phi_o + np.pi, 2 * np.pi) - np.pi)
        indices = [_linear_index(theta_i / (np.pi / 2) * (ni - 1), ni),
                   _linear_index(theta_o / (np.pi / 2) * (no - 1), no),
                   _linear_index(phi_d / np.pi * (npd - 1), npd)]
        return _multilinear(self.values, indices)


class AnisotropicTable(_Table):
    """Anisotropic 4D table over (theta_i, phi_i, theta_o, phi_o)."""

    name = "table4d"
    isotropic = False

    @staticmethod
    def _check(values):
        if values.ndim != 5 or values.shape[-1] != 3 or min(values.shape[:4]) < 2:
            raise SpecError(f"anisotropic table must be (Ni, Pi, No, Po, 3), got {values.shape}")

    @classmethod
    def from_model(cls, model, shape=(16, 32, 16, 32)):
        ni, pi_, no, po = shape
        eps = 1e-6
        ti = np.minimum(np.linspace(0, np.pi / 2, ni), np.pi / 2 - eps)[:, None, None, None]
        fi = (np.arange(pi_) * 2 * np.pi / pi_)[None, :, None, None]
        to = np.minimum(np.linspace(0, np.pi / 2, no), np.pi / 2 - eps)[None, None, :, None]
        fo = (np.arange(po) * 2 * np.pi / po)[None, None, None, :]
        ti, fi, to, fo = np.broadcast_arrays(ti, fi, to, fo)
        wi = np.stack([np.sin(ti) * np.cos(fi), np.sin(ti) * np.sin(fi), np.cos(ti)], -1)
        wo = np.stack([np.sin(to) * np.cos(fo), np.sin(to) * np.sin(fo), np.cos(to)], -1)
        return cls(model.f(wi, wo), source=f"<{model.spec} {ni}x{pi_}x{no}x{po}>")

    def _f(self, wi, wo):
        ni, pi_, no, po = self.values.shape[:4]
        theta_i, phi_i = _angles(wi)
        theta_o, phi_o = _angles(wo)
        indices = [_linear_index(theta_i / (np.pi / 2) * (ni - 1), ni),
                   _linear_index(np.mod(phi_i, 2 * np.pi) / (2 * np.pi) * pi_, pi_, True),
                   _linear_index(theta_o / (np.pi / 2) * (no - 1), no),
                   _linear_index(np.mod(phi_o, 2 * np.pi) / (2 * np.pi) * po, po, True)]
        return _multilinear(self.values, indices)


def load_table(path):
    """A table model from an .npz file holding ``values`` (4D isotropic or 5D anisotropic)."""
    path = Path(path)
    if not path.is_file():
        raise SpecError(f"table: {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as data:
            if "values" not in data:
                raise SpecError(f"table: {path}: no 'values' array in the file")
            shape = data["values"].shape
            if int(np.prod(shape)) > MAX_TABLE_VALUES:
                raise SpecError(f"table: {path}: {shape} is too large")
            values = data["values"]
    except (OSError, ValueError) as error:
        raise SpecError(f"table: {path}: cannot read ({error})") from error
    cls = IsotropicTable if values.ndim == 4 else AnisotropicTable
    return cls(values, source=path)
