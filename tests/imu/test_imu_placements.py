"""Named placements: names, aliases, attachment points, theta."""

from __future__ import annotations

import numpy as np
import pytest
from imu_motions import make_motion

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu import ALIASES, PLACEMENTS, VirtualSensor, get_placement, location_names
from vsmp_imu.motion import Motion, forward_kinematics, smpl22_skeleton

DATASET_LOCATIONS = {
    "waist", "chest", "back", "head", "left_wrist", "right_wrist", "left_upper_arm", "right_upper_arm",
    "left_thigh", "right_thigh", "left_lower_leg", "right_lower_leg", "left_ankle", "right_ankle",
}


def test_every_dataset_location_exists_and_every_alias_resolves():
    assert set(PLACEMENTS) >= DATASET_LOCATIONS
    for alias, target in ALIASES.items():
        assert get_placement(alias).name == target
    assert get_placement("pelvis").name == "waist"
    assert get_placement("hip").name == "waist"
    assert get_placement("Dominant-Wrist").name == "right_wrist"
    assert get_placement("thigh").name == "right_thigh"
    assert get_placement("ankle").name == "right_ankle"
    assert get_placement("wrist").name == "right_wrist"


def test_every_body_part_of_the_annotation_vocabulary_has_a_placement():
    vocabulary = ("head", "torso", "left_shoulder", "right_shoulder", "left_upper_arm", "right_upper_arm",
                  "left_forearm", "right_forearm", "left_hand", "right_hand", "pelvis", "left_thigh",
                  "right_thigh", "left_lower_leg", "right_lower_leg", "left_foot", "right_foot")
    for part in vocabulary:
        placement = get_placement(part)
        side = part.split("_")[0]
        if side in ("left", "right"):
            assert placement.name.startswith(side), part


def test_unknown_location_lists_the_allowed_names():
    with pytest.raises(ValidationError) as exc:
        get_placement("elbow_pit")
    assert exc.value.field == "location"
    assert "waist" in exc.value.allowed and "dominant_wrist" in exc.value.allowed
    assert set(location_names()) >= DATASET_LOCATIONS | set(ALIASES)


def test_every_placement_sits_on_an_smpl22_segment():
    motion = make_motion(1.0)
    for name, p in PLACEMENTS.items():
        r = p.attachment_m(motion)
        assert r.shape == (3,) and np.isfinite(r).all(), name
        assert np.linalg.norm(r) < 0.5, name  # on the body, near its segment


def test_wrist_sensor_sits_on_the_forearm_just_before_the_wrist():
    motion = make_motion(1.0)
    for side in ("left", "right"):
        p = get_placement(f"{side}_wrist")
        assert p.segment == f"{side}_elbow"  # oriented with the forearm (the wrist joint's parent segment)
        elbow, wrist = motion.joint_index(f"{side}_elbow"), motion.joint_index(f"{side}_wrist")
        bone = motion.positions[0, wrist] - motion.positions[0, elbow]
        r = p.attachment_m(motion)
        on_bone = r - np.asarray(p.surface_m)  # the default body is 1.70 m: no surface scaling
        np.testing.assert_allclose(on_bone, 0.9 * bone, atol=1e-3)
        assert p.surface_m[1] > 0.02  # back of the wrist faces up in the T-pose (palms down)


def test_attachment_follows_body_size():
    small = smpl22_skeleton(1.50)
    quats = np.zeros((2, 22, 4))
    quats[..., 3] = 1.0
    pos, rot = forward_kinematics(small, quats, np.tile([0.0, small.pelvis_height(), 0.0], (2, 1)))
    small_motion = Motion(pos, rot, 30.0)
    big_motion = make_motion(1.0)
    for name in ("right_thigh", "waist"):
        r_small = get_placement(name).attachment_m(small_motion)
        r_big = get_placement(name).attachment_m(big_motion)
        np.testing.assert_allclose(r_small, r_big * 1.50 / 1.70, rtol=1e-3)


def test_theta_holds_the_nominal_configuration():
    motion = make_motion(1.0)
    sensor = VirtualSensor.at("thigh", acc_bias=(0.1, 0.0, 0.0))
    theta = sensor.theta(motion)
    assert theta["location"] == "right_thigh" and theta["segment"] == "right_hip"
    assert theta["mounting_xyzw"] == [0.0, 0.0, 0.0, 1.0]
    assert theta["acc_bias_m_s2"] == [0.1, 0.0, 0.0]
    assert len(theta["attachment_m"]) == 3
    np.testing.assert_allclose(theta["attachment_m"], get_placement("right_thigh").attachment_m(motion))
    override = VirtualSensor.at("waist", attachment_m=(0.0, 0.1, 0.0)).theta(motion)
    assert override["attachment_m"] == [0.0, 0.1, 0.0]


def test_placement_on_a_motion_without_that_joint_names_the_joint():
    motion = make_motion(1.0)
    stripped = Motion(motion.positions[:, :3], motion.rotations[:, :3], motion.fps,
                      motion.joint_names[:3], motion.parents[:3])
    with pytest.raises(ValidationError, match="right_elbow"):
        get_placement("right_wrist").attachment_m(stripped)
