"""The rank map's numerics pinned against independent computations: the kernel bandwidth from a
hand-worked example, the smoothed quantiles against a root-found mixture of Gaussians, weighted
quantiles and spreads against repeated samples, the tie-breaking offset, and the map as the
composition of its two stored grids (one thread or several)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.stats import norm

from vsmp_imu.grounding.rank import (
    GAP_WIDTHS,
    KDE_BINS,
    ChannelMap,
    _balance_weights,
    _kernel_smoothed,
    _probs,
    _quantile_grid,
    _spread,
    window_bandwidths,
)
from vsmp_imu.quantiles import sorted_quantiles


def _windows(means_per_channel, per_window, wobble=0.3):
    """Rows (n * per_window, C): window w of channel c sits at means[c][w] +- wobble (mean exact)."""
    means = np.asarray(means_per_channel, dtype=float).T  # (n, C)
    offsets = wobble * np.where(np.arange(per_window) % 2 == 0, 1.0, -1.0)  # per_window even: mean 0
    return (means[:, None, :] + offsets[None, :, None]).reshape(-1, means.shape[1])


def test_bandwidth_of_a_few_windows_is_silvermans_from_their_means():
    # channel 0: means 0..4 -> sd sqrt(2), IQR 2 (2 / 1.349 > sd): scale sqrt(2)
    # channel 1: means 0, 0, 0, 0, 10 -> IQR 0: scale sd = 4
    # channel 2: means 0, 1, 2, 3, 40 -> sd 15.2, IQR 2: scale 2 / 1.349
    x = _windows([[0, 1, 2, 3, 4], [0, 0, 0, 0, 10], [0, 1, 2, 3, 40]], per_window=4)
    factor = 0.9 * 5 ** -0.2  # below GAP_WIDTHS / 5
    expected = np.array([np.sqrt(2.0), 4.0, 2.0 / 1.349]) * factor
    assert window_bandwidths(x, 4) == pytest.approx(expected, rel=1e-12)


def test_bandwidth_of_many_windows_is_capped_by_their_gaps():
    means = np.arange(200.0)
    x = _windows([means], per_window=2)
    scale = min(means.std(), (np.quantile(means, 0.75) - np.quantile(means, 0.25)) / 1.349)
    assert window_bandwidths(x, 2)[0] == pytest.approx(scale * GAP_WIDTHS / 200, rel=1e-12)


def _mixture_quantiles(points, h, probs):
    """Quantiles of the mean of N(point, h^2), shrunk to the points' mean and variance."""
    mean, sd = points.mean(), points.std()
    cdf = lambda x, p: norm.cdf((x - points) / h).mean() - p  # noqa: E731
    lo, hi = points.min() - 10 * h, points.max() + 10 * h
    q = np.array([brentq(cdf, lo, hi, args=(p,), xtol=1e-12) for p in probs])
    return mean + (q - mean) / np.sqrt(1 + (h / sd) ** 2)


def _bin(lo: float, hi: float, h: float) -> float:
    """The width of one bin of the histogram on which levels from `lo` to `hi` are smoothed."""
    return (hi - lo + 8 * h) / KDE_BINS


@pytest.mark.parametrize("h", [0.2, 1.0])
def test_smoothed_quantiles_are_those_of_the_gaussian_mixture_with_the_variance_kept(h):
    points = np.array([0.0, 0.1, 0.2, 3.0, 3.1, 7.0])  # three plateaus, as a few windows give
    probs = _probs(len(points))
    grid = np.concatenate([[points[0]], points, [points[-1]]])  # its quantile grid at probs
    out = _kernel_smoothed(grid, probs, h)
    step = _bin(points[0], points[-1], h)
    assert out[1:-1] == pytest.approx(_mixture_quantiles(points, h, probs[1:-1]), abs=3 * step)
    # the ends: the outer smoothed levels, or the data's extremes where those lie further out
    assert out[0] == min(out[1], grid[0]) and out[-1] == max(out[-2], grid[-1])


def test_a_kernel_narrower_than_the_gaps_leaves_each_level_where_it_is():
    # two levels 50 apart, a kernel of 0.001 (a still posture's gyroscope gets about 2e-5 rad/s): the
    # smoothed quartiles are the levels themselves, not a ramp across the gap between them
    grid = np.array([0.0, 0.0, 50.0, 50.0])
    out = _kernel_smoothed(grid, _probs(2), 0.001)
    step = _bin(0.0, 50.0, 0.001)
    assert out[1:-1] == pytest.approx([0.0, 50.0], abs=step)


