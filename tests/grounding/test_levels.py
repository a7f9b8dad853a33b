"""Window levels: an event class's window means mapped onto the real ones (grounding.levels)."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.levels import MIN_WINDOWS, PARTS, LevelMap, part_means, shift_course


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
    assert PARTS == 1  # the default: the whole window's mean
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


def test_each_quarter_follows_the_real_ones_and_the_shift_has_no_step():
    """Real windows that change posture in the middle (a low first half, a high second half, at
    a level that varies per window), synthetic ones that change too early and too little: each
    quarter's mean is mapped onto the real ones' of that quarter, through a shift that runs
    linearly between the quarters' centres."""
    rng = np.random.default_rng(11)
    n_t = 40
    step_real = np.r_[np.zeros(n_t // 2), np.ones(n_t // 2)]
    step_syn = np.r_[np.zeros(n_t // 4), np.ones(3 * n_t // 4)]
    real = (rng.normal(-2.0, 0.5, (200, 1, 1)) + 6.0 * step_real[None, :, None]
            + rng.normal(0, 0.2, (200, n_t, 1)))
    syn = (rng.normal(0.0, 0.3, (150, 1, 1)) + 2.0 * step_syn[None, :, None]
           + rng.normal(0, 0.2, (150, n_t, 1)))
    y_syn, y_real = np.zeros(150, int), np.zeros(200, int)
    out = LevelMap(parts=4).fit(syn, y_syn, real, y_real, classes=[0]).transform(syn, y_syn)
    got, want = part_means(out, 4), part_means(real, 4)
    # the outer quarters, whose shift is flat across them, land where the real ones are
    for q in (0.1, 0.5, 0.9):
        for k in (0, 3):
            assert np.quantile(got[:, k], q) == pytest.approx(np.quantile(want[:, k], q), abs=0.35)
    # a single level could not: it moves the whole window and keeps the early, small change
    one = LevelMap(parts=1).fit(syn, y_syn, real, y_real, classes=[0]).transform(syn, y_syn)
    assert abs(np.median(part_means(one, 4)[:, 3] - part_means(one, 4)[:, 0]) - 6.0) > 3.0
    assert abs(np.median(got[:, 3] - got[:, 0]) - 6.0) < 1.0
    # the added shift changes by at most its range over a quarter's length per sample: no step
    added = out - syn
    span = np.ptp(added, axis=1).max()
    assert np.abs(np.diff(added, axis=1)).max() <= span / (n_t / 4) + 1e-9


def test_the_shift_course_is_flat_outside_and_linear_between_the_part_centres():
    shift = np.array([[1.0, 10.0, -2.0, 3.0]])[:, :, None].reshape(1, 4)  # one window, one channel
    course = shift_course(shift, 40, 4)[0, :, 0]
    assert course.shape == (40,)
    assert np.allclose(course[:5], 1.0) and np.allclose(course[-5:], 3.0)  # before the first centre, after the last
    assert course[15] == pytest.approx(10.0, abs=0.5) and course[25] == pytest.approx(-2.0, abs=0.7)
    assert np.allclose(shift_course(np.array([[2.0, -1.0]]), 5, 1), [[[2.0, -1.0]] * 5])


def test_only_the_named_classes_with_evidence_enough_move():
    rng = np.random.default_rng(3)
    syn = _windows(rng.normal(0, 1, (90, 2)), seed=4)
    y_syn = np.repeat([0, 1, 2], 30)
    real = _windows(rng.normal(5, 1, (70, 2)), seed=5)
    y_real = np.r_[np.zeros(30), np.ones(30), np.full(10, 2)].astype(int)
    y_real[-7:] = 3  # class 2 keeps 3 real windows: too few
    levels = LevelMap().fit(syn, y_syn, real, y_real, classes=[1, 2])
    out = levels.transform(syn, y_syn)
    assert np.array_equal(out[y_syn == 0], syn[y_syn == 0])  # not an event class
    assert np.array_equal(out[y_syn == 2], syn[y_syn == 2])  # 3 real windows < MIN_WINDOWS
    assert not np.allclose(out[y_syn == 1], syn[y_syn == 1])
    assert levels.skipped_ == {2: 3} and MIN_WINDOWS > 3
    assert set(levels.classes_) == {1} and levels.classes_[1]["real_windows"] == 30
    assert levels.classes_[1]["mean_abs_shift"][0] > 3.0


def test_a_few_real_windows_move_the_means_to_their_level_and_no_further():
    """A low-resource budget leaves an event class a handful of real windows (HAPT12 at 5 %: 5 to
    11 per transition): the kernel-smoothed map moves the synthetic means to the real ones' level
    and spreads them no wider than a few real windows' spread allows."""
    rng = np.random.default_rng(8)
    real_means = np.c_[rng.normal(-4.0, 0.5, MIN_WINDOWS), rng.normal(6.0, 0.5, MIN_WINDOWS)]
    syn = _windows(np.c_[rng.normal(1.0, 0.3, 150), rng.normal(0.0, 1.0, 150)], seed=9)
    levels = LevelMap().fit(syn, np.full(150, 5), _windows(real_means, seed=10), np.full(MIN_WINDOWS, 5), [5])
    means = levels.transform(syn, np.full(150, 5)).mean(axis=1)
    assert levels.classes_[5]["real_windows"] == MIN_WINDOWS
    assert np.median(means, axis=0) == pytest.approx(np.median(real_means, axis=0), abs=0.5)
    low, high = real_means.min(axis=0), real_means.max(axis=0)
    span = high - low
    assert (means >= low - span).all() and (means <= high + span).all()


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
        "too_few": {"SIT_TO_STAND": 3}}}}
    with console.capture() as captured:
        _print_summary(summary)
    assert ("window levels at waist: mapped STAND_TO_LIE (23); too few real windows: SIT_TO_STAND (3)"
            in " ".join(captured.get().split()))


def test_the_command_line_default_is_the_library_default():
    from vsmp_imu.cli.common import LEVEL_PARTS, WINDOW_LEVELS
    from vsmp_imu.grounding import floors
    from vsmp_imu.pipeline.spec import GenerationSpec

    assert LEVEL_PARTS.default == PARTS == GenerationSpec().level_parts
    assert f"with {floors.WINDOW_LEVELS.floor} real windows" in WINDOW_LEVELS.help


def test_each_bad_input_names_its_own_field():
    """The error names the argument that is wrong: synthetic, real or X, and the channels when
    the two sides disagree."""
    good, bad = np.zeros((30, 10, 2)), np.zeros((30, 10))
    labels = np.zeros(30, int)
    with pytest.raises(ValidationError, match=r"^field 'synthetic': synthetic must be windows") as err:
        LevelMap().fit(bad, labels, good, labels, classes=[0])
    assert err.value.field == "synthetic"
    with pytest.raises(ValidationError, match=r"^field 'real': real must be windows") as err:
        LevelMap().fit(good, labels, bad, labels, classes=[0])
    assert err.value.field == "real"
    with pytest.raises(ValidationError, match="channels") as err:
        LevelMap().fit(good, labels, np.zeros((30, 10, 3)), labels, classes=[0])
    assert err.value.field == "channels"
    fitted = LevelMap().fit(good, labels, good, labels, classes=[0])
    with pytest.raises(ValidationError, match=r"^field 'X': X must be windows") as err:
        fitted.transform(bad, labels)
    assert err.value.field == "X"


def test_float32_real_windows_map_as_their_float64_values():
    """The fold hands D_rank's windows over as float32: their means are taken in float64, so the
    map is the one their float64 values give."""
    rng = np.random.default_rng(21)
    real = _windows(np.c_[rng.normal(-3.0, 1.0, 40), rng.normal(5.0, 0.5, 40)], seed=22, n_t=128).astype(np.float32)
    syn = _windows(np.c_[rng.normal(1.0, 0.3, 40), rng.normal(2.0, 2.0, 40)], seed=23, n_t=128).astype(np.float32)
    y = np.full(40, 1)
    from32 = LevelMap().fit(syn, y, real, y, classes=[1]).transform(syn, y)
    from64 = LevelMap().fit(syn.astype(np.float64), y, real.astype(np.float64), y, classes=[1]).transform(syn, y)
    assert from32.dtype == np.float64
    assert np.array_equal(from32, from64)


def test_a_class_without_synthetic_windows_is_not_reported_and_the_next_class_still_maps():
    """An event class the generation has no windows of is neither mapped nor listed as having too
    few real windows (it has 30), and the classes after it are still fitted."""
    rng = np.random.default_rng(12)
    syn = _windows(rng.normal(0, 1, (30, 2)), seed=13)
    real = _windows(rng.normal(5, 1, (60, 2)), seed=14)
    y_syn, y_real = np.full(30, 2), np.repeat([1, 2], 30)
    levels = LevelMap().fit(syn, y_syn, real, y_real, classes=[1, 2])
    assert levels.skipped_ == {}
    assert set(levels.classes_) == {2}
    assert not np.allclose(levels.transform(syn, y_syn), syn)


def test_one_synthetic_window_is_too_few_and_said_so():
    rng = np.random.default_rng(15)
    syn = _windows(rng.normal(0, 1, (1, 2)), seed=16)
    real = _windows(rng.normal(5, 1, (30, 2)), seed=17)
    levels = LevelMap().fit(syn, np.full(1, 3), real, np.full(30, 3), classes=[3])
    assert levels.skipped_ == {3: 30} and levels.classes_ == {}
    assert np.array_equal(levels.transform(syn, np.full(1, 3)), syn)


def test_min_windows_synthetic_windows_are_enough():
    """The floor holds for the synthetic side as for the real one: exactly `min_windows` windows map."""
    rng = np.random.default_rng(18)
    syn = _windows(rng.normal(0, 1, (MIN_WINDOWS, 2)), seed=19)
    real = _windows(rng.normal(5, 1, (30, 2)), seed=20)
    levels = LevelMap().fit(syn, np.full(MIN_WINDOWS, 6), real, np.full(30, 6), classes=[6])
    assert levels.skipped_ == {} and set(levels.classes_) == {6}
    short = LevelMap().fit(syn[:-1], np.full(MIN_WINDOWS - 1, 6), real, np.full(30, 6), classes=[6])
    assert short.skipped_ == {6: 30} and short.classes_ == {}


def test_a_class_with_too_few_real_windows_does_not_stop_the_classes_after_it():
    rng = np.random.default_rng(24)
    syn = _windows(rng.normal(0, 1, (60, 2)), seed=25)
    y_syn = np.repeat([2, 5], 30)
    real = _windows(rng.normal(5, 1, (33, 2)), seed=26)
    y_real = np.r_[np.full(3, 2), np.full(30, 5)]
    levels = LevelMap().fit(syn, y_syn, real, y_real, classes=[2, 5])
    assert levels.skipped_ == {2: 3}
    assert set(levels.classes_) == {5}
    out = levels.transform(syn, y_syn)
    assert np.array_equal(out[y_syn == 2], syn[y_syn == 2])
    assert not np.allclose(out[y_syn == 5], syn[y_syn == 5])


def test_the_reported_shift_is_the_mean_absolute_shift_per_channel_to_four_decimals():
    """`classes_[c]["mean_abs_shift"]`, per channel, is the mean over the fit's synthetic windows of
    how far transform moves each window (levels away from zero, so a shift and a level differ)."""
    rng = np.random.default_rng(27)
    syn = _windows(np.c_[rng.normal(10.0, 0.5, 60), rng.normal(-4.0, 0.4, 60)], seed=28)
    real = _windows(np.c_[rng.normal(12.5, 0.5, 80), rng.normal(-3.0, 0.4, 80)], seed=29)
    y_syn, y_real = np.full(60, 4), np.full(80, 4)
    levels = LevelMap().fit(syn, y_syn, real, y_real, classes=[4])
    moved = (levels.transform(syn, y_syn) - syn).mean(axis=1)  # (N, C): each window's constant shift
    reported = levels.classes_[4]["mean_abs_shift"]
    assert len(reported) == 2
    assert reported == pytest.approx(np.abs(moved).mean(axis=0), abs=5e-5)
    assert reported[0] == pytest.approx(2.5, abs=0.3) and reported[1] == pytest.approx(1.0, abs=0.3)
    assert all(v == round(v, 4) for v in reported) and any(v != round(v, 3) for v in reported)


def test_halves_shift_linearly_between_their_centres():
    """parts=2: flat over the first and last quarter, a straight line between the halves' centres."""
    course = shift_course(np.array([[1.0, 10.0, 5.0, -5.0]]), 40, 2)  # one window: (part 0: c0, c1), (part 1: c0, c1)
    assert course.shape == (1, 40, 2)
    t = np.arange(40)
    want = np.stack([np.interp(t, [10, 30], [1.0, 5.0]), np.interp(t, [10, 30], [10.0, -5.0])], axis=1)
    assert np.allclose(course[0], want)
    rng = np.random.default_rng(30)
    syn = _windows(rng.normal(0, 1, (30, 2)), seed=31, n_t=40)
    real = _windows(rng.normal(5, 1, (30, 2)), seed=32, n_t=40)
    y = np.full(30, 0)
    out = LevelMap(parts=2).fit(syn, y, real, y, classes=[0]).transform(syn, y)
    assert out.shape == syn.shape
    assert np.median(part_means(out, 2), axis=0) == pytest.approx(np.median(part_means(real, 2), axis=0), abs=0.5)
