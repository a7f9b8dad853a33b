"""Simulation-in-the-loop calibration (bounded CEM over eta)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.grounding.align import Convention, axes_matrix
from vsmp_imu.grounding.calibrate import (
    ETA_HIGH,
    ETA_LOW,
    ETA_NAMES,
    SimInTheLoopCalibrator,
    cem_update,
    eta_rotation,
)
from vsmp_imu.grounding.stats import segment, summarize_windows
from vsmp_imu.imu import VirtualSensor, draw_noise, sensor_readings, simulate_kinematics
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "imu"))
from imu_motions import make_motion, walking  # noqa: E402

TRUTH = np.array([[8, -6, 12, 0.3, -0.2, 0.1, 0.02, -0.03, 0.01, 1.8, 0.6]])


@pytest.fixture(scope="module")
def setup():
    root, local = walking()
    kin = simulate_kinematics(make_motion(12.0, 30.0, root, local), "waist", 50.0)
    sensor = VirtualSensor.at("waist")
    noise = draw_noise(sensor, kin.n_samples, 50.0, 0, "sim")
    real_noise = draw_noise(sensor, kin.n_samples, 50.0, 1, "real")
    return kin, noise, real_noise


def _real(kin, noise, truth, axes=("left", "up", "forward")):
    x = sensor_readings(kin, eta_rotation(truth), truth[:, 3:6], truth[:, 6:9], truth[:, 9], truth[:, 10],
                        True, noise)[0]
    p = axes_matrix(axes)
    return np.concatenate([x[:, :3] @ p.T, x[:, 3:] @ p.T], axis=1)


def test_cem_recovers_a_mounting_offset(setup):
    kin, noise, real_noise = setup
    target = summarize_windows(segment(_real(kin, real_noise, TRUTH), 100), 50.0)
    res = SimInTheLoopCalibrator().calibrate(kin, target, Convention(), np.random.default_rng(0), noise=noise)
    assert res.loss_final < 0.05 * res.loss_nominal
    assert res.eta["roll_deg"] == pytest.approx(8, abs=2.5)
    assert res.eta["pitch_deg"] == pytest.approx(-6, abs=2.5)
    assert res.eta["yaw_deg"] == pytest.approx(12, abs=4)
    assert res.eta["acc_noise_scale"] > 1.0  # truth 1.8: more noise than nominal
    assert len(res.loss_history) == 30
    assert all(a >= b for a, b in zip(res.loss_history, res.loss_history[1:], strict=False))
    values = np.array(list(res.eta.values()))
    assert (values >= ETA_LOW - 1e-12).all() and (values <= ETA_HIGH + 1e-12).all()


def test_cem_scores_in_the_target_axis_convention(setup):
    kin, noise, real_noise = setup
    conv = Convention(axes=("up", "right", "forward"))
    target = summarize_windows(segment(_real(kin, real_noise, TRUTH, conv.axes), 100), 50.0)
    aligned = SimInTheLoopCalibrator().calibrate(kin, target, conv, np.random.default_rng(0), noise=noise)
    wrong = SimInTheLoopCalibrator().calibrate(kin, target, Convention(), np.random.default_rng(0), noise=noise)
    assert aligned.loss_final < 0.1 * wrong.loss_final


def test_cem_finds_the_gravity_convention_when_searched(setup):
    kin, noise, real_noise = setup
    x = sensor_readings(kin, None, None, None, 1.0, 1.0, False, real_noise)[0]  # linear acceleration
    target = summarize_windows(segment(x, 100), 50.0)
    res = SimInTheLoopCalibrator(search_gravity=True).calibrate(
        kin, target, Convention(), np.random.default_rng(3), noise=noise)
    assert res.gravity_included is False
    linear = res.readings[:, :3] - res.gravity
    assert np.abs(linear.mean(0)).max() < 1.0
    assert np.linalg.norm(res.gravity, axis=1) == pytest.approx(G, abs=1e-6)


def test_cem_is_deterministic_and_returns_x_opt(setup):
    kin, noise, real_noise = setup
    target = summarize_windows(segment(_real(kin, real_noise, TRUTH), 100), 50.0)
    a = SimInTheLoopCalibrator(n_iterations=5).calibrate(kin, target, Convention(), np.random.default_rng(9),
                                                         noise=noise)
    b = SimInTheLoopCalibrator(n_iterations=5).calibrate(kin, target, Convention(), np.random.default_rng(9),
                                                         noise=noise)
    assert a.eta == b.eta and np.array_equal(a.readings, b.readings)
    eta = np.array([list(a.eta.values())])
    expect = sensor_readings(kin, eta_rotation(eta), eta[:, 3:6], eta[:, 6:9], eta[:, 9], eta[:, 10], True, noise)
    assert np.allclose(a.readings, expect[0])


def test_eta_rotation_is_scipys_extrinsic_zxy():
    from scipy.spatial.transform import Rotation

    eta = np.random.default_rng(11).uniform(-60, 60, (50, 11))
    expected = Rotation.from_euler("zxy", eta[:, 0:3], degrees=True).as_matrix()
    assert np.allclose(eta_rotation(eta), expected, atol=1e-12)
    assert eta_rotation(eta[0]).shape == (1, 3, 3)


def test_cem_update_of_one_population_keeps_the_lowest_losses_in_stable_order():
    """One population (N, D) with losses (N,), as the motion fit calls it: the order by loss, ties in
    candidate order, and the mean and std (at least the floor) of the n_elite best."""
    candidates = np.arange(12, dtype=float).reshape(6, 2)
    losses = np.array([3.0, 1.0, 2.0, 1.0, 5.0, 0.5])
    order, mean, std = cem_update(candidates, losses, 3, np.array([0.0, 10.0]))
    assert order.tolist() == [5, 1, 3, 2, 0, 4]
    elite = candidates[[5, 1, 3]]
    np.testing.assert_allclose(mean, elite.mean(axis=0))
    np.testing.assert_allclose(std, [elite[:, 0].std(), 10.0])


def test_streams_calibrated_in_lockstep_get_what_each_gets_alone(setup):
    """calibrate_many scores the candidates of several streams together (BatchObjective with S > 1),
    streams with and without noise apart; each result is the one its stream gets alone."""
    from vsmp_imu.grounding.calibrate import CemProblem

    kin, noise, real_noise = setup
    other = TRUTH * np.array([[-1, 0.5, -0.5, 1, 1, 1, 1, 1, 1, 0.7, 1.2]])
    targets = [summarize_windows(segment(_real(kin, real_noise, t), 100), 50.0) for t in (TRUTH, other, TRUTH)]
    noises = [noise, noise, None]

    def problems():
        return [CemProblem(kin, t, Convention(), np.random.default_rng(20 + i), None, z)
                for i, (t, z) in enumerate(zip(targets, noises, strict=True))]

    cal = SimInTheLoopCalibrator(n_iterations=4, n_candidates=16)
    together = cal.calibrate_many(problems())
    for i, problem in enumerate(problems()):
        alone = cal.calibrate_many([problem])[0]
        assert together[i].eta == alone.eta
        assert together[i].loss_history == alone.loss_history
        np.testing.assert_array_equal(together[i].readings, alone.readings)
    assert together[0].eta != together[1].eta


def test_the_calibration_record_holds_eta_gravity_losses_and_the_iteration_count(setup):
    kin, noise, real_noise = setup
    target = summarize_windows(segment(_real(kin, real_noise, TRUTH), 100), 50.0)
    res = SimInTheLoopCalibrator(n_iterations=3, n_candidates=8).calibrate(
        kin, target, Convention(), np.random.default_rng(1), noise=noise)
    record = res.as_dict()
    assert record == {"eta": res.eta, "gravity_included": res.gravity_included, "loss_nominal": res.loss_nominal,
                      "loss_final": res.loss_final, "iterations": 3}
    assert list(record["eta"]) == list(ETA_NAMES)


def test_a_convention_record_holds_every_field():
    conv = Convention(axes=("up", "right", "forward"), gravity_included=False, acc_unit="g", gyr_unit="deg/s",
                      channel_names=("a", "b", "c", "d", "e", "f"))
    assert conv.as_dict() == {"axes": ["up", "right", "forward"], "gravity_included": False, "acc_unit": "g",
                              "gyr_unit": "deg/s", "channel_names": ["a", "b", "c", "d", "e", "f"]}
