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
band-energy distribution, and r holds the mean and std of the accelerometer
and gyroscope vector norms (relative to the target's) and the per-channel
normalized autocorrelation at the lags.

Every function takes windows with arbitrary leading batch axes, so a whole
population of CEM candidates is scored in one vectorized call.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def window_covariance(w: np.ndarray) -> np.ndarray:
    """Cross-channel covariance of each window: (..., L, C) -> (..., C, C)."""
    centered = w - w.mean(axis=-2, keepdims=True)
    return np.einsum("...ti,...tj->...ij", centered, centered) / max(w.shape[-2] - 1, 1)


def band_edges(fs_hz: float) -> np.ndarray:
    return np.array([*PSD_BAND_EDGES_HZ, fs_hz / 2.0])


def window_band_energy(w: np.ndarray, fs_hz: float) -> np.ndarray:
    """Relative band energy per channel: (..., L, C) -> (..., C, 6); bands sum to 1."""
    centered = w - w.mean(axis=-2, keepdims=True)
    power = np.abs(np.fft.rfft(centered, axis=-2)) ** 2  # (..., F, C)
    freqs = np.fft.rfftfreq(w.shape[-2], d=1.0 / fs_hz)
    edges = band_edges(fs_hz)
    bands = []
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        mask = (freqs >= lo) & (freqs <= hi) if i == 0 else (freqs > lo) & (freqs <= hi)
        bands.append(power[..., mask, :].sum(axis=-2))
    energy = np.stack(bands, axis=-1)  # (..., C, 6)
    return energy / (energy.sum(axis=-1, keepdims=True) + _EPS)


def window_acf(w: np.ndarray, lags: tuple[int, ...] = ACF_LAGS) -> np.ndarray:
    """Normalized autocorrelation per channel at `lags`: (..., L, C) -> (..., C, n_lags).

    Lags at or beyond the window length read 0.
    """
    length = w.shape[-2]
    centered = w - w.mean(axis=-2, keepdims=True)
    spec = np.fft.rfft(centered, n=2 * length, axis=-2)
    acov = np.fft.irfft(np.abs(spec) ** 2, n=2 * length, axis=-2)[..., :length, :]
    acf = acov / (acov[..., :1, :] + _EPS)
    out = np.zeros((*w.shape[:-2], w.shape[-1], len(lags)))
    for k, lag in enumerate(lags):
        if lag < length:
            out[..., k] = acf[..., lag, :]
    return out


def window_norms(w: np.ndarray) -> np.ndarray:
    """Mean and std of the acc and gyro vector norms: (..., L, 6) -> (..., 4)."""
    acc = np.linalg.norm(w[..., 0:3], axis=-1)
    gyr = np.linalg.norm(w[..., 3:6], axis=-1)
    return np.stack([acc.mean(-1), acc.std(-1), gyr.mean(-1), gyr.std(-1)], axis=-1)


@dataclass(frozen=True)
class StatSummary:
    """The statistics of one 6-channel (acc, gyr) sensor stream or window set.

    Arrays may carry leading batch axes (one summary per CEM candidate).
    """

    cov: np.ndarray  # (..., 6, 6)
    psd: np.ndarray  # (..., 6, 6 bands)
    norms: np.ndarray  # (..., 4)
    acf: np.ndarray  # (..., 6, n_lags)


def summarize_windows(windows: np.ndarray, fs_hz: float) -> StatSummary:
    """Average statistics over the window axis: (..., W, L, 6) -> summary (...)."""
    if windows.shape[-1] != 6:
        raise ValueError(f"expected 6 channels (acc xyz, gyr xyz), got {windows.shape[-1]}")
    return StatSummary(
        cov=window_covariance(windows).mean(axis=-3),
        psd=window_band_energy(windows, fs_hz).mean(axis=-3),
        norms=window_norms(windows).mean(axis=-2),
        acf=window_acf(windows).mean(axis=-3),
    )


def summarize_sequence(x: np.ndarray, fs_hz: float, window_s: float = COV_WINDOW_S) -> StatSummary:
    """Statistics of a (..., T, 6) sequence over its 2 s windows."""
    return summarize_windows(segment(x, int(round(window_s * fs_hz))), fs_hz)


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

    def fit(self, windows: np.ndarray, labels: np.ndarray) -> TargetStatistics:
        """windows: (N, L, 6) real D_stat windows of one sensor location; labels: (N,)."""
        windows = np.asarray(windows, dtype=np.float64)
        labels = np.asarray(labels)
        if windows.ndim != 3 or len(windows) != len(labels) or len(windows) == 0:
            raise ValueError("fit needs (N, L, 6) windows and N labels, N > 0")
        self.overall_ = summarize_windows(windows, self.fs_hz)
        self.per_class_ = {}
        for cls in np.unique(labels):
            mask = labels == cls
            if mask.sum() >= self.min_windows:
                self.per_class_[int(cls)] = summarize_windows(windows[mask], self.fs_hz)
        self.n_windows_ = len(windows)
        return self

    def for_class(self, label: int | None) -> StatSummary:
        """The target summary for a class (or the pooled one)."""
        if label is None:
            return self.overall_
        return self.per_class_.get(int(label), self.overall_)
