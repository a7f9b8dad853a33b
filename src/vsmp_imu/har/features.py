"""ECDF features for the Random Forest backbone (paper appendix "ECDF Feature
Extraction for Random Forest")."""

from __future__ import annotations

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.quantiles import sorted_quantiles

# K = 15 fixed ECDF levels per channel (paper appendix, ECDF features).
N_LEVELS = 15


def ecdf_levels(n_levels: int = N_LEVELS) -> np.ndarray:
    """Evenly spaced probability levels strictly inside (0, 1): k / (K + 1), k = 1..K.

    The ends 0 and 1 (window minimum and maximum) are left out: they follow
    single outlying samples rather than the distribution of the window.
    """
    if n_levels < 1:
        raise ValidationError(f"need at least one ECDF level, got {n_levels}", field="n_levels")
    return np.arange(1, n_levels + 1) / (n_levels + 1)


def _windows(X: np.ndarray) -> np.ndarray:
    """`X` as float32 `(N, T, C)` windows, or a ValidationError naming its shape."""
    X = np.asarray(X, dtype=np.float32)
    if X.ndim != 3:
        raise ValidationError(f"windows must be (N, T, C), got shape {X.shape}", field="X")
    return X


def ecdf_features(X: np.ndarray, n_levels: int = N_LEVELS) -> np.ndarray:
    """`(N, T, C)` windows -> `(N, C * K)` features: per channel, the window's empirical
    quantiles at the K levels, channels concatenated (channel-major)."""
    X = _windows(X)
    q = sorted_quantiles(X, ecdf_levels(n_levels), axis=1)  # (K, N, C), as np.quantile
    return np.ascontiguousarray(q.transpose(1, 2, 0).reshape(len(X), -1), dtype=np.float32)


def segment_means(X: np.ndarray, n_segments: int) -> np.ndarray:
    """`(N, T, C)` windows -> `(N, C * n_segments)`: each channel's mean over
    `n_segments` equal, consecutive parts of the window (segment-major).

    ECDF features do not see the order of a window's values, so a transition
    and its time reversal look alike to them; the segment means keep the
    window's slow course (for the accelerometer, where gravity points from
    the window's start to its end).
    """
    X = _windows(X)
    if not 1 <= n_segments <= X.shape[1]:
        raise ValidationError(
            f"need 1..{X.shape[1]} segments for windows of {X.shape[1]} samples, got {n_segments}",
            field="n_segments",
        )
    edges = np.linspace(0, X.shape[1], n_segments + 1).round().astype(int)
    parts = [X[:, a:b].mean(axis=1) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    return np.ascontiguousarray(np.concatenate(parts, axis=1), dtype=np.float32)
