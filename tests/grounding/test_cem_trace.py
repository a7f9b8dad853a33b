"""The bounded CEM step by step: a scripted random generator fixes every draw, spies record
the candidates and their losses, and each iteration is checked against the appendix rule
(clip(mean + std z), elite = the 20 % lowest losses, new mean and std of the elite with a
floor, best-so-far tracking, the gravity-flag probability clipped to [0.05, 0.95])."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.grounding import calibrate as cal
from vsmp_imu.grounding.align import Convention
from vsmp_imu.grounding.calibrate import (
    ETA_HIGH,
    ETA_INIT_STD,
    ETA_LOW,
    ETA_NAMES,
    ETA_NOMINAL,
    MIN_STD_FRACTION,
    SimInTheLoopCalibrator,
    eta_rotation,
)
from vsmp_imu.grounding.stats import sim_loss, summarize_sequence
from vsmp_imu.imu import VirtualSensor, draw_noise, sensor_readings, simulate_kinematics

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "imu"))
from imu_motions import make_motion, walking  # noqa: E402

FS = 50.0
FLOOR = MIN_STD_FRACTION * (ETA_HIGH - ETA_LOW)


class ScriptedRng:
    """Stands in for np.random.Generator: returns the given draws in order."""

    def __init__(self, normals, uniforms=()):
        self.normals, self.uniforms = iter(normals), iter(uniforms)

    def standard_normal(self, shape):
        z = np.asarray(next(self.normals), dtype=float)
        assert z.shape == shape
        return z

    def random(self, n):
        u = np.asarray(next(self.uniforms), dtype=float)
        assert u.shape == (n,)
        return u


@pytest.fixture(scope="module")
def setup():
    root, local = walking()
    kin = simulate_kinematics(make_motion(6.0, 30.0, root, local), "waist", FS)
    noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples, FS, 0, "sim")
    return kin, noise


def _readings(kin, eta, gravity, noise):
    eta = np.asarray(eta, dtype=float)[None]
    return sensor_readings(kin, eta_rotation(eta), eta[:, 3:6], eta[:, 6:9], eta[:, 9], eta[:, 10],
                           gravity, noise)[0]


def _target(kin, noise, gravity=True):
    truth = np.array([6, -4, 8, 0.2, -0.1, 0.1, 0.01, -0.02, 0.01, 1.5, 0.8])
    return summarize_sequence(_readings(kin, truth, gravity, noise), FS)


@pytest.fixture
def spy(monkeypatch):
    """Records the eta rows, gravity flags and losses of every scoring call (one stream: the
    batch's only row), then the weights of X_opt."""
    seen = {"eta": [], "grav": [], "loss": []}
    weights, batch, loss = SimInTheLoopCalibrator._weights, cal.BatchObjective.__call__, cal.sim_loss

    def spy_batch(self, eta, gravity):
        assert eta.shape[0] == 1
        seen["eta"].append(np.array(eta[0]))
        seen["grav"].append(np.array(gravity[0]))
        return batch(self, eta, gravity)

    def spy_weights(base, eta, gravity, with_noise):
        seen["eta"].append(np.array(eta))
        seen["grav"].append(np.array(gravity))
        return weights(base, eta, gravity, with_noise)

    def spy_loss(candidate, target):
        out = loss(candidate, target)
        seen["loss"].append(np.array(out).reshape(-1))
        return out

    monkeypatch.setattr(SimInTheLoopCalibrator, "_weights", staticmethod(spy_weights))
    monkeypatch.setattr(cal.BatchObjective, "__call__", spy_batch)
    monkeypatch.setattr(cal, "sim_loss", spy_loss)
    return seen


def test_each_iteration_follows_the_cem_rule(setup, spy):
    kin, noise = setup
    z1 = np.random.default_rng(0).normal(size=(10, 11))
    z1[0], z1[1], z1[2] = 0.0, 1.0, -10.0  # the mean, mean + std, and one clipped at the low bounds
    z1[:, 10] = 0.3  # one coordinate equal in every candidate: its elite std is 0, the floor holds
    z2 = np.zeros((10, 11))
    z2[1] = 1.0
    res = SimInTheLoopCalibrator(n_iterations=2, n_candidates=10).calibrate(
        kin, _target(kin, noise), Convention(), ScriptedRng([z1, z2]), noise=noise)
    assert len(spy["eta"]) == 4  # nominal, two iterations, X_opt
    eta1 = spy["eta"][1]
    assert np.allclose(eta1, np.clip(ETA_NOMINAL + ETA_INIT_STD * z1, ETA_LOW, ETA_HIGH))
    assert np.array_equal(eta1[2, :10], ETA_LOW[:10])
    losses1 = spy["loss"][1]
    elite = np.argsort(losses1, kind="stable")[:2]  # 20 % of 10
    mean2 = eta1[elite].mean(0)
    std2 = np.maximum(eta1[elite].std(0), FLOOR)
    assert std2[10] == FLOOR[10]
    eta2 = spy["eta"][2]
    assert np.allclose(eta2[0], mean2) and np.allclose(eta2[1], np.clip(mean2 + std2, ETA_LOW, ETA_HIGH))
    all_losses = np.concatenate([spy["loss"][0], losses1, spy["loss"][2]])
    all_etas = np.concatenate([spy["eta"][0], eta1, eta2])
    running = [min(all_losses[: 1 + 10 * (k + 1)]) for k in range(2)]
    assert res.loss_history == pytest.approx(running, rel=0, abs=0)
    best = int(np.argmin(all_losses))  # the first candidate reaching the minimum
    assert res.loss_final == all_losses[best]
    assert [res.eta[n] for n in ETA_NAMES] == pytest.approx(list(all_etas[best]), abs=0)


@pytest.mark.parametrize("gravity", [True, False])
def test_the_gravity_flag_probability_moves_to_the_elite_and_stays_inside_the_clip(setup, spy, gravity):
    kin, noise = setup
    zeros = np.zeros((10, 11))
    u1 = np.array([0.5, 0.49, 0.99, 0.2, 0.7, 0.1, 0.6, 0.3, 0.8, 0.0])
    u2 = np.array([0.96, 0.94, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5]) if gravity else \
        np.array([0.04, 0.06, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5])
    res = SimInTheLoopCalibrator(n_iterations=2, n_candidates=10, search_gravity=True).calibrate(
        kin, _target(kin, noise, gravity), Convention(gravity_included=True), ScriptedRng([zeros, zeros], [u1, u2]),
        noise=noise)
    assert spy["grav"][1].tolist() == (u1 < 0.5).tolist()  # starts at p = 0.5
    elite = np.argsort(spy["loss"][1], kind="stable")[:2]
    assert (spy["grav"][1][elite] == gravity).all()  # the right convention scores best
    p2 = 0.95 if gravity else 0.05  # clipped, never 1 or 0
    assert spy["grav"][2].tolist() == (u2 < p2).tolist()
    assert res.gravity_included is gravity


@pytest.mark.parametrize("gravity", [True, False])
def test_without_iterations_the_nominal_eta_and_convention_are_returned(setup, spy, gravity):
    kin, noise = setup
    target = _target(kin, noise, gravity)
    res = SimInTheLoopCalibrator(n_iterations=0).calibrate(
        kin, target, Convention(gravity_included=gravity), np.random.default_rng(0), noise=noise)
    assert res.loss_history == [] and res.loss_final == res.loss_nominal
    assert res.gravity_included is gravity
    assert [res.eta[n] for n in ETA_NAMES] == list(ETA_NOMINAL)


def test_ties_keep_the_first_candidate(setup, spy):
    kin, _ = setup
    z = np.zeros((64, 11))
    z[:, 9] = np.linspace(-3, 3, 64)  # only the noise scale differs, and without noise it cannot matter
    res = SimInTheLoopCalibrator(n_iterations=2).calibrate(
        kin, _target(kin, None), Convention(), ScriptedRng([z, np.zeros((64, 11))]))
    losses = spy["loss"][1]
    assert len(losses) == 64 and np.all(losses == spy["loss"][0][0])  # 64 exact ties with the nominal
    assert res.eta["acc_noise_scale"] == 1.0  # the nominal came first and stays
    eta1 = spy["eta"][1]
    assert np.allclose(spy["eta"][2][0], eta1[:13].mean(0))  # stable order: the first 13 are the elite


@pytest.mark.parametrize("search", [False, True])
def test_the_reported_eta_reproduces_the_reported_loss(setup, search):
    kin, noise = setup
    target = _target(kin, noise)
    res = SimInTheLoopCalibrator(n_iterations=4, n_candidates=16, search_gravity=search).calibrate(
        kin, target, Convention(), np.random.default_rng(5), noise=noise)
    eta = [res.eta[n] for n in ETA_NAMES]
    again = sim_loss(summarize_sequence(_readings(kin, eta, res.gravity_included, noise), FS), target)
    assert float(again) == pytest.approx(res.loss_final, rel=1e-9)
    assert res.loss_final < res.loss_nominal


def test_elite_ties_are_broken_by_candidate_order(setup, spy):
    kin, _ = setup
    rng = np.random.default_rng(1)
    z = np.zeros((64, 11))
    z[:, 0] = rng.integers(0, 3, 64) * 0.2  # three roll offsets: three groups of exactly tied losses
    z[:, 9] = np.linspace(-3, 3, 64)  # noise scales tell the tied candidates apart (no noise: no effect)
    SimInTheLoopCalibrator(n_iterations=2).calibrate(
        kin, _target(kin, None), Convention(), ScriptedRng([z, np.zeros((64, 11))]))
    losses, eta1 = spy["loss"][1], spy["eta"][1]
    assert len(np.unique(losses)) == 3
    elite = np.argsort(losses, kind="stable")[:13]
    boundary = losses[elite[-1]]
    assert (losses == boundary).sum() > (losses[elite] == boundary).sum()  # the cut falls inside a tie group
    assert np.allclose(spy["eta"][2][0], eta1[elite].mean(0))


@pytest.mark.parametrize("search", [False, True])
def test_the_best_so_far_is_the_single_best_candidate_ever_scored(setup, monkeypatch, search):
    # scripted losses: nominal 10; iteration 1 best 5 (candidate 3), iteration 2 best 4 (candidate 1)
    # while its second best (7) is worse than 5: only the single best may decide an update
    kin, noise = setup
    scripted = iter([np.array([10.0]), np.array([9, 9, 9, 5, 9, 9, 9, 9, 9, 9.0]),
                     np.array([7, 4, 8, 8, 8, 8, 8, 8, 8, 8.0])])
    monkeypatch.setattr(cal, "sim_loss", lambda candidate, target: next(scripted))
    z = np.random.default_rng(3).normal(size=(10, 11))
    u = np.array([0.9, 0.1, 0.9, 0.1, 0.9, 0.9, 0.9, 0.9, 0.9, 0.9])  # candidates 1 and 3 with gravity
    res = SimInTheLoopCalibrator(n_iterations=2, n_candidates=10, search_gravity=search).calibrate(
        kin, _target(kin, noise), Convention(gravity_included=False), ScriptedRng([z, z], [u, u]),
        noise=noise)
    assert res.loss_nominal == 10.0 and res.loss_history == [5.0, 4.0] and res.loss_final == 4.0
    assert res.gravity_included is search  # candidate 1's flag, not candidate 0's
