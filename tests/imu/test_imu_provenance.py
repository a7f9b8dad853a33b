"""What a simulated recording says about itself (the provenance a synthetic sample keeps), the
attachment rule of a placement in words and numbers, and the checks on reading weights."""

from __future__ import annotations

import json

import numpy as np
import pytest
from imu_motions import constant, make_motion, smooth_random, walking
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu import ImuSimulator, VirtualSensor
from vsmp_imu.imu.kinematics import simulate_kinematics
from vsmp_imu.imu.placement import PLACEMENTS, Placement, get_placement
from vsmp_imu.imu.readings import reading_weights
from vsmp_imu.imu.recording import ImuRecording
from vsmp_imu.motion import Motion
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

THETA_KEYS = {"location", "segment", "attachment_m", "attachment_rule", "mounting_xyzw", "acc_bias_m_s2",
              "gyr_bias_rad_s", "acc_noise_density_m_s2_per_sqrt_hz", "gyr_noise_density_rad_s_per_sqrt_hz",
              "acc_bias_walk_m_s2_per_sqrt_s", "gyr_bias_walk_rad_s_per_sqrt_s"}


@pytest.fixture(scope="module")
def motion():
    root, local = walking()
    return make_motion(3.0, 30.0, root, local, smp_id="walk-1")


# -- provenance --------------------------------------------------------------------------------
def test_a_recording_says_how_it_was_simulated(motion):
    sim = ImuSimulator(50.0, noise=False, seed=7, smoothing_hz=6.0, trim_s=0.2)
    rec = sim.simulate(motion)  # the waist by default
    sensor = VirtualSensor.at("waist")
    assert rec.meta == {
        "kind": "imu_recording", "location": "waist", "motion": motion.meta,
        "sensor": sensor.theta(attachment_m=sim.kinematics_.attachment_m),
        "simulator": "ImuSimulator", "fs_hz": 50.0, "noise": False, "seed": 7, "smoothing_hz": 6.0,
        "trim_s": 0.2, "gravity_m_s2": STANDARD_GRAVITY_M_S2,
    }
    assert sim.settings()["noise"] is False and ImuSimulator(50.0).settings()["noise"] is True
    assert sim.kinematics_.n_samples == rec.n_samples
    json.dumps(rec.meta)  # JSON-ready


def test_theta_names_every_sensor_parameter_with_its_unit():
    sensor = VirtualSensor.at("left_wrist", acc_bias=(0.1, 0.0, -0.2), gyr_bias=(0.0, 0.01, 0.0))
    theta = sensor.theta()
    assert set(theta) == THETA_KEYS
    assert theta["location"] == "left_wrist" and theta["segment"] == "left_elbow"
    assert theta["attachment_m"] is None  # neither given nor resolved on a motion
    assert theta["attachment_rule"] == "0.9 toward left_wrist, skin (0, 0.03, 0) m"
    assert theta["acc_bias_m_s2"] == [0.1, 0.0, -0.2] and theta["gyr_bias_rad_s"] == [0.0, 0.01, 0.0]
    assert theta["acc_noise_density_m_s2_per_sqrt_hz"] == sensor.acc_noise_density
    assert theta["gyr_noise_density_rad_s_per_sqrt_hz"] == sensor.gyr_noise_density
    assert theta["acc_bias_walk_m_s2_per_sqrt_s"] == sensor.acc_bias_walk
    assert theta["gyr_bias_walk_rad_s_per_sqrt_s"] == sensor.gyr_bias_walk
    assert sensor.theta(attachment_m=(1, 2, 3))["attachment_m"] == [1.0, 2.0, 3.0]


def test_a_sensor_named_by_location_holds_that_placement():
    sensor = VirtualSensor.at("wrist")
    assert sensor.placement is PLACEMENTS["right_wrist"] and sensor.name == "right_wrist"
    assert VirtualSensor(placement="pocket").placement is get_placement("right_thigh")


def test_the_simulators_smoothing_reaches_the_kinematics():
    root, local = smooth_random(4, max_hz=6.0)
    jittery = make_motion(3.0, 30.0, root, local)
    for cutoff in (3.0, 12.0):
        rec = ImuSimulator(50.0, noise=False, smoothing_hz=cutoff).simulate(jittery, "right_wrist")
        kin = simulate_kinematics(jittery, VirtualSensor.at("right_wrist"), 50.0, smoothing_hz=cutoff)
        assert np.allclose(rec.data[:, 3:], kin.gyr_seg, atol=1e-12)
    slow, fast = (ImuSimulator(50.0, noise=False, smoothing_hz=c).simulate(jittery, "right_wrist").data
                  for c in (3.0, 12.0))
    assert not np.allclose(slow, fast)


def test_settings_are_checked_before_the_sensor_is_looked_up(motion):
    with pytest.raises(ValidationError) as err:
        ImuSimulator(50.0, smoothing_hz=-1.0).simulate(motion, "no_such_place")
    assert err.value.field == "smoothing_hz"


# -- placements --------------------------------------------------------------------------------
@pytest.mark.parametrize(("placement", "rule"), [
    (PLACEMENTS["right_wrist"], "0.9 toward right_wrist, skin (0, 0.03, 0) m"),
    (PLACEMENTS["waist"], "skin (0, 0.05, 0.12) m"),
    (Placement("p", "pelvis"), "at the joint"),
    (Placement("p", "pelvis", "spine1", 0.5), "0.5 toward spine1"),
    (Placement("p", "pelvis", "spine1", 0.0, (0.0, 0.1, 0.0)), "skin (0, 0.1, 0) m"),
    (Placement("p", "pelvis", None, 0.5), "at the joint"),
])
def test_the_attachment_rule_in_words(placement, rule):
    assert placement.rule() == rule


