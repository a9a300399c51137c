"""Cube maps in the OpenGL cube-map convention, applied in glTF's Y-up frame.

A Blender direction (x, y, z) is first written in the Y-up frame of Blender's
glTF exporter, g = (x, z, -y); the OpenGL cube-map table then selects the
face by the major axis of g and gives (s, t) in [0, 1] within it:

    face 0 +X' (Blender +X): sc = -gz, tc = -gy      face 1 -X' (-X): sc = +gz, tc = -gy
    face 2 +Y' (Blender +Z): sc = +gx, tc = +gz      face 3 -Y' (-Z): sc = +gx, tc = -gz
    face 4 +Z' (Blender -Y): sc = +gx, tc = -gy      face 5 -Z' (+Y): sc = -gx, tc = -gy
    s = (sc / |ma| + 1) / 2,  t = (tc / |ma| + 1) / 2

s runs along the columns and t down the rows from the top. The six N x N faces
are stored left to right in that order as one strip of shape (N, 6N); side
faces then appear with +Z up. A map of size N has shape (N, 6N).
"""

import functools

import numpy as np

from ..errors import BakeError
from .grid import bilinear, gather_padded
from .layout import MAX_TEXELS, Layout

__all__ = ["Cube", "CUBE"]

#: Blender axis and sign of each face's outward normal, for docs and tests.
FACE_NAMES = ("+X", "-X", "+Z", "-Z", "-Y", "+Y")


#: GL-frame direction of face point (a, b) is _FACE_TABLE[face] @ (1, a, b).
_FACE_TABLE = np.array(
    [
        [[1, 0, 0], [0, 0, -1], [0, -1, 0]],
        [[-1, 0, 0], [0, 0, -1], [0, 1, 0]],
        [[0, 1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, 1, 0], [-1, 0, 0], [0, 0, -1]],
        [[0, 1, 0], [0, 0, -1], [1, 0, 0]],
        [[0, -1, 0], [0, 0, -1], [-1, 0, 0]],
    ],
    dtype=np.float64,
)


def _face_to_gl(face, a, b):
    """GL-frame (unnormalised) direction of face coordinates a, b in [-1, 1].

    face and a may be column arrays and b a row array (as
    bake.envmap.convert.resample passes a cube target's coordinates): the face
    table is then gathered per column, not per sub-sample, and the sums
    broadcast (the same operations on every element)."""
    face = np.asarray(face, dtype=np.intp)
    a, b = np.asarray(a), np.asarray(b)
    if face.shape != a.shape:
        face, a = np.broadcast_arrays(face, a)
    table = _FACE_TABLE[face]
    return table[..., 0] + table[..., 1] * a[..., None] + table[..., 2] * b[..., None]


def _gl_to_blender(g):
    return np.stack([g[..., 0], -g[..., 2], g[..., 1]], -1)


def face_uv(directions):
    """(face, a, b): face index and face coordinates a, b in [-1, 1] of directions."""
    d = np.asarray(directions, dtype=np.float64)
    gx, gy, gz = d[..., 0], d[..., 2], -d[..., 1]
    ax, ay, az = np.abs(gx), np.abs(gy), np.abs(gz)
    x_major = (ax >= ay) & (ax >= az)
    y_major = ~x_major & (ay >= az)
    z_major = ~x_major & ~y_major
    face = np.where(
        x_major, np.where(gx >= 0, 0, 1), np.where(y_major, np.where(gy >= 0, 2, 3), 0)
    )
    face = np.where(z_major, np.where(gz >= 0, 4, 5), face)
    sc = np.select(
        [face == 0, face == 1, face == 5],
        [-gz, gz, -gx],
        default=gx,
    )
    tc = np.select([face == 2, face == 3], [gz, -gz], default=-gy)
    major = np.maximum(np.maximum(ax, ay), az)
    major = np.where(major > 0, major, 1.0)
    return face, sc / major, tc / major


