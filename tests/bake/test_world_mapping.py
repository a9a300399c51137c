"""bake.world_mapping: Blender's Mapping node on world directions, checked against
closed forms (a turn about +Z is a shift of the lat-long image's columns; the
TEXTURE type undoes the POINT type; Euler XYZ is Rz Ry Rx). Cycles itself is
the reference in tests/blender/test_world_mapping.py."""

import math

import numpy as np
import pytest

from bake.envmap import convert, get_layout
from bake.errors import BakeError
from bake.world_mapping import WorldMapping, euler_xyz


def _image(rows=16):
    rng = np.random.default_rng(3)
    return rng.uniform(0.1, 2.0, (rows, 2 * rows, 3)).astype(np.float32)


@pytest.mark.parametrize("shift", [1, 5, -3])
def test_a_turn_about_z_shifts_the_latlong_columns(shift):
    image = _image()
    width = image.shape[1]
    mapping = WorldMapping(rotation=(0.0, 0.0, 2.0 * math.pi * shift / width))
    # One sub-sample per texel at the source's own size: each texel centre maps
    # onto another texel centre, so the bilinear lookup is exact (the polar rows'
    # longitude box filter is the same in both conversions).
    turned = convert(image, "latlong", "latlong", image.shape[0], samples=1,
                     transform=mapping.texture_directions)
    still = convert(image, "latlong", "latlong", image.shape[0], samples=1)
    np.testing.assert_allclose(still[1:-1], image[1:-1], rtol=1e-6)
    # u = 0.5 - azimuth / 2 pi: the lookup turned by +angle reads the column
    # ``shift`` to the left, so the image moves ``shift`` columns to the right.
    np.testing.assert_allclose(turned, np.roll(still, shift, axis=1), rtol=1e-5, atol=1e-6)
    assert np.abs(turned - still).max() > 0.1


def test_texture_type_is_the_inverse_of_point_type():
    rotation = (0.4, -1.1, 2.5)
    d = get_layout("latlong").texel_directions((8, 16)).reshape(-1, 3)
    there = WorldMapping("POINT", rotation=rotation).texture_directions(d)
    back = WorldMapping("TEXTURE", rotation=rotation).texture_directions(there)
    np.testing.assert_allclose(back, d, atol=1e-12)


def test_euler_xyz_applies_x_then_y_then_z():
    x, y, z = 0.3, -0.7, 1.9
    single = [euler_xyz((x, 0, 0)), euler_xyz((0, y, 0)), euler_xyz((0, 0, z))]
    np.testing.assert_allclose(euler_xyz((x, y, z)), single[2] @ single[1] @ single[0],
                               atol=1e-15)
    # +90 degrees about X takes +Z to -Y (right-handed).
    np.testing.assert_allclose(euler_xyz((math.pi / 2, 0, 0)) @ [0, 0, 1], [0, -1, 0],
                               atol=1e-15)


def test_scale_and_location_change_directions_only_where_the_type_uses_them():
    d = np.array([[0.6, 0.0, 0.8]])
    assert not WorldMapping(scale=(2.0, 2.0, 2.0)).moves_directions
    assert WorldMapping(scale=(1.0, 1.0, 2.0)).moves_directions
    assert not WorldMapping("VECTOR", location=(1.0, 0.0, 0.0)).moves_directions
    squashed = WorldMapping(scale=(1.0, 1.0, 0.0)).texture_directions(d)
    np.testing.assert_allclose(squashed, [[1.0, 0.0, 0.0]])
    shifted = WorldMapping("POINT", location=(0.0, 0.0, -0.8)).texture_directions(d)
    np.testing.assert_allclose(shifted, [[1.0, 0.0, 0.0]])
    assert WorldMapping().is_identity and not WorldMapping(strength=2.0).is_identity


def test_bad_values_are_refused():
    with pytest.raises(BakeError, match="Strength is negative"):
        WorldMapping(strength=-1.0)
    with pytest.raises(BakeError, match="finite"):
        WorldMapping(rotation=(0.0, float("nan"), 0.0))
    with pytest.raises(BakeError, match="Mapping type"):
        WorldMapping("SPIRAL")
