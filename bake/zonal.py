"""Convolution of a lat-long environment with a zonal (radially symmetric) kernel.

For a kernel k(cos gamma) that depends only on the angle gamma between an
input direction l and the output direction c,

    E(c) = sum over input texels of L(l) omega(l) k(l . c),

is invariant under rotation about the pole, so for every pair of latitude
rows (output row a, input row b) it is a circular convolution along
longitude: E_a = IFFT( sum_b FFT(L_b) * FFT(K_ab) ), with K_ab(dphi) the
kernel between the two rows at longitude difference dphi. The cost is
O(H_out H_in W log W) whatever the kernel's width, against O(H^2 W^2) for
the direct sum (MEASURED.md: 2e-13 agreement, 0.06 s for a 128 x 64 slice).

Narrow kernels are integrated over each input texel with s x s sub-samples
(``supersample``) instead of being point-sampled at texel centres, and each
output row's kernel is normalized to the kernel's exact integral, so a
constant environment gives exactly integral(k) times the constant.
"""

import functools
import math
import threading

import numpy as np

from .envmap import get_layout
from .errors import BakeError
from .progress import report

__all__ = ["zonal_convolve", "apply_row_kernels", "row_kernel_spectra", "apply_kernel_spectra",
           "kernel_integral", "brute_force_convolve"]

#: Output rows processed together (bounds the kernel spectrum's memory).
_ROW_CHUNK_BYTES = 1 << 27


def gauss_legendre(count: int):
    """Gauss-Legendre nodes and weights on [-1, 1] by Newton's method on the Legendre
    recurrence (to machine precision; agrees with numpy's leggauss to ~1e-15, which
    solves a count x count eigenproblem: 0.3 s for 1024 nodes, against ~10 ms here)."""
    i = np.arange(1, count + 1)
    x = np.cos(np.pi * (i - 0.25) / (count + 0.5))  # Tricomi's initial guess
    for _ in range(100):
        p0, p1 = np.ones_like(x), x.copy()
        for k in range(2, count + 1):
            p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
        derivative = count * (x * p1 - p0) / (x * x - 1.0)
        step = p1 / derivative
        x -= step
        if np.max(np.abs(step)) < 1e-15:
            break
    p0, p1 = np.ones_like(x), x.copy()
    for k in range(2, count + 1):
        p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
    derivative = count * (x * p1 - p0) / (x * x - 1.0)
    weights = 2.0 / ((1.0 - x * x) * derivative * derivative)
    return x[::-1].copy(), weights[::-1].copy()


_rules: dict = {}
_rules_lock = threading.Lock()


def _gamma_rule(nodes: int):
    """Nodes gamma = pi t^2 (dense near 0, where narrow kernels live) and weights
    (computed once per process, under a lock: filtering threads share it)."""
    with _rules_lock:
        if nodes not in _rules:
            t, w = gauss_legendre(nodes)
            t = 0.5 * (t + 1.0)
            gamma = np.pi * t * t
            _rules[nodes] = (gamma, 0.5 * w * 2.0 * np.pi * t * np.sin(gamma))
        return _rules[nodes]


def kernel_integral(kernel, nodes: int = 1024) -> float:
    """2 pi * integral over gamma in [0, pi] of k(cos gamma) sin(gamma) d gamma.

    Gauss-Legendre in t with gamma = pi t^2: exact to ~1e-10 for lobes as
    narrow as a Phong exponent of 10^5.
    """
    gamma, weights = _gamma_rule(nodes)
    return float(2.0 * np.pi * np.sum(np.asarray(kernel(np.cos(gamma)), dtype=np.float64)
                                      * weights))


