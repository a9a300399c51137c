"""Layouts: conventions, texel <-> direction maps, Jacobians and solid angles."""

import numpy as np
import pytest

from bake.envmap import LAYOUTS, get_layout
from bake.envmap.cube import FACE_NAMES
from bake.errors import BakeError

AXES = {"+X": (1, 0, 0), "-X": (-1, 0, 0), "+Y": (0, 1, 0), "-Y": (0, -1, 0),
        "+Z": (0, 0, 1), "-Z": (0, 0, -1)}
SIZES = [2, 3, 5, 16, 17, 64, 257]


@pytest.mark.parametrize("name", list(LAYOUTS))
@pytest.mark.parametrize("size", SIZES)
def test_solid_angles_sum_to_four_pi(name, size):
    layout = get_layout(name)
    omega = layout.solid_angles(layout.shape(size))
    assert omega.shape == layout.shape(size)
    assert omega.min() >= 0.0
    assert abs(omega.sum() / (4 * np.pi) - 1.0) < 1e-5


def _in_domain(layout, x, y, shape):
    """Coordinates whose direction maps back to them (inside disks for the round layouts)."""
    if layout.name == "sphere":
        bx, by = 2 * x / shape[0] - 1, 1 - 2 * y / shape[0]
        return bx**2 + by**2 < 0.98
    if layout.name == "paraboloid":
        s = 2 * (x % shape[0]) / shape[0] - 1
        t = 1 - 2 * y / shape[0]
        return s**2 + t**2 < 0.999
    return np.ones_like(x, dtype=bool)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_coords_invert_directions(name):
    layout = get_layout(name)
    shape = layout.shape(32)
    rng = np.random.default_rng(1)
    x = rng.uniform(0.01, shape[1] - 0.01, 20000)
    y = rng.uniform(0.01, shape[0] - 0.01, 20000)
    keep = _in_domain(layout, x, y, shape)
    if name == "cube":  # stay off the shared face edges, where either face is right
        keep &= np.abs(np.round(x / 32) * 32 - x) > 1e-6
    x, y = x[keep], y[keep]
    d = layout.directions(x, y, shape)
    np.testing.assert_allclose(np.linalg.norm(d, axis=-1), 1.0, atol=1e-12)
    back_x, back_y = layout.coords(d, shape)
    np.testing.assert_allclose(back_x, x, atol=1e-8)
    np.testing.assert_allclose(back_y, y, atol=1e-8)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_direction_to_texel_inverts_texel_directions(name):
    layout = get_layout(name)
    shape = layout.shape(24)
    d = layout.texel_directions(shape)
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    keep = _in_domain(layout, cols + 0.5, rows + 0.5, shape)
    row, col = layout.direction_to_texel(d[keep], shape)
    np.testing.assert_array_equal(row, rows[keep])
    np.testing.assert_array_equal(col, cols[keep])


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_jacobian_matches_finite_differences(name):
    """The closed-form d(omega)/d(texel area) equals |dd/dx x dd/dy| of the mapping."""
    layout = get_layout(name)
    shape = layout.shape(16)
    rng = np.random.default_rng(2)
    x = rng.uniform(0.2, shape[1] - 0.2, 4000)
    y = rng.uniform(0.2, shape[0] - 0.2, 4000)
    keep = _in_domain(layout, x, y, shape)
    if name == "cube":
        keep &= np.abs(np.round(x / 16) * 16 - x) > 1e-3
    if name == "latlong":
        keep &= (y > 0.5) & (y < shape[0] - 0.5)
    x, y = x[keep], y[keep]
    h = 1e-5
    ddx = (layout.directions(x + h, y, shape) - layout.directions(x - h, y, shape)) / (2 * h)
    ddy = (layout.directions(x, y + h, shape) - layout.directions(x, y - h, shape)) / (2 * h)
    numeric = np.linalg.norm(np.cross(ddx, ddy), axis=-1)
    np.testing.assert_allclose(layout.jacobian(x, y, shape), numeric, rtol=1e-6)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_solid_angles_match_dense_quadrature_of_the_jacobian(name):
    """Per texel, the exact solid angle equals a 64 x 64 midpoint sum of the Jacobian."""
    layout = get_layout(name)
    shape = layout.shape(6)
    exact = layout.solid_angles(shape)
    m = 64
    sub = (np.arange(m) + 0.5) / m
    rows, cols = np.mgrid[0:shape[0], 0:shape[1]]
    x = cols[..., None, None] + sub[None, None, None, :]
    y = rows[..., None, None] + sub[None, None, :, None]
    x, y = np.broadcast_arrays(x, y)
    jac = layout.jacobian(x, y, shape)
    if name in ("sphere", "paraboloid"):  # only the part inside the unit disk counts
        n = shape[0]
        s = 2 * (x % n) / n - 1
        t = 1 - 2 * y / n
        jac = np.where(s**2 + t**2 <= 1, jac, 0.0)
    quadrature = jac.mean(axis=(-1, -2))
    # Midpoint error is O(1/m^2) inside; texels cut by a disk's rim converge as
    # O(1/m) (a staircase edge), about 1/m of such a texel's solid angle.
    tolerance = 2e-4 * exact.max() if name == "latlong" or name == "cube" else exact.max() / m
    np.testing.assert_allclose(quadrature, exact, atol=tolerance)


