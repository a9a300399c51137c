"""Error figures of a rendered image against a reference, over a pixel mask.

Every function takes linear radiance images ``test`` and ``reference`` of
shape (H, W, 3) (or (H, W) for a single channel) and a boolean ``mask``
(H, W) of the pixels that count (an object's pixels, eroded at its
silhouette). Sums run over the masked pixels only; an empty mask is refused.

Formulas (r = reference, t = test, over the N masked pixels; for luminance
Y = 0.2126 R + 0.7152 G + 0.0722 B, Rec. 709 / linear sRGB):

- relative RMS         sqrt( sum (t - r)^2 / sum r^2 )             (0: exact)
- bias                 mean(t) / mean(r)                           (1: unbiased)
- PSNR (dB)            10 log10( peak^2 / mean (t - r)^2 ), peak = max r
- relative error       |t - r| / max(r, floor) per pixel, floor = 1% of mean r
                       (so near-black pixels do not dominate); its percentiles
- by view elevation    per band [lo, hi) of n.v (the last band closed at 1): the
                       band's pixels, the relative RMS of luminance over them
                       and the band's share of the whole mask's squared error,
                       sum_band (t - r)^2 / sum_mask (t - r)^2 (the shares sum
                       to 1): where on the object the error is (grazing views,
                       the silhouette, are where lookup methods break)
- noise of a mean      two renders a, b with different seeds: the relative RMS
                       of their mean (a + b)/2 against the converged image is
                       sqrt( sum (a - b)^2 / 4 / sum ((a + b)/2)^2 )
- FLIP                 NVIDIA's perceptual difference (Andersson et al. 2020) of
                       the two images tonemapped to sRGB by bake.preview.tonemap
                       at one exposure, through the optional ``flip-evaluator``
                       package (LDR-FLIP), averaged over the mask; None when the
                       package is absent (inside Blender it usually is).
"""

import numpy as np

from . import preview

__all__ = ["LUMINANCE", "luminance", "relative_rms", "bias", "psnr", "relative_errors",
           "percentiles", "noise_of_mean", "flip", "flip_available", "erode", "compare",
           "by_view", "VIEW_BANDS", "signed_heatmap", "absolute_heatmap"]

LUMINANCE = np.array([0.2126, 0.7152, 0.0722])
PERCENTILES = (50, 90, 99)
#: Band edges of n.v for :func:`by_view`: those of the Hybrid's error table
#: (bake/hybrid_errors.json) and 1, from grazing (0) to facing the camera (1).
VIEW_BANDS = (0.0, 0.1, 0.2, 0.35, 0.5, 0.7, 0.85, 1.0)


def luminance(image) -> np.ndarray:
    """(H, W, 3+) linear RGB -> (H, W) luminance; (H, W) passes through."""
    image = np.asarray(image, dtype=np.float64)
    return image if image.ndim == 2 else image[..., :3] @ LUMINANCE


def _masked(test, reference, mask):
    test, reference = np.asarray(test, np.float64), np.asarray(reference, np.float64)
    if test.shape != reference.shape:
        raise ValueError(f"test {test.shape} and reference {reference.shape} differ in shape")
    mask = np.asarray(mask, dtype=bool)
    if mask.shape != test.shape[:2]:
        raise ValueError(f"mask {mask.shape} does not match the images {test.shape[:2]}")
    if not mask.any():
        raise ValueError("the mask selects no pixel")
    return test[mask], reference[mask]


def relative_rms(test, reference, mask, channel="luminance"):
    """sqrt(sum (t - r)^2 / sum r^2) over the mask: of luminance (``"luminance"``),
    or per channel (``"rgb"``: an array of 3)."""
    if channel == "luminance":
        t, r = _masked(luminance(test), luminance(reference), mask)
        return float(np.sqrt(np.sum((t - r) ** 2) / max(np.sum(r**2), 1e-300)))
    t, r = _masked(test[..., :3], reference[..., :3], mask)
    return np.sqrt(np.sum((t - r) ** 2, axis=0) / np.maximum(np.sum(r**2, axis=0), 1e-300))


