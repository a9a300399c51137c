"""Sphere maps (Heidrich; OpenGL's GL_SPHERE_MAP), seen from -Y.

The map is the image of a mirror ball seen by an orthographic camera placed
at -Y looking along +Y, with +Z up and +X to the right: the reference view
direction (from the ball to the viewer) is -Y. In that camera's eye frame
e = (x, z, -y) of a Blender direction, a reflected direction r maps to

    m = sqrt(r_x^2 + r_y^2 + (r_z + 1)^2),   (X, Y) = (r_x, r_y) / m

with (X, Y) in the unit disk, X to the right and Y up; the centre is the
direction back to the viewer (-Y) and the rim is +Y, straight behind the
ball. Solid angle is uniform in (X, Y): d omega = 4 dX dY, so each texel's
solid angle is 4 times its area inside the disk. Texels outside the disk
hold the rim direction (+Y). A map of size N has shape (N, N).
"""

import functools

import numpy as np

from ..errors import BakeError
from .grid import bilinear, disk_clipped_integral
from .layout import MAX_TEXELS, MIN_SIZE, Layout

__all__ = ["Sphere", "SPHERE"]


def _inner_area(x, y0, y1):
    return (y1 - y0) + 0.0 * x


class Sphere(Layout):
    name = "sphere"
    faces = 1

    def _shape(self, size):
        return size, size

    def shape(self, size):
        return self._shape(self.check_size(size))

    def size_of(self, shape):
        height, width = shape
        if width != height or height < MIN_SIZE:
            raise BakeError(f"sphere map must be square, got {height}x{width}")
        if height * width > MAX_TEXELS:
            raise BakeError(f"sphere map of {height}x{width} texels is too large")
        return height

    def covered_texels(self, shape):
        return float(shape[0] * shape[1]) * np.pi / 4.0

    @staticmethod
    def _disk(x, y, n):
        big_x = 2.0 * np.asarray(x, dtype=np.float64) / n - 1.0
        big_y = 1.0 - 2.0 * np.asarray(y, dtype=np.float64) / n
        return big_x, big_y

    def directions(self, x, y, shape):
        big_x, big_y = self._disk(x, y, shape[0])
        rho2 = big_x * big_x + big_y * big_y
        scale = np.where(rho2 > 1.0, 1.0 / np.sqrt(np.maximum(rho2, 1e-300)), 1.0)
        big_x, big_y = big_x * scale, big_y * scale
        z = np.sqrt(np.clip(1.0 - big_x * big_x - big_y * big_y, 0.0, None))
        eye = np.stack([2.0 * big_x * z, 2.0 * big_y * z, 2.0 * z * z - 1.0], -1)
        direction = np.stack([eye[..., 0], -eye[..., 2], eye[..., 1]], -1)
        return direction / np.linalg.norm(direction, axis=-1, keepdims=True)

    def coords(self, directions, shape):
        n = shape[0]
        d = np.asarray(directions, dtype=np.float64)
        ex, ey, ez = d[..., 0], d[..., 2], -d[..., 1]
        m = np.sqrt(ex * ex + ey * ey + (ez + 1.0) ** 2)
        safe = m > 1e-12
        big_x = np.where(safe, ex / np.where(safe, m, 1.0), 1.0)
        big_y = np.where(safe, ey / np.where(safe, m, 1.0), 0.0)
        return (big_x + 1.0) * 0.5 * n, (1.0 - big_y) * 0.5 * n

    def jacobian(self, x, y, shape):
        n = shape[0]
        big_x, big_y = self._disk(x, y, n)
        inside = big_x * big_x + big_y * big_y <= 1.0
        return np.where(inside, 4.0 * (2.0 / n) ** 2, 1e-12)

    def solid_angles(self, shape):
        return _sphere_solid_angles(int(shape[0]))

    def sampler(self, image, spacing=None):
        image = self.check_image(image)
        shape = image.shape[:2]
        stack = image[None]

        def sample(directions):
            face, px, py = self.face_coords(directions, shape)
            return bilinear(stack, face, px, py)

        return sample


@functools.lru_cache(maxsize=16)
def _sphere_solid_angles(n: int) -> np.ndarray:
    edges = np.linspace(-1.0, 1.0, n + 1)
    return 4.0 * disk_clipped_integral(edges, _inner_area)[::-1].copy()


SPHERE = Sphere()