def test_a_narrow_kernel_on_a_dense_core_with_sparse_tails_gives_the_mixtures_tails():
    # as a still posture's channel: most samples in a narrow core, a few spikes far out in the tails,
    # the kernel (from the windows' near-equal means) far narrower than a histogram bin
    rng = np.random.default_rng(3)
    points = np.sort(np.concatenate([rng.normal(0.0, 0.02, 300), [-1.4, -0.9, 0.5, 0.6, 1.1]]))
    probs = _probs(len(points))
    grid = np.concatenate([[points[0]], points, [points[-1]]])
    h = 2e-5
    out = _kernel_smoothed(grid, probs, h)
    step = _bin(points[0], points[-1], h)
    assert out[1:-1] == pytest.approx(_mixture_quantiles(points, h, probs[1:-1]), abs=3 * step)


def test_smoothing_keeps_the_mean_and_variance_and_leaves_degenerate_columns_alone():
    rng = np.random.default_rng(4)
    points = np.sort(np.concatenate([rng.normal(0, 1, 400), rng.normal(6, 0.5, 200)]))
    probs = _probs(len(points))
    grid = np.concatenate([[points[0] - 1], points, [points[-1] + 1]])
    out = _kernel_smoothed(grid, probs, 0.8)[1:-1]
    assert out.mean() == pytest.approx(points.mean(), abs=0.01)
    assert out.std() == pytest.approx(points.std(), rel=0.01)
    assert np.array_equal(_kernel_smoothed(grid, probs, 0.0), grid)
    flat = np.full(5, 2.0)
    assert np.array_equal(_kernel_smoothed(flat, _probs(3), 0.5), flat)


def test_weighted_quantiles_and_spread_are_those_of_the_repeated_sample():
    values = np.array([[3.0, -1.0], [1.0, 5.0], [2.0, 0.0], [7.0, 2.0]])
    weights = np.array([1.0, 2.0, 1.0, 4.0])
    probs, grid = _quantile_grid(values, 10, weights)
    assert np.array_equal(probs, _probs(4))
    for c in range(2):
        order = np.argsort(values[:, c])
        cum = np.cumsum(weights[order])
        mid = (cum - weights[order] / 2) / cum[-1]  # each value's mid-rank in the weighted sample
        span = values[:, c].max() - values[:, c].min()
        expected = np.interp(probs, mid, values[order, c]) + np.arange(6) * span * 1e-12
        assert grid[:, c] == pytest.approx(expected, rel=0, abs=1e-13)
    repeated = np.repeat(values, weights.astype(int), axis=0)
    assert _spread(values, weights) == pytest.approx(repeated.std(axis=0), rel=1e-12)
    assert np.array_equal(_spread(values, None), values.std(axis=0))


def test_unweighted_grid_is_hazen_quantiles_plus_a_rank_offset_that_breaks_ties():
    values = np.array([[4.0], [1.0], [1.0], [9.0], [2.0]])
    probs, grid = _quantile_grid(values, 4096)
    base = sorted_quantiles(values[:, 0], probs, method="hazen")
    assert grid[:, 0] - base == pytest.approx(np.arange(7) * 8.0 * 1e-12, rel=1e-3, abs=1e-16)
    assert np.all(np.diff(grid[:, 0]) > 0)  # the two 1.0 levels are told apart


def test_grid_is_capped_at_the_requested_number_of_quantiles():
    values = np.arange(100.0)[:, None]
    probs, grid = _quantile_grid(values, 10)
    assert np.array_equal(probs, _probs(10)) and grid.shape == (12, 1)


def test_balance_weights_are_the_ratio_of_real_to_synthetic_shares():
    syn = np.array([0, 0, 0, 1, 2])  # shares 0.6, 0.2, 0.2; class 2 has no real sample
    real = np.array([0, 1, 1, 1])  # shares 0.25, 0.75
    w = _balance_weights(syn, real)
    assert w == pytest.approx([0.25 / 0.6] * 3 + [0.75 / 0.2, 1.0], rel=1e-12)


@pytest.mark.parametrize("threads", [1, 2])
def test_the_map_is_the_real_inverse_cdf_of_the_synthetic_cdf(threads):
    rng = np.random.default_rng(9)
    syn = rng.gamma(2.0, 1.0, size=(600, 3))
    real = rng.normal(0.0, 1.0, size=(400, 3)) * [1.0, 2.0, 3.0]
    m = ChannelMap(syn, real, 256, threads=threads)
    x = rng.gamma(2.0, 1.0, size=(5000, 3))  # above the threaded-rows threshold
    out = m.apply(x)
    for c in range(3):
        p = np.interp(x[:, c], m.v_grid[:, c], m.v_probs)
        assert np.array_equal(out[:, c], np.interp(p, m.r_probs, m.r_grid[:, c]))
    assert np.array_equal(out, ChannelMap(syn, real, 256, threads=1).apply(x))
    assert m.apply(x[:7].reshape(7, 1, 3)).shape == (7, 1, 3)


