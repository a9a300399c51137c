"""The prefilter as it was before the multi-scale rewrite (frozen as the baseline).

benchmarks/prefilter.py times today's bake against this path in the same run:
the 3D map's slices each filtered by the previous zonal convolution (full
working resolution, kernel integrated over every input texel, heavy tails
on a coarse copy only when the core is small against the map), with the
probe converted to lat-long at the map's size. Copied from bake/zonal.py and
bake/prefilter.py at commit 5f1b839 (what did not change is imported, not
copied: prefilter._half_width); not used by Glossy. zonal.apply_row_kernels is
copied too, as it was at e0a7db2 (before its narrow kernels' spectra became a
product with a cosine table), so the baseline keeps its own speed.
"""

import math

import numpy as np

from bake import lobes
from bake.envmap import convert, get_layout
from bake.prefilter import _half_width
from bake.zonal import (
    _rows,
    _Table,
    checked_arguments,
    kernel_integral,
    suggested_supersample,
)

_ROW_CHUNK_BYTES = 1 << 27


def apply_row_kernels(half_weights, band_spectrum, width, target=None):
    """Output rows from per-row kernels over an input band, by circular convolution.

    half_weights: (A, B, W // 2 + 1) kernel weights of A output rows over B
    input rows at longitude offsets 0..W/2 (the kernel is even in longitude:
    the other half is mirrored here); band_spectrum: (B, W // 2 + 1, C)
    row spectra of those input rows; target: the kernel's exact integral, to
    which each output row's weights are rescaled (None: no rescaling).
    Returns (A, W, C) float32: for every frequency a (rows x band) by
    (band x channels) product (batched BLAS), then the inverse transform.
    """
    weights = np.concatenate([half_weights,
                              half_weights[:, :, 1:width - width // 2][:, :, ::-1]], 2)
    if target is not None:
        totals = weights.sum(axis=(1, 2))
        scale = np.where(totals > 0, target / np.where(totals > 0, totals, 1.0), 0.0)
        weights *= scale[:, None, None]
    kernel_spectrum = np.fft.rfft(weights, axis=2)  # (A, B, F)
    combined = np.matmul(kernel_spectrum.transpose(2, 0, 1),
                         band_spectrum.transpose(1, 0, 2)).transpose(1, 0, 2)
    return np.fft.irfft(combined, n=width, axis=1).astype(np.float32)


def zonal_convolve(image, kernel, out_height=None, *, supersample: int = 1, normalize=True,
                   ):
    """Convolve a lat-long image (H, W, C) with a zonal kernel.

    kernel: vectorized function of cos(gamma) (any shape) -> weights (1/sr).
    out_height: output rows (default H); the output has the input's W columns,
    shape (out_height, W, C), float32. ``supersample``: sub-samples per
    input-texel side for integrating the kernel. ``normalize``: rescale each
    output row's discrete kernel to the kernel's exact integral.
    """
    image, out_height, s = checked_arguments(image, out_height, supersample)
    height, width, channels = image.shape
    theta_in_edges = np.pi * np.arange(height + 1) / height
    theta_out, _ = _rows(out_height)
    # Sub-sample positions within an input texel: latitude and longitude offsets.
    sub = (np.arange(s) + 0.5) / s
    theta_sub = theta_in_edges[:-1, None] + sub[None, :] * (np.pi / height)  # (H, s)
    cos_edges = np.cos(theta_in_edges)
    # Exact solid angle of each latitude sub-band, per longitude texel.
    band_edges = theta_in_edges[:-1, None] + np.arange(s + 1)[None, :] * (np.pi / height / s)
    band_omega = (np.cos(band_edges[:, :-1]) - np.cos(band_edges[:, 1:])) * (2 * np.pi / width / s)
    del cos_edges
    # The kernel is even in dphi (and the sub-offsets are symmetric): compute
    # columns 0..W/2 and mirror the rest.
    half = width // 2 + 1
    dphi = 2.0 * np.pi * (np.arange(half)[:, None] + (sub[None, :] - 0.5)) / width  # (W/2+1, s)
    cos_dphi = np.cos(dphi)
    target = kernel_integral(kernel) if normalize else None
    table = _Table(kernel)
    spectrum = np.fft.rfft(image.astype(np.float64), axis=1)  # (H, F, C)
    freqs = spectrum.shape[1]
    out = np.empty((out_height, width, channels), dtype=np.float32)
    per_row = height * width * s * s * 8 * 3
    chunk = max(1, _ROW_CHUNK_BYTES // max(per_row, 1))
    # Narrow kernels: small chunks keep each chunk's input band narrow too.
    band_rows = (table.support + np.pi / height) / (np.pi / out_height)
    chunk = int(min(chunk, max(4, 2 * band_rows)))
    sin_sub, cos_sub = np.sin(theta_sub), np.cos(theta_sub)
    # Input rows farther in latitude than the kernel's support (plus a texel)
    # cannot contribute: each chunk of output rows reads only its band.
    reach = table.support + np.pi / height
    theta_in = np.pi * (np.arange(height) + 0.5) / height
    for start in range(0, out_height, chunk):
        stop = min(start + chunk, out_height)
        ta = theta_out[start:stop]
        band = np.nonzero((theta_in >= ta.min() - reach) & (theta_in <= ta.max() + reach))[0]
        b0, b1 = (int(band[0]), int(band[-1]) + 1) if band.size else (0, 0)
        sa, ca = np.sin(ta), np.cos(ta)
        # cos(gamma) for (a, b, sub_b, m, sub_phi): cos a cos b + sin a sin b cos dphi.
        cos_gamma = (ca[:, None, None, None, None] * cos_sub[None, b0:b1, :, None, None]
                     + (sa[:, None, None, None, None] * sin_sub[None, b0:b1, :, None, None])
                     * cos_dphi[None, None, None, :, :]).astype(np.float32)
        weights = table(cos_gamma) * band_omega[None, b0:b1, :, None, None].astype(np.float32)
        if s > 1:
            weights = weights.sum(axis=(2, 4), dtype=np.float64)  # (A, H, W/2+1)
        else:
            weights = weights[:, :, 0, :, 0].astype(np.float64)
        out[start:stop] = apply_row_kernels(weights, spectrum[b0:b1], width, target)
    del freqs
    return out


def _filter(work, kernel):
    """Zonal convolution of the working lat-long map (H, 2H, 3) -> (H, 2H, 3).

    A kernel much narrower than the sphere is split into a *core*, kept within
    6x its half width (tapered to 0 by 12x), filtered at the working
    resolution over the band of rows it reaches, and a *tail* (heavy GGX
    tails reach across the sphere), which is smooth on the scale of the core
    and so is filtered on a coarse copy of the map and interpolated back.
    Each part is normalized to its own exact integral, so the sum keeps the
    kernel's energy exactly (a constant map stays its constant).
    """
    height = work.shape[0]
    texel = np.pi / height
    half = _half_width(kernel)
    if half < 0.25 * texel / 8:
        # Narrower than the finest sub-texel spacing: below the map's
        # resolution the lobe's shape cannot matter, only its energy. Use a
        # Gaussian of a quarter texel carrying the same integral.
        energy = kernel_integral(kernel)
        sigma = 0.25 * texel

        def kernel(cos_gamma, energy=energy, sigma=sigma):
            gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
            return energy * np.exp(-0.5 * (gamma / sigma) ** 2) / (2 * np.pi * sigma**2)

        half = _half_width(kernel)
    supersample = suggested_supersample(half, texel)
    core_radius = 6.0 * half
    coarse_rows = int(np.clip(math.ceil(4.0 * np.pi / core_radius), 32, height))
    if core_radius >= np.pi / 2 or coarse_rows >= height:
        return zonal_convolve(work, kernel, supersample=supersample)

    def window(cos_gamma):
        gamma = np.arccos(np.clip(cos_gamma, -1.0, 1.0))
        x = np.clip((gamma - core_radius) / core_radius, 0.0, 1.0)
        return 0.5 * (1.0 + np.cos(np.pi * x))

    def core(cos_gamma):
        return kernel(cos_gamma) * window(cos_gamma)

    def tail(cos_gamma):
        return kernel(cos_gamma) * (1.0 - window(cos_gamma))

    result = zonal_convolve(work, core, supersample=supersample)
    coarse = convert(work, "latlong", "latlong", coarse_rows)
    tail_map = zonal_convolve(coarse, tail)
    centres = get_layout("latlong").texel_directions(work.shape[:2])
    result = result + get_layout("latlong").sampler(tail_map)(centres).astype(np.float32)
    return result.astype(np.float32)


def legacy_3d(image, fit, size, layout="cube"):
    """{slice.k: (size, 2 size, 3)} of a single-lobe 3D map by the previous path."""
    work = convert(image, layout, "latlong", size)
    layers = {}
    for k, s in enumerate(fit.slices):
        lobe = s.lobes[0]
        profile = np.asarray(lobe.profile, dtype=np.float64)

        def kernel(cos_gamma, profile=profile):
            return np.interp(np.arccos(np.clip(cos_gamma, -1.0, 1.0)), lobes.GAMMA, profile)

        layers[f"slice.{k}"] = _filter(work, kernel) * np.asarray(lobe.weight, np.float32)
    return layers
