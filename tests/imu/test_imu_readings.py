"""Noise, bias, the vectorized candidate path and seeding."""

from __future__ import annotations

import numpy as np
import pytest
from imu_motions import make_motion, smooth_random
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu import (
    ImuSimulator,
    VirtualSensor,
    draw_noise,
    sensor_readings,
    simulate_kinematics,
    simulate_many,
)
from vsmp_imu.imu.sensor import ACC_NOISE_DENSITY, GYR_NOISE_DENSITY
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as GRAVITY_M_S2

GRAVITY_READING = np.array([0.0, GRAVITY_M_S2, 0.0])


@pytest.fixture(scope="module")
def static_long():
    return make_motion(60.0, fps=30.0)


@pytest.fixture(scope="module")
def moving():
    root, local = smooth_random(7)
    return make_motion(10.0, root=root, local=local)


def test_white_noise_std_matches_the_nominal_sigma(static_long):
    fs = 100.0
    sensor = VirtualSensor.at("waist", acc_bias_walk=0.0, gyr_bias_walk=0.0)
    rec = ImuSimulator(fs, seed=11).simulate(static_long, sensor)
    acc_err = rec.data[:, :3] - GRAVITY_READING
    gyr_err = rec.data[:, 3:]
    sigma_a = ACC_NOISE_DENSITY * np.sqrt(fs)
    sigma_w = GYR_NOISE_DENSITY * np.sqrt(fs)
    np.testing.assert_allclose(acc_err.std(axis=0), sigma_a, rtol=0.05)
    np.testing.assert_allclose(gyr_err.std(axis=0), sigma_w, rtol=0.05)
    np.testing.assert_allclose(acc_err.mean(axis=0), 0.0, atol=5 * sigma_a / np.sqrt(len(acc_err)))
    # per-sample white noise: neighbouring samples are uncorrelated
    lag1 = np.corrcoef(acc_err[:-1, 0], acc_err[1:, 0])[0, 1]
    assert abs(lag1) < 0.05


def test_noise_std_scales_with_the_square_root_of_the_rate(static_long):
    sensor = VirtualSensor.at("waist", acc_bias_walk=0.0, gyr_bias_walk=0.0)
    std = {fs: (ImuSimulator(fs, seed=2).simulate(static_long, sensor).data[:, :3] - GRAVITY_READING).std()
           for fs in (25.0, 100.0)}
    assert std[100.0] / std[25.0] == pytest.approx(2.0, rel=0.06)


def test_bias_shows_up_as_a_mean_offset(static_long):
    acc_bias, gyr_bias = (0.2, -0.3, 0.1), (0.01, 0.0, -0.02)
    sensor = VirtualSensor.at("chest", acc_bias=acc_bias, gyr_bias=gyr_bias, acc_bias_walk=0.0, gyr_bias_walk=0.0)
    rec = ImuSimulator(50.0, seed=4).simulate(static_long, sensor)
    n = rec.n_samples
    np.testing.assert_allclose(rec.data[:, :3].mean(0) - GRAVITY_READING, acc_bias,
                               atol=5 * sensor.noise_std(50.0)["acc_white"] / np.sqrt(n))
    np.testing.assert_allclose(rec.data[:, 3:].mean(0), gyr_bias,
                               atol=5 * sensor.noise_std(50.0)["gyr_white"] / np.sqrt(n))
    exact = ImuSimulator(50.0, noise=False).simulate(static_long, sensor)
    np.testing.assert_allclose(exact.data[:, :3], np.tile(GRAVITY_READING + acc_bias, (n, 1)), atol=1e-9)


def test_bias_random_walk_has_the_nominal_step_size(static_long):
    fs = 50.0
    sensor = VirtualSensor.at("waist", acc_noise_density=0.0, gyr_noise_density=0.0,
                              acc_bias_walk=0.02, gyr_bias_walk=0.002)
    rec = ImuSimulator(fs, seed=8).simulate(static_long, sensor)
    steps_a = np.diff(rec.data[:, :3] - GRAVITY_READING, axis=0)
    steps_w = np.diff(rec.data[:, 3:], axis=0)
    np.testing.assert_allclose(steps_a.std(0), 0.02 / np.sqrt(fs), rtol=0.06)
    np.testing.assert_allclose(steps_w.std(0), 0.002 / np.sqrt(fs), rtol=0.06)
    # a walk, not white noise: the spread grows over the recording
    drift = rec.data[:, 3:]
    assert np.abs(drift[-500:]).mean() > np.abs(drift[:50]).mean()


def test_no_noise_is_exact_kinematics(moving):
    rec = ImuSimulator(50.0, noise=False).simulate(moving, "right_wrist")
    kin = simulate_kinematics(moving, "right_wrist", 50.0)
    np.testing.assert_array_equal(rec.data[:, :3], kin.acc_lin_seg + kin.grav_seg)
    np.testing.assert_array_equal(rec.data[:, 3:], kin.gyr_seg)
    noisy = ImuSimulator(50.0, noise=True).simulate(moving, "right_wrist")
    assert not np.allclose(noisy.data, rec.data)