def test_latlong_follows_blenders_environment_texture():
    ll = get_layout("latlong")
    shape = (64, 128)
    # u = 0.5 is +X, u = 0.25 is +Y, u = 0.75 is -Y; row 0 is the zenith.
    for u, axis in [(0.5, "+X"), (0.25, "+Y"), (0.75, "-Y"), (0.0, "-X")]:
        d = ll.directions(u * 128, 32.0, shape)
        np.testing.assert_allclose(d, AXES[axis], atol=1e-12)
    np.testing.assert_allclose(ll.directions(10.0, 0.0, shape), AXES["+Z"], atol=1e-12)
    np.testing.assert_allclose(ll.directions(10.0, 64.0, shape), AXES["-Z"], atol=1e-12)


def test_cube_faces_and_orientation():
    cube = get_layout("cube")
    n = 8
    shape = cube.shape(n)
    for face, name in enumerate(FACE_NAMES):
        centre = cube.directions(face * n + n / 2, n / 2, shape)
        np.testing.assert_allclose(centre, AXES[name], atol=1e-12)
    # Side faces (+X, -X, -Y, +Y) show +Z at the top of the face.
    for face in (0, 1, 4, 5):
        top = cube.directions(face * n + n / 2, 0.0, shape)
        assert top[2] > 0.7
    # GL convention on +X' (Blender +X): s grows towards -gz = +Y (Blender).
    right = cube.directions(0 * n + n - 0.01, n / 2, shape)
    assert right[1] > 0.7


def test_paraboloid_and_sphere_reference_axes():
    par = get_layout("paraboloid")
    n = 16
    np.testing.assert_allclose(par.directions(n / 2, n / 2, (n, 2 * n)), AXES["+Z"], atol=1e-12)
    np.testing.assert_allclose(par.directions(1.5 * n, n / 2, (n, 2 * n)), AXES["-Z"], atol=1e-12)
    # Rim of both halves at the same (s, t) is the same horizon direction.
    np.testing.assert_allclose(par.directions(n - 1e-9, n / 2, (n, 2 * n)), AXES["+X"], atol=1e-9)
    np.testing.assert_allclose(par.directions(2 * n, n / 2, (n, 2 * n)), AXES["+X"], atol=1e-9)
    np.testing.assert_allclose(par.directions(n / 2, 0.0, (n, 2 * n)), AXES["+Y"], atol=1e-12)
    sph = get_layout("sphere")
    np.testing.assert_allclose(sph.directions(n / 2, n / 2, (n, n)), AXES["-Y"], atol=1e-12)
    # Half way to the rim (rho = 1/sqrt 2) the reflection is perpendicular to the view.
    r = n / 2 * (1 - 1 / np.sqrt(2))
    np.testing.assert_allclose(sph.directions(n / 2, r, (n, n)), AXES["+Z"], atol=1e-12)
    np.testing.assert_allclose(sph.directions(n - r, n / 2, (n, n)), AXES["+X"], atol=1e-12)
    np.testing.assert_allclose(sph.directions(n, n / 2, (n, n)), AXES["+Y"], atol=1e-12)


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_any_leading_shape_broadcasts(name):
    layout = get_layout(name)
    shape = layout.shape(8)
    rng = np.random.default_rng(3)
    d = rng.normal(size=(2, 3, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    x, y = layout.coords(d, shape)
    assert x.shape == y.shape == (2, 3)
    x6, y6 = layout.coords(d.reshape(6, 3), shape)
    np.testing.assert_array_equal(x6, x.reshape(6))


@pytest.mark.parametrize("name", list(LAYOUTS))
@pytest.mark.parametrize("size", [0, 1, -4, 10**6, 2.5])
def test_bad_sizes_are_rejected(name, size):
    with pytest.raises(BakeError, match="size"):
        get_layout(name).shape(size)


def test_unknown_layout():
    with pytest.raises(BakeError, match="unknown environment-map layout 'octahedral'"):
        get_layout("octahedral")
