"""Environment maps: lat-long, cube, dual-paraboloid and sphere parameterizations.

Public API (see each layout module for its exact convention):

- :data:`LAYOUTS` and :func:`get_layout` -- the four parameterizations;
- ``layout.directions(x, y, shape)`` / ``layout.coords(d, shape)`` -- continuous
  texel <-> direction maps; ``layout.texel_directions(shape)`` and
  ``layout.direction_to_texel(d, shape)`` for texel centres and indices;
- ``layout.solid_angles(shape)`` -- exact per-texel solid angles (sum 4 pi);
- :func:`sample` -- bilinear lookup by direction, continuous across cube edges,
  the lat-long seam and poles;
- :func:`convert` -- any layout to any other at any size, area-correct;
- :mod:`.mip` -- solid-angle-weighted MIP pyramids with seamless borders.
"""

from ..errors import BakeError
from .convert import convert
from .cube import CUBE
from .latlong import LATLONG
from .layout import Layout
from .paraboloid import PARABOLOID
from .sphere import SPHERE

__all__ = ["LAYOUTS", "get_layout", "convert", "sample", "Layout", "radiant_power"]

LAYOUTS = {layout.name: layout for layout in (LATLONG, CUBE, PARABOLOID, SPHERE)}


def get_layout(name) -> Layout:
    """The Layout called ``name`` (``latlong``, ``cube``, ``paraboloid``, ``sphere``)."""
    if isinstance(name, Layout):
        return name
    try:
        return LAYOUTS[name]
    except (KeyError, TypeError):
        allowed = ", ".join(LAYOUTS)
        raise BakeError(
            f"unknown environment-map layout {name!r} (use one of: {allowed})"
        ) from None


def sample(image, layout, directions):
    """Bilinear radiance (..., C) of ``image`` in ``layout`` at unit directions (..., 3)."""
    return get_layout(layout).sampler(image)(directions)


def radiant_power(image, layout):
    """Sum over texels of L * d omega, per channel (C,), float64 (W/m^2 * sr units of L)."""
    import numpy as np

    layout = get_layout(layout)
    image = layout.check_image(image)
    omega = layout.solid_angles(image.shape[:2])
    return np.einsum("hw,hwc->c", omega, image.astype(np.float64))
