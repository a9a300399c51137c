"""Order-2 (9-coefficient) real spherical harmonics and irradiance from them.

Ramamoorthi & Hanrahan 2001: E(n) = sum_lm A_l L_lm Y_lm(n) with A_0 = pi,
A_1 = 2 pi / 3, A_2 = pi / 4; here divided by pi so that E is the
irradiance over pi (radiance reflected by a white Lambertian surface).
"""

import numpy as np

from .envmap import get_layout

__all__ = ["basis", "project", "irradiance"]

_A = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)


def basis(d):
    """Real SH basis Y_lm (..., 9) at unit directions d (..., 3), l <= 2."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        0.282095 * np.ones_like(x),
        0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
        1.092548 * x * z, 0.546274 * (x * x - y * y),
    ], -1)


def project(image, layout):
    """SH coefficients (9, C) of an environment map: sum over texels of L Y omega."""
    layout = get_layout(layout)
    image = layout.check_image(image)
    shape = image.shape[:2]
    omega = layout.solid_angles(shape)
    y = basis(layout.texel_directions(shape))
    return np.einsum("hwk,hw,hwc->kc", y, omega, image.astype(np.float64))


def irradiance(coefficients, normals):
    """Irradiance / pi (..., C) at unit normals from SH coefficients (9, C)."""
    return basis(np.asarray(normals, dtype=np.float64)) @ (coefficients * _A[:, None]) / np.pi
