"""Pictures of a BRDF for people: in-plane polar slices and the albedo curve.

matplotlib is an optional dependency: only this module imports it, and only
when a plot is asked for.
"""

from pathlib import Path

import numpy as np

from .. import outputs
from ..errors import BakeError
from .vectors import spherical

__all__ = ["plot_brdf", "albedo_curve", "in_plane_slice", "polar_image"]

#: Curve colours of :func:`polar_image` (uint8 RGB), one per view angle.
CURVE_COLORS = ((214, 39, 40), (31, 119, 180), (44, 160, 44), (255, 127, 14), (148, 103, 189))

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def in_plane_slice(model, theta_o_deg, n=721):
    """(theta_i signed, f cos theta_i luminance) in the plane of incidence of wo.

    wo lies at +theta_o in the x-z plane; negative theta_i is the mirror side.
    """
    theta = np.radians(np.linspace(-90.0, 90.0, n))
    wi = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], -1)
    t = np.radians(theta_o_deg)
    wo = np.array([np.sin(t), 0.0, np.cos(t)])
    value = model.f(wi, np.broadcast_to(wo, wi.shape)) @ LUMINANCE * np.cos(theta)
    return theta, value


def polar_image(model, views=(0.0, 30.0, 60.0), height=160):
    """uint8 RGB (height, 2 height, 3): the in-plane slices of f cos (luminance) as
    polar curves, one colour per view angle (CURVE_COLORS), each scaled to the
    largest value over all views; grey half circles at 1/4, 1/2 and 1 of it and a
    grey line for the normal. Needs no matplotlib (Blender's panel shows it)."""
    width = 2 * height
    image = np.full((height, width, 3), 255, np.uint8)
    radius = height - 6
    cx, cy = width / 2, height - 3

    def plot(theta, value, color, thickness=1):
        x = np.rint(cx + value * radius * np.sin(theta)).astype(int)
        y = np.rint(cy - value * radius * np.cos(theta)).astype(int)
        for dx in range(-thickness + 1, thickness):
            for dy in range(-thickness + 1, thickness):
                xi, yi = np.clip(x + dx, 0, width - 1), np.clip(y + dy, 0, height - 1)
                image[yi, xi] = color

    circle = np.radians(np.linspace(-90, 90, 2000))
    for fraction in (0.25, 0.5, 1.0):
        plot(circle, np.full_like(circle, fraction), (200, 200, 200))
    plot(np.zeros(400), np.linspace(0, 1, 400), (200, 200, 200))
    slices = [in_plane_slice(model, view, 2001) for view in views]
    peak = max(float(np.max(value)) for _, value in slices) or 1.0
    for index, (theta, value) in enumerate(slices):
        color = CURVE_COLORS[index % len(CURVE_COLORS)]
        plot(theta, np.clip(value / peak, 0, 1), color, 2)
        plot(np.full(200, np.radians(views[index])), np.linspace(0.9, 1.0, 200), color)
    return image


def albedo_curve(model, n=31, samples=2048):
    """(theta_o in degrees, albedo RGB (n, 3)) from normal to grazing incidence."""
    theta = np.linspace(0.0, 89.0, n)
    wo = spherical(np.cos(np.radians(theta)), np.zeros(n))
    return theta, model.albedo(wo, samples)


def plot_brdf(model, path, views=(0.0, 30.0, 60.0, 80.0)):
    """Write a PNG: polar in-plane slices of f cos for each view angle, and rho(theta_o)."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:
        raise BakeError("--plot needs matplotlib (pip install matplotlib==3.10.9)") from error
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise BakeError(f"{path}: the plot file name must end in .png")
    if not path.parent.is_dir():
        raise BakeError(f"{path.parent}: output folder does not exist")
    figure = plt.figure(figsize=(11, 5))
    polar = figure.add_subplot(1, 2, 1, projection="polar")
    for view in views:
        theta, value = in_plane_slice(model, view)
        line, = polar.plot(theta, value, label=f"theta_o = {view:g} deg")
        polar.plot([np.radians(view)] * 2, [0, value.max() * 1.05 + 1e-9], ":",
                   color=line.get_color())
    polar.set_theta_zero_location("N")
    polar.set_theta_direction(-1)  # +theta (the viewer side) to the right
    polar.set_thetamin(-90)
    polar.set_thetamax(90)
    polar.set_title("f cos(theta_i) in the plane of incidence (luminance)", fontsize=9)
    polar.legend(loc="lower left", fontsize=8)
    axis = figure.add_subplot(1, 2, 2)
    theta_o, rho = albedo_curve(model)
    for channel, color in enumerate(("tab:red", "tab:green", "tab:blue")):
        axis.plot(theta_o, rho[:, channel], color=color)
    axis.set_xlabel("theta_o (degrees)")
    axis.set_ylabel("directional albedo")
    axis.set_ylim(0, max(1.05, float(rho.max()) * 1.05))
    axis.grid(alpha=0.3)
    axis.set_title(model.spec if len(model.spec) < 70 else model.spec[:67] + "...", fontsize=9)
    try:
        return outputs.atomic_write(path, lambda target: figure.savefig(target, dpi=100,
                                                                        format="png"))
    finally:
        plt.close(figure)