class _Table:
    """A zonal kernel tabulated on u = sqrt(1 - cos gamma) (uniform, 16384 nodes).

    u is proportional to gamma near the lobe centre, so narrow lobes keep
    their resolution; a lookup is one multiply, a floor and a lerp (no arccos).
    """

    NODES = 16384

    def __init__(self, kernel):
        self.u_max = math.sqrt(2.0)
        u = np.linspace(0.0, self.u_max, self.NODES)
        self.values = np.asarray(kernel(1.0 - u * u), dtype=np.float64)
        self.values = np.append(self.values, self.values[-1]).astype(np.float32)
        self.scale = (self.NODES - 1) / self.u_max
        peak = float(np.abs(self.values).max())
        significant = np.nonzero(np.abs(self.values) > 1e-9 * peak)[0] if peak > 0 else [0]
        last_u = u[min(int(significant[-1]) + 1, self.NODES - 1)]
        #: Angle beyond which the kernel is below 1e-9 of its peak (rad).
        self.support = 2.0 * math.asin(min(last_u / math.sqrt(2.0), 1.0))

    def __call__(self, cos_gamma):
        return self.at_versine(np.maximum(1.0 - cos_gamma, 0.0))

    def at_versine(self, versine):
        """The kernel at 1 - cos(gamma) = ``versine`` (>= 0; any shape): the table's own
        variable is its square root, so a caller that has the versine in a form
        accurate near gamma = 0 (float32 1 - cos gamma is not: 6e-8 steps put
        gamma on steps of 0.02 degrees there) keeps that accuracy."""
        u = np.sqrt(versine) * np.float32(self.scale)
        index = np.minimum(u.astype(np.int32), self.NODES - 1)
        frac = (u - index).astype(np.float32)
        low = self.values[index]
        return low + (self.values[index + 1] - low) * frac


def _rows(height):
    """Centre latitudes (polar angles) and exact solid-angle row factors of a lat-long map."""
    theta = np.pi * (np.arange(height) + 0.5) / height
    edges = np.cos(np.pi * np.arange(height + 1) / height)
    return theta, edges[:-1] - edges[1:]


def row_spectrum(image):
    """Per-row longitude spectra of a lat-long image (H, W, C): (H, W // 2 + 1, C) complex.

    The only transform of the input :func:`zonal_convolve` needs; compute it
    once per image and pass it as ``spectrum=`` to filter with many kernels.
    """
    return np.fft.rfft(np.asarray(image, dtype=np.float64), axis=1)


def _column_reach(ta, tb, reach):
    """Largest longitude difference (rad) at which any output row ta (A,) and input
    row tb (B,) come within angle ``reach``; pi when a pole is within reach."""
    sa, ca = np.sin(ta)[:, None], np.cos(ta)[:, None]
    sb, cb = np.sin(tb)[None, :], np.cos(tb)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        c = (math.cos(min(reach, np.pi)) - ca * cb) / (sa * sb)
    c = np.where(np.isfinite(c), c, -1.0)
    return float(np.arccos(np.clip(c, -1.0, 1.0)).max()) if c.size else 0.0


