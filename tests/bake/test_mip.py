"""MIP pyramids: constants, power conservation, positivity and no seams at cube edges."""

import numpy as np
import pytest

from bake.envmap import convert, get_layout, radiant_power
from bake.envmap.mip import FILTERS, pyramid
from bake.errors import BakeError

LAYOUTS = ["cube", "latlong"]


def _shape(layout, size):
    return get_layout(layout).shape(size)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("filter_name", list(FILTERS))
def test_constant_map_stays_constant(layout, filter_name):
    image = np.full((*_shape(layout, 32), 3), 3.25, np.float32)
    levels = pyramid(image, layout, filter_name)
    assert len(levels) == 6 and levels[-1].shape[0] == 1
    for level in levels:
        np.testing.assert_allclose(level, 3.25, rtol=1e-6)


@pytest.mark.parametrize("layout", LAYOUTS)
@pytest.mark.parametrize("filter_name", list(FILTERS))
def test_single_bright_texel_keeps_its_power_at_every_level(layout, filter_name):
    shape = _shape(layout, 32)
    # A face centre, an edge, a cube vertex texel, and a lat-long pole row.
    spots = [(16, 16), (0, 40), (31, 32 * 3 - 1), (0, 0), (31, 5)]
    for row, col in spots:
        image = np.zeros((*shape, 3), np.float32)
        image[row, col % shape[1]] = [1e4, 1.0, 0.0]
        power = radiant_power(image, layout)
        for level in pyramid(image, layout, filter_name):
            assert level.min() >= 0.0
            # float32 sums of up to 6 * 32^2 terms: relative 1e-6 per level.
            np.testing.assert_allclose(radiant_power(level, layout), power, rtol=1e-5)


def _edge_and_face_jumps(level):
    """Largest |L_p - L_q| over neighbour pairs across cube edges and inside faces.

    The neighbour across an edge is found geometrically, independently of the
    pyramid's own border tables: for each edge texel, the texel of another
    face whose centre direction is nearest to its own.
    """
    cube = get_layout("cube")
    n = level.shape[0]
    faces = cube.to_faces(level)
    inside = max(np.abs(np.diff(faces, axis=1)).max(), np.abs(np.diff(faces, axis=2)).max())
    directions = cube.to_faces(cube.texel_directions(level.shape[:2]))
    on_edge = np.zeros((n, n), bool)
    on_edge[[0, -1], :] = on_edge[:, [0, -1]] = True
    face_of = np.broadcast_to(np.arange(6)[:, None, None], (6, n, n))[:, on_edge]
    d = directions[:, on_edge].reshape(-1, 3)
    values = faces[:, on_edge].reshape(-1, 3)
    face_of = face_of.reshape(-1)
    cosine = d @ d.T
    cosine[face_of[:, None] == face_of[None, :]] = -2.0
    nearest = cosine.argmax(axis=1)
    across = float(np.abs(values - values[nearest]).max())
    return across, float(inside)


@pytest.mark.parametrize("filter_name", list(FILTERS))
@pytest.mark.parametrize("source", ["smooth", "forest"])
def test_no_seams_at_cube_edges_on_any_level(filter_name, source, forest):
    if source == "forest":
        image = convert(forest, "latlong", "cube", 128)
    else:
        d = get_layout("cube").texel_directions(_shape("cube", 128))
        image = np.exp(4 * (d @ np.array([0.6, -0.48, 0.64]) - 1))[..., None] * [1, 2, 3]
    for index, level in enumerate(pyramid(image, "cube", filter_name)):
        if level.shape[0] < 2:
            continue
        across, inside = _edge_and_face_jumps(level)
        assert across <= inside, (index, across, inside)


def test_gaussian_levels_are_smoother_than_box(forest):
    cube = convert(forest, "latlong", "cube", 64)
    box, g4, g6 = (pyramid(cube, "cube", f)[2] for f in ("box", "gauss4", "gauss6"))
    roughness = [np.abs(np.diff(level, axis=1)).mean() for level in (box, g4, g6)]
    assert roughness[0] > roughness[1] > roughness[2]


def test_pyramid_shapes_and_level_limit():
    image = np.ones((*_shape("cube", 24), 3), np.float32)
    assert [lvl.shape[0] for lvl in pyramid(image, "cube")] == [24, 12, 6, 3]
    assert len(pyramid(image, "cube", levels=2)) == 2


def test_bad_pyramid_requests():
    cube = np.ones((*_shape("cube", 8), 3), np.float32)
    with pytest.raises(BakeError, match="unknown MIP filter"):
        pyramid(cube, "cube", "lanczos")
    with pytest.raises(BakeError, match="cube and latlong"):
        pyramid(np.ones((8, 8, 3), np.float32), "sphere")
    with pytest.raises(BakeError, match="levels"):
        pyramid(cube, "cube", levels=0)
    bad = cube.copy()
    bad[0, 0, 0] = np.inf
    with pytest.raises(BakeError, match="NaN or infinite"):
        pyramid(bad, "cube")


@pytest.mark.parametrize("height", [2, 64, 1024])
def test_the_lat_long_box_reduction_is_the_solid_angle_weighted_mean(height):
    """reduce_latlong (by row weights, in blocks of rows on two threads from 1024 rows
    up) against its definition: each parent the solid-angle-weighted mean of its
    four children, its solid angle their sum, computed directly in float64 from the
    texels' exact solid angles (LatLong.solid_angles)."""
    from bake.envmap.mip import _REDUCE_BLOCK_TEXELS, reduce_latlong

    width = 2 * height
    rng = np.random.default_rng(height)
    image = (rng.random((height, width, 3)) ** 4 * 1e3).astype(np.float32)
    omega = get_layout("latlong").solid_angles((height, width)).astype(np.float64)
    weighted = image.astype(np.float64) * omega[..., None]
    parent_power = sum(weighted[i::2, j::2] for i in (0, 1) for j in (0, 1))
    parent_omega = sum(omega[i::2, j::2] for i in (0, 1) for j in (0, 1))
    expected = parent_power / parent_omega[..., None]
    if height == 1024:
        assert height // 2 > _REDUCE_BLOCK_TEXELS // width  # several blocks of rows
    parent, row_omega = reduce_latlong(image)
    assert parent.shape == (height // 2, height, 3) and parent.dtype == np.float32
    np.testing.assert_allclose(row_omega, parent_omega[:, 0], rtol=1e-12)
    # float32 children and row weights: within a few float32 roundings of the mean.
    np.testing.assert_allclose(parent, expected, rtol=3e-7 * 8, atol=0)
    # Reduced again from its own row solid angles, as bake.envmap.convert chains it.
    grand, _ = reduce_latlong(parent, row_omega)
    np.testing.assert_allclose(grand, reduce_latlong(np.ascontiguousarray(parent))[0],
                               rtol=1e-6)