def test_probabilities_are_mid_ranks_between_zero_and_one():
    assert np.array_equal(_probs(4), [0.0, 0.125, 0.375, 0.625, 0.875, 1.0])


def test_each_end_is_the_outer_smoothed_level_or_the_grid_end_whichever_lies_further_out():
    points = np.array([-1.0, -0.8, -0.2, 0.3, 0.5])
    grid = np.concatenate([[-1.2], points, [0.5]])  # the low end further out than the lowest level
    out = _kernel_smoothed(grid, _probs(5), 0.5)
    assert out[0] == -1.2 and out[1] > -1.2
    assert out[-1] == out[-2] > 0.5  # the top smoothed level lies beyond the data's maximum


def test_weighted_quantiles_order_tied_values_by_position():
    rng = np.random.default_rng(2)
    values = rng.integers(0, 3, size=(200, 1)).astype(float)  # three levels, many ties
    weights = rng.uniform(0.1, 5.0, size=200)
    probs, grid = _quantile_grid(values, 4096, weights)
    order = np.argsort(values[:, 0], kind="stable")  # ties keep their input order
    cum = np.cumsum(weights[order])
    expected = np.interp(probs, (cum - weights[order] / 2) / cum[-1], values[order, 0]) \
        + np.arange(len(probs)) * 2.0 * 1e-12
    assert grid[:, 0] == pytest.approx(expected, rel=0, abs=1e-13)


def test_both_sides_are_smoothed_with_one_bandwidth_relative_to_their_spread():
    rng = np.random.default_rng(6)
    per_window = 10
    real = rng.normal(0, 1, size=(12 * per_window, 3)) * [0.05, 1.0, 4.0] + rng.normal(
        0, [0.1, 3.0, 3.0], size=(12, 1, 3)).repeat(per_window, axis=0).reshape(-1, 3)  # one spread below 1
    syn = rng.gamma(2.0, 1.0, size=(300, 3)) * [0.1, 2.0, 0.5]
    weights = rng.uniform(0.5, 2.0, size=300)
    m = ChannelMap(syn, real, 64, weights, per_window=per_window)
    h_real = window_bandwidths(real, per_window)  # in the real data's units
    relative = h_real / real.std(axis=0)
    assert np.array_equal(m.r_grid, _quantile_grid(real, 64, bandwidths=relative * real.std(axis=0))[1])
    assert np.array_equal(m.v_grid, _quantile_grid(syn, 64, weights, bandwidths=relative * _spread(syn, weights))[1])
    rows = ChannelMap(syn, real, 64, weights)  # without a window length every row is a window
    assert np.array_equal(rows.r_grid, _quantile_grid(real, 64, bandwidths=window_bandwidths(real, 1))[1])
    assert not np.allclose(m.r_grid, rows.r_grid)  # windows matter


def test_the_tie_offset_follows_the_weighted_grid_span_below_one():
    values = np.array([[0.0], [0.1], [0.2], [0.4]])  # a span of 0.4, its top value lightly weighted
    weights = np.array([1.0, 1.0, 1.0, 0.1])
    probs, grid = _quantile_grid(values, 4096, weights)
    cum = np.cumsum(weights)
    plain = np.interp(probs, (cum - weights / 2) / cum[-1], values[:, 0])
    assert plain[-2] < plain[-1] == 0.4
    assert grid[:, 0] - plain == pytest.approx(np.arange(6) * 0.4 * 1e-12, rel=0, abs=1e-15)


def test_a_map_applied_to_single_precision_values_returns_double_precision():
    """Window means or readings stored as float32 are mapped in float64: the result is the float64
    input's mapping, not rounded to float32 (which moves values by up to 1e-7 of their size)."""
    rng = np.random.default_rng(6)
    syn, real = rng.normal(size=(500, 3)), rng.normal(3.0, 2.0, (400, 3)) * 1e3
    m = ChannelMap(syn, real, 128)
    x = rng.normal(size=(50, 3)).astype(np.float32)
    out = m.apply(x)
    assert out.dtype == np.float64
    np.testing.assert_array_equal(out, m.apply(x.astype(np.float64)))
