"""Dual-paraboloid maps (Heidrich & Seidel), with the extended [-1, 1]^2 domain.

The front paraboloid faces +Z (world up, the sky hemisphere), the back one -Z.
For a unit direction d, in the front half (d_z >= 0)

    (s, t) = (d_x, d_y) / (1 + d_z)

and in the back half (d_z < 0) ``(s, t) = (d_x, d_y) / (1 - d_z)``, so a rim
point (s, t) names the same horizon direction in both halves and they join
without mirroring. The image is 2N wide and N high: the front half on the
left, the back half on the right; within a half s runs along the columns
(+X to the right) and t up the rows (+Y at the top).

Each half covers the whole square [-1, 1]^2, not just the unit disk: a texel
outside the disk holds the direction the paraboloid formula gives there,

    d = (2s, 2t, +-(1 - s^2 - t^2)) / (1 + s^2 + t^2),

which lies slightly in the other hemisphere. This "extended domain" lets
bilinear filtering and MIP-mapping near the rim read valid data. Only the
disk part of a texel counts in its solid angle, so the solid angles of a map
sum to 4 pi.
"""

import functools

import numpy as np

from ..errors import BakeError
from .grid import bilinear, disk_clipped_integral
from .layout import MAX_TEXELS, MIN_SIZE, Layout

__all__ = ["Paraboloid", "PARABOLOID"]


def _inner_paraboloid(x, y0, y1):
    """Integral over y in [y0, y1] of the paraboloid Jacobian 4 / (1 + x^2 + y^2)^2."""
    a2 = 1.0 + x * x
    a = np.sqrt(a2)

    def antiderivative(y):
        return 2.0 * y / (a2 * (a2 + y * y)) + 2.0 * np.arctan(y / a) / (a2 * a)

    return antiderivative(y1) - antiderivative(y0)


class Paraboloid(Layout):
    name = "paraboloid"
    faces = 2

    def _shape(self, size):
        return size, 2 * size

    def shape(self, size):
        return self._shape(self.check_size(size))

    def size_of(self, shape):
        height, width = shape
        if width != 2 * height or height < MIN_SIZE:
            raise BakeError(
                f"dual-paraboloid map must be two square halves (N x 2N), got {height}x{width}"
            )
        if height * width > MAX_TEXELS:
            raise BakeError(f"dual-paraboloid map of {height}x{width} texels is too large")
        return height

    def covered_texels(self, shape):
        return float(shape[0] * shape[1]) * np.pi / 4.0

    def to_faces(self, image):
        n = image.shape[0]
        return image.reshape(n, 2, n, image.shape[2]).transpose(1, 0, 2, 3)

    def from_faces(self, stack):
        faces, n, _, channels = stack.shape
        return np.ascontiguousarray(stack.transpose(1, 0, 2, 3).reshape(n, faces * n, channels))

    @staticmethod
    def _half_st(x, y, n):
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        half = np.clip(np.floor(x / n), 0, 1).astype(np.intp)
        s = 2.0 * (x - half * n) / n - 1.0
        t = 1.0 - 2.0 * y / n
        return half, s, t

    def directions(self, x, y, shape):
        half, s, t = self._half_st(x, y, shape[0])
        r2 = s * s + t * t
        z = (1.0 - r2) * np.where(half == 0, 1.0, -1.0)
        return np.stack([2.0 * s, 2.0 * t, z], -1) / (1.0 + r2)[..., None]

    def _half_coords(self, directions, n):
        d = np.asarray(directions, dtype=np.float64)
        back = d[..., 2] < 0
        denominator = 1.0 + np.abs(d[..., 2])
        s = d[..., 0] / denominator
        t = d[..., 1] / denominator
        return back.astype(np.intp), (s + 1.0) * 0.5 * n, (1.0 - t) * 0.5 * n

    def coords(self, directions, shape):
        n = shape[0]
        half, px, py = self._half_coords(directions, n)
        return half * n + np.clip(px, 0.0, n), np.clip(py, 0.0, n)

    def jacobian(self, x, y, shape):
        n = shape[0]
        _, s, t = self._half_st(x, y, n)
        return (2.0 / n) ** 2 * 4.0 / (1.0 + s * s + t * t) ** 2

    def solid_angles(self, shape):
        return np.tile(_half_solid_angles(int(shape[0])), (1, 2))

    def face_coords(self, directions, shape):
        """Half index and texel-centred coordinates in the padded halves (border 1)."""
        half, px, py = self._half_coords(directions, shape[0])
        return half, px + 0.5, py + 0.5

    def sampler(self, image, spacing=None):
        """Bilinear lookups, continuous across the rim where the two halves meet.

        Each half gets a one-texel border continuing its extended domain: a
        border texel holds the direction the paraboloid formula gives at its
        centre (always in the other hemisphere), looked up in the other half.
        Where the disk touches the square's sides a lookup then interpolates
        across the rim instead of clamping to a texel inside it.
        """
        image = self.check_image(image)
        shape = image.shape[:2]
        n = shape[0]
        stack = self.to_faces(image)
        padded = np.zeros((2, n + 2, n + 2, stack.shape[3]), dtype=stack.dtype)
        padded[:, 1:-1, 1:-1] = stack
        border = np.ones((n + 2, n + 2), dtype=bool)
        border[1:-1, 1:-1] = False
        rows, cols = np.nonzero(border)
        for half in (0, 1):
            x = half * n + (cols - 0.5)  # border texel centres, outside [0, n]
            d = self._extended_directions(half, x - half * n, rows - 0.5, n)
            other = np.full(rows.shape, 1 - half)
            _, px, py = self._half_coords(d, n)
            padded[half, rows, cols] = bilinear(padded[:, 1:-1, 1:-1], other, px - 0.5, py - 0.5)

        def sample(directions):
            face, px, py = self.face_coords(directions, shape)
            return bilinear(padded, face, px, py)

        return sample

    @staticmethod
    def _extended_directions(half, x, y, n):
        """Directions at in-half coordinates x, y (may lie outside [0, n])."""
        s = 2.0 * np.asarray(x, dtype=np.float64) / n - 1.0
        t = 1.0 - 2.0 * np.asarray(y, dtype=np.float64) / n
        r2 = s * s + t * t
        z = (1.0 - r2) * (1.0 if half == 0 else -1.0)
        return np.stack([2.0 * s, 2.0 * t, z], -1) / (1.0 + r2)[..., None]


@functools.lru_cache(maxsize=16)
def _half_solid_angles(n: int) -> np.ndarray:
    edges = np.linspace(-1.0, 1.0, n + 1)
    # disk_clipped_integral has y ascending with the row; image rows go down in t.
    return disk_clipped_integral(edges, _inner_paraboloid)[::-1].copy()


PARABOLOID = Paraboloid()