def bias(test, reference, mask) -> float:
    """mean(t) / mean(r) of luminance over the mask (1 = no bias)."""
    t, r = _masked(luminance(test), luminance(reference), mask)
    return float(np.mean(t) / max(np.mean(r), 1e-300))


def psnr(test, reference, mask, peak=None) -> float:
    """10 log10(peak^2 / MSE) of luminance in dB; peak defaults to the reference's maximum."""
    t, r = _masked(luminance(test), luminance(reference), mask)
    peak = float(np.max(r)) if peak is None else float(peak)
    mse = float(np.mean((t - r) ** 2))
    return float("inf") if mse == 0 else float(10 * np.log10(peak**2 / mse))


def relative_errors(test, reference, mask, signed=False) -> np.ndarray:
    """(H, W) per-pixel (t - r) / max(r, floor) of luminance, floor = 1% of the masked
    mean of r; absolute value unless ``signed``; 0 outside the mask."""
    t, r = luminance(test), luminance(reference)
    _, masked_r = _masked(t, r, mask)
    floor = 0.01 * max(float(np.mean(masked_r)), 1e-300)
    error = (t - r) / np.maximum(r, floor)
    error = error if signed else np.abs(error)
    return np.where(mask, error, 0.0)


def percentiles(test, reference, mask, q=PERCENTILES) -> dict:
    """Percentiles of the per-pixel absolute relative error: {"p50": ..., ...}."""
    error = relative_errors(test, reference, mask)[np.asarray(mask, bool)]
    return {f"p{k}": float(np.percentile(error, k)) for k in q}


def noise_of_mean(a, b, mask) -> float:
    """Relative RMS noise of (a + b) / 2 for two independent renders a, b (luminance)."""
    ta, tb = _masked(luminance(a), luminance(b), mask)
    mean = 0.5 * (ta + tb)
    return float(np.sqrt(np.sum((ta - tb) ** 2) / 4 / max(np.sum(mean**2), 1e-300)))


def flip_available() -> bool:
    try:
        import flip_evaluator  # noqa: F401
    except ImportError:
        return False
    return True


def flip(test, reference, mask, exposure=None):
    """Mean LDR-FLIP over the mask of both images tonemapped at one exposure
    (default: the reference's masked median luminance to 0.18); None if
    ``flip-evaluator`` is not installed."""
    try:
        import flip_evaluator
    except ImportError:
        return None
    _masked(luminance(test), luminance(reference), mask)
    if exposure is None:
        exposure = exposure_for(reference, mask)
    as_ldr = [preview.tonemap(image, exposure).astype(np.float32) / 255.0
              for image in (reference, test)]
    error_map, _, _ = flip_evaluator.evaluate(as_ldr[0], as_ldr[1], "LDR", inputsRGB=True,
                                              applyMagma=False, computeMeanError=False)
    error_map = np.asarray(error_map, dtype=np.float64)
    error_map = error_map[..., 0] if error_map.ndim == 3 else error_map
    return float(np.mean(error_map[np.asarray(mask, bool)]))


def exposure_for(reference, mask) -> float:
    """The exposure that maps the masked median luminance of ``reference`` to 0.18."""
    values = luminance(reference)[np.asarray(mask, bool)]
    values = values[values > 0]
    return 0.18 / max(float(np.median(values)) if values.size else 1.0, 1e-8)


def erode(mask, pixels=1) -> np.ndarray:
    """Boolean mask shrunk by ``pixels`` (4-neighbour steps): drops silhouette pixels,
    which mix the object with what is behind it."""
    mask = np.asarray(mask, dtype=bool)
    for _ in range(int(pixels)):
        padded = np.pad(mask, 1, constant_values=False)
        mask = (padded[1:-1, 1:-1] & padded[:-2, 1:-1] & padded[2:, 1:-1]
                & padded[1:-1, :-2] & padded[1:-1, 2:])
    return mask