class Cube(Layout):
    name = "cube"
    faces = 6

    def _shape(self, size):
        return size, 6 * size

    def shape(self, size):
        return self._shape(self.check_size(size))

    def size_of(self, shape):
        height, width = shape
        if width != 6 * height or height < 1:
            raise BakeError(
                f"cube map must be a strip of six square faces (N x 6N), got {height}x{width}"
            )
        if height * width > MAX_TEXELS:
            raise BakeError(f"cube map of {height}x{width} texels is too large")
        return height

    def covered_texels(self, shape):
        return float(shape[0] * shape[1])

    def to_faces(self, image):
        n = image.shape[0]
        return image.reshape(n, 6, n, image.shape[2]).transpose(1, 0, 2, 3)

    def from_faces(self, stack):
        faces, n, _, channels = stack.shape
        return np.ascontiguousarray(stack.transpose(1, 0, 2, 3).reshape(n, faces * n, channels))

    def directions(self, x, y, shape):
        n = shape[0]
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        face = np.clip(np.floor(x / n), 0, 5).astype(np.intp)
        a = 2.0 * (x - face * n) / n - 1.0
        b = 2.0 * y / n - 1.0
        g = _face_to_gl(face, a, b)
        g /= np.linalg.norm(g, axis=-1, keepdims=True)
        return _gl_to_blender(g)

    def coords(self, directions, shape):
        n = shape[0]
        face, a, b = face_uv(directions)
        x = face * n + np.clip((a + 1.0) * 0.5 * n, 0.0, n)
        y = np.clip((b + 1.0) * 0.5 * n, 0.0, n)
        return x, y

    def jacobian(self, x, y, shape):
        n = shape[0]
        x = np.asarray(x, dtype=np.float64)
        face = np.clip(np.floor(x / n), 0, 5)
        a = 2.0 * (x - face * n) / n - 1.0
        b = 2.0 * np.asarray(y, dtype=np.float64) / n - 1.0
        return (2.0 / n) ** 2 * (1.0 + a * a + b * b) ** -1.5

    def solid_angles(self, shape):
        n = shape[0]
        return np.tile(_face_solid_angles(n), (1, 6))

    def face_coords(self, directions, shape):
        n = shape[0]
        face, a, b = face_uv(directions)
        # Texel-centred coordinates inside the padded face (border 1).
        return face, (a + 1.0) * 0.5 * n + 0.5, (b + 1.0) * 0.5 * n + 0.5

    def pad_index(self, shape, border: int) -> np.ndarray:
        """(6, N + 2b, N + 2b) flat indices of each face padded from its neighbours.

        A border texel at depth k beyond an edge is the texel at depth k - 1
        inside the adjacent face, found by unfolding the cube across that edge
        (Heidrich's cross-face borders); the b x b corner blocks, where three
        faces meet and no unfolding exists, are -1. Flat indices address the
        (6, N, N) face stack.
        """
        return _cube_pad_index(int(shape[0]), int(border)).copy()

    def sampler(self, image, spacing=None):
        """Bilinear lookups continuous across every face edge and cube vertex."""
        image = self.check_image(image)
        shape = image.shape[:2]
        padded = gather_padded(self.to_faces(image), self.pad_index(shape, 1), fill_corners=True)

        def sample(directions):
            face, px, py = self.face_coords(directions, shape)
            return bilinear(padded, face, px, py)

        return sample


@functools.lru_cache(maxsize=32)
def _face_solid_angles(n: int) -> np.ndarray:
    edges = np.linspace(-1.0, 1.0, n + 1)
    a, b = np.meshgrid(edges, edges)
    corner = np.arctan2(a * b, np.sqrt(a * a + b * b + 1.0))
    return corner[1:, 1:] - corner[1:, :-1] - corner[:-1, 1:] + corner[:-1, :-1]


@functools.lru_cache(maxsize=32)
def _cube_pad_index(n: int, border: int) -> np.ndarray:
    if border > n:
        raise ValueError(f"border {border} is wider than the face ({n})")
    size = n + 2 * border
    index = np.full((6, size, size), -1, dtype=np.intp)
    inner = np.arange(n)
    face_ids = np.arange(6)[:, None, None]
    index[:, border:-border or None, border:-border or None] = (
        face_ids * n * n + inner[None, :, None] * n + inner[None, None, :]
    )
    # Border positions with exactly one coordinate outside the face.
    faces, rows, cols = np.meshgrid(np.arange(6), np.arange(size), np.arange(size), indexing="ij")
    r, c = rows - border, cols - border
    out_r = (r < 0) | (r >= n)
    out_c = (c < 0) | (c >= n)
    edge = out_r ^ out_c
    faces, r, c, out_r = faces[edge], r[edge], c[edge], out_r[edge]
    depth = np.where(out_r, np.where(r < 0, -r, r - n + 1), np.where(c < 0, -c, c - n + 1))
    # A point just beyond the edge, level with the border texel's centre.
    eps = 1e-7
    along = 2.0 * (np.where(out_r, c, r) + 0.5) / n - 1.0
    beyond = np.where(np.where(out_r, r, c) < 0, -1.0 - eps, 1.0 + eps)
    a = np.where(out_r, along, beyond)
    b = np.where(out_r, beyond, along)
    g = _face_to_gl(faces, a, b)
    neighbour, na, nb = face_uv(_gl_to_blender(g / np.linalg.norm(g, axis=-1, keepdims=True)))
    px = (na + 1.0) * 0.5 * n
    py = (nb + 1.0) * 0.5 * n
    across_x = np.minimum(px, n - px) < 0.25
    col_n = np.where(across_x, 0, np.clip(np.floor(px), 0, n - 1)).astype(np.intp)
    row_n = np.where(across_x, np.clip(np.floor(py), 0, n - 1), 0).astype(np.intp)
    step_x = np.where(px < n / 2, 1, -1)
    step_y = np.where(py < n / 2, 1, -1)
    edge_x = np.where(px < n / 2, 0, n - 1)
    edge_y = np.where(py < n / 2, 0, n - 1)
    col_n = np.where(across_x, edge_x + step_x * (depth - 1), col_n)
    row_n = np.where(across_x, row_n, edge_y + step_y * (depth - 1))
    index[faces, r + border, c + border] = neighbour * n * n + row_n * n + col_n
    index.setflags(write=False)
    return index


CUBE = Cube()
