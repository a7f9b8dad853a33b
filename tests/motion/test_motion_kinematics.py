"""Quaternion helpers, the vectorized FK, and the anatomical DOF conventions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from vsmp_imu.motion import quat
from vsmp_imu.motion.dofs import (
    BUILTIN_POSES,
    DOF_INDEX,
    N_DOFS,
    PELVIS_FLEX_SHARE,
    dofs_to_local_quats,
    expand_pose,
    limits_array,
    mirror_dofs,
    pose_vector,
    soft_limit,
)
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, forward_kinematics, smpl22_skeleton

J = {n: i for i, n in enumerate(SMPL22_JOINTS)}


def _pose(pose: dict) -> np.ndarray:
    sk = smpl22_skeleton()
    local = dofs_to_local_quats(pose_vector(pose, pose_vector(BUILTIN_POSES["standing"]))[None])
    pos, _ = forward_kinematics(sk, local, np.zeros((1, 3)))
    return pos[0]


def _direction(pos: np.ndarray, a: str, b: str) -> np.ndarray:
    v = pos[J[b]] - pos[J[a]]
    return v / np.linalg.norm(v)


def test_quaternion_helpers_match_scipy():
    rng = np.random.default_rng(0)
    angles = rng.uniform(-3, 3, size=(20, 3))
    assert np.allclose(quat.euler("YXZ", *angles.T), Rotation.from_euler("YXZ", angles).as_quat())
    a, b = Rotation.random(20, random_state=1), Rotation.random(20, random_state=2)
    prod = quat.multiply(a.as_quat(), b.as_quat())
    assert np.allclose(Rotation.from_quat(prod).as_matrix(), (a * b).as_matrix())
    v = rng.normal(size=(20, 3))
    assert np.allclose(quat.rotate(a.as_quat(), v), a.apply(v))


def test_fast_fk_equals_skeleton_fk():
    rng = np.random.default_rng(3)
    sk = smpl22_skeleton(1.8, rng.uniform(0.97, 1.03, 22))
    local = Rotation.random(40 * 22, random_state=4).as_quat().reshape(40, 22, 4)
    root = rng.normal(size=(40, 3))
    pos_ref, rot_ref = forward_kinematics(sk, local, root)
    pos, rot = quat.forward_kinematics(sk.offsets, sk.parents, local, root)
    assert np.allclose(pos, pos_ref, atol=1e-12)
    same = np.abs((rot * rot_ref).sum(axis=-1))  # q and -q are one rotation
    assert np.allclose(same, 1.0, atol=1e-12)


@pytest.mark.parametrize(("pose", "a", "b", "expected"), [
    ({}, "left_shoulder", "left_elbow", (0, -1, 0)),  # arms hang down
    ({"shoulder_flex": 90, "shoulder_abd": 0}, "left_shoulder", "left_elbow", (0, 0, 1)),  # forward
    ({"shoulder_flex": 90, "shoulder_abd": 0}, "right_shoulder", "right_elbow", (0, 0, 1)),
    ({"shoulder_abd": 90}, "left_shoulder", "left_elbow", (1, 0, 0)),  # sideways = the body's left
    ({"shoulder_abd": 90}, "right_shoulder", "right_elbow", (-1, 0, 0)),
    ({"shoulder_abd": 0, "elbow_flex": 90}, "left_elbow", "left_wrist", (0, 0, 1)),  # forearm forward
    ({"hip_flex": 90}, "left_hip", "left_knee", (0, 0, 1)),  # thigh forward
    ({"knee_flex": 90}, "right_knee", "right_ankle", (0, 0, -1)),  # shank backward
    ({"trunk_flex": 90}, "spine2", "neck", (0, 0, 1)),  # bend forward
    ({"root_pitch": -90}, "pelvis", "head", (0, 0, -1)),  # lying on the back, head behind
])
def test_dof_conventions(pose, a, b, expected):
    direction = _direction(_pose(pose), a, b)
    assert np.dot(direction, expected) > 0.95, direction


def test_right_side_is_the_mirror_of_the_left():
    pos = _pose({"shoulder_flex": 40, "shoulder_abd": 30, "elbow_flex": 70, "hip_flex": 30,
                 "knee_flex": 45, "shoulder_rot": 20, "hip_abd": 10})
    for stem in ("wrist", "elbow", "knee", "ankle", "foot"):
        left = pos[J[f"left_{stem}"]] - pos[J["pelvis"]]
        right = pos[J[f"right_{stem}"]] - pos[J["pelvis"]]
        # the SMPL skeleton is itself only nearly symmetric (a few mm)
        assert np.allclose(left * [-1, 1, 1], right, atol=0.02), stem


def test_mirror_dofs_swaps_sides_and_flips_lateral_centre_dofs():
    v = np.zeros(N_DOFS)
    v[DOF_INDEX["left_elbow_flex"]] = 50
    v[DOF_INDEX["trunk_twist"]] = 10
    v[DOF_INDEX["trunk_flex"]] = 20
    m = mirror_dofs(v)
    assert m[DOF_INDEX["right_elbow_flex"]] == 50 and m[DOF_INDEX["left_elbow_flex"]] == 0
    assert m[DOF_INDEX["trunk_twist"]] == -10 and m[DOF_INDEX["trunk_flex"]] == 20
    assert np.allclose(mirror_dofs(m), v)


def test_expand_pose_and_unknown_dof():
    assert expand_pose({"elbow_flex": 10}) == {"left_elbow_flex": 10.0, "right_elbow_flex": 10.0}
    with pytest.raises(KeyError):
        expand_pose({"elbow_flexion": 10})


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-400, 400), min_size=2, max_size=2).map(sorted))
def test_soft_limit_is_monotonic_and_bounded(pair):
    low, high = limits_array()
    col = DOF_INDEX["left_elbow_flex"]
    values = np.zeros((2, N_DOFS))
    values[:, col] = pair
    out = soft_limit(values, low, high)[:, col]
    assert low[col] - 1e-9 <= out[0] <= out[1] <= high[col] + 1e-9
    if pair[1] > pair[0] + 1e-6:
        assert out[1] > out[0] or out[1] >= high[col] - 1e-6


def _globals(pose: dict[str, float]) -> np.ndarray:
    values = pose_vector(pose, np.zeros(N_DOFS))[None]
    local = dofs_to_local_quats(values)
    sk = smpl22_skeleton()
    _, rot = forward_kinematics(sk, local, np.zeros((1, 3)))
    return rot[0]


def test_pelvis_tilt_turns_only_the_pelvis_segment():
    j = J
    base = {"hip_flex": 60.0, "hip_abd": 10.0, "trunk_flex": 20.0, "root_roll": 8.0, "knee_flex": 30.0}
    a = _globals(base)
    b = _globals({**base, "pelvis_tilt": -20.0})
    delta = Rotation.from_quat(a[j["pelvis"]]).inv() * Rotation.from_quat(b[j["pelvis"]])
    assert np.degrees(delta.magnitude()) == pytest.approx(20.0, abs=1e-6)
    for name in ("left_hip", "right_hip", "left_knee", "spine1", "spine3", "head"):
        assert np.allclose(a[j[name]], b[j[name]], atol=1e-9) or np.allclose(a[j[name]], -b[j[name]], atol=1e-9)


def test_trunk_flexion_is_shared_with_the_pelvis():
    j = J
    upright = _globals({})
    bent = _globals({"trunk_flex": 40.0})
    tilt = Rotation.from_quat(upright[j["pelvis"]]).inv() * Rotation.from_quat(bent[j["pelvis"]])
    assert np.degrees(tilt.magnitude()) == pytest.approx(40.0 * PELVIS_FLEX_SHARE, abs=1e-6)
    # thighs stay vertical; the chest bends by the full trunk flexion
    assert np.allclose(upright[j["left_hip"]], bent[j["left_hip"]], atol=1e-9)
    chest = Rotation.from_quat(upright[j["spine3"]]).inv() * Rotation.from_quat(bent[j["spine3"]])
    assert np.degrees(chest.magnitude()) == pytest.approx(40.0, abs=1e-6)