def by_view(test, reference, mask, cos_view, edges=VIEW_BANDS) -> list:
    """Where the error is, by view elevation: one dict per band [lo, hi) of
    ``cos_view`` (H, W: n.v per pixel, clipped to [0, 1]; the last band includes
    its upper edge) with the band's ``pixels`` of the mask, the ``relative_rms`` of
    luminance over them (None for a band with no pixel or a black reference) and
    its ``error_share``: the band's sum of (t - r)^2 over the whole mask's (the
    shares sum to 1; all 0 when test equals reference)."""
    t, r = _masked(luminance(test), luminance(reference), mask)
    cos_view = np.asarray(cos_view, dtype=np.float64)
    if cos_view.shape != np.asarray(mask).shape:
        raise ValueError(f"cos_view {cos_view.shape} does not match the mask "
                         f"{np.asarray(mask).shape}")
    edges = np.asarray(edges, dtype=np.float64)
    mu = np.clip(cos_view[np.asarray(mask, bool)], edges[0], edges[-1])
    band = np.clip(np.searchsorted(edges, mu, side="right") - 1, 0, len(edges) - 2)
    squares = (t - r) ** 2
    total = float(np.sum(squares))
    out = []
    for index in range(len(edges) - 1):
        inside = band == index
        energy = float(np.sum(r[inside] ** 2))
        out.append({"from": float(edges[index]), "to": float(edges[index + 1]),
                    "pixels": int(inside.sum()),
                    "relative_rms": float(np.sqrt(np.sum(squares[inside]) / energy))
                    if inside.any() and energy > 0 else None,
                    "error_share": float(np.sum(squares[inside]) / total) if total > 0 else 0.0})
    return out


def compare(test, reference, mask) -> dict:
    """All figures of ``test`` against ``reference`` over ``mask`` (JSON-ready)."""
    rgb = relative_rms(test, reference, mask, channel="rgb")
    return {"relative_rms": relative_rms(test, reference, mask),
            "relative_rms_rgb": [float(x) for x in rgb],
            "bias": bias(test, reference, mask),
            "psnr_db": psnr(test, reference, mask),
            "relative_error": percentiles(test, reference, mask),
            "flip": flip(test, reference, mask)}


def _ramp(stops, x):
    """Piecewise-linear colour ramp: stops (K, 3) in [0, 1] at even spacing, x in [0, 1]."""
    stops = np.asarray(stops, dtype=np.float64)
    position = np.clip(x, 0.0, 1.0) * (len(stops) - 1)
    low = np.minimum(position.astype(int), len(stops) - 2)
    t = (position - low)[..., None]
    return stops[low] * (1 - t) + stops[low + 1] * t


def signed_heatmap(test, reference, mask, scale=0.5) -> np.ndarray:
    """uint8 (H, W, 3): blue where t < r, red where t > r, white where equal; full
    colour at a relative error of +-``scale``; grey outside the mask."""
    error = relative_errors(test, reference, mask, signed=True) / scale
    colour = _ramp([(0.1, 0.2, 0.8), (1.0, 1.0, 1.0), (0.8, 0.1, 0.1)], 0.5 + 0.5 * error)
    colour = np.where(np.asarray(mask, bool)[..., None], colour, 0.25)
    return np.round(colour * 255).astype(np.uint8)


def absolute_heatmap(test, reference, mask, scale=0.5) -> np.ndarray:
    """uint8 (H, W, 3): black (no error) through red and yellow to white at
    ``scale`` relative error; grey outside the mask."""
    error = relative_errors(test, reference, mask) / scale
    colour = _ramp([(0, 0, 0), (0.7, 0.05, 0.05), (1.0, 0.8, 0.1), (1, 1, 1)], error)
    colour = np.where(np.asarray(mask, bool)[..., None], colour, 0.25)
    return np.round(colour * 255).astype(np.uint8)
