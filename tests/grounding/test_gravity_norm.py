"""Keeping the gravity magnitude through rank grounding: the slow part of the accelerometer gets
the simulated magnitude back (scaled to the real sensor's), in the direction the map gave it; the
fast part and the gyroscope stay as mapped."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.gravity import (
    gravity_scale,
    rescale_slow_part,
    restore_gravity_norm,
    slow_norm,
    slow_part,
)

FS = 50.0
# what a user reads when the scale cannot be measured
NO_SCALE = r"^field 'gravity': gravity scale needs real window means and synthetic norms\.$"


def _signal(acc_slow, fast_amp=0.0, n=500):
    t = np.arange(n) / FS
    x = np.zeros((n, 6))
    x[:, :3] = acc_slow
    x[:, 2] += fast_amp * np.sin(2 * np.pi * 8.0 * t)  # 8 Hz: far above the 1 s average's pass band
    x[:, 3:] = np.sin(t)[:, None] * [0.1, 0.2, 0.3]
    return x


def test_a_static_window_gets_the_simulated_magnitude_in_the_mapped_direction():
    before = _signal([0.0, 0.0, 9.80665])
    after = _signal([6.0, 0.5, 4.8])  # a channel-wise map's reading: |a| = 7.7
    out = restore_gravity_norm(before, after, FS, scale=10.05 / 9.80665)
    slow = slow_part(out[:, :3], FS)
    assert np.linalg.norm(slow, axis=1) == pytest.approx(10.05, rel=1e-9)
    direction = np.array([6.0, 0.5, 4.8]) / np.linalg.norm([6.0, 0.5, 4.8])
    assert slow / np.linalg.norm(slow, axis=1, keepdims=True) == pytest.approx(np.tile(direction, (500, 1)))
    assert np.array_equal(out[:, 3:], after[:, 3:])  # the gyroscope is not touched


def test_the_fast_part_stays_as_mapped():
    before = _signal([0.0, 0.0, 9.8], fast_amp=1.0)
    after = _signal([0.0, 0.0, 6.0], fast_amp=2.0)
    out = restore_gravity_norm(before, after, FS)
    change = out[:, :3] - after[:, :3]
    # the change is the slow part's rescaling: nearly constant, no 8 Hz component added or removed
    core = slice(50, 450)
    assert change[core, 2] == pytest.approx(3.8, abs=0.05)
    assert np.ptp(change[core, 2]) < 0.1
    assert np.allclose(change[:, :2], 0.0)


def test_a_window_already_at_its_magnitude_is_left_as_it_is():
    before = _signal([0.0, 0.0, 9.8])
    after = _signal([0.0, 9.8 * np.sin(0.3), 9.8 * np.cos(0.3)])  # only the direction changed
    assert np.allclose(restore_gravity_norm(before, after, FS), after, atol=1e-12)


def test_the_scale_is_the_ratio_of_the_medians():
    real = np.array([[0.0, 0.0, 10.0], [0.0, 10.2, 0.0], [9.9, 0.0, 0.0]])
    assert gravity_scale(real, np.array([9.8, 9.81, 9.7, 12.0])) == pytest.approx(10.0 / 9.805)
    with pytest.raises(ValidationError):
        gravity_scale(real[:0], np.array([9.8]))


def test_signals_of_different_shapes_are_refused():
    with pytest.raises(ValidationError) as err:
        restore_gravity_norm(np.zeros((10, 6)), np.zeros((11, 6)), FS)
    assert err.value.field == "signals"


def _moving_average(x, n):
    """Centred mean over n (odd) samples, the edge samples held beyond the ends."""
    x = np.asarray(x, dtype=np.float64)
    pad = np.concatenate([np.repeat(x[:1], n // 2, axis=0), x, np.repeat(x[-1:], n // 2, axis=0)])
    kernel = np.ones(n) / n
    return np.stack([np.convolve(pad[:, j], kernel, mode="valid") for j in range(x.shape[1])], axis=1)


def _swaying(n=300, seed=0):
    """A (T, 6) signal whose accelerometer sways at 1 Hz around gravity: a 0.3 s average keeps part
    of the sway that a 1 s average removes."""
    t = np.arange(n) / FS
    rng = np.random.default_rng(seed)
    x = np.zeros((n, 6))
    x[:, :3] = [1.0, -2.0, 9.0] + np.sin(2 * np.pi * t)[:, None] * [2.0, 1.0, -1.5]
    x[:, :3] += 0.2 * rng.standard_normal((n, 3))
    x[:, 3:] = rng.standard_normal((n, 3))
    return x


def test_the_slow_part_is_a_centred_moving_average_with_the_edges_held():
    ramp = np.stack([np.arange(40.0), 2.0 * np.arange(40.0) ** 1.5, -np.arange(40.0)], axis=1)
    got = slow_part(ramp, FS, window_s=0.3)  # 15 samples
    np.testing.assert_allclose(got, _moving_average(ramp, 15), rtol=0, atol=1e-9)
    assert got[0, 0] == pytest.approx(28.0 / 15.0)  # (7 x 0 + 0 + ... + 7) / 15: the edge held, not mirrored


def test_a_window_under_one_and_a_half_samples_leaves_the_signal_as_it_is():
    x = _swaying(50)[:, :3]
    np.testing.assert_allclose(slow_part(x, FS, window_s=0.02), x, rtol=0, atol=1e-12)  # round(1.0) = 1 sample
    np.testing.assert_allclose(slow_part(x, FS, window_s=0.005), x, rtol=0, atol=1e-12)  # round(0.25) = 0: still 1


def test_integer_counts_average_to_fractions():
    counts = np.array([[0, 0, 1000], [1, 0, 1001], [0, 3, 1000], [2, 0, 1003], [0, 0, 1000]], dtype=np.int64)
    got = slow_part(counts, FS, window_s=0.06)  # 3 samples
    np.testing.assert_allclose(got, _moving_average(counts, 3), rtol=0, atol=1e-9)
    assert got.dtype == np.float64 and got[1, 1] == pytest.approx(1.0)


def test_the_slow_norm_reads_the_window_it_is_given():
    acc = _swaying()[:, :3]
    expected = np.linalg.norm(_moving_average(acc, 15), axis=1)
    got = slow_norm(acc, FS, window_s=0.3)
    np.testing.assert_allclose(got, expected, rtol=1e-12)
    assert np.ptp(got[50:250]) > 0.5  # the 0.3 s average keeps part of the sway (1 s would not)


def test_restoring_with_a_shorter_window_uses_it_for_both_signals():
    before, after = _swaying(seed=1), _swaying(seed=2)
    after[:, :3] = after[:, :3] @ np.array([[0.8, 0.1, 0.0], [0.0, 0.7, 0.2], [0.1, 0.0, 0.6]])  # a mapped reading
    scale = 1.02
    out = restore_gravity_norm(before, after, FS, scale=scale, window_s=0.3)
    # by definition: after's fast part kept, its 0.3 s slow part turned to scale x before's 0.3 s slow norm
    slow_after = _moving_average(after[:, :3], 15)
    target = scale * np.linalg.norm(_moving_average(before[:, :3], 15), axis=1)
    expected = after[:, :3] - slow_after + slow_after / np.linalg.norm(slow_after, axis=1)[:, None] * target[:, None]
    np.testing.assert_allclose(out[:, :3], expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(out[:, 3:], after[:, 3:])
    assert np.abs(out - restore_gravity_norm(before, after, FS, scale=scale)).max() > 0.1  # the window matters


def test_a_slow_part_too_small_to_have_a_direction_is_left_as_it_is():
    after = np.zeros((6, 6))
    after[:, 0] = [0.0, 1e-10, 1e-9, 0.0, 1e-10, 1e-9]  # slow norms at and under 1e-9
    after[:, 3:] = 0.5
    out = rescale_slow_part(after, np.full(6, 9.8), FS, window_s=0.02)  # 1-sample window: slow = signal
    assert np.isfinite(out).all()
    np.testing.assert_array_equal(out, after)


def test_a_slow_part_under_one_unit_is_rescaled_too():
    # a sensor reading in g: |slow| 0.8 g rescaled to 1.0 g, direction kept
    after = np.zeros((100, 6))
    after[:, :3] = [0.0, 0.48, 0.64]
    out = rescale_slow_part(after, np.full(100, 1.0), FS)
    np.testing.assert_allclose(out[:, :3], np.tile([0.0, 0.6, 0.8], (100, 1)), rtol=1e-12)
    tiny = after * 1e-8  # 8e-9: above the guard, rescaled all the same
    np.testing.assert_allclose(rescale_slow_part(tiny, np.full(100, 1.0), FS)[:, :3],
                               np.tile([0.0, 0.6, 0.8], (100, 1)), rtol=1e-9)


def test_float32_signals_give_the_float64_result():
    before32, after32 = _swaying(seed=3).astype(np.float32), _swaying(seed=4).astype(np.float32)
    expected = restore_gravity_norm(before32.astype(np.float64), after32.astype(np.float64), FS, scale=1.01)
    got = restore_gravity_norm(before32, after32, FS, scale=1.01)
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, expected)
    target = np.full(len(after32), 9.9)
    got = rescale_slow_part(after32, target, FS)
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, rescale_slow_part(after32.astype(np.float64), target, FS))


def test_the_scale_is_computed_in_float64_for_float32_input():
    real = np.array([[1.0, 1.0, 0.0], [0.0, 3.0, 9.7], [5.0, 5.0, 6.0]], dtype=np.float32)
    syn = np.array([1.0, 1.0 + 2.0 ** -23], dtype=np.float32)  # the float64 median 1 + 2^-24 is no float32
    expected = np.median(np.linalg.norm(real.astype(np.float64), axis=1)) / (1.0 + 2.0 ** -24)
    assert gravity_scale(real, syn) == pytest.approx(expected, rel=1e-15)
    assert gravity_scale(real, syn) == gravity_scale(real.astype(np.float64), syn.astype(np.float64))


def test_one_synthetic_norm_is_enough_and_norms_in_g_are_fine():
    real = np.array([[0.0, 0.0, 1.02], [0.0, 1.0, 0.0]])  # a sensor reading in g
    assert gravity_scale(real, np.array([0.98])) == pytest.approx(1.01 / 0.98)
    assert gravity_scale(real, np.array([0.5, 0.98, 0.99])) == pytest.approx(1.01 / 0.98)


@pytest.mark.parametrize("syn", [[], [0.0], [0.0, 0.0, 9.8], [-1.0, -2.0], [-9.8, 0.0, 9.8]],
                         ids=["none", "zero", "median-zero", "negative", "median-zero-mixed"])
def test_the_scale_is_refused_without_a_positive_synthetic_median(syn):
    real = np.array([[0.0, 0.0, 10.0], [0.0, 10.2, 0.0]])
    with pytest.raises(ValidationError, match=NO_SCALE) as err:
        gravity_scale(real, np.array(syn, dtype=np.float64))
    assert err.value.field == "gravity"


def test_the_scale_is_refused_without_real_windows():
    with pytest.raises(ValidationError, match=NO_SCALE) as err:
        gravity_scale(np.zeros((0, 3)), np.array([9.8]))
    assert err.value.field == "gravity"


@pytest.mark.parametrize("shape", [(10, 2), (10,), (10, 0)])
def test_signals_without_three_accelerometer_columns_are_refused(shape):
    with pytest.raises(ValidationError) as err:
        restore_gravity_norm(np.ones(shape), np.ones(shape), FS)
    assert err.value.field == "signals"


def test_an_accelerometer_only_signal_is_rescaled():
    before = np.tile([0.0, 0.0, 9.8], (100, 1))
    after = np.tile([0.0, 3.0, 4.0], (100, 1))
    out = restore_gravity_norm(before, after, FS)
    np.testing.assert_allclose(out, np.tile([0.0, 5.88, 7.84], (100, 1)), rtol=1e-12)
