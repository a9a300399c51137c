"""A world's Environment Texture as Blender renders it: Mapping node and Strength.

Artists turn an HDRI with a Mapping node between Texture Coordinate and the
Environment Texture, and brighten it with the Background's Strength. A probe
resampled from the image alone ("World Only") must apply both, or it shows
the world turned and at the wrong brightness against what Cycles renders.

:class:`WorldMapping` holds the Mapping node's type and its Location,
Rotation (Euler XYZ, radians) and Scale, and the Background's Strength, and
applies them as Cycles does (svm_mapping: POINT ``R (v * s) + l``, TEXTURE
``R^T (v - l) / s``, VECTOR ``R (v * s)``, NORMAL ``normalize(R (v / s))``,
with R = Rz Ry Rx and a division by a zero scale giving 0). The texture then
looks up the lat-long image in the direction of the mapped vector (the
Environment Texture normalizes it), so :meth:`WorldMapping.texture_directions`
returns unit vectors. World directions are Blender's (+Z up), shape (..., 3).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import BakeError

__all__ = ["WorldMapping", "euler_xyz", "VECTOR_TYPES"]

VECTOR_TYPES = ("POINT", "TEXTURE", "VECTOR", "NORMAL")


def euler_xyz(rotation) -> np.ndarray:
    """(3, 3) rotation matrix of Blender's Euler XYZ angles (rad): Rz @ Ry @ Rx."""
    x, y, z = (float(a) for a in rotation)
    cx, sx, cy, sy, cz, sz = math.cos(x), math.sin(x), math.cos(y), math.sin(y), \
        math.cos(z), math.sin(z)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cx, -sx], [0.0, sx, cx]])
    ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    rz = np.array([[cz, -sz, 0.0], [sz, cz, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def _safe_divide(a, b):
    b = np.asarray(b, dtype=np.float64)
    return np.where(b != 0.0, a / np.where(b != 0.0, b, 1.0), 0.0)


@dataclass(frozen=True)
class WorldMapping:
    """How a world shows its lat-long image: a Mapping node and the Background's Strength.

    vector_type: one of VECTOR_TYPES; location, rotation (Euler XYZ, rad), scale:
    the node's inputs; strength: the Background's Strength (a scalar).
    The default is the identity (no Mapping node, Strength 1).
    """

    vector_type: str = "POINT"
    location: tuple = (0.0, 0.0, 0.0)
    rotation: tuple = (0.0, 0.0, 0.0)
    scale: tuple = (1.0, 1.0, 1.0)
    strength: float = 1.0
    _matrix: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        if self.vector_type not in VECTOR_TYPES:
            raise BakeError(f"unknown Mapping type {self.vector_type!r} "
                            f"(use one of: {', '.join(VECTOR_TYPES)})")
        values = [*self.location, *self.rotation, *self.scale, self.strength]
        if len(values) != 10 or not all(math.isfinite(float(v)) for v in values):
            raise BakeError("the world's Mapping and Strength must be finite numbers")
        if self.strength < 0:
            raise BakeError(f"the world's Background Strength is negative ({self.strength:g})")
        object.__setattr__(self, "_matrix", euler_xyz(self.rotation))

    @property
    def moves_directions(self) -> bool:
        """False when every world direction looks up the image in the same direction
        (no rotation, a uniform positive scale, no location that shifts points)."""
        scale = np.asarray(self.scale, dtype=np.float64)
        uniform = bool(np.all(scale > 0) and np.ptp(scale) == 0)
        shifted = self.vector_type in ("POINT", "TEXTURE") and any(self.location)
        return bool(any(self.rotation) or not uniform or shifted)

    @property
    def is_identity(self) -> bool:
        """True when the world is its image as it is (nothing to apply)."""
        return not self.moves_directions and self.strength == 1.0

    def texture_directions(self, directions):
        """Unit lookup directions (..., 3) of the image for world directions (..., 3).

        A mapped vector of zero length (a zero scale on every axis) looks up +X
        (Cycles divides by its zero length there: the result is undefined).
        """
        v = np.asarray(directions, dtype=np.float64)
        r = self._matrix
        location = np.asarray(self.location, dtype=np.float64)
        scale = np.asarray(self.scale, dtype=np.float64)
        if self.vector_type == "POINT":
            out = (v * scale) @ r.T + location
        elif self.vector_type == "TEXTURE":
            out = _safe_divide((v - location) @ r, scale)
        elif self.vector_type == "VECTOR":
            out = (v * scale) @ r.T
        else:  # NORMAL (normalized below anyway)
            out = _safe_divide(v, scale) @ r.T
        length = np.linalg.norm(out, axis=-1, keepdims=True)
        fallback = np.zeros_like(out)
        fallback[..., 0] = 1.0
        return np.where(length > 0, out / np.where(length > 0, length, 1.0), fallback)

    def to_meta(self) -> dict:
        """The parameters as plain JSON values (recorded in a probe's header)."""
        return {"vector_type": self.vector_type, "location": [float(v) for v in self.location],
                "rotation": [float(v) for v in self.rotation],
                "scale": [float(v) for v in self.scale], "strength": float(self.strength)}
