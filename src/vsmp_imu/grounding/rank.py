"""Rank-based sensor grounding: x_r = G_r^-1(F_v(x_v)) per channel.

Paper, "Rank-based sensor grounding" and appendix "Rank-Based Sensor
Grounding". F_v is the empirical CDF of the fold's convention-aligned
synthetic samples of one sensor location, G_r the CDF of the real D_rank
windows kernel-smoothed (a Gaussian kernel whose bandwidth follows the spread
of the windows' means, variance kept: `window_bandwidths`, `_kernel_smoothed`),
so that a few real windows, each a plateau, do not turn the map into a
staircase. Both are continuous (linearly interpolated between levels), so the
map is monotone and keeps each window's temporal order. With `per_class=True`, a class with enough samples on both sides gets
its own pair of distributions.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from vsmp_imu.errors import ValidationError
from vsmp_imu.executor import thread_map
from vsmp_imu.grounding import floors
from vsmp_imu.quantiles import sorted_quantiles

DEFAULT_N_QUANTILES = 4096
# bins of the grid on which a distribution is kernel-smoothed (`_kernel_smoothed`)
KDE_BINS = 4096
# widest kernel, in window-mean spreads per window (`window_bandwidths`)
GAP_WIDTHS = 20.0
# below this many rows per channel threads cost more than they save (np.interp keeps the GIL)
_THREADED_ROWS = 4096


def _quantile_grid(values: np.ndarray, n_quantiles: int, weights: np.ndarray | None = None,
                   threads: int = 1, bandwidths: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(probs (Q,), quantiles (Q, C)) of each column at `_probs`, strictly increasing.

    With `weights` (N,), weighted quantiles; with `bandwidths` (C,), those of the
    kernel-smoothed distribution (`_kernel_smoothed`). A
    tiny rank-proportional offset breaks ties (quantized sensors) so the inverse
    map is strictly monotone and never merges distinct inputs. Columns are independent: with `threads` > 1
    they are computed side by side (sorting and interpolation release the GIL).
    """
    probs = _probs(min(n_quantiles, values.shape[0]))

    def column(c: int) -> np.ndarray:
        if weights is None:
            return sorted_quantiles(values[:, c], probs, method="hazen")
        order = np.argsort(values[:, c], kind="stable")
        cum = np.cumsum(weights[order])
        mid = (cum - 0.5 * weights[order]) / cum[-1]
        return np.interp(probs, mid, values[order, c])

    def smoothed(c: int) -> np.ndarray:
        grid = column(c)
        return grid if bandwidths is None else _kernel_smoothed(grid, probs, float(bandwidths[c]))

    grid = np.stack(thread_map(smoothed, range(values.shape[1]), threads), axis=1)
    span = np.maximum(grid[-1] - grid[0], 1e-9)
    return probs, grid + np.arange(grid.shape[0])[:, None] * span * 1e-12


def _probs(n: int) -> np.ndarray:
    """Mid-rank probabilities plus both ends, so the extremes map too: 0, (k + 0.5) / n, 1."""
    return np.concatenate([[0.0], (np.arange(n) + 0.5) / n, [1.0]])


def _spread(values: np.ndarray, weights: np.ndarray | None) -> np.ndarray:
    """Standard deviation (C,) of each column, weighted when `weights` are given."""
    if weights is None:
        return values.std(axis=0)
    mean = np.average(values, axis=0, weights=weights)
    return np.sqrt(np.average((values - mean) ** 2, axis=0, weights=weights))


def window_bandwidths(values: np.ndarray, per_window: int) -> np.ndarray:
    """Kernel bandwidth (C,) for rows (N, C) that are n windows of `per_window` samples.

    The samples of one window are not independent: what a few windows leave
    unknown is where another window's level would fall. So the bandwidth comes
    from the windows' means, scale = min(sd, IQR / 1.349): Silverman's
    0.9 scale n^(-1/5) for few windows, and no more than GAP_WIDTHS scale / n,
    the order of the gap between neighbouring window levels where they are
    sparse, once many windows overlap (there a wider kernel would only blur
    the real peaks).
    """
    means = values.reshape(-1, per_window, values.shape[-1]).mean(axis=1)
    n = len(means)
    sd = means.std(axis=0)
    q25, q75 = np.quantile(means, [0.25, 0.75], axis=0)
    scale = np.where(q75 > q25, np.minimum(sd, (q75 - q25) / 1.349), sd)
    return scale * min(0.9 * n ** -0.2, GAP_WIDTHS / n)


