"""Rank grounding by its properties: monotone, real order statistics at the grid points (up to
the kernel smoothing of both distributions, `window_bandwidths`), extremes onto extremes,
classes where they belong. Nothing here depends on how the map interpolates between grid points."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.rank import (
    DEFAULT_N_QUANTILES,
    RankGrounder,
    _sample_labels,
    window_bandwidths,
)


@pytest.fixture
def rng():
    return np.random.default_rng(12)


def test_order_statistics_map_onto_real_order_statistics(rng):
    syn = rng.gamma(2.0, 1.0, size=(300, 2))
    real = rng.normal(5.0, 2.0, size=(300, 2))
    g = RankGrounder(class_balanced=False).fit(syn, real)
    out = g.transform(syn)
    h = window_bandwidths(real, 1)  # the kernel's width: the map is exact up to it
    for c in range(2):
        order = np.argsort(syn[:, c])
        dev = np.abs(out[order, c] - np.sort(real[:, c]))  # k-th onto (smoothed) k-th
        assert np.median(dev) < h[c] and dev.max() < 0.5 * real[:, c].std()
        assert abs(out[:, c].mean() - real[:, c].mean()) < 0.05 * real[:, c].std()
        assert 0.97 < out[:, c].std() / real[:, c].std() < 1.01  # the smoothing keeps the variance


def test_map_is_monotone_and_sends_extremes_to_real_extremes(rng):
    syn = rng.normal(0, 1, size=(500, 3))
    real = rng.exponential(2.0, size=(400, 3))
    g = RankGrounder(class_balanced=False, n_quantiles=64).fit(syn, real)
    x = np.linspace(-6, 6, 2001)[:, None].repeat(3, 1)
    out = g.transform(x)
    assert (np.diff(out, axis=0) >= 0).all()
    h = window_bandwidths(real, 1)  # a smoothed end may lie up to a few kernel widths outside
    lo, hi = real.min(0) - 4 * h, real.max(0) + 4 * h
    assert (lo <= out[0]).all() and (out[0] <= real.min(0) + 1e-6).all()
    assert (real.max(0) - 1e-6 <= out[-1]).all() and (out[-1] <= hi).all()
    inside = g.transform(syn)
    assert (inside >= lo).all() and (inside <= hi).all()


def test_fewer_quantiles_keep_the_real_quantiles_at_the_grid_points(rng):
    syn = rng.uniform(0, 1, size=(4000, 1))
    real = rng.normal(10, 3, size=(4000, 1))
    g = RankGrounder(class_balanced=False, n_quantiles=50).fit(syn, real)
    probs = (np.arange(50) + 0.5) / 50
    at_grid = np.quantile(syn[:, 0], probs, method="hazen")[:, None]
    want = np.quantile(real[:, 0], probs, method="hazen")
    h = window_bandwidths(real, 1)[0]
    assert np.abs(g.transform(at_grid)[:, 0] - want).max() < 3 * h
    g = RankGrounder()
    assert DEFAULT_N_QUANTILES == 4096 and (g.n_quantiles, g.min_class_samples) == (4096, 200)
    assert (g.per_class, g.class_balanced) == (False, True)


def test_per_class_maps_need_enough_samples_on_both_sides(rng):
    syn = np.concatenate([rng.normal(0, 1, (200, 1)), rng.normal(10, 1, (200, 1))])
    real = np.concatenate([rng.normal(-5, 1, (200, 1)), rng.normal(5, 1, (100, 1))])
    ys, yr = np.repeat([0, 1], 200), np.repeat([0, 1], [200, 100])
    g = RankGrounder(per_class=True, min_class_samples=100).fit(syn, real, ys, yr)
    assert sorted(g.per_class_) == [0, 1]  # class 1 has exactly 100 real samples
    assert sorted(RankGrounder(per_class=True, min_class_samples=101).fit(syn, real, ys, yr).per_class_) == [0]
    out = g.transform(syn, ys)
    assert out[ys == 0].mean() == pytest.approx(-5, abs=0.3) and out[ys == 1].mean() == pytest.approx(5, abs=0.3)
    unseen = g.transform(syn[:5], np.full(5, 7))
    assert np.allclose(unseen, g.overall_.apply(syn[:5]))
    assert np.allclose(g.transform(syn), g.overall_.apply(syn))


def test_sample_labels_repeat_per_window_sample():
    assert _sample_labels(np.zeros((2, 3, 6)), np.array([4, 5])).tolist() == [4, 4, 4, 5, 5, 5]
    assert _sample_labels(np.zeros((2, 6)), np.array([4, 5])).tolist() == [4, 5]
    assert _sample_labels(np.zeros((2, 2, 3, 6)), np.array([1, 2])).tolist() == [1] * 6 + [2] * 6


@pytest.mark.parametrize(("syn", "real", "field"), [
    (np.zeros((5, 2)), np.zeros((5, 3)), "channels"),
    (np.zeros(5), np.zeros((5, 1)), "synthetic"),
    (np.zeros((5, 1)), np.zeros((0, 1)), "real"),
    (np.full((5, 1), np.nan), np.zeros((5, 1)), "synthetic"),
    (np.zeros((5, 1)), np.full((5, 1), np.inf), "real"),
])
def test_fit_rejects_bad_input_by_field(syn, real, field):
    with pytest.raises(ValidationError) as err:
        RankGrounder(class_balanced=False).fit(syn, real)
    assert err.value.field == field


def test_per_class_needs_labels_and_transform_checks_channels(rng):
    syn, real = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    for ys, yr in ((None, None), (np.zeros(50), None), (None, np.zeros(50))):
        with pytest.raises(ValidationError) as err:
            RankGrounder(per_class=True, class_balanced=False).fit(syn, real, ys, yr)
        assert err.value.field == "labels"
        assert err.value.message == "per_class grounding needs synthetic and real labels"
    g = RankGrounder(class_balanced=False).fit(syn, real)
    with pytest.raises(ValidationError) as err:
        g.transform(np.zeros((4, 3)))
    assert err.value.field == "channels" and err.value.message == "expected 2 channels, got 3"


def _classes(rng, means, n_windows, scale=1.0):
    x = np.concatenate([rng.normal(m, scale, (n, 50, 1)) for m, n in zip(means, n_windows, strict=True)])
    return x, np.repeat(np.arange(len(means)), n_windows)


@pytest.mark.parametrize("per_class", [False, True])
def test_a_class_without_real_windows_does_not_shape_the_pooled_map(rng, per_class):
    # synthetic classes 0, 1 (seen) and 2 (unseen: no real window), real classes 0 and 1
    syn, ys = _classes(rng, [-2.0, 2.0, 8.0], [20, 20, 20], scale=0.5)
    real, yr = _classes(rng, [-1.0, 1.0], [20, 20], scale=0.3)
    with_unseen = RankGrounder(per_class=per_class).fit(syn, real, ys, yr)
    seen = ys < 2
    without = RankGrounder(per_class=per_class).fit(syn[seen], real, ys[seen], yr)
    assert with_unseen.mapping(2) == "pooled"
    # the seen classes map as if the unseen class had not been generated (to rounding: the
    # class-balance weights differ by a common factor)
    assert np.allclose(with_unseen.transform(syn[seen], ys[seen]), without.transform(syn[seen], ys[seen]),
                       rtol=0, atol=1e-9)
    # the unseen class takes the seen classes' map: its values land above the seen ones, not
    # squeezed into the real classes' range as a pooled F_v with it would squeeze them
    unseen = with_unseen.transform(syn[~seen], ys[~seen])
    assert unseen.mean() > real.max() - 0.1
    assert np.allclose(unseen, without.transform(syn[~seen]), rtol=0, atol=1e-9)


@pytest.mark.parametrize("per_class", [False, True])
def test_a_class_named_unseen_keeps_its_values_and_the_seen_classes_map_as_before(rng, per_class):
    syn, ys = _classes(rng, [-2.0, 2.0, 8.0], [20, 20, 20], scale=0.5)
    real, yr = _classes(rng, [-1.0, 1.0], [20, 20], scale=0.3)
    lent = RankGrounder(per_class=per_class).fit(syn, real, ys, yr)
    kept = RankGrounder(per_class=per_class).fit(syn, real, ys, yr, unseen=[2, 5])
    assert kept.unmapped_ == frozenset({2}) and kept.mapping(2) == "none"
    assert np.array_equal(kept.transform(syn[ys == 2], ys[ys == 2]), syn[ys == 2])
    seen = ys < 2
    assert np.array_equal(kept.transform(syn[seen], ys[seen]), lent.transform(syn[seen], ys[seen]))
    # a class with real samples is mapped even when a caller names it
    assert RankGrounder(per_class=per_class).fit(syn, real, ys, yr, unseen=[1]).mapping(1) == lent.mapping(1)


def test_a_pool_of_unseen_classes_only_is_left_as_it_is(rng):
    syn, ys = _classes(rng, [5.0, 9.0], [10, 10])
    real, yr = _classes(rng, [-1.0, 1.0], [10, 10])
    g = RankGrounder(per_class=True).fit(syn, real, ys + 2, yr)  # synthetic classes 2, 3; real 0, 1
    assert g.unmapped_ == frozenset({2, 3}) and g.mapping(2) == "none"
    assert np.array_equal(g.transform(syn, ys + 2), syn)
    # without labels a caller asks for the pooled map, as before
    assert not np.allclose(g.transform(syn), syn)


def test_labels_change_nothing_for_the_pooled_map(rng):
    syn, ys = _classes(rng, [-2.0, 2.0], [15, 5])
    real, yr = _classes(rng, [-1.0, 1.0], [10, 10])
    g = RankGrounder().fit(syn, real, ys, yr)
    assert g.mapping(0) == g.mapping(1) == "pooled"
    assert np.array_equal(g.transform(syn, ys), g.transform(syn))


def test_mapping_names_a_class_with_its_own_map(rng):
    # class 0 has 20 windows of 50 samples on both sides (>= min_class_samples), class 1 only 2
    syn, ys = _classes(rng, [-2.0, 2.0], [20, 2])
    real, yr = _classes(rng, [-1.0, 1.0], [20, 2])
    g = RankGrounder(per_class=True).fit(syn, real, ys, yr)
    assert sorted(g.per_class_) == [0]
    assert g.mapping(0) == "class" and g.mapping(1) == "pooled"


def test_synthetic_labels_alone_ground_as_no_labels():
    rng = np.random.default_rng(3)
    syn, ys = _classes(rng, [-2.0, 2.0], [30, 10])
    real, _ = _classes(rng, [-1.0, 1.0], [10, 30])
    alone = RankGrounder().fit(syn, real, synthetic_labels=ys)
    assert np.array_equal(alone.transform(syn), RankGrounder().fit(syn, real).transform(syn))


@pytest.mark.parametrize("balanced", [True, False])
def test_an_unseen_class_leaves_the_weighted_pooled_map_as_it_was(balanced):
    rng = np.random.default_rng(5)
    syn, ys = _classes(rng, [-2.0, 2.0, 8.0], [30, 10, 20], scale=0.5)  # unequal shares: weights matter
    real, yr = _classes(rng, [-1.0, 1.0], [10, 30], scale=0.3)
    seen = ys < 2
    with_unseen = RankGrounder(class_balanced=balanced).fit(syn, real, ys, yr)
    without = RankGrounder(class_balanced=balanced).fit(syn[seen], real, ys[seen], yr)
    assert np.allclose(with_unseen.transform(syn), without.transform(syn), rtol=0, atol=1e-9)
    unweighted = RankGrounder(class_balanced=False).fit(syn[seen], real, ys[seen], yr)
    assert np.allclose(with_unseen.transform(syn), unweighted.transform(syn), rtol=0, atol=1e-9) is not balanced


def test_a_class_map_keeps_the_window_length_for_its_bandwidth():
    from vsmp_imu.grounding.rank import ChannelMap

    rng = np.random.default_rng(8)
    syn, ys = _classes(rng, [-2.0, 2.0], [20, 20])
    real, yr = _classes(rng, [-1.0, 1.0], [20, 20])
    g = RankGrounder(per_class=True).fit(syn, real, ys, yr)
    own = ChannelMap(syn[ys == 0].reshape(-1, 1), real[yr == 0].reshape(-1, 1), g.n_quantiles, per_window=50)
    assert np.array_equal(g.per_class_[0].r_grid, own.r_grid)


def test_wrong_channels_of_windows_name_the_channel_count():
    rng = np.random.default_rng(1)
    g = RankGrounder().fit(rng.normal(size=(10, 5, 2)), rng.normal(size=(10, 5, 2)))
    with pytest.raises(ValidationError) as err:
        g.transform(np.zeros((4, 5, 3)))
    assert err.value.message == "expected 2 channels, got 3"
