"""Filter a few slices, combine the rest: a 3D map's lobes as mixes of its own lobes.

The K slices (times L lobe sequences) of a 3D map hold radially symmetric
lobes whose shapes change smoothly with the view elevation, so most of
them are close to a linear combination of a few others. Filtering is
linear in the kernel, so if profile p_k = sum_i c_ki p_i over a chosen set
of profiles i, then the filtered map of slice k is sum_i c_ki M_i: only the
chosen profiles are filtered (the costly part), the others cost one
weighted sum of maps.

:func:`choose` picks the set greedily: it starts empty and adds the
profile the current set reproduces worst, until every profile's relative L1
error (2 pi int |p - q| sin g dg over 2 pi int p sin g dg, the fraction of
the lobe's energy misplaced; for a non-negative environment the filtered
value is off by at most that fraction of the brightest radiance the lobe
covers) is at most ``tolerance``. Coefficients come from least squares in
the energy measure (weights sin(gamma) d gamma) and are rescaled to sum to
1, so every combined lobe keeps unit integral (energy is exact). The
chosen profiles themselves are exact. Chosen kernels are true lobes (not
signed basis functions), so each is filtered like any lobe.
"""

import numpy as np

__all__ = ["choose", "energy_error", "TOLERANCE"]

#: Largest relative L1 error (fraction of the lobe's energy) of a combined lobe.
TOLERANCE = 0.005


def _energy_weights(gamma):
    widths = np.diff(gamma)
    weights = np.zeros_like(gamma)
    weights[:-1] += 0.5 * widths
    weights[1:] += 0.5 * widths
    return 2.0 * np.pi * np.sin(gamma) * weights


def energy_error(approx, profile, gamma) -> float:
    """The relative L1 error of lobe ``approx`` standing for ``profile`` (both (G,) at
    angles ``gamma``): 2 pi int |approx - profile| sin g dg over 2 pi int profile sin g
    dg, the measure :func:`choose` bounds (profile's negative parts clipped to 0)."""
    area = _energy_weights(np.asarray(gamma, dtype=np.float64))
    profile = np.clip(np.asarray(profile, dtype=np.float64), 0.0, None)
    approx = np.clip(np.asarray(approx, dtype=np.float64), 0.0, None)
    total = float(profile @ area)
    return float(np.abs(approx - profile) @ area) / total if total > 0 else 0.0


def choose(profiles, gamma, tolerance=TOLERANCE):
    """(chosen indices, coefficients (J, len(chosen)), errors (J,)) for profiles (J, G).

    profiles: unit-integral lobe profiles tabulated at angles ``gamma`` (G,)
    rad; row k of the coefficients gives profile k as a mix of the chosen
    ones (an identity row for a chosen profile).
    """
    profiles = np.clip(np.asarray(profiles, dtype=np.float64), 0.0, None)
    area = _energy_weights(np.asarray(gamma, dtype=np.float64))
    totals = profiles @ area
    scaled = profiles * np.sqrt(area)
    count = profiles.shape[0]
    chosen: list[int] = []
    coefficients = np.zeros((count, 0))
    errors = np.ones(count)
    while errors.max() > tolerance and len(chosen) < count:
        chosen.append(int(np.argmax(errors)))
        basis = scaled[chosen].T  # (G, r)
        coefficients = np.linalg.lstsq(basis, scaled.T, rcond=None)[0].T  # (J, r)
        sums = coefficients.sum(axis=1, keepdims=True)
        coefficients = coefficients / np.where(np.abs(sums) > 1e-12, sums, 1.0)
        approx = coefficients @ profiles[chosen]
        errors = (np.abs(approx - profiles) @ area) / np.where(totals > 0, totals, 1.0)
        errors[chosen] = 0.0
    for row, index in enumerate(chosen):  # chosen profiles are exactly themselves
        coefficients[index] = 0.0
        coefficients[index, row] = 1.0
    return chosen, coefficients, errors