def _kernel_smoothed(grid: np.ndarray, probs: np.ndarray, h: float) -> np.ndarray:
    """Quantiles at `probs` of one column's distribution (its quantile `grid` at `probs`)
    convolved with a Gaussian of sd `h`, then shrunk towards the mean by
    1 / sqrt(1 + h^2 / sd^2) so mean and variance stay the data's.

    With few real windows, each a plateau, the empirical distribution has gaps
    between the windows' levels, and a quantile map onto it would step from
    plateau to plateau inside one synthetic window; onto the smoothed one it ramps.
    """
    inner = grid[1:-1]
    mean, sd = float(inner.mean()), float(inner.std())
    if not (h > 0 and sd > 0):
        return grid
    edges = np.linspace(grid[0] - 4 * h, grid[-1] + 4 * h, KDE_BINS + 1)
    density = gaussian_filter1d(np.histogram(inner, edges)[0].astype(np.float64),
                                h / (edges[1] - edges[0]), mode="constant")
    cdf = np.concatenate([[0.0], np.cumsum(density)])
    cdf /= cdf[-1]
    # the CDF's knots: where each run of bins with mass begins and ends (a kernel narrower than the
    # gaps between levels leaves empty bins, and inverting across one must not spread a bin's mass
    # over the gap)
    rising = np.flatnonzero(np.diff(cdf) > 0)
    knots = np.union1d(rising, rising + 1)
    smooth = mean + (np.interp(probs, cdf[knots], edges[knots]) - mean) / np.sqrt(1.0 + (h / sd) ** 2)
    # the kernel's far tails are no data: the ends are the outer levels, or the data's own
    # extremes where those lie further out (so every input value maps strictly inside)
    smooth[0], smooth[-1] = min(smooth[1], grid[0]), max(smooth[-2], grid[-1])
    return smooth


class ChannelMap:
    """One pair (F_v, G_r^-1) for C channels, both kernel-smoothed with the same bandwidth
    relative to their spread, from real windows of `per_window` samples (`window_bandwidths`)."""

    def __init__(self, synthetic: np.ndarray, real: np.ndarray, n_quantiles: int,
                 synthetic_weights: np.ndarray | None = None, threads: int = 1, per_window: int = 1) -> None:
        self.threads = threads
        relative = window_bandwidths(real, per_window) / np.maximum(real.std(axis=0), 1e-12)
        self.v_probs, self.v_grid = _quantile_grid(synthetic, n_quantiles, synthetic_weights, threads,
                                                   bandwidths=relative * _spread(synthetic, synthetic_weights))
        self.r_probs, self.r_grid = _quantile_grid(real, n_quantiles, threads=threads,
                                                   bandwidths=relative * real.std(axis=0))

    def apply(self, x: np.ndarray) -> np.ndarray:
        flat = x.reshape(-1, x.shape[-1])
        out = np.empty_like(flat, dtype=np.float64)

        def column(c: int) -> None:
            p = np.interp(flat[:, c], self.v_grid[:, c], self.v_probs)
            out[:, c] = np.interp(p, self.r_probs, self.r_grid[:, c])

        thread_map(column, range(flat.shape[1]), self.threads if len(flat) >= _THREADED_ROWS else 1)
        return out.reshape(x.shape)


