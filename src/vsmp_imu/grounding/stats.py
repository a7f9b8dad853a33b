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
whole population follow from moments of the features computed once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsmp_imu.executor import thread_map

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
        self._blocks: dict[bytes, np.ndarray] = {}  # sub-blocks of the stack per support (`_quadratic_forms`)

    @classmethod
    def of_sequence(cls, x: np.ndarray, fs_hz: float, window_s: float = COV_WINDOW_S) -> LinearMoments:
        """Moments of a (T, F) sequence cut into 2 s windows."""
        return cls(segment(np.asarray(x, dtype=np.float64), int(round(window_s * fs_hz))), fs_hz)

    def summarize(self, weights: np.ndarray | None = None) -> StatSummary:
        """Statistics of features @ weights; weights (N, F, 6) or None for the features."""
        if weights is None:
            single = np.eye(self.cov.shape[0])[None]
            return StatSummary(*(a[0] for a in _summary_arrays(self, *channel_columns(single))))
        return self.summarize_channels(*channel_columns(np.asarray(weights, dtype=np.float64)))

    def summarize_channels(self, cols: np.ndarray, features: np.ndarray) -> StatSummary:
        """`summarize` of the weights given channel by channel (`channel_columns`): cols (6, N, k)
        on features (6, k), every other weight zero."""
        return StatSummary(*_summary_arrays(self, cols, features))


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
    n_band, n_lag = m.band.shape[0], m.lagged.shape[0]
    energy = diag[:, :n_band].swapaxes(-1, -2)  # (N, 6, B)
    psd = energy / (energy.sum(axis=-1, keepdims=True) + _EPS)
    var = diag[:, -1]  # (N, 6)
    denom = var[..., None] * max(m.length - 1, 1) * m.n_windows + _EPS
    acf = diag[:, n_band : n_band + n_lag].swapaxes(-1, -2) / denom
    second = diag[:, -2]
    centered_sq = var * (max(m.length - 1, 1) / m.length)
    # RMS |a|, RMS |a - mean a|, RMS |w|, RMS |w - mean w|
    norms = np.sqrt(np.stack([second, centered_sq], axis=-1).reshape(-1, 2, 3, 2).sum(axis=2)).reshape(-1, 4)
    wt = np.zeros((cols.shape[1], m.cov.shape[0], 6))
    wt[:, features, np.arange(6)[:, None]] = cols.transpose(1, 0, 2)
    cov = wt.swapaxes(-1, -2) @ (m.cov @ wt)
    return cov, psd, norms, acf


def _quadratic_forms(m: LinearMoments, cols: np.ndarray, features: np.ndarray) -> np.ndarray:
    """w_c^T M w_c (N, X, 6) for every candidate's channel weights w_c and every moment matrix M
    of `m`'s stack (X, F, F), over the features each channel reads only (`channel_columns`): the
    sub-blocks of the stack are kept per feature set, each form is one product of the weights'
    outer products with them."""
    c, n, k = cols.shape
    key = features.tobytes()
    blocks = m._blocks.get(key)
    if blocks is None:
        sub = m._stack[:, features[:, :, None], features[:, None, :]]  # (X, 6, k, k)
        blocks = np.ascontiguousarray(sub.reshape(len(sub), c, k * k).transpose(1, 2, 0))  # (6, k*k, X)
        m._blocks[key] = blocks
    outer = (cols[:, :, :, None] * cols[:, :, None, :]).reshape(c, n, k * k)
    return (outer @ blocks).transpose(1, 2, 0)


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
    """L_sim for every candidate (leading axes of `candidate`) against one target."""
    cov_err = np.linalg.norm(candidate.cov - target.cov, axis=(-2, -1)) / (
        np.linalg.norm(target.cov) + _EPS
    )
    psd_err = np.sqrt(((candidate.psd - target.psd) ** 2).sum(axis=(-2, -1)))
    scale = np.array([target.norms[0], target.norms[0], target.norms[2], target.norms[2]]) + 1e-3
    r_cand = np.concatenate(
        [candidate.norms / scale, candidate.acf.reshape(*candidate.acf.shape[:-2], -1)], axis=-1
    )
    r_targ = np.concatenate([target.norms / scale, target.acf.reshape(-1)])
    r_err = np.sqrt(((r_cand - r_targ) ** 2).sum(axis=-1))
    return LAMBDA_COV * cov_err + LAMBDA_PSD * psd_err + LAMBDA_R * r_err


class TargetStatistics:
    """D_stat: per-class statistics of the real training windows of one fold.

    Classes with fewer than `min_windows` windows fall back to the all-class
    statistics (the fold's pooled D_stat).
    """

    def __init__(self, fs_hz: float, min_windows: int = 20) -> None:
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
