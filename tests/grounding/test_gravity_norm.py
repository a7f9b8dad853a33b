"""Keeping the gravity magnitude through rank grounding: the slow part of the accelerometer gets
the simulated magnitude back (scaled to the real sensor's), in the direction the map gave it; the
fast part and the gyroscope stay as mapped."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.gravity import gravity_scale, restore_gravity_norm, slow_part

FS = 50.0


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
