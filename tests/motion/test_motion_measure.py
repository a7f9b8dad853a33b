"""Control measurements on motions whose true values are known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.motion import measure
from vsmp_imu.motion.dofs import BUILTIN_POSES, DOF_INDEX, dofs_to_local_quats, pose_vector
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.quat import forward_kinematics
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, SMPL22_PARENTS, smpl22_skeleton
from vsmp_imu.motion.tracks import minimum_jerk

FPS = 30.0
ARM = ["left_wrist", "left_elbow", "left_shoulder", "right_wrist", "right_elbow", "right_shoulder"]


def _motion(curves: dict[str, np.ndarray], n: int) -> Motion:
    values = np.repeat(pose_vector(BUILTIN_POSES["standing"])[None], n, axis=0)
    for name, curve in curves.items():
        values[:, DOF_INDEX[name]] = curve
    sk = smpl22_skeleton()
    pos, rot = forward_kinematics(sk.offsets, sk.parents, dofs_to_local_quats(values),
                                  np.tile([0.0, 0.9, 0.0], (n, 1)))
    return Motion(pos, rot, FPS, SMPL22_JOINTS, SMPL22_PARENTS, {})


def _curls(n_cycles: int, period_s: float, lag_s: float = 0.0, rest_s: float = 1.0):
    """Both elbows flex 10 -> 130 -> 10 degrees n_cycles times (raised-cosine), with rests."""
    total = 2 * rest_s + n_cycles * period_s
    t = np.arange(int(total * FPS) + 1) / FPS

    def elbow(shift: float) -> np.ndarray:
        u = np.clip((t - rest_s - shift) / period_s, 0, n_cycles)
        return 10 + 60 * (1 - np.cos(2 * np.pi * u))

    return _motion({"left_elbow_flex": elbow(lag_s), "right_elbow_flex": elbow(0.0)}, len(t))


def test_lowpass_removes_high_frequency():
    t = np.arange(300) / FPS
    x = np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.sin(2 * np.pi * 12.0 * t)
    y = measure.lowpass(x, FPS)
    assert np.abs(y - np.sin(2 * np.pi * t))[30:-30].max() < 0.05


@pytest.mark.parametrize(("n", "period"), [(3, 1.2), (6, 0.8), (9, 0.5)])
def test_repetitions_and_frequency(n, period):
    m = _curls(n, period)
    reps = measure.count_repetitions(m, ARM)
    assert reps.count == n
    assert reps.frequency_hz == pytest.approx(1.0 / period, rel=0.07)


def test_no_cycles_in_a_still_motion():
    m = _motion({}, 90)
    assert measure.count_repetitions(m, ARM).count == 0


def test_range_of_motion_and_speed_scale_with_the_excursion():
    t = np.arange(121) / FPS
    small = _motion({"left_elbow_flex": 10 + 30 * minimum_jerk(t / 2)}, len(t))
    large = _motion({"left_elbow_flex": 10 + 90 * minimum_jerk(t / 2)}, len(t))
    assert measure.range_of_motion(small, ["left_elbow"]) == pytest.approx(np.radians(30), rel=0.03)
    assert measure.range_of_motion(large, ["left_elbow"]) == pytest.approx(np.radians(90), rel=0.03)
    # mean angular speed = excursion / duration
    assert measure.mean_joint_speed(large, ["left_elbow"]) == pytest.approx(np.radians(90) / 4, rel=0.05)


@pytest.mark.parametrize("move_s", [0.4, 0.6, 0.9])
def test_phase_duration_from_velocity_landmarks(move_s):
    # rest 1 s, a slow preparation (1.2 s), hold, a fast central movement, hold, slow return
    t = np.arange(int(6.5 * FPS)) / FPS
    prep = 20 * minimum_jerk((t - 1.0) / 1.2)
    main = 110 * minimum_jerk((t - 2.5) / move_s)
    back = -130 * minimum_jerk((t - 2.5 - move_s - 0.3) / 1.5)
    m = _motion({"left_elbow_flex": 10 + prep + main + back}, len(t))
    phase = measure.phase_duration(m, ["left_elbow"])
    # a minimum-jerk movement is above 20 % of its peak speed for 74.4 % of its duration
    assert phase.duration_s == pytest.approx(0.744 * move_s, rel=0.06)
    assert 2.5 < phase.peak_s < 2.5 + move_s


def test_elbow_measures_read_the_hinge_not_the_forearm_twist():
    # a fast 100 deg pronation, then a slower elbow flexion: the pronation turns the
    # forearm segment (and its sensor), but the elbow measures read the flexion alone
    t = np.arange(int(5 * FPS)) / FPS
    flex = 10 + 90 * minimum_jerk((t - 2.5) / 0.9)
    alone = _motion({"left_elbow_flex": flex}, len(t))
    turned = _motion({"left_elbow_flex": flex, "left_wrist_rot": 100 * minimum_jerk((t - 1.0) / 0.5)}, len(t))
    phase = measure.phase_duration(turned, ["left_elbow"])
    assert phase.duration_s == pytest.approx(0.744 * 0.9, rel=0.06)
    assert 2.5 < phase.peak_s < 3.4
    assert measure.range_of_motion(turned, ["left_elbow"]) == pytest.approx(np.radians(90), rel=0.03)
    assert measure.mean_joint_speed(turned, ["left_elbow"]) == pytest.approx(
        measure.mean_joint_speed(alone, ["left_elbow"]), rel=0.02)
    # the twist is still measured, as the forearm's
    twist = [measure.joint_plane_ranges(m)[("forearm", "transverse")] for m in (alone, turned)]
    assert twist[1] > twist[0] + 80


def test_symmetry_score_separates_lagged_arms():
    sym = _curls(4, 1.0)
    asym = _curls(4, 1.0, lag_s=0.3)
    assert measure.symmetry_score(sym, ARM) > 0.97
    assert measure.symmetry_score(asym, ARM) < measure.SYMMETRY_THRESHOLD
    assert measure.classify_symmetry(measure.symmetry_score(sym, ARM)) == "symmetric"
    assert measure.symmetry_pairs(["left_wrist", "right_knee"]) == [("left_wrist", "right_wrist"),
                                                                  ("left_knee", "right_knee")]
    assert np.isnan(measure.symmetry_score(_motion({}, 60), ARM))


def test_unknown_joint_is_a_validation_error():
    from vsmp_imu.errors import ValidationError

    with pytest.raises(ValidationError, match="no joint named 'left_wirst'"):
        measure.range_of_motion(_motion({}, 30), ["left_wirst"])
