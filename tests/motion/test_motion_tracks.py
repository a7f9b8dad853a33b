"""Keyframe tracks (motion.tracks): stop, smooth and land keys."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.imu import simulate_kinematics
from vsmp_imu.motion import tracks
from vsmp_imu.motion.recipe import KeyFrame
from vsmp_imu.motion.tracks import LAND_SPEED, hermite_track, minimum_jerk

FS = 1000.0


def _track(stop, land=None):
    t = np.arange(0.0, 2.0 + 1e-9, 1.0 / FS)
    times, values = np.array([0.0, 1.0, 2.0]), np.array([[0.0], [1.0], [1.0]])
    return t, hermite_track(times, values, np.array(stop), t, None if land is None else np.array(land))[:, 0]


def test_stop_keys_follow_minimum_jerk_and_rest_at_the_keys():
    t, x = _track([True, True, True])
    assert np.allclose(x[t <= 1.0], minimum_jerk(t[t <= 1.0]), atol=1e-12)
    v = np.gradient(x, 1.0 / FS)
    assert abs(v[t == 1.0][0]) < 1e-3


def test_a_land_key_is_reached_moving_and_left_at_rest():
    t, x = _track([True, False, True], land=[False, True, False])
    v = np.gradient(x, 1.0 / FS)
    before, after = v[(t > 0.995) & (t < 1.0)], v[(t > 1.0) & (t < 1.005)]
    assert before == pytest.approx(LAND_SPEED * 1.0, abs=0.02)  # the segment's mean speed: 1 per second
    assert np.abs(after).max() < 0.02
    assert np.all(np.diff(x[t <= 1.0]) >= -1e-12)  # no overshoot on the way down
    assert x[t >= 1.0] == pytest.approx(1.0)  # the seat holds


def test_a_land_key_parses_in_the_compact_form():
    assert KeyFrame.model_validate([1.0, "seated", "land"]).ease == "land"


@pytest.mark.parametrize(("name", "lowering"), [("stand_to_sit", "lean_and_lower"), ("stand_to_lie", "crouch_down")])
def test_sitting_down_meets_the_seat(backend, library, name, lowering, monkeypatch):
    """A waist that sits down reads a short deceleration peak when the seat stops it."""

    def peak(speed: float) -> float:
        monkeypatch.setattr(tracks, "LAND_SPEED", speed)
        m = backend.generate(library.get(name).smp, seed=0)
        [seat] = [p["end_s"] for p in m.meta["phases"] if p["recipe_primitive"] == lowering]
        kin = simulate_kinematics(m, "waist", 50.0)
        near = (kin.times > seat - 0.05) & (kin.times < seat + 0.3)
        return float(np.linalg.norm(kin.specific_force_seg()[near], axis=1).max())

    landed, stopped = peak(LAND_SPEED), peak(0.0)
    assert landed > stopped + 0.5 and landed > 9.81 + 2.0, (landed, stopped)
