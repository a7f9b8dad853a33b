"""Per-channel z-score normalisation, fitted on training windows only."""

from __future__ import annotations

import numpy as np

from vsmp_imu.errors import ValidationError


class ChannelStandardizer:
    """z-score each channel with the mean and standard deviation of the windows given
    to `fit` (all time steps pooled). Channels with zero spread keep scale 1."""

    def __init__(self, eps: float = 1e-8) -> None:
        self.eps = eps

    def fit(self, X: np.ndarray) -> ChannelStandardizer:
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 3 or len(X) == 0:
            raise ValidationError(
                f"need (N, T, C) windows with N > 0, got shape {X.shape}", field="X"
            )
        self.mean_ = X.mean(axis=(0, 1))
        std = X.std(axis=(0, 1))
        self.scale_ = np.where(std > self.eps, std, 1.0)
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        return ((np.asarray(X) - self.mean_) / self.scale_).astype(np.float32)

    def fit_transform(self, X: np.ndarray) -> np.ndarray:
        return self.fit(X).transform(X)
