"""Keyframe tracks (motion.tracks): stop, smooth and pass keys."""

from __future__ import annotations

import numpy as np

from vsmp_imu.motion.tracks import hermite_track, key_velocities, minimum_jerk

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


def test_a_pass_key_goes_on_as_a_smooth_one_and_stops_where_the_curve_turns_or_holds():
    times = np.array([0.0, 1.0, 2.0, 3.0])
    values = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0], [3.0, 0.0, 1.0], [3.0, 0.0, 1.0]])
    stop, through = np.array([True, False, False, True]), np.array([False, True, True, False])
    smooth = key_velocities(times, values, stop)
    passed = key_velocities(times, values, stop, through)
    assert smooth[1].tolist() == [1.5, 0.0, 0.5]  # Catmull-Rom: (3 - 0) / 2, (0 - 0) / 2, (1 - 0) / 2
    assert passed[1].tolist() == [1.5, 0.0, 0.0]  # goes on (as smooth); turns; holds after
    assert passed[2].tolist() == [0.0, 0.0, 0.0]  # every DOF holds after the key
    assert np.array_equal(key_velocities(times, values, stop, np.zeros(4, bool)), smooth)


def test_a_pass_key_never_swings_past_a_key_where_the_curve_turns():
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 3.0 + 1e-9, 1.0 / FS)
    times = np.array([0.0, 0.4, 1.9, 3.0])  # uneven: Catmull-Rom swings past a short side
    stop = np.array([True, False, False, True])
    overshoot = {}
    for name, through in (("smooth", None), ("pass", np.array([False, True, True, False]))):
        worst = 0.0
        for _ in range(200):
            steps = rng.uniform(0.2, 2.0, size=3) * np.array([1.0, -1.0, 1.0])  # up, down, up: two turns
            values = np.cumsum(np.r_[0.0, steps])[:, None]
            x = hermite_track(times, values, stop, t, through=through)[:, 0]
            for a, b in zip(range(3), range(1, 4), strict=True):
                seg = x[(t >= times[a]) & (t <= times[b])]
                lo, hi = sorted((values[a, 0], values[b, 0]))
                worst = max(worst, lo - seg.min(), seg.max() - hi)
        overshoot[name] = worst
    assert overshoot["smooth"] > 0.05 and overshoot["pass"] < 1e-9  # each segment stays between its keys
