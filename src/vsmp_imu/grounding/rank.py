"""Rank-based sensor grounding: x_r = G_r^-1(F_v(x_v)) per channel.

Paper, "Rank-based sensor grounding" and appendix "Rank-Based Sensor
Grounding". F_v is the empirical CDF of the fold's convention-aligned synthetic
samples of one sensor location, G_r the empirical CDF of the real D_rank
windows. Both are continuous (linearly interpolated between order statistics),
so the map is monotone and keeps each window's temporal order. With
`per_class=True`, a class with enough samples on both sides gets its own pair
of distributions.
"""

from __future__ import annotations

import numpy as np

from vsmp_imu.errors import ValidationError

DEFAULT_N_QUANTILES = 4096


def _quantile_grid(values: np.ndarray, n_quantiles: int) -> np.ndarray:
    """Quantiles at mid-rank probabilities of each column: (N, C) -> (Q, C), strictly increasing.

    A tiny rank-proportional offset breaks ties (quantized sensors) so the
    inverse map is strictly monotone and never merges distinct inputs.
    """
    n = values.shape[0]
    probs = _probs(min(n_quantiles, n))
    grid = np.quantile(values, probs, axis=0, method="hazen")
    span = np.maximum(grid[-1] - grid[0], 1e-9)
    return grid + np.arange(grid.shape[0])[:, None] * span * 1e-12


def _probs(n: int) -> np.ndarray:
    return (np.arange(n) + 0.5) / n


class _ChannelMap:
    """One pair (F_v, G_r^-1) for C channels."""

    def __init__(self, synthetic: np.ndarray, real: np.ndarray, n_quantiles: int) -> None:
        self.v_grid = _quantile_grid(synthetic, n_quantiles)
        self.r_grid = _quantile_grid(real, n_quantiles)
        self.v_probs = _probs(self.v_grid.shape[0])
        self.r_probs = _probs(self.r_grid.shape[0])

    def apply(self, x: np.ndarray) -> np.ndarray:
        flat = x.reshape(-1, x.shape[-1])
        out = np.empty_like(flat, dtype=np.float64)
        for c in range(flat.shape[1]):
            p = np.interp(flat[:, c], self.v_grid[:, c], self.v_probs)
            out[:, c] = np.interp(p, self.r_probs, self.r_grid[:, c])
        return out.reshape(x.shape)


class RankGrounder:
    """Channel-wise quantile matching from synthetic to real marginals.

    fit(synthetic, real) with windows (N, T, C) or samples (N, C); labels are
    needed only with `per_class=True`. transform(x, labels) maps (..., T, C).
    """

    def __init__(
        self, per_class: bool = False, n_quantiles: int = DEFAULT_N_QUANTILES, min_class_samples: int = 200
    ) -> None:
        self.per_class = per_class
        self.n_quantiles = n_quantiles
        self.min_class_samples = min_class_samples

    def fit(
        self,
        synthetic: np.ndarray,
        real: np.ndarray,
        synthetic_labels: np.ndarray | None = None,
        real_labels: np.ndarray | None = None,
    ) -> RankGrounder:
        syn = _as_samples(synthetic, "synthetic")
        rea = _as_samples(real, "real")
        if syn.shape[1] != rea.shape[1]:
            raise ValidationError(
                f"synthetic has {syn.shape[1]} channels but real has {rea.shape[1]}", field="channels"
            )
        self.n_channels_ = syn.shape[1]
        self.overall_ = _ChannelMap(syn, rea, self.n_quantiles)
        self.per_class_: dict[int, _ChannelMap] = {}
        if self.per_class:
            if synthetic_labels is None or real_labels is None:
                raise ValidationError("per_class grounding needs synthetic and real labels", field="labels")
            syn_lab = _sample_labels(synthetic, synthetic_labels)
            rea_lab = _sample_labels(real, real_labels)
            for cls in np.intersect1d(np.unique(syn_lab), np.unique(rea_lab)):
                s, r = syn[syn_lab == cls], rea[rea_lab == cls]
                if min(len(s), len(r)) >= self.min_class_samples:
                    self.per_class_[int(cls)] = _ChannelMap(s, r, self.n_quantiles)
        return self

    def transform(self, x: np.ndarray, labels: np.ndarray | None = None) -> np.ndarray:
        """Ground windows (N, T, C) (or any (..., C) array when not per class)."""
        x = np.asarray(x, dtype=np.float64)
        if x.shape[-1] != self.n_channels_:
            raise ValidationError(f"expected {self.n_channels_} channels, got {x.shape[-1]}", field="channels")
        if not self.per_class_ or labels is None:
            return self.overall_.apply(x)
        out = np.empty_like(x)
        labels = np.asarray(labels)
        for cls in np.unique(labels):
            mask = labels == cls
            out[mask] = self.per_class_.get(int(cls), self.overall_).apply(x[mask])
        return out


def _as_samples(x: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim < 2 or x.size == 0:
        raise ValidationError(f"{name} data must be a non-empty (N, T, C) or (N, C) array", field=name)
    flat = x.reshape(-1, x.shape[-1])
    if not np.isfinite(flat).all():
        raise ValidationError(f"{name} data contains NaN or inf", field=name)
    return flat


def _sample_labels(x: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Repeat per-window labels for every sample of the window."""
    labels = np.asarray(labels)
    per_window = int(np.prod(np.asarray(x).shape[1:-1])) if np.asarray(x).ndim > 2 else 1
    return np.repeat(labels, per_window)