def test_a_fraction_of_one_puts_the_sensor_on_the_next_joint():
    """fraction 1 toward the wrist: the attachment is the whole forearm bone, whatever the pose."""
    bent = make_motion(1.0, 30.0, local={"right_elbow": constant(Rotation.from_euler("y", 70, degrees=True)),
                                         "right_shoulder": constant(Rotation.from_euler("z", -40, degrees=True))})
    at_wrist = Placement("p", "right_elbow", "right_wrist", 1.0)
    j, w = bent.joint_index("right_elbow"), bent.joint_index("right_wrist")
    world = Rotation.from_quat(bent.rotations[0, j]).apply(at_wrist.attachment_m(bent))
    assert np.allclose(bent.positions[0, j] + world, bent.positions[0, w], atol=1e-9)


def test_the_attachment_is_in_the_segment_frame_so_turning_the_body_leaves_it():
    upright = make_motion(1.0, 30.0)
    turned = make_motion(1.0, 30.0, local={"pelvis": constant(Rotation.from_euler("y", 90, degrees=True))})
    for name in ("right_wrist", "left_thigh", "right_foot"):
        p = PLACEMENTS[name]
        assert np.allclose(p.attachment_m(turned), p.attachment_m(upright), atol=1e-9)


def test_without_a_target_joint_a_fraction_adds_nothing():
    p = Placement("p", "pelvis", None, 0.5, (0.0, 0.1, 0.0))
    assert np.allclose(p.attachment_m(make_motion(1.0, 30.0)), [0.0, 0.1, 0.0])


def test_a_skeleton_other_than_smpl22_keeps_the_nominal_skin_offset():
    positions = np.tile([[0.0, 1.0, 0.0], [0.0, 1.5, 0.0]], (5, 1, 1))
    rotations = np.tile([0.0, 0.0, 0.0, 1.0], (5, 2, 1))
    two = Motion(positions, rotations, 30.0, joint_names=("base", "tip"), parents=(-1, 0))
    p = Placement("p", "base", None, 0.0, (0.0, 0.05, 0.1))
    assert np.allclose(p.attachment_m(two), [0.0, 0.05, 0.1])


# -- reading weights ---------------------------------------------------------------------------
def test_default_weights_are_unit_noise_with_gravity():
    assert np.array_equal(reading_weights(), reading_weights(np.eye(3), np.zeros(3), np.zeros(3), 1.0, 1.0, True))


def test_one_parameter_with_n_candidates_gives_n_weight_sets():
    biases = np.arange(12, dtype=float).reshape(4, 3)
    for kwargs in ({"acc_bias": biases}, {"gyr_bias": biases}, {"acc_noise_scale": np.arange(4.0)},
                   {"gyr_noise_scale": np.arange(4.0)}, {"gravity_included": [True, False, True, False]},
                   {"mounting": Rotation.random(4, random_state=1).as_matrix()}):
        w = reading_weights(**kwargs)
        assert w.shape == (4, 16, 6)
    w = reading_weights(acc_bias=biases, gyr_bias=biases[::-1])
    assert np.array_equal(w[:, 9, :3], biases) and np.array_equal(w[:, 9, 3:], biases[::-1])


def test_gravity_included_is_a_flag():
    assert np.array_equal(reading_weights(gravity_included=2), reading_weights(gravity_included=True))
    assert np.array_equal(reading_weights(gravity_included=0), reading_weights(gravity_included=False))


@pytest.mark.parametrize(("kwargs", "field", "message"), [
    (dict(mounting=np.eye(2)), "mounting", "expected shape (3, 3) or (N, 3, 3), got (2, 2)"),
    (dict(acc_bias=np.zeros(4)), "acc_bias", "expected shape (3,) or (N, 3), got (4,)"),
    (dict(gyr_noise_scale=np.ones((2, 2))), "gyr_noise_scale", "expected a scalar or (N,), got shape (2, 2)"),
    (dict(gravity_included=[]), "gravity_included", "expected a scalar or (N,), got shape (0,)"),
    (dict(acc_bias=np.zeros((2, 3)), gyr_bias=np.zeros((3, 3))), "candidates",
     "candidate counts disagree (mounting: 1, acc_bias: 2, gyr_bias: 3, acc_noise_scale: 1, "
     "gyr_noise_scale: 1, gravity_included: 1)"),
])
def test_weight_errors_name_the_argument(kwargs, field, message):
    with pytest.raises(ValidationError) as err:
        reading_weights(**kwargs)
    assert err.value.field == field and err.value.message == message


# -- recordings --------------------------------------------------------------------------------
def test_a_recording_stores_floats_and_accepts_any_positive_rate():
    rec = ImuRecording(np.arange(12).reshape(2, 6), ("a", "b", "c", "d", "e", "f"), 0.5)
    assert rec.data.dtype == np.float64 and rec.fs_hz == 0.5
    with pytest.raises(ValidationError) as err:
        ImuRecording(np.zeros((2, 2)), ("a", "a"), 50.0)
    assert err.value.message == "channel names must be unique" and err.value.field == "channel_names"