class _SubGrid:
    """Sub-sample positions of an (H, W) lat-long grid's input texels: s per texel in
    latitude and, per row, s_phi <= s in longitude, so that no row is sampled more
    densely across than along: s_phi = ceil(s w / h) for a texel of angular height
    h = pi / H and width w = sin(theta) 2 pi / W at its edge nearer the equator (s
    at the equator of a W = 2H grid, 1 for the thin texels at the poles, where s x s
    sub-samples of every column would cost most and add nothing). Holds their
    latitudes (sin, cos) and the exact solid angle of each latitude sub-band per
    longitude sub-step."""

    def __init__(self, height, width, s):
        edges = np.pi * np.arange(height + 1) / height
        sub = (np.arange(s) + 0.5) / s
        self.theta = edges[:-1, None] + sub[None, :] * (np.pi / height)  # (H, s)
        self.sin = np.sin(self.theta)
        band = edges[:-1, None] + np.arange(s + 1)[None, :] * (np.pi / height / s)
        #: Solid angle of each latitude sub-band (H, s), over one whole texel's longitude.
        self.band_omega = (np.cos(band[:, :-1]) - np.cos(band[:, 1:])) * (2 * np.pi / width)
        widest = np.maximum(np.sin(edges[:-1]), np.sin(edges[1:]))
        widest = np.where((edges[:-1] < np.pi / 2) & (edges[1:] > np.pi / 2), 1.0, widest)
        self.s_phi = np.clip(np.ceil(s * widest * (2.0 * np.pi / width) / (np.pi / height)
                                     - 1e-9), 1, s).astype(np.intp)  # (H,)
        self.width = width
        self._dphi: dict = {}
        self.s = s

    def _versine_dphi(self, count):
        """(W/2 + 1, count) float32: 2 sin^2(dphi / 2) at ``count`` longitude sub-steps of
        columns 0..W/2 (cached)."""
        if count not in self._dphi:
            sub = (np.arange(count) + 0.5) / count
            dphi = 2.0 * np.pi * (np.arange(self.width // 2 + 1)[:, None]
                                  + (sub[None, :] - 0.5)) / self.width
            self._dphi[count] = (2.0 * np.sin(0.5 * dphi) ** 2).astype(np.float32)
        return self._dphi[count]

    def weights(self, table, ta, sa, b0, b1, cols):
        """Kernel integrated over input texels (rows b0:b1, columns 0:cols) for output
        rows at polar angles ta with sines sa (A,): (A, b1 - b0, cols) float64."""
        out = np.empty((len(ta), b1 - b0, cols))
        counts = self.s_phi[b0:b1]
        start = b0
        while start < b1:  # runs of input rows with one longitude sub-step count
            stop = start + 1
            while stop < b1 and counts[stop - b0] == counts[start - b0]:
                stop += 1
            out[:, start - b0:stop - b0] = self._weights(table, ta, sa, start, stop, cols,
                                                         int(counts[start - b0]))
            start = stop
        return out

    def _weights(self, table, ta, sa, b0, b1, cols, count):
        # 1 - cos(gamma) for (a, b, sub_b, m, sub_phi), in the haversine form
        # 2 sin^2((a - b) / 2) + sin a sin b 2 sin^2(dphi / 2): a sum of two
        # non-negative terms, accurate in float32 down to gamma = 0 (1 - (cos a
        # cos b + sin a sin b cos dphi) is not).
        along = (2.0 * np.sin(0.5 * (ta[:, None, None] - self.theta[None, b0:b1, :])) ** 2
                 ).astype(np.float32)[:, :, :, None, None]
        across = (sa[:, None, None] * self.sin[None, b0:b1, :]).astype(np.float32)
        versine = along + across[:, :, :, None, None] * \
            self._versine_dphi(count)[None, None, None, :cols, :]
        omega = (self.band_omega[b0:b1] / count).astype(np.float32)
        weights = table.at_versine(versine) * omega[None, :, :, None, None]
        if self.s > 1 or count > 1:
            return weights.sum(axis=(2, 4), dtype=np.float64)
        return weights[:, :, 0, :, 0].astype(np.float64)


@functools.lru_cache(maxsize=8)
def _cosine_table(width):
    """(multiplicity (W // 2 + 1,), table (W // 2 + 1, W // 2 + 1)) of a W-point even
    sequence given by its first half h_0..h_{W/2}: its DFT is real,
    K_m = sum_k h_k mult_k cos(2 pi m k / W) (mult 1 at k = 0 and at the Nyquist
    offset W/2 of an even W, else 2: the mirrored half), and table[k, m] =
    mult_k cos(2 pi m k / W)."""
    offsets = np.arange(width // 2 + 1)
    mult = np.where((offsets == 0) | ((width % 2 == 0) & (offsets == width // 2)), 1.0, 2.0)
    return mult, mult[:, None] * np.cos(2.0 * np.pi * np.outer(offsets, offsets) / width)


#: Longitude offsets up to which a kernel's spectrum is a product with the cosine
#: table (BLAS) rather than an FFT of the whole row: measured faster up to half
#: the offsets (at least 48) for W = 128-1024 (8 output x 40 input rows).
_COSINE_COLUMNS = 48


def apply_row_kernels(half_weights, band_spectrum, width, target=None):
    """Output rows from per-row kernels over an input band, by circular convolution.

    half_weights: (A, B, K) kernel weights of A output rows over B input rows
    at longitude offsets 0..K-1 (K <= W // 2 + 1; zero beyond). The kernel is
    even in longitude, so its spectrum is real: a product with the cosine
    table for a narrow kernel, an FFT of the mirrored row otherwise.
    band_spectrum: (F, B, C) complex row spectra of those input rows,
    frequency-major (F = W // 2 + 1; row_spectrum(...).transpose(1, 0, 2)).
    target: the kernel's exact integral, to which each output row's weights
    are rescaled (None: no rescaling). Returns (A, W, C) float32: for every
    frequency a real (rows x band) by complex (band x channels) product (one
    batched real BLAS call on the spectrum's real and imaginary parts), then
    the inverse transform.
    """
    return apply_kernel_spectra(row_kernel_spectra(half_weights, width, target),
                                band_spectrum, width)


def row_kernel_spectra(half_weights, width, target=None):
    """(F, A, B) float64 real longitude spectra of the per-row kernels of
    :func:`apply_row_kernels` (same arguments)."""
    rows, band, cols = half_weights.shape
    half = width // 2 + 1
    mult, table = _cosine_table(width)
    weights = half_weights
    if target is not None:
        totals = np.einsum("abk,k->a", weights, mult[:cols])
        scale = np.where(totals > 0, target / np.where(totals > 0, totals, 1.0), 0.0)
        weights = weights * scale[:, None, None]
    if cols <= max(_COSINE_COLUMNS, half // 2):
        kernel = weights.reshape(rows * band, cols) @ table[:cols]
    else:
        full = np.zeros((rows, band, width))
        full[:, :, :cols] = weights
        mirrored = weights[:, :, 1:min(cols, width - width // 2)]
        full[:, :, width - mirrored.shape[2]:] = mirrored[:, :, ::-1]
        kernel = np.fft.rfft(full, axis=2).real.reshape(rows * band, half)
    return np.ascontiguousarray(kernel.reshape(rows, band, half).transpose(2, 0, 1))


def apply_kernel_spectra(kernel, band_spectrum, width):
    """(A, W, C) float32 output rows from :func:`row_kernel_spectra`' (F, A, B) kernel
    and the band's (F, B, C) complex row spectra (:func:`apply_row_kernels`)."""
    spectrum = np.ascontiguousarray(band_spectrum)
    combined = np.matmul(kernel, spectrum.view(np.float64)).view(np.complex128)  # (F, A, C)
    return np.fft.irfft(combined.transpose(1, 0, 2), n=width, axis=1).astype(np.float32)


def checked_arguments(image, out_height, supersample):
    """(image array, output rows, sub-samples) of a zonal convolution, or BakeError:
    a lat-long (H, W, C) image, out_height >= 1 (default H), supersample in [1, 16]."""
    image = np.asarray(image)
    get_layout("latlong").check_image(image)
    out_height = int(out_height or image.shape[0])
    if out_height < 1:
        raise BakeError(f"output height must be >= 1, not {out_height}")
    s = int(supersample)
    if not 1 <= s <= 16:
        raise BakeError(f"supersample must be in [1, 16], not {supersample}")
    return image, out_height, s


def zonal_convolve(image, kernel, out_height=None, *, supersample: int = 1, normalize=True,
                   progress=None, spectrum=None, supersample_radius=None):
    """Convolve a lat-long image (H, W, C) with a zonal kernel.

    kernel: vectorized function of cos(gamma) (any shape) -> weights (1/sr).
    out_height: output rows (default H); the output has the input's W columns,
    shape (out_height, W, C), float32. ``supersample``: sub-samples per
    input-texel side for integrating the kernel; ``supersample_radius``
    (rad): only input texels within this angle of an output direction's row
    and column are sub-sampled (where a narrow kernel varies within a
    texel), the rest point-sampled at texel centres (default: all texels).
    ``normalize``: rescale each output row's discrete kernel to the kernel's
    exact integral. ``spectrum``: :func:`row_spectrum` of ``image``, when
    already computed.

    Cost: the kernel is evaluated only on the input rows and longitude
    columns within its support (plus a texel) of each chunk of output rows,
    so a narrow kernel costs in proportion to the texels it covers, not to
    the whole sphere.
    """
    image, out_height, s = checked_arguments(image, out_height, supersample)
    height, width, channels = image.shape
    theta_out, _ = _rows(out_height)
    # The kernel is even in dphi (and the sub-offsets are symmetric): compute
    # columns 0..W/2 and mirror the rest.
    half = width // 2 + 1
    target = kernel_integral(kernel) if normalize else None
    table = _Table(kernel)
    if spectrum is None:
        spectrum = row_spectrum(image)  # (H, F, C)
    elif spectrum.shape != (height, width // 2 + 1, channels):
        raise BakeError(f"spectrum shape {spectrum.shape} does not match the image {image.shape}")
    by_frequency = spectrum.transpose(1, 0, 2)  # (F, H, C): apply_row_kernels' order
    near = table.support if supersample_radius is None else min(supersample_radius,
                                                                 table.support)
    fine = _SubGrid(height, width, s)
    coarse = fine if (s == 1 or near >= table.support) else _SubGrid(height, width, 1)
    out = np.empty((out_height, width, channels), dtype=np.float32)
    texel = np.pi / height
    # Bytes per output row of the sub-sampled part (float32 cos and weights).
    near_cells = (2 * (near + texel) / texel + 1) * min(half, (near + texel) / texel * 4 + 2)
    per_row = max(near_cells * s * s, height * 2) * 8 * 3
    chunk = max(1, _ROW_CHUNK_BYTES // max(int(per_row), 1))
    # Narrow kernels: small chunks keep each chunk's input band narrow too.
    band_rows = (table.support + texel) / (np.pi / out_height)
    chunk = int(min(chunk, max(4, 2 * band_rows), 8))
    # Input rows farther in latitude than the kernel's support (plus a texel)
    # cannot contribute: each chunk of output rows reads only its band.
    reach = table.support + texel
    near_reach = near + texel
    theta_in = np.pi * (np.arange(height) + 0.5) / height

    def band_of(ta, distance):
        band = np.nonzero((theta_in >= ta.min() - distance) & (theta_in <= ta.max() + distance))[0]
        return (int(band[0]), int(band[-1]) + 1) if band.size else (0, 0)

    def columns(ta, b0, b1, distance):
        # Longitude columns within reach (sub-samples extend half a texel).
        reach_phi = _column_reach(ta, theta_in[b0:b1], distance) + np.pi / width
        return int(min(half, math.ceil(reach_phi / (2.0 * np.pi / width)) + 1))

    # The grids are symmetric about the equator: output row a and input row b
    # see the same kernel weights as rows out_height - 1 - a and height - 1 - b
    # (cos gamma = cos a cos b + sin a sin b cos dphi is unchanged when both
    # latitudes are mirrored, and so are the sub-samples and their solid
    # angles). Each chunk of the northern half computes its kernel spectra
    # once and applies them to its own band and, reversed, to the mirrored
    # band for the mirrored rows (with an odd row count the middle row's chunk
    # and its mirror overlap and write the same values).
    north = (out_height + 1) // 2
    for start in range(0, north, chunk):
        stop = min(start + chunk, north)
        ta = theta_out[start:stop]
        b0, b1 = band_of(ta, reach)
        sa = np.sin(ta)
        cols = columns(ta, b0, b1, reach)
        weights = coarse.weights(table, ta, sa, b0, b1, cols)  # (A, band, cols)
        if coarse is not fine:
            n0, n1 = band_of(ta, near_reach)
            near_cols = min(cols, columns(ta, n0, n1, near_reach))
            weights[:, n0 - b0:n1 - b0, :near_cols] = fine.weights(table, ta, sa, n0, n1,
                                                                   near_cols)
        kernel = row_kernel_spectra(weights, width, target)  # (F, A, band)
        out[start:stop] = apply_kernel_spectra(kernel, by_frequency[:, b0:b1], width)
        out[out_height - stop:out_height - start] = apply_kernel_spectra(
            kernel[:, ::-1, ::-1], by_frequency[:, height - b1:height - b0], width)
        report(progress, stop / north,
               f"convolving rows {min(2 * stop, out_height)}/{out_height}")
    return out


def brute_force_convolve(directions, values, solid_angles, kernel, targets, normalize=True,
                         chunk=256):
    """Reference: E(c) = sum_t L_t omega_t k(d_t . c) over every texel t, per target c.

    directions (T, 3), values (T, C), solid_angles (T,), targets (..., 3).
    With ``normalize`` each target's weights are scaled to the kernel's
    integral, like :func:`zonal_convolve`.
    """
    targets = np.asarray(targets, dtype=np.float64)
    flat = targets.reshape(-1, 3)
    out = np.empty((flat.shape[0], values.shape[1]))
    target = kernel_integral(kernel) if normalize else None
    for start in range(0, flat.shape[0], chunk):
        cos = np.clip(flat[start:start + chunk] @ directions.T, -1.0, 1.0)
        weights = np.asarray(kernel(cos), dtype=np.float64) * solid_angles[None, :]
        if normalize:
            totals = weights.sum(axis=1, keepdims=True)
            weights *= target / np.where(totals > 0, totals, 1.0)
        out[start:start + chunk] = weights @ values
    return out.reshape(*targets.shape[:-1], values.shape[1])


def suggested_supersample(kernel_width: float, texel: float) -> int:
    """Sub-samples per side so that a kernel of angular ``kernel_width`` spans >= 3 of them."""
    if kernel_width <= 0:
        return 8
    return int(np.clip(math.ceil(3.0 * texel / kernel_width), 1, 8))
