"""Scene-linear colour of a Blender image's pixels.

``Image.pixels`` holds float images (EXR, HDR) in scene-linear already, but
8/16-bit images (PNG, JPEG) as their stored values, in the image's colour
space: an sRGB image must go through the sRGB transfer function (IEC
61966-2-1, the piecewise curve Blender's sRGB colour space uses) before it is
light that Cycles would render. 128/255 is 0.2158 in linear, not 0.502.
"""

import numpy as np

__all__ = ["srgb_to_linear", "linear_rgb"]

SRGB_SPACES = ("sRGB", "sRGB EOTF")
#: Colour spaces whose stored values are already linear (or are data).
LINEAR_SPACES = ("Non-Color", "Linear Rec.709", "Linear", "Raw", "Linear CIE-XYZ E")


def srgb_to_linear(c):
    """The sRGB decoding curve on stored values c in [0, 1] (any shape, float64)."""
    c = np.asarray(c, dtype=np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_rgb(rgb, image, strict=False):
    """``rgb`` (..., 3) read from ``image.pixels`` as scene-linear values.

    Float images and images in a linear or data colour space are returned as
    they are; an integer sRGB image is decoded. Any other colour space of an
    integer image is returned as it is, or with ``strict`` raises ValueError
    naming it (Glossy cannot reproduce Blender's OpenColorIO transform).
    """
    if image.is_float:
        return rgb
    space = image.colorspace_settings.name
    if space in SRGB_SPACES:
        return srgb_to_linear(rgb).astype(np.asarray(rgb).dtype)
    if strict and space not in LINEAR_SPACES:
        raise ValueError(f"image '{image.name}' is an 8/16-bit image in the '{space}' colour "
                         "space, which Glossy cannot convert to linear: use sRGB, Non-Color "
                         "or a float image (EXR, HDR)")
    return rgb
