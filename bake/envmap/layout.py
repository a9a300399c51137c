"""The interface every environment-map parameterization implements.

A layout maps between directions (world space, Blender's right-handed +Z-up
frame, unit vectors of shape (..., 3)) and continuous image coordinates
(x, y): x in [0, W] along columns, y in [0, H] down the rows, texel (i, j)
covering [j, j + 1] x [i, i + 1]. Images are (H, W, C) float arrays, row 0 at
the top.
"""

import numpy as np

from ..errors import BakeError
from .grid import bilinear

__all__ = ["Layout", "MAX_TEXELS", "MIN_SIZE"]

MIN_SIZE = 2
#: Largest image a layout accepts, in texels (about 1 GiB of float32 RGB).
MAX_TEXELS = 1 << 26


class Layout:
    """Base class; subclasses set ``name`` and implement the geometry."""

    name = ""
    #: Number of faces of the internal face stack (F, h, w, C).
    faces = 1

    # --- sizes ---------------------------------------------------------
    def shape(self, size: int) -> tuple[int, int]:
        """Image shape (H, W) of a map of the given size (see the subclass)."""
        raise NotImplementedError

    def check_size(self, size) -> int:
        """Validate a user-given size; returns it as int or raises BakeError."""
        try:
            value = int(size)
        except (TypeError, ValueError):
            raise BakeError(f"size must be a whole number, not {size!r}") from None
        if value != size or value < MIN_SIZE:
            raise BakeError(f"size must be a whole number >= {MIN_SIZE}, not {size!r}")
        height, width = self._shape(value)
        if height * width > MAX_TEXELS:
            largest = self.largest_size()
            raise BakeError(
                f"size {value} is too large for a {self.name} map "
                f"({height}x{width} texels); the largest is {largest}"
            )
        return value

    def largest_size(self) -> int:
        size = MIN_SIZE
        while True:
            height, width = self._shape(size * 2)
            if height * width > MAX_TEXELS:
                break
            size *= 2
        low, high = size, size * 2
        while high - low > 1:
            mid = (low + high) // 2
            h, w = self._shape(mid)
            low, high = (mid, high) if h * w <= MAX_TEXELS else (low, mid)
        return low

    def _shape(self, size: int) -> tuple[int, int]:
        raise NotImplementedError

    def check_image(self, image) -> np.ndarray:
        """Validate an (H, W, C) image for this layout; returns it as a float array."""
        image = np.asarray(image)
        if image.ndim == 2:
            image = image[:, :, None]
        if image.ndim != 3 or image.shape[2] < 1:
            raise BakeError(f"{self.name} image must have shape (H, W, C), got {image.shape}")
        if image.dtype.kind != "f":
            image = image.astype(np.float32)
        self.size_of(image.shape[:2])
        return image

    def size_of(self, shape) -> int:
        """The size of a map of image shape (H, W); raises BakeError if none fits."""
        raise NotImplementedError

    def covered_texels(self, shape) -> float:
        """How many texels of this shape cover the sphere once (for sampling rates)."""
        return float(shape[0] * shape[1])

    # --- geometry --------------------------------------------------------
    def directions(self, x, y, shape) -> np.ndarray:
        """Unit directions (..., 3) at continuous image coordinates x, y (...)."""
        raise NotImplementedError

    def coords(self, directions, shape):
        """Continuous image coordinates (x, y) of unit directions (..., 3)."""
        raise NotImplementedError

    def jacobian(self, x, y, shape) -> np.ndarray:
        """Solid angle per unit texel area (sr per texel^2) at (x, y)."""
        raise NotImplementedError

    def solid_angles(self, shape) -> np.ndarray:
        """Exact solid angle (sr) of every texel, (H, W) float64; sums to 4 pi."""
        raise NotImplementedError

    def texel_directions(self, shape) -> np.ndarray:
        """Directions (H, W, 3) of the texel centres."""
        height, width = shape
        y, x = np.mgrid[0:height, 0:width] + 0.5
        return self.directions(x, y, shape)

    def direction_to_texel(self, directions, shape):
        """Integer (row, col) of the texel containing each direction."""
        height, width = shape
        x, y = self.coords(directions, shape)
        col = np.clip(np.floor(x).astype(np.intp), 0, width - 1)
        row = np.clip(np.floor(y).astype(np.intp), 0, height - 1)
        return row, col

    # --- face stacks and sampling ---------------------------------------
    def to_faces(self, image: np.ndarray) -> np.ndarray:
        """(H, W, C) image -> (F, h, w, C) face stack (a view where possible)."""
        return image[None]

    def from_faces(self, stack: np.ndarray) -> np.ndarray:
        """(F, h, w, C) face stack -> (H, W, C) image."""
        return stack[0]

    def face_coords(self, directions, shape):
        """(face, px, py): face index and texel-centred coordinates within it."""
        x, y = self.coords(directions, shape)
        return np.zeros(np.shape(x), dtype=np.intp), x - 0.5, y - 0.5

    def sampler(self, image: np.ndarray, spacing: float | None = None):
        """A function directions (..., 3) -> bilinear values (..., C).

        ``spacing`` (radians) is the distance between the directions the
        caller will sample; layouts whose texels are locally much smaller
        (lat-long rows near the poles) prefilter so that sampling at that
        spacing does not alias.
        """
        image = self.check_image(image)
        stack = self.to_faces(image)
        shape = image.shape[:2]

        def sample(directions):
            face, px, py = self.face_coords(directions, shape)
            return bilinear(stack, face, px, py)

        return sample