@dataclass(eq=False, repr=False)
class RankGrounder:
    """Channel-wise quantile matching from synthetic to real marginals.

    fit(synthetic, real) with windows (N, T, C) or samples (N, C).
    transform(x, labels) maps (..., T, C).

    `class_balanced=True` (with labels) weights the synthetic samples so their
    class mix matches the real one before F_v is taken: the synthetic pool is
    generated with its own class proportions (rare classes oversampled, motions
    of different lengths), and an unweighted pooled F_v would shift every
    class's values. `per_class=True` fits one map per class instead (a class with fewer than
    `min_class_samples` samples on either side keeps the pooled map).

    Classes with no real sample never shape F_v: the pooled map is fitted on the synthetic
    classes the real data has and carries over to them. Two cases leave a class as it is
    (`unmapped_`, for `transform` with labels; without labels it applies the pooled map): the
    synthetic pool holds no class with real samples (nothing says how its values become real
    ones), or the caller names it in `unseen`, a class with no real window anywhere (the
    seen classes' map would give it their marginals: docs/results.md, "The seen classes' map
    is not lent to an unseen class").
    `threads` > 1 fits and maps the channels side by side (same result).
    """

    per_class: bool = False
    n_quantiles: int = DEFAULT_N_QUANTILES
    min_class_samples: int = floors.RANK_MAP.floor
    class_balanced: bool = True
    threads: int = 1

    def fit(
        self,
        synthetic: np.ndarray,
        real: np.ndarray,
        synthetic_labels: np.ndarray | None = None,
        real_labels: np.ndarray | None = None,
        unseen: Iterable[int] = (),
    ) -> RankGrounder:
        syn = _as_samples(synthetic, "synthetic")
        rea = _as_samples(real, "real")
        if syn.shape[1] != rea.shape[1]:
            raise ValidationError(
                f"synthetic has {syn.shape[1]} channels but real has {rea.shape[1]}", field="channels"
            )
        self.n_channels_ = syn.shape[1]
        if self.per_class and (synthetic_labels is None or real_labels is None):
            raise ValidationError("per_class grounding needs synthetic and real labels", field="labels")
        labelled = synthetic_labels is not None and real_labels is not None
        syn_lab = _sample_labels(synthetic, synthetic_labels) if labelled else None
        rea_lab = _sample_labels(real, real_labels) if labelled else None
        per_window = _samples_per_window(real)
        self.overall_ = self._pooled_map(syn, rea, syn_lab, rea_lab, per_window)
        unseen = {int(c) for c in unseen}
        if labelled and unseen:  # no sort of the per-sample labels when no class is named
            unseen = (unseen & set(np.unique(syn_lab).tolist())) - set(np.unique(rea_lab).tolist())
            self.unmapped_ = self.unmapped_ | unseen
        self.per_class_: dict[int, ChannelMap] = {}
        if self.per_class:
            for cls in np.intersect1d(np.unique(syn_lab), np.unique(rea_lab)):
                s, r = syn[syn_lab == cls], rea[rea_lab == cls]
                if min(len(s), len(r)) >= self.min_class_samples:
                    self.per_class_[int(cls)] = ChannelMap(s, r, self.n_quantiles, threads=self.threads,
                                                           per_window=per_window)
        return self

    def _pooled_map(self, syn: np.ndarray, rea: np.ndarray, syn_lab: np.ndarray | None,
                    rea_lab: np.ndarray | None, per_window: int) -> ChannelMap:
        """The pooled pair, F_v from the synthetic classes the real data has (class-balanced);
        sets `unmapped_` when it has none of them."""
        self.unmapped_: frozenset[int] = frozenset()
        weights = None
        if syn_lab is not None and rea_lab is not None:
            if self.class_balanced:
                weights = _balance_weights(syn_lab, rea_lab)
            known = np.isin(syn_lab, np.unique(rea_lab))
            if known.any() and not known.all():
                syn, weights = syn[known], None if weights is None else weights[known]
            elif not known.any():  # nothing learns how synthetic values become real ones
                self.unmapped_ = frozenset(int(c) for c in np.unique(syn_lab))
        return ChannelMap(syn, rea, self.n_quantiles, weights, self.threads, per_window)

    def transform(self, x: np.ndarray, labels: np.ndarray | None = None) -> np.ndarray:
        """Ground windows (N, T, C), or rows (N, C) with N labels (any (..., C) array when
        not per class). Each value maps on its own: grounding many samples concatenated gives
        the same values as grounding them one by one, only faster."""
        x = np.asarray(x, dtype=np.float64)
        if x.shape[-1] != self.n_channels_:
            raise ValidationError(f"expected {self.n_channels_} channels, got {x.shape[-1]}", field="channels")
        if labels is None:
            return self.overall_.apply(x)
        out = np.empty_like(x)
        labels = np.asarray(labels)
        for cls in np.unique(labels):
            mask = labels == cls
            out[mask] = x[mask] if int(cls) in self.unmapped_ else \
                self.per_class_.get(int(cls), self.overall_).apply(x[mask])
        return out

    def mapping(self, label: int) -> str:
        """How `transform` maps class `label` given its labels: 'class' (its own map), 'pooled' or
        'none' (left as it is: no class of the synthetic pool had real windows, or the class was
        named `unseen`)."""
        if label in self.unmapped_:
            return "none"
        return "class" if label in self.per_class_ else "pooled"


def _balance_weights(syn_labels: np.ndarray, real_labels: np.ndarray) -> np.ndarray:
    """Per-sample weights giving the synthetic pool the real class proportions.

    Classes absent from the real data keep weight 1 relative to their share.
    """
    classes, syn_counts = np.unique(syn_labels, return_counts=True)
    real_share = {c: n / len(real_labels) for c, n in zip(*np.unique(real_labels, return_counts=True),
                                                            strict=True)}
    syn_share = syn_counts / len(syn_labels)
    factor = {c: (real_share.get(c, s) / s) for c, s in zip(classes, syn_share, strict=True)}
    return np.array([factor[c] for c in syn_labels], dtype=np.float64)


def _as_samples(x: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim < 2 or x.size == 0:
        raise ValidationError(f"{name} data must be a non-empty (N, T, C) or (N, C) array", field=name)
    flat = x.reshape(-1, x.shape[-1])
    if not np.isfinite(flat).all():
        raise ValidationError(f"{name} data contains NaN or inf", field=name)
    return flat


def _samples_per_window(x: np.ndarray) -> int:
    """T of windows (N, T, C); 1 for rows (N, C)."""
    shape = np.shape(x)
    return int(np.prod(shape[1:-1])) if len(shape) > 2 else 1


def _sample_labels(x: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Repeat per-window labels for every sample of the window."""
    return np.repeat(np.asarray(labels), _samples_per_window(x))
