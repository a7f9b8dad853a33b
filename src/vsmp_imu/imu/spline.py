"""Smoothing splines of order 5 for uniformly sampled trajectories.

The position trajectory is fitted with a quintic B-spline (C4: acceleration is
C2-continuous) with one knot per frame and a third-difference penalty on the
coefficients (a P-spline, Eilers & Marx 1996). It is the discrete form of the
quintic smoothing spline minimising sum (y - f)^2 + lam * int f'''^2.

On a uniform grid the fit acts on a sinusoid of frequency f like the filter

    H(f) = 1 / (1 + lam * (2 sin(w/2))^6 / b(w)^2),   w = 2 pi f / fps,

with b(w) = (66 + 52 cos w + 2 cos 2w) / 120 the sampled quintic B-spline.
We choose lam so that H(cutoff_hz) = 1/2: a 6th-order low-pass whose pass band
is flat (clean motions are reproduced; at 8 Hz cutoff a 2 Hz component keeps
99.98 % of its amplitude) and whose stop band removes frame-to-frame jitter
that double differentiation would otherwise amplify.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import BSpline
from scipy.linalg import cho_solve_banded, cholesky_banded

DEGREE = 5
# Sampled quintic cardinal B-spline at its interior knots.
_B_KERNEL = np.array([1.0, 26.0, 66.0, 26.0, 1.0]) / 120.0
_D3_KERNEL = np.array([-1.0, 3.0, -3.0, 1.0])
# Smallest penalty: near-interpolation that keeps the system positive definite.
MIN_PENALTY = 1e-8


def penalty_for_cutoff(cutoff_hz: float | None, fps: float) -> float:
    """lam giving a half-amplitude response at `cutoff_hz` (None or >= Nyquist: interpolate)."""
    if cutoff_hz is None or cutoff_hz >= 0.5 * fps:
        return MIN_PENALTY
    w = 2.0 * np.pi * cutoff_hz / fps
    b = (66.0 + 52.0 * np.cos(w) + 2.0 * np.cos(2.0 * w)) / 120.0
    return max(float(b * b / (2.0 * np.sin(w / 2.0)) ** 6), MIN_PENALTY)


def _gram_bands(kernel: np.ndarray, n_rows: int, n_cols: int, bands: int) -> np.ndarray:
    """Upper banded form (LAPACK layout) of K^T K for the Toeplitz K with K[i, i+a] = kernel[a]."""
    out = np.zeros((bands + 1, n_cols))
    width = len(kernel)
    for k in range(min(width, bands + 1)):
        diag = np.zeros(n_cols - k)
        for a in range(width - k):
            # column p pairs rows i = p - a (0 <= i < n_rows)
            lo, hi = a, min(n_rows + a, n_cols - k)
            diag[lo:hi] += kernel[a] * kernel[a + k]
        out[bands - k, k:] = diag
    return out


def smoothing_spline(y: np.ndarray, fps: float, cutoff_hz: float | None) -> BSpline:
    """Quintic smoothing spline through y (T, ...) sampled at t = k / fps (t0 = 0)."""
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if n < 3:  # n data rows + (m - 3) penalty rows must cover the m = n + 4 coefficients
        raise ValueError(f"need at least 3 samples, got {n}")
    m = n + DEGREE - 1
    lam = penalty_for_cutoff(cutoff_hz, fps)
    ab = _gram_bands(_B_KERNEL, n, m, DEGREE) + lam * _gram_bands(_D3_KERNEL, m - 3, m, DEGREE)
    flat = y.reshape(n, -1)
    rhs = np.zeros((m, flat.shape[1]))
    for a, b in enumerate(_B_KERNEL):
        rhs[a:a + n] += b * flat
    coef = cho_solve_banded((cholesky_banded(ab), False), rhs)
    knots = np.arange(-DEGREE, n + DEGREE) / fps
    return BSpline(knots, coef.reshape((m,) + y.shape[1:]), DEGREE, extrapolate=False)
