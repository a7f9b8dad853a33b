"""Temporal and multivariate IMU statistics (D_stat) and the simulation loss.

Paper, appendix "Simulation-in-the-Loop Optimization":
L_sim = l_S ||S(X) - S(D)||_F + l_psd ||PSD(X) - PSD(D)||_2 + l_r ||r(X) - r(D)||_2
with l = (1.0, 0.5, 0.5), 2 s covariance windows, PSD bands [0,0.5], (0.5,1],
(1,2], (2,4], (4,8], (8, fs/2] Hz and autocorrelation lags {1,2,5,10,20,50}.
The loss never compares per-channel marginal distributions: that is the job of
rank grounding.

The paper leaves the scale of each term open. Here each term is made
dimensionless so the weights mean what they say: the covariance error is
relative to the target's Frobenius norm, the PSD is the per-channel relative
band-energy distribution, and r holds RMS vector-norm statistics of the
accelerometer and gyroscope (relative to the target's) and the per-channel
normalized autocorrelation at the lags. Statistics are pooled over the 2 s
windows (moments summed, then normalized).

All of them are quadratic forms in the signal. `LinearMoments` exploits that:
readings of every CEM candidate are features @ weights, so the statistics of a
whole population follow from moments of the features computed once, each
channel's over the few features it reads (`channel_columns`); `MomentsBatch`
scores the populations of several streams together.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from vsmp_imu.executor import thread_map
from vsmp_imu.grounding import floors

COV_WINDOW_S = 2.0
PSD_BAND_EDGES_HZ = (0.0, 0.5, 1.0, 2.0, 4.0, 8.0)  # last band is (8, fs/2]
ACF_LAGS = (1, 2, 5, 10, 20, 50)
LAMBDA_COV, LAMBDA_PSD, LAMBDA_R = 1.0, 0.5, 0.5
_EPS = 1e-12


def segment(x: np.ndarray, length: int) -> np.ndarray:
    """Cut (..., T, C) into non-overlapping windows (..., W, length, C).

    A sequence shorter than `length` becomes one window of its own length.
    """
    t = x.shape[-2]
    if t <= length:
        return x[..., None, :, :]
    w = t // length
    head = x[..., : w * length, :]
    return head.reshape(*x.shape[:-2], w, length, x.shape[-1])


def band_edges(fs_hz: float) -> np.ndarray:
    return np.array([*PSD_BAND_EDGES_HZ, fs_hz / 2.0])


def _band_matrix(n_samples: int, fs_hz: float) -> np.ndarray:
    """(Q, 6) indicator of which rfft bin falls in which band."""
    freqs = np.fft.rfftfreq(n_samples, d=1.0 / fs_hz)
    edges = band_edges(fs_hz)
    bands = np.zeros((freqs.size, len(edges) - 1))
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        bands[:, i] = (freqs >= lo) & (freqs <= hi) if i == 0 else (freqs > lo) & (freqs <= hi)
    return bands


@dataclass(frozen=True)
class StatSummary:
    """The statistics of one 6-channel (acc, gyr) stream or window set.

    Arrays may carry leading batch axes (one summary per CEM candidate).
    """

    cov: np.ndarray  # (..., 6, 6) mean window covariance
    psd: np.ndarray  # (..., 6, 6 bands) relative band energy per channel
    norms: np.ndarray  # (..., 4) RMS |a|, RMS |a - mean a|, RMS |w|, RMS |w - mean w|
    acf: np.ndarray  # (..., 6, n_lags) normalized autocorrelation


class LinearMoments:
    """Pooled window moments of features (..., T, F) (or windows (..., W, L, F)).

    `summarize(weights)` gives the statistics of the signal features @ weights
    for N candidate weight matrices (N, F, C) at once; `summarize()` (identity
    weights) gives the statistics of the features themselves.
    """

    def __init__(self, windows: np.ndarray, fs_hz: float) -> None:
        w = np.asarray(windows, dtype=np.float64)
        length = w.shape[-2]
        w = w.reshape(-1, length, w.shape[-1])  # all windows pooled
        centered = w - w.mean(axis=-2, keepdims=True)
        self.length = length
        self.n_windows = w.shape[0]
        self.fs_hz = fs_hz
        ct = centered.swapaxes(-1, -2)
        self.cov = (ct @ centered).sum(0) / (max(length - 1, 1) * self.n_windows)
        self.second = (w.swapaxes(-1, -2) @ w).sum(0) / (length * self.n_windows)
        spec = np.fft.rfft(centered, axis=-2)  # (W, Q, F)
        cross = np.einsum("wqf,wqg->qfg", spec, spec.conj()).real
        self.band = np.einsum("qb,qfg->bfg", _band_matrix(length, fs_hz), cross)
        lagged = []
        for lag in ACF_LAGS:
            a = np.zeros_like(self.cov)
            if lag < length:
                a = (ct[:, :, lag:] @ centered[:, : length - lag, :]).sum(0)
            lagged.append((a + a.T) / 2)
        self.lagged = np.stack(lagged)  # (K, F, F)
        self._stack = np.concatenate([self.band, self.lagged, self.second[None], self.cov[None]])
        self._blocks: dict[bytes, np.ndarray] = {}  # sub-blocks of the stack per feature set (`blocks`)

    @classmethod
    def of_sequence(cls, x: np.ndarray, fs_hz: float, window_s: float = COV_WINDOW_S) -> LinearMoments:
        """Moments of a (T, F) sequence cut into 2 s windows."""
        return cls(segment(np.asarray(x, dtype=np.float64), int(round(window_s * fs_hz))), fs_hz)

    def blocks(self, features: np.ndarray) -> np.ndarray:
        """The stack's coefficients (6, k(k+1)/2, X) of the pairwise products of each channel's
        weights on its features (6, k) (`_pair_blocks`), kept per feature set."""
        key = features.tobytes()
        if key not in self._blocks:
            self._blocks[key] = _pair_blocks(self._stack, features)
        return self._blocks[key]

    def summarize(self, weights: np.ndarray | None = None) -> StatSummary:
        """Statistics of features @ weights; weights (N, F, 6) or None for the features."""
        if weights is None:
            single = np.eye(self.cov.shape[0])[None]
            return StatSummary(*(a[0] for a in _summary_arrays(self, *channel_columns(single))))
        return StatSummary(*_summary_arrays(self, *channel_columns(np.asarray(weights, dtype=np.float64))))


class MomentsBatch:
    """The `LinearMoments` of S streams on the same features, scored together: each statistic is
    one product over every stream's candidates (`summarize_channels`), whatever the other
    streams of the batch (the values of a batch of one)."""

    def __init__(self, moments: list[LinearMoments]) -> None:
        self.moments = moments
        # each covariance as L L^T (eigen-decomposed: the constant feature makes it singular)
        lam, vec = np.linalg.eigh(np.stack([m.cov for m in moments]))
        self.root = vec * np.sqrt(np.clip(lam, 0.0, None))[:, None, :]  # (S, F, F)
        self.length = np.array([m.length for m in moments])[:, None, None]  # against (S, N, 6)
        self.n_windows = np.array([m.n_windows for m in moments])[:, None, None]
        self.n_band = moments[0].band.shape[0]
        self._blocks: dict[bytes, np.ndarray] = {}

    def summarize_channels(self, cols: np.ndarray, features: np.ndarray) -> StatSummary:
        """Statistics (S, N, ...) of every stream's N candidates: cols (S, 6, N, k) on features (S, 6, k)."""
        key = features.tobytes()
        if key not in self._blocks:
            self._blocks[key] = np.stack([m.blocks(f) for m, f in zip(self.moments, features, strict=True)])
        diag = _forms(cols, self._blocks[key]).transpose(0, 2, 3, 1)  # (S, N, X, 6)
        # covariance of channels c, d: (L^T w_c) . (L^T w_d), each pair c <= d once
        g = cols @ self.root[np.arange(len(cols))[:, None, None], features]  # (S, 6, N, F)
        i, j = _pairs(6)
        pairs = np.einsum("scnf,scnf->snc", g[:, i], g[:, j])
        cov = np.empty((*pairs.shape[:2], 6, 6))
        cov[..., i, j] = pairs
        cov[..., j, i] = pairs
        return StatSummary(*_statistics(diag, cov, self.n_band, self.length, self.n_windows))