def test_vectorized_candidates_equal_single_calls(moving):
    kin = simulate_kinematics(moving, "right_wrist", 50.0)
    sensor = VirtualSensor.at("right_wrist")
    noise = draw_noise(sensor, kin.n_samples, 50.0, 5, "right_wrist")
    rng = np.random.default_rng(0)
    n = 16
    mounts = Rotation.from_euler("xyz", rng.uniform(-15, 15, (n, 3)), degrees=True).as_matrix()
    b_a, b_w = rng.uniform(-0.5, 0.5, (n, 3)), rng.uniform(-0.05, 0.05, (n, 3))
    k_a, k_w = rng.uniform(0.5, 2.0, n), rng.uniform(0.5, 2.0, n)
    grav = rng.random(n) < 0.5
    batch = sensor_readings(kin, mounts, b_a, b_w, k_a, k_w, grav, noise)
    assert batch.shape == (n, kin.n_samples, 6)
    for i in range(n):
        single = sensor_readings(kin, mounts[i], b_a[i], b_w[i], k_a[i], k_w[i], bool(grav[i]), noise)
        np.testing.assert_allclose(batch[i], single[0], rtol=0, atol=1e-12)
    # candidates differ only by their parameters: same noise realization, scaled
    same = sensor_readings(kin, mounts[0], b_a[0], b_w[0], [1.0, 2.0], 1.0, bool(grav[0]), noise)
    np.testing.assert_allclose(same[1, :, :3] - same[0, :, :3], noise.acc, atol=1e-12)


def test_gravity_removed_gives_linear_acceleration(moving):
    kin = simulate_kinematics(moving, "waist", 50.0)
    both = sensor_readings(kin, gravity_included=[True, False])
    np.testing.assert_allclose(both[1, :, :3], kin.acc_lin_seg, atol=1e-12)
    np.testing.assert_allclose(both[0, :, :3] - both[1, :, :3], kin.grav_seg, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(kin.grav_seg, axis=1), GRAVITY_M_S2)


def test_candidate_arrays_must_agree(moving):
    kin = simulate_kinematics(moving, "waist", 50.0)
    with pytest.raises(ValidationError, match="candidate counts"):
        sensor_readings(kin, np.tile(np.eye(3), (4, 1, 1)), acc_bias=np.zeros((3, 3)))
    with pytest.raises(ValidationError, match="mounting"):
        sensor_readings(kin, np.eye(4))
    other = draw_noise(VirtualSensor.at("waist"), kin.n_samples + 1, 50.0, 0)
    with pytest.raises(ValidationError, match="noise"):
        sensor_readings(kin, noise=other)


def test_same_seed_same_bytes_and_different_seed_differs(moving, tmp_path):
    a = ImuSimulator(50.0, seed=3).simulate(moving, "waist")
    b = ImuSimulator(50.0, seed=3).simulate(moving, "waist")
    c = ImuSimulator(50.0, seed=4).simulate(moving, "waist")
    assert a.to_csv_text() == b.to_csv_text()
    assert a.data.tobytes() == b.data.tobytes()
    assert not np.array_equal(a.data, c.data)
    assert a.meta["seed"] == 3


def test_simulate_many_prefixes_channels_and_draws_independent_noise(static_long):
    rec = simulate_many(static_long, ["left_wrist", "right_wrist"], fs_hz=50.0, seed=1)
    assert rec.channel_names[:2] == ("left_wrist_acc_x", "left_wrist_acc_y")
    assert rec.channel_names[6:] == tuple(f"right_wrist_{c}" for c in ("acc_x", "acc_y", "acc_z",
                                                                          "gyr_x", "gyr_y", "gyr_z"))
    assert rec.locations == ("left_wrist", "right_wrist")
    left, right = rec.at_location("left_wrist"), rec.at_location("right_wrist")
    # both wrists are static in the T-pose: same physics, different noise draws
    np.testing.assert_allclose(left.data.mean(0), right.data.mean(0), atol=0.01)
    assert abs(np.corrcoef(left.data[:, 0], right.data[:, 0])[0, 1]) < 0.1
    assert set(rec.meta["sensors"]) == {"left_wrist", "right_wrist"}
    with pytest.raises(ValidationError, match="duplicate"):
        simulate_many(static_long, ["wrist", "right_wrist"])


def test_kinematics_keep_provenance(moving):
    kin = simulate_kinematics(moving, "hand", 50.0)
    assert kin.location == "right_wrist" and kin.segment == "right_elbow"
    assert kin.meta["smoothing_hz"] == 8.0 and kin.meta["motion_fps"] == 30.0
    assert kin.times[0] == pytest.approx(0.2)


def test_bad_settings_raise_validation_errors(moving):
    with pytest.raises(ValidationError, match="fs_hz"):
        ImuSimulator(0.0).simulate(moving)
    with pytest.raises(ValidationError, match="trim_s"):
        ImuSimulator(50.0, trim_s=6.0).simulate(moving)
    with pytest.raises(ValidationError, match="acc_noise_density"):
        VirtualSensor.at("waist", acc_noise_density=-1.0)
    with pytest.raises(ValidationError, match="acc_bias"):
        VirtualSensor.at("waist", acc_bias=(1.0, 2.0))
