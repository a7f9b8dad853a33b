"""Motion plausibility rules of the quality filter."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.filtering.plausibility import A_CAP, MotionPlausibilityFilter, motion_energy
from vsmp_imu.motion import Motion, forward_kinematics, smpl22_skeleton
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G


def _real(rng, n, scale=1.0):
    w = rng.normal(0, scale, (n, 100, 6))
    w[..., 1] += G
    return w


def _motion(jump: float = 0.0) -> Motion:
    sk = smpl22_skeleton(1.7)
    t = 30
    quats = np.tile([0.0, 0.0, 0.0, 1.0], (t, 22, 1))
    root = np.c_[np.zeros(t), np.full(t, 0.94), np.linspace(0, 0.3, t)]
    root[15:, 2] += jump
    pos, rot = forward_kinematics(sk, quats, root)
    return Motion(pos, rot, 30.0)


def test_energy_definition():
    w = np.zeros((10, 6))
    w[::2, 0] = 1.0  # acc x alternates 0/1: variance 0.25
    w[::2, 3] = 1.0  # gyro x alternates: contributes 0.1 * 0.25
    assert motion_energy(w) == pytest.approx(0.25 + 0.025)


def test_thresholds_per_class_and_fallback():
    rng = np.random.default_rng(1)
    windows = np.concatenate([_real(rng, 120, 1.0), _real(rng, 30, 5.0)])
    labels = np.array([0] * 120 + [1] * 30)
    f = MotionPlausibilityFilter().fit(windows, labels)
    assert 0 in f.per_class_ and 1 not in f.per_class_
    assert f.thresholds_for(1) is f.overall_
    assert f.thresholds_for(0).a_max < f.overall_.a_max
    assert f.overall_.a_max <= A_CAP


def test_window_verdicts_name_the_rule():
    rng = np.random.default_rng(2)
    f = MotionPlausibilityFilter().fit(_real(rng, 200), np.zeros(200, int))
    ok = _real(rng, 1)[0]
    assert f.check_window(ok, 0).passed
    spike = ok.copy()
    spike[50, 0] = 80.0
    v = f.check_window(spike, 0)
    assert not v.passed and "a_max" in v.reason
    spin = ok.copy()
    spin[10, 4] = 40.0
    assert "w_max" in f.check_window(spin, 0).reason
    static = np.zeros((100, 6))
    static[:, 1] = G
    assert "energy" in f.check_window(static, 0).reason
    nan = ok.copy()
    nan[3, 3] = np.nan
    assert not f.check_window(nan, 0).passed
    # the batch check gives each window the verdict of the single check
    batch = np.stack([ok, spike, spin, static, nan])
    singles = [f.check_window(w, 0) for w in batch]
    assert [v.as_dict() for v in f.check_windows(batch, np.zeros(5, int))] == [v.as_dict() for v in singles]
    assert [v.passed for v in singles] == [True, False, False, False, False]


def test_motion_jump_and_missing_frames():
    f = MotionPlausibilityFilter()
    assert f.check_motion(_motion()).passed
    v = f.check_motion(_motion(jump=0.5))
    assert not v.passed and "jumped" in v.reason
    broken = _motion()
    broken.positions[5, 3] = np.nan
    assert "missing" in f.check_motion(broken).reason
