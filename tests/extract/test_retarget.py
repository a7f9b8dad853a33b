"""Landmarks -> SMPL-22 motion: conventions, directions, twist, gaps."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from vsmp_imu.extract.calibrate import motion_landmarks, motion_track
from vsmp_imu.extract.landmarks import LM, world_to_yup
from vsmp_imu.extract.retarget import align, fill_gaps, track_to_motion
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.library import ActivityLibrary

BONES = [("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"), ("right_shoulder", "right_elbow"),
         ("right_elbow", "right_wrist"), ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
         ("right_hip", "right_knee"), ("right_knee", "right_ankle"), ("left_ankle", "left_foot")]


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def motions(library):
    backend = ProceduralBackend(library)
    return {name: backend.generate(library.get(name).smp, seed=3)
            for name in ("walking", "jumping_jacks", "two_arm_curl")}


def _dirs(motion, a, b):
    v = motion.positions[:, motion.joint_index(b)] - motion.positions[:, motion.joint_index(a)]
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _angle_deg(m1, m2, joint):
    i = m1.joint_index(joint)
    r = Rotation.from_quat(m1.rotations[:, i]).inv() * Rotation.from_quat(m2.rotations[:, i])
    return np.degrees(r.magnitude())


def test_mediapipe_world_axes_become_y_up_facing_plus_z():
    # a person facing the camera: their left shoulder on the image right (+x), head up (-y),
    # nose toward the camera (-z)
    mp = np.zeros((33, 3))
    mp[LM["left_shoulder"]] = (0.2, -0.5, 0.0)
    mp[LM["right_shoulder"]] = (-0.2, -0.5, 0.0)
    mp[LM["nose"]] = (0.0, -0.7, -0.1)
    p = world_to_yup(mp)
    assert p[LM["left_shoulder"], 0] > 0  # +X is the body's left
    assert p[LM["nose"], 1] > p[LM["left_shoulder"], 1]  # +Y up
    assert p[LM["nose"], 2] > 0  # facing +Z
    assert np.isclose(np.linalg.det(np.diag([1.0, -1.0, -1.0])), 1.0)  # a proper rotation


@pytest.mark.parametrize("name", ["walking", "jumping_jacks", "two_arm_curl"])
def test_bone_directions_are_recovered_exactly_and_lengths_imposed(motions, name):
    truth = motions[name]
    seen = track_to_motion(motion_track(truth), height_m=1.80, lowpass_hz=None)
    assert seen.n_frames == truth.n_frames and seen.fps == truth.fps
    for a, b in BONES:
        cos = np.sum(_dirs(truth, a, b) * _dirs(seen, a, b), axis=1)
        assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 0.1, (a, b)
    # lengths are the 1.80 m skeleton's, constant over time
    femur = np.linalg.norm(seen.positions[:, 4] - seen.positions[:, 1], axis=1)
    assert np.ptp(femur) < 1e-9 and femur[0] == pytest.approx(0.3754 * 1.80 / 1.70, rel=0.01)
    assert seen.body_height_m() == pytest.approx(1.80, rel=0.01)
    # twist-bearing segments: hand from the palm, head from ears and eyes, pelvis from the hips
    assert _angle_deg(truth, seen, "left_wrist").max() < 5
    assert _angle_deg(truth, seen, "right_wrist").max() < 5
    assert _angle_deg(truth, seen, "head").max() < 5
    assert _angle_deg(truth, seen, "pelvis").max() < 5
    # root held fixed
    assert np.ptp(seen.positions[:, 0], axis=0).max() < 1e-12 and seen.meta["root"] == "fixed"


def test_whole_body_rotation_is_followed(motions):
    truth = motions["jumping_jacks"]
    turned = truth.positions @ Rotation.from_euler("y", 120, degrees=True).as_matrix().T
    rots = (Rotation.from_euler("y", 120, degrees=True)
            * Rotation.from_quat(truth.rotations.reshape(-1, 4))).as_quat().reshape(truth.rotations.shape)
    from vsmp_imu.motion.motion import Motion

    turned_motion = Motion(turned, rots, truth.fps, meta={})
    seen = track_to_motion(motion_track(turned_motion), lowpass_hz=None)
    assert _angle_deg(turned_motion, seen, "pelvis").max() < 5


def test_gaps_are_interpolated_when_short_and_held_when_long(motions):
    truth = motions["walking"]
    det = np.ones(truth.n_frames, bool)
    det[10:14] = False  # 4 frames at 30 fps: interpolated
    det[100:160] = False  # 2 s: held
    det[:3] = False  # leading: held
    seen = track_to_motion(motion_track(truth, detected=det), lowpass_hz=None)
    meta = seen.meta
    assert meta["detected"] == det.astype(int).tolist()
    assert meta["detected_fraction"] == pytest.approx(det.mean(), abs=1e-6)  # rounded to 6 places
    assert meta["interpolated_fraction"] == pytest.approx(4 / truth.n_frames, abs=1e-6)
    assert meta["held_fraction"] == pytest.approx(63 / truth.n_frames, abs=1e-6)
    assert seen.is_finite()
    # held frames repeat the pose on their side of the gap
    assert np.allclose(seen.positions[100], seen.positions[99]) and np.allclose(seen.positions[0], seen.positions[3])


def test_no_pose_gives_no_motion(motions):
    truth = motions["walking"]
    assert track_to_motion(motion_track(truth, detected=np.zeros(truth.n_frames, bool))) is None


def test_fill_gaps_values():
    x = np.array([0.0, np.nan, 2.0, np.nan, np.nan, np.nan, 6.0, np.nan])
    valid = ~np.isnan(x)
    out, interp, held = fill_gaps(x, valid, max_gap=1)
    assert out.tolist() == [0.0, 1.0, 2.0, 2.0, 6.0, 6.0, 6.0, 6.0]
    assert interp.tolist() == [False, True] + [False] * 6
    assert held.tolist() == [False, False, False, True, True, True, False, True]
    with pytest.raises(ValueError):
        fill_gaps(x, np.zeros(8, bool), 1)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1, 1), min_size=12, max_size=12))
def test_align_maps_the_primary_axis_exactly(values):
    v = np.array(values).reshape(4, 3)
    if min(np.linalg.norm(v, axis=1)) < 1e-3:
        return
    d0, a0, d, a = (v[i] / np.linalg.norm(v[i]) for i in range(4))
    if abs(d0 @ a0) > 0.99 or abs(d @ a) > 0.99:
        return
    r = align(d0, a0, d[None], a[None])
    assert np.allclose(r.apply(d0), d, atol=1e-9)
    # the secondary axis lands in the plane of d and a, on a's side
    img = r.apply(a0 - (a0 @ d0) * d0)[0]
    assert abs(img @ np.cross(d, a)) < 1e-9 and img @ (a - (a @ d) * d) > 0


def test_motion_landmarks_are_hip_centred_in_mediapipe_axes(motions):
    lm = motion_landmarks(motions["walking"])
    mid = 0.5 * (lm[:, LM["left_hip"]] + lm[:, LM["right_hip"]])
    assert np.abs(mid).max() < 1e-12
    assert (lm[:, LM["nose"], 1] < lm[:, LM["left_hip"], 1]).all()  # y down: the head is above
    assert (lm[:, LM["left_shoulder"], 0] > lm[:, LM["right_shoulder"], 0]).mean() > 0.95
