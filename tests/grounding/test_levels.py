"""Window levels: an event class's window means mapped onto the real ones (grounding.levels)."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.levels import MIN_WINDOWS, SPREAD_BOUNDS, LevelMap


def _windows(levels: np.ndarray, seed: int, n_t: int = 50, wiggle: float = 0.3) -> np.ndarray:
    """Windows (N, T, 2) at the given per-window levels (N, 2), each with its own course inside."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n_t)
    course = wiggle * np.sin(2 * np.pi * (t[None, :, None] + rng.uniform(0, 1, (len(levels), 1, 2))))
    return levels[:, None, :] + course


def test_the_mapped_means_follow_the_real_ones_and_the_course_inside_stays():
    rng = np.random.default_rng(0)
    real = _windows(np.c_[rng.normal(-3.0, 1.0, 300), rng.normal(5.0, 0.5, 300)], seed=1)
    syn = _windows(np.c_[rng.normal(1.0, 0.3, 200), rng.normal(2.0, 2.0, 200)], seed=2)
    y_syn, y_real = np.full(200, 7), np.full(300, 7)
    out = LevelMap().fit(syn, y_syn, real, y_real, classes=[7]).transform(syn, y_syn)
    means = out.mean(axis=1)
    # the synthetic means' quantiles now sit where the real means' do
    for q in (0.1, 0.5, 0.9):
        assert np.quantile(means, q, axis=0) == pytest.approx(np.quantile(real.mean(axis=1), q, axis=0), abs=0.3)
    # a constant shift per window: what the window does inside it is untouched
    assert np.allclose(out - means[:, None, :], syn - syn.mean(axis=1)[:, None, :])
    # and the map is monotone per channel: the windows keep their order
    for c in range(2):
        assert (np.argsort(means[:, c]) == np.argsort(syn.mean(axis=1)[:, c])).all()


def test_only_the_named_classes_with_evidence_enough_move():
    rng = np.random.default_rng(3)
    syn = _windows(rng.normal(0, 1, (90, 2)), seed=4)
    y_syn = np.repeat([0, 1, 2], 30)
    real = _windows(rng.normal(5, 1, (70, 2)), seed=5)
    y_real = np.r_[np.zeros(30), np.ones(30), np.full(10, 2)].astype(int)  # class 2: too few real windows
    levels = LevelMap().fit(syn, y_syn, real, y_real, classes=[1, 2])
    out = levels.transform(syn, y_syn)
    assert np.array_equal(out[y_syn == 0], syn[y_syn == 0])  # not an event class
    assert np.array_equal(out[y_syn == 2], syn[y_syn == 2])  # 10 real windows < MIN_WINDOWS
    assert not np.allclose(out[y_syn == 1], syn[y_syn == 1])
    assert levels.skipped_ == {2: 10} and MIN_WINDOWS > 10
    assert set(levels.classes_) == {1} and levels.classes_[1]["real_windows"] == 30
    assert levels.classes_[1]["mean_abs_shift"][0] > 3.0


def test_a_class_without_real_windows_is_left_alone_and_said_so():
    syn = _windows(np.zeros((30, 2)), seed=6)
    real = _windows(np.ones((30, 2)), seed=7)
    levels = LevelMap().fit(syn, np.full(30, 4), real, np.full(30, 0), classes=[4])
    assert levels.skipped_ == {4: 0}
    assert np.array_equal(levels.transform(syn, np.full(30, 4)), syn)


def test_mismatched_channels_and_shapes_are_named():
    with pytest.raises(ValidationError, match="channels"):
        LevelMap().fit(np.zeros((30, 10, 2)), np.zeros(30), np.zeros((30, 10, 3)), np.zeros(30), classes=[0])
    with pytest.raises(ValidationError, match="windows"):
        LevelMap().fit(np.zeros((30, 2)), np.zeros(30), np.zeros((30, 10, 2)), np.zeros(30), classes=[0])


def test_generate_prints_which_transitions_got_window_levels():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "window_levels": {"waist": {
        "classes": {"STAND_TO_LIE": {"real_windows": 23, "mean_abs_shift": [1.1, 0.7, 0.5, 0.1, 0.1, 0.1]}},
        "too_few": {"SIT_TO_STAND": 11}}}}
    with console.capture() as captured:
        _print_summary(summary)
    assert ("window levels at waist: mapped STAND_TO_LIE (23); too few real windows: SIT_TO_STAND (11)"
            in " ".join(captured.get().split()))


