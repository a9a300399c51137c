"""Lat-long (equirectangular) maps in the convention of Blender's Environment Texture.

For a direction d (world space, +Z up), exactly as Cycles' Environment
Texture node (shared/docs/CYCLES.md):

    u = 0.5 - atan2(d_y, d_x) / (2 pi),   v = 1 - acos(d_z) / pi

with v = 0 the bottom image row, so row 0 of the array (first EXR row) is the
zenith. u = 0.5 is +X, u = 0.25 is +Y, u = 0.75 is -Y. A map of size N has
shape (H, W) = (N, 2N); any H, W >= 2 is accepted as input.
"""

import math

import numpy as np

from ..errors import BakeError
from .grid import bilinear
from .layout import MAX_TEXELS, MIN_SIZE, Layout

__all__ = ["LatLong"]


class LatLong(Layout):
    name = "latlong"
    faces = 1

    def _shape(self, size):
        return size, 2 * size

    def shape(self, size):
        return self._shape(self.check_size(size))

    def size_of(self, shape):
        height, width = shape
        if height < 1 or width < MIN_SIZE:
            raise BakeError(f"lat-long image must be at least 1x2 texels, got {height}x{width}")
        if height * width > MAX_TEXELS:
            raise BakeError(f"lat-long image of {height}x{width} texels is too large")
        return height

    def directions(self, x, y, shape):
        height, width = shape
        theta = np.pi * np.asarray(y, dtype=np.float64) / height
        phi = np.pi - 2.0 * np.pi * np.asarray(x, dtype=np.float64) / width
        sin_theta = np.sin(theta)
        return np.stack([sin_theta * np.cos(phi), sin_theta * np.sin(phi), np.cos(theta)], -1)

    def coords(self, directions, shape):
        height, width = shape
        d = np.asarray(directions, dtype=np.float64)
        u = 0.5 - np.arctan2(d[..., 1], d[..., 0]) / (2.0 * np.pi)
        x = np.mod(u, 1.0) * width
        y = np.arccos(np.clip(d[..., 2], -1.0, 1.0)) / np.pi * height
        return x, y

    def jacobian(self, x, y, shape):
        height, width = shape
        theta = np.pi * np.asarray(y, dtype=np.float64) / height
        return np.sin(theta) * (np.pi / height) * (2.0 * np.pi / width) + 0.0 * np.asarray(x)

    def solid_angles(self, shape):
        height, width = shape
        cos_edges = np.cos(np.pi * np.arange(height + 1) / height)
        rows = (cos_edges[:-1] - cos_edges[1:]) * (2.0 * np.pi / width)
        return np.repeat(rows[:, None], width, axis=1)

    def pad_index(self, shape, border: int) -> np.ndarray:
        """(1, H + 2b, W + 2b) flat indices of a padded copy.

        Columns wrap around (the u seam); a row above row 0 is the row below it
        seen across the pole: row -1 - r holds row r shifted by W/2 (exact for
        even W), and likewise at the bottom pole.
        """
        height, width = shape
        rows = np.arange(-border, height + border)
        cols = np.arange(-border, width + border)
        across = (rows < 0) | (rows >= height)
        mirrored = np.where(rows >= height, 2 * height - 1 - rows, rows)
        real_rows = np.where(rows < 0, -1 - rows, mirrored)
        real_rows = np.clip(real_rows, 0, height - 1)
        shift = np.where(across, width // 2, 0)
        real_cols = np.mod(cols[None, :] + shift[:, None], width)
        return (real_rows[:, None] * width + real_cols)[None]

    def face_coords(self, directions, shape):
        """Coordinates in the pole-padded stack built by :meth:`sampler`.

        Padded row 0 is the north pole itself (at y = 0), rows 1..H the image
        rows (centres at y = i + 0.5) and row H + 1 the south pole (y = H);
        columns wrap with one extra column each side.
        """
        height = shape[0]
        x, y = self.coords(directions, shape)
        south = height + 1.0 - 2.0 * (height - y)
        py = np.where(y < 0.5, 2.0 * y, np.where(y > height - 0.5, south, y + 0.5))
        return np.zeros(np.shape(x), dtype=np.intp), x + 0.5, py

    def sampler(self, image, spacing=None):
        """Bilinear lookups continuous across the u seam and at both poles.

        Each pole takes the mean of its nearest row, so every longitude meets
        the same value there. With ``spacing`` (radians), rows whose texels
        are narrower than the sample spacing (towards the poles) are first
        box-filtered along longitude to that width, so sparse samples do not
        alias there.
        """
        image = self.check_image(image)
        shape = image.shape[:2]
        if spacing is not None:
            image = self._prefilter_rows(image, spacing)
        rows = np.concatenate(
            [image[:1].mean(axis=1, keepdims=True).repeat(image.shape[1], 1), image,
             image[-1:].mean(axis=1, keepdims=True).repeat(image.shape[1], 1)], axis=0
        )
        padded = np.concatenate([rows[:, -1:], rows, rows[:, :1]], axis=1)[None]

        def sample(directions):
            face, px, py = self.face_coords(directions, shape)
            return bilinear(padded, face, px, py)

        return sample

    def upsampled(self, image, height):
        """(height, 2 height, C) float32: :meth:`sampler` (no spacing) of a lat-long
        ``image`` (h, w, C) looked up at the texel centres of a height x 2 height
        lat-long grid, computed separably: every target row shares one source
        latitude and every target column one longitude, so the bilinear lookup is
        a lerp between two pole-padded rows, then between two wrapped columns
        (equal to the sampler to float32 rounding; no per-texel direction)."""
        image = self.check_image(image)
        rows_in, cols_in = image.shape[:2]
        y = (np.arange(height) + 0.5) * (rows_in / height)  # the sampler's coords (y, x)
        x = np.mod((np.arange(2 * height) + 0.5) / (2 * height), 1.0) * cols_in
        south = rows_in + 1.0 - 2.0 * (rows_in - y)
        py = np.where(y < 0.5, 2.0 * y, np.where(y > rows_in - 0.5, south, y + 0.5))
        px = x + 0.5
        data = image.astype(np.float32, copy=False)
        rows = np.concatenate([data[:1].mean(axis=1, keepdims=True).repeat(cols_in, 1), data,
                               data[-1:].mean(axis=1, keepdims=True).repeat(cols_in, 1)], 0)
        padded = np.concatenate([rows[:, -1:], rows, rows[:, :1]], axis=1)
        py = np.clip(py, 0.0, rows_in + 1.0)
        px = np.clip(px, 0.0, cols_in + 1.0)
        y0 = np.minimum(py.astype(np.intp), rows_in)
        x0 = np.minimum(px.astype(np.intp), cols_in)
        fy = (py - y0).astype(np.float32)[:, None, None]
        fx = (px - x0).astype(np.float32)[None, :, None]
        across = padded[y0] * (1 - fy) + padded[y0 + 1] * fy  # (height, w + 2, C)
        return across[:, x0] * (1 - fx) + across[:, x0 + 1] * fx

    def resampled(self, image, height, k, spacing=None):
        """(height, 2 height, C) float32: bake.envmap.convert.resample of :meth:`sampler`
        (``spacing`` as there) onto a height x 2 height lat-long grid with k x k
        sub-samples per texel, each weighted by the target's Jacobian, computed
        separably: a lat-long target's sub-sample rows share one source latitude
        and its columns one longitude, and its Jacobian depends on the row alone,
        so each texel's mean is the column sub-samples' mean lerp of two wrapped
        columns, then the rows' Jacobian-weighted lerp of two pole-padded rows
        (equal to resample to float32 rounding, the sums in another order;
        k (H + 2 + height) 2 height lerps instead of (k height)^2 2 directions).
        """
        image = self.check_image(image)
        if spacing is not None:
            image = self._prefilter_rows(image, spacing)
        rows_in, cols_in = image.shape[:2]
        height, k = int(height), int(k)
        offsets = (np.arange(k) + 0.5) / k
        data = image.astype(np.float32, copy=False)
        rows = np.concatenate([data[:1].mean(axis=1, keepdims=True).repeat(cols_in, 1), data,
                               data[-1:].mean(axis=1, keepdims=True).repeat(cols_in, 1)], 0)
        padded = np.concatenate([rows[:, -1:], rows, rows[:, :1]], axis=1)
        # Columns: the sampler's x of each sub-sample's longitude (coords' arctan2).
        x = (np.arange(2 * height)[:, None] + offsets[None, :]).reshape(-1)
        phi = np.pi - 2.0 * np.pi * x / (2 * height)
        u = 0.5 - np.arctan2(np.sin(phi), np.cos(phi)) / (2.0 * np.pi)
        px = np.clip(np.mod(u, 1.0) * cols_in + 0.5, 0.0, cols_in + 1.0).reshape(2 * height, k)
        x0 = np.minimum(px.astype(np.intp), cols_in)
        fx = (px - x0).astype(np.float32)
        across = np.zeros((rows_in + 2, 2 * height, data.shape[2]), np.float32)
        for a in range(k):
            t = fx[None, :, a, None]
            across += padded[:, x0[:, a]] * (1 - t) + padded[:, x0[:, a] + 1] * t
        across /= np.float32(k)
        # Rows: the sampler's pole-padded y of each sub-sample's latitude, weighted by
        # sin(theta) (the Jacobian's factor that varies; the rest cancels).
        y = np.arange(height)[:, None] + offsets[None, :]  # (height, k)
        theta = np.pi * y / height
        ys = np.arccos(np.clip(np.cos(theta), -1.0, 1.0)) / np.pi * rows_in
        south = rows_in + 1.0 - 2.0 * (rows_in - ys)
        py = np.where(ys < 0.5, 2.0 * ys, np.where(ys > rows_in - 0.5, south, ys + 0.5))
        py = np.clip(py, 0.0, rows_in + 1.0)
        y0 = np.minimum(py.astype(np.intp), rows_in)
        fy = (py - y0).astype(np.float32)
        weights = np.sin(theta)
        weights = (weights / weights.sum(axis=1, keepdims=True)).astype(np.float32)
        out = np.zeros((height, 2 * height, data.shape[2]), np.float32)
        for b in range(k):
            t = fy[:, b, None, None]
            out += weights[:, b, None, None] * (across[y0[:, b]] * (1 - t)
                                                + across[y0[:, b] + 1] * t)
        return out

    def near(self, directions, margin, shape):
        """(H, W) bool: the texels of a ``shape`` lat-long image whose centre lies within
        ``margin`` (rad; one for all, or one per direction (n,)) of any of
        ``directions`` (n, 3), conservatively (a texel's row band of
        latitudes and, per row, the longitude span the margin reaches at the band's
        smallest sine; whole rows where the band reaches a pole)."""
        height, width = shape
        d_theta, d_phi = math.pi / height, 2.0 * math.pi / width
        directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        theta = np.arccos(np.clip(directions[:, 2], -1.0, 1.0))
        margin = np.broadcast_to(np.asarray(margin, dtype=np.float64), theta.shape)
        column = np.mod(0.5 - np.arctan2(directions[:, 1], directions[:, 0]) / (2.0 * np.pi),
                        1.0) * width - 0.5
        first = np.clip(np.floor((theta - margin) / d_theta - 0.5), 0, height - 1).astype(np.intp)
        last = np.clip(np.ceil((theta + margin) / d_theta - 0.5), 0, height - 1).astype(np.intp)
        low = np.minimum(np.sin(np.clip(theta - margin, 0.0, np.pi)),
                         np.sin(np.clip(theta + margin, 0.0, np.pi)))
        polar = (theta - margin <= 0.0) | (theta + margin >= np.pi)
        with np.errstate(divide="ignore"):
            span = np.where(polar | (low <= 0.0), np.inf,
                            np.arcsin(np.minimum(np.sin(np.minimum(margin, 0.5 * math.pi))
                                                 / np.maximum(low, 1e-300), 1.0)) / d_phi)
        span = np.where(span >= 0.5 * math.pi / d_phi, np.inf, span)  # past a quarter turn: all
        # One (row, start, stop) interval per direction and row of its band, painted
        # into a difference array along each row (wrapping intervals split in two).
        rows_per = last - first + 1
        owner = np.repeat(np.arange(len(theta)), rows_per)
        rows = first[owner] + (np.arange(len(owner)) - np.repeat(np.cumsum(rows_per) - rows_per,
                                                                  rows_per))
        whole = ~np.isfinite(span[owner])
        near = np.zeros(shape, dtype=bool)
        near[np.unique(rows[whole])] = True
        rows, owner = rows[~whole], owner[~whole]
        start = np.floor(column[owner] - span[owner] - 1.0).astype(np.intp)
        stop = np.ceil(column[owner] + span[owner] + 1.0).astype(np.intp) + 1  # exclusive
        full = (stop - start) >= width
        near[np.unique(rows[full])] = True
        rows, start, stop = rows[~full], start[~full], stop[~full]
        marks = np.zeros((height, width + 1), dtype=np.int32)
        begin, end = np.mod(start, width), np.mod(start, width) + (stop - start)
        wraps = end > width
        np.add.at(marks, (rows, begin), 1)
        np.add.at(marks, (rows[~wraps], end[~wraps]), -1)
        np.add.at(marks, (rows[wraps], np.full(int(wraps.sum()), width)), -1)
        np.add.at(marks, (rows[wraps], np.zeros(int(wraps.sum()), dtype=np.intp)), 1)
        np.add.at(marks, (rows[wraps], end[wraps] - width), -1)
        near |= np.cumsum(marks, axis=1)[:, :width] > 0
        return near

    @staticmethod
    def _prefilter_rows(image, spacing):
        height, width = image.shape[:2]
        theta = np.pi * (np.arange(height) + 0.5) / height
        texel_width = np.maximum(np.sin(theta), 1e-12) * 2.0 * np.pi / width
        half = np.floor((spacing / texel_width - 1.0) / 2.0).astype(np.intp)
        half = np.clip(half, 0, (width - 1) // 2)
        if not half.any():
            return image
        out = image.copy()
        rows = np.nonzero(half)[0]
        block = image[rows].astype(np.float64)
        cumulative = np.concatenate(
            [np.zeros((rows.size, 1, image.shape[2])), np.cumsum(block, axis=1)], axis=1
        )
        total = cumulative[:, -1:, :]
        h = half[rows][:, None]
        cols = np.arange(width)[None, :]
        start, stop = cols - h, cols + h + 1

        def prefix(index):
            wraps = np.floor_divide(index, width)
            return np.take_along_axis(
                cumulative, np.mod(index, width)[:, :, None], axis=1
            ) + wraps[:, :, None] * total

        out[rows] = ((prefix(stop) - prefix(start)) / (2 * h + 1)[:, :, None]).astype(image.dtype)
        return out


LATLONG = LatLong()
