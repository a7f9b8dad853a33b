"""Forearm pronation turns a wrist-worn sensor (the forearm segment carries the twist)."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.imu.simulator import ImuSimulator
from vsmp_imu.motion.dofs import BUILTIN_POSES, DOF_INDEX, N_DOFS, dofs_to_local_quats, pose_vector
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.quat import forward_kinematics
from vsmp_imu.motion.skeleton import SMPL22_JOINTS, SMPL22_PARENTS, smpl22_skeleton

FPS, SECONDS, TURN_HZ, TURN_DEG = 100.0, 4.0, 1.0, 60.0


def _motion(pronation_deg: float) -> Motion:
    """Standing, elbows at 90 degrees, the forearms turning palm down and up `pronation_deg`."""
    t = np.arange(int(SECONDS * FPS) + 1) / FPS
    dofs = np.tile(pose_vector(BUILTIN_POSES["standing"]), (len(t), 1))
    dofs[:, [DOF_INDEX["left_elbow_flex"], DOF_INDEX["right_elbow_flex"]]] = 90.0
    wave = pronation_deg * np.sin(2 * np.pi * TURN_HZ * t)
    dofs[:, DOF_INDEX["left_wrist_rot"]] = wave
    dofs[:, DOF_INDEX["right_wrist_rot"]] = wave
    assert dofs.shape[1] == N_DOFS
    skeleton = smpl22_skeleton()
    root = np.tile([0.0, 1.0, 0.0], (len(t), 1))
    pos, rot = forward_kinematics(skeleton.offsets, skeleton.parents, dofs_to_local_quats(dofs), root)
    return Motion(pos, rot, FPS, SMPL22_JOINTS, SMPL22_PARENTS, {"test": "pronation"})


def _forearm_axis(motion: Motion, side: str) -> np.ndarray:
    """The forearm's long axis (elbow -> wrist) in the forearm segment frame."""
    from scipy.spatial.transform import Rotation

    e, w = motion.joint_index(f"{side}_elbow"), motion.joint_index(f"{side}_wrist")
    bone = Rotation.from_quat(motion.rotations[:, e]).apply(motion.positions[:, w] - motion.positions[:, e],
                                                             inverse=True).mean(axis=0)
    return bone / np.linalg.norm(bone)


@pytest.mark.parametrize("side", ["left", "right"])
def test_pronation_turns_the_wrist_sensor_about_the_forearm(side):
    sim = ImuSimulator(noise=False)
    turning, still = _motion(TURN_DEG), _motion(0.0)
    axis = _forearm_axis(turning, side)
    gyr = {name: sim.simulate(m, f"{side}_wrist").data[:, 3:6] for name, m in
           (("turning", turning), ("still", still))}
    about_axis = {k: float(np.sqrt(np.mean((g @ axis) ** 2))) for k, g in gyr.items()}
    expected = np.radians(TURN_DEG) * 2 * np.pi * TURN_HZ / np.sqrt(2)  # RMS of the twist rate
    assert about_axis["still"] < 1e-6
    assert about_axis["turning"] == pytest.approx(expected, rel=0.1)
    off_axis = gyr["turning"] - np.outer(gyr["turning"] @ axis, axis)
    assert np.sqrt(np.mean(off_axis ** 2)) < 0.05 * about_axis["turning"]


def test_pronation_moves_no_joint_and_keeps_the_hand_orientation():
    from vsmp_imu.motion.dofs import _side_rotations
    from vsmp_imu.motion.quat import euler, multiply

    turning, still = _motion(TURN_DEG), _motion(0.0)
    np.testing.assert_allclose(turning.positions, still.positions, atol=1e-9)
    # the hand's global orientation is the forearm's flexion followed by the twist about the arm, as before
    dofs = np.zeros((5, N_DOFS))
    dofs[:, DOF_INDEX["left_wrist_rot"]] = np.linspace(-80, 80, 5)
    dofs[:, DOF_INDEX["left_elbow_flex"]] = 40.0
    q = _side_rotations(dofs, "left", np.zeros(5))
    hand = multiply(q["left_elbow"], q["left_wrist"])
    old = multiply(euler("Y", -np.radians(dofs[:, DOF_INDEX["left_elbow_flex"]])),
                   euler("XZY", np.radians(dofs[:, DOF_INDEX["left_wrist_rot"]]), np.zeros(5), np.zeros(5)))
    np.testing.assert_allclose(np.abs(np.sum(hand * old, axis=1)), 1.0, atol=1e-12)