def _spread_windows(levels: np.ndarray, spreads: np.ndarray, seed: int, n_t: int = 50) -> np.ndarray:
    """Windows (N, T, 2) at the given per-window levels and spreads (N, 2): a sine of random phase."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n_t, endpoint=False)
    course = np.sqrt(2) * np.sin(2 * np.pi * (t[None, :, None] + rng.uniform(0, 1, (len(levels), 1, 2))))
    return levels[:, None, :] + spreads[:, None, :] * course


def test_window_spreads_follow_the_real_ones_window_by_window_and_the_shape_stays():
    rng = np.random.default_rng(8)
    real = _spread_windows(rng.normal(0, 1, (300, 2)), np.c_[rng.lognormal(0, 0.6, 300), rng.lognormal(-1, 0.2, 300)],
                           seed=9)
    syn_spread = np.c_[rng.lognormal(0.7, 0.1, 200), rng.lognormal(-1, 0.8, 200)]  # too vigorous, too wide
    syn = _spread_windows(rng.normal(0, 1, (200, 2)), syn_spread, seed=10)
    y_syn, y_real = np.full(200, 3), np.full(300, 3)
    plain = LevelMap().fit(syn, y_syn, real, y_real, classes=[3]).transform(syn, y_syn)
    levels = LevelMap(spreads=True).fit(syn, y_syn, real, y_real, classes=[3])
    out = levels.transform(syn, y_syn)
    spread, real_spread = out.std(axis=1), real.std(axis=1)
    for q in (0.1, 0.5, 0.9):  # the spreads' quantiles now sit where the real ones do, per channel
        assert np.quantile(spread, q, axis=0) == pytest.approx(np.quantile(real_spread, q, axis=0), rel=0.15)
    # without spreads they stay where they were
    assert np.median(plain.std(axis=1)[:, 0]) > 1.5 * np.median(real_spread[:, 0])
    # the means are those of window levels alone, the windows keep their spread order and shape
    assert np.allclose(out.mean(axis=1), plain.mean(axis=1))
    for c in range(2):
        assert (np.argsort(spread[:, c]) == np.argsort(syn_spread[:, c])).all()
    shape = (out - out.mean(axis=1, keepdims=True)) / spread[:, None, :]
    assert np.allclose(shape, (syn - syn.mean(axis=1, keepdims=True)) / syn.std(axis=1)[:, None, :])
    assert levels.classes_[3]["median_spread_factor"][0] < 0.8


def test_a_window_that_barely_moves_is_not_blown_up():
    rng = np.random.default_rng(11)
    real = _spread_windows(rng.normal(0, 1, (50, 2)), rng.lognormal(0, 0.2, (50, 2)), seed=12)
    syn = _spread_windows(rng.normal(0, 1, (50, 2)), np.r_[rng.lognormal(0, 0.2, (49, 2)), [[1e-6, 1e-6]]], seed=13)
    out = LevelMap(spreads=True).fit(syn, np.zeros(50), real, np.zeros(50), classes=[0]).transform(syn, np.zeros(50))
    assert out[-1].std(axis=0).max() == pytest.approx(SPREAD_BOUNDS[1] * 1e-6, rel=1e-3)  # clipped


def test_generate_prints_the_window_spread_factors():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "window_spreads": {"waist": {
        "classes": {"SIT_TO_STAND": {"real_windows": 40, "median_spread_factor": [0.81, 1.2]}}, "too_few": {}}}}
    with console.capture() as captured:
        _print_summary(summary)
    assert "window spreads SIT_TO_STAND at waist: median factor per channel 0.81, 1.20" in " ".join(
        captured.get().split())


def test_spreads_alone_leave_the_means_where_they_are():
    rng = np.random.default_rng(14)
    real = _spread_windows(rng.normal(5, 1, (100, 2)), rng.lognormal(0, 0.3, (100, 2)), seed=15)
    syn = _spread_windows(rng.normal(0, 1, (100, 2)), rng.lognormal(1, 0.3, (100, 2)), seed=16)
    y = np.zeros(100, int)
    levels = LevelMap(spreads=True, means=False).fit(syn, y, real, y, classes=[0])
    out = levels.transform(syn, y)
    assert np.allclose(out.mean(axis=1), syn.mean(axis=1))
    assert np.median(out.std(axis=1)) == pytest.approx(np.median(real.std(axis=1)), rel=0.15)
    assert "mean_abs_shift" not in levels.classes_[0] and levels.maps_ == {}
