"""Keyframe tracks (motion.tracks): stop and smooth keys."""

from __future__ import annotations

import numpy as np

from vsmp_imu.motion.tracks import hermite_track, minimum_jerk

FS = 1000.0


def _track(stop):
    t = np.arange(0.0, 2.0 + 1e-9, 1.0 / FS)
    times, values = np.array([0.0, 1.0, 2.0]), np.array([[0.0], [1.0], [2.0]])
    return t, hermite_track(times, values, np.array(stop), t)[:, 0]


def test_stop_keys_follow_minimum_jerk_and_rest_at_the_keys():
    t, x = _track([True, True, True])
    assert np.allclose(x[t <= 1.0], minimum_jerk(t[t <= 1.0]), atol=1e-12)
    v = np.gradient(x, 1.0 / FS)
    assert abs(v[t == 1.0][0]) < 1e-3


def test_a_smooth_key_is_passed_at_its_neighbours_speed_without_a_jump():
    t, x = _track([True, False, True])
    v = np.gradient(x, 1.0 / FS)
    assert abs(v[t == 1.0][0] - 1.0) < 1e-3  # Catmull-Rom: (2 - 0) / (2 - 0)
    a = np.gradient(v, 1.0 / FS)
    assert np.abs(np.diff(a[(t > 0.9) & (t < 1.1)])).max() < 0.1  # C2: no step in the acceleration
    assert np.all(np.diff(x) >= -1e-12)