def channel_columns(weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weights (N, F, 6) channel by channel: (cols (6, N, k), features (6, k)), each channel's
    features that any candidate weights first (in order), padded to one size k with features it
    weights zero; cols[c, n, i] = weights[n, features[c, i], c]."""
    if weights.shape[-1] != 6:
        raise ValueError(f"expected 6 output channels (acc xyz, gyr xyz), got {weights.shape[-1]}")
    support = np.any(weights != 0, axis=0).T  # (6, F)
    k = max(int(support.sum(axis=1).max()), 1)
    features = np.argsort(~support, axis=1, kind="stable")[:, :k]
    return weights[:, features, np.arange(6)[:, None]].transpose(1, 0, 2), features


def _summary_arrays(m: LinearMoments, cols: np.ndarray, features: np.ndarray):
    diag = _quadratic_forms(m, cols, features)  # (N, X, 6)
    wt = np.zeros((cols.shape[1], m.cov.shape[0], 6))
    wt[:, features, np.arange(6)[:, None]] = cols.transpose(1, 0, 2)
    cov = wt.swapaxes(-1, -2) @ (m.cov @ wt)
    return _statistics(diag, cov, m.band.shape[0], np.asarray(m.length), np.asarray(m.n_windows))


def _statistics(diag: np.ndarray, cov: np.ndarray, n_band: int, length: np.ndarray, n_windows: np.ndarray):
    """(cov, psd, norms, acf) from the quadratic forms `diag` (..., X, 6) of the moments stack
    (bands, lags, second moment, covariance) and the covariances (..., 6, 6). `length` and
    `n_windows` (window length and count) broadcast against diag's leading axes."""
    energy = diag[..., :n_band, :].swapaxes(-1, -2)  # (..., 6, B)
    psd = energy / (energy.sum(axis=-1, keepdims=True) + _EPS)
    var = diag[..., -1, :]  # (..., 6)
    steps = np.maximum(length - 1, 1)
    acf = diag[..., n_band:-2, :].swapaxes(-1, -2) / (var * (steps * n_windows) + _EPS)[..., None]
    second = diag[..., -2, :]
    centered_sq = var * (steps / length)
    # RMS |a|, RMS |a - mean a|, RMS |w|, RMS |w - mean w|
    lead = var.shape[:-1]
    norms = np.sqrt(np.stack([second, centered_sq], axis=-1).reshape(*lead, 2, 3, 2).sum(axis=-2)).reshape(*lead, 4)
    return cov, psd, norms, acf


def _quadratic_forms(m: LinearMoments, cols: np.ndarray, features: np.ndarray) -> np.ndarray:
    """w_c^T M w_c (N, X, 6) for every candidate's channel weights w_c and every moment matrix M
    of `m`'s stack (X, F, F), over the features each channel reads only (`channel_columns`)."""
    return _forms(cols, m.blocks(features)).transpose(1, 2, 0)


def _forms(cols: np.ndarray, blocks: np.ndarray) -> np.ndarray:
    """(..., 6, N, X): each form as one product of the weights' pairwise products
    w_i w_j, i <= j (..., 6, N, k(k+1)/2) with the stack's sub-blocks on those pairs
    (..., 6, k(k+1)/2, X; `_pair_blocks`: the matrices are symmetric, so each pair off the
    diagonal counts twice)."""
    i, j = _pairs(cols.shape[-1])
    return (cols[..., i] * cols[..., j]) @ blocks


@lru_cache(maxsize=8)
def _pairs(k: int) -> tuple[np.ndarray, np.ndarray]:
    """Index pairs (i, j), i <= j, of a k x k matrix (row by row)."""
    return np.triu_indices(k)


def _pair_blocks(stack: np.ndarray, features: np.ndarray) -> np.ndarray:
    """The symmetric matrices `stack` (X, F, F) on each channel's features (6, k), as the
    coefficients of the pairwise products (6, k(k+1)/2, X): M_ii, and 2 M_ij for i < j."""
    i, j = _pairs(features.shape[1])
    sub = stack[:, features[:, i], features[:, j]]  # (X, 6, pairs)
    return np.ascontiguousarray((sub * np.where(i == j, 1.0, 2.0)).transpose(1, 2, 0))


def summarize_windows(windows: np.ndarray, fs_hz: float) -> StatSummary:
    """Statistics of real windows (N, L, 6), pooled (what D_stat holds)."""
    windows = np.asarray(windows)
    if windows.shape[-1] != 6:
        raise ValueError(f"expected 6 channels (acc xyz, gyr xyz), got {windows.shape[-1]}")
    return LinearMoments(windows, fs_hz).summarize()


def summarize_sequence(x: np.ndarray, fs_hz: float, window_s: float = COV_WINDOW_S) -> StatSummary:
    """Statistics of one (T, 6) sequence over its 2 s windows."""
    return LinearMoments.of_sequence(x, fs_hz, window_s).summarize()


def sim_loss(candidate: StatSummary, target: StatSummary) -> np.ndarray:
    """L_sim for every candidate (leading axes of `candidate`) against one target (or, with
    leading axes of its own, a target per candidate set, broadcast against them)."""
    cov_err = np.linalg.norm(candidate.cov - target.cov, axis=(-2, -1)) / (
        np.linalg.norm(target.cov, axis=(-2, -1)) + _EPS
    )
    psd_err = np.sqrt(((candidate.psd - target.psd) ** 2).sum(axis=(-2, -1)))
    scale = target.norms[..., [0, 0, 2, 2]] + 1e-3
    r_cand = np.concatenate(
        [candidate.norms / scale, candidate.acf.reshape(*candidate.acf.shape[:-2], -1)], axis=-1
    )
    r_targ = np.concatenate([target.norms / scale, target.acf.reshape(*target.acf.shape[:-2], -1)], axis=-1)
    r_err = np.sqrt(((r_cand - r_targ) ** 2).sum(axis=-1))
    return LAMBDA_COV * cov_err + LAMBDA_PSD * psd_err + LAMBDA_R * r_err


class TargetStatistics:
    """D_stat: per-class statistics of the real training windows of one fold.

    Classes with fewer than `min_windows` windows fall back to the all-class
    statistics (the fold's pooled D_stat).
    """

    def __init__(self, fs_hz: float, min_windows: int = floors.STAT_TARGET.floor) -> None:
        self.fs_hz = fs_hz
        self.min_windows = min_windows

    def fit(self, windows: np.ndarray, labels: np.ndarray, threads: int = 1) -> TargetStatistics:
        """windows: (N, L, 6) real D_stat windows of one sensor location; labels: (N,).
        `threads` > 1 summarizes the classes side by side (same result)."""
        windows = np.asarray(windows, dtype=np.float64)
        labels = np.asarray(labels)
        if windows.ndim != 3 or len(windows) != len(labels) or len(windows) == 0:
            raise ValueError("fit needs (N, L, 6) windows and N labels, N > 0")
        classes = [int(c) for c in np.unique(labels) if (labels == c).sum() >= self.min_windows]
        subsets = [windows] + [windows[labels == c] for c in classes]
        self.overall_, *per_class = thread_map(lambda w: summarize_windows(w, self.fs_hz), subsets, threads)
        self.per_class_ = dict(zip(classes, per_class, strict=True))
        self.n_windows_ = len(windows)
        return self

    def for_class(self, label: int | None) -> StatSummary:
        """The target summary for a class (or the pooled one)."""
        if label is None:
            return self.overall_
        return self.per_class_.get(int(label), self.overall_)
