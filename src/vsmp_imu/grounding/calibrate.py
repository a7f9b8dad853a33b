"""Simulation-in-the-loop calibration of the residual simulator parameters eta.

Paper, "Simulation-in-the-loop optimization" and appendix
"Simulation-in-the-Loop Optimization": eta = {dR_s, db_a, db_w, k_a, k_w}
(+ the gravity convention when the target does not declare it) is found by a
bounded cross-entropy method (30 iterations, 64 candidates, elite fraction
0.20, initial std 5 deg / 0.25 m/s^2 / 0.02 rad/s / 0.10) minimizing L_sim
against D_stat. The segment kinematics are simulated once; every candidate
only re-mixes them (`vsmp_imu.imu.sensor_readings`), vectorized over the
population.

The loss compares statistics in the target's axis convention (a fixed signed
permutation; D_stat is SI in memory), because cross-channel covariance is
frame-dependent; X_opt itself stays in the simulator's sensor frame and is
aligned afterwards. Each candidate is scored under its gravity flag (the
target's declared convention, or the searched one); X_opt is returned with
gravity included plus the sensor-frame gravity, and alignment applies the
chosen convention.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vsmp_imu.grounding.align import Convention, axes_matrix
from vsmp_imu.grounding.stats import LinearMoments, StatSummary, sim_loss
from vsmp_imu.imu import ImuNoise, SegmentKinematics, reading_features
from vsmp_imu.imu.readings import channel_weights, fill_weights

# Appendix table "Residual simulator parameters": search ranges.
ETA_NAMES = (
    "roll_deg", "pitch_deg", "yaw_deg",
    "acc_bias_x", "acc_bias_y", "acc_bias_z",
    "gyr_bias_x", "gyr_bias_y", "gyr_bias_z",
    "acc_noise_scale", "gyr_noise_scale",
)  # fmt: skip
ETA_LOW = np.array([-10, -10, -15, -0.5, -0.5, -0.5, -0.05, -0.05, -0.05, 0.5, 0.5], dtype=float)
ETA_HIGH = np.array([10, 10, 15, 0.5, 0.5, 0.5, 0.05, 0.05, 0.05, 2.0, 2.0], dtype=float)
ETA_NOMINAL = np.array([0, 0, 0, 0, 0, 0, 0, 0, 0, 1.0, 1.0], dtype=float)
# Appendix: initial search standard deviations.
ETA_INIT_STD = np.array([5, 5, 5, 0.25, 0.25, 0.25, 0.02, 0.02, 0.02, 0.10, 0.10], dtype=float)
MIN_STD_FRACTION = 1e-3  # of each range; keeps the search from collapsing to a point


def eta_rotation(eta: np.ndarray) -> np.ndarray:
    """Mounting-offset matrices (N, 3, 3) from eta rows (roll about z/forward, pitch x/left, yaw y/up).

    Extrinsic z, then x, then y: R = R_y(yaw) R_x(pitch) R_z(roll), the same as
    scipy's `Rotation.from_euler("zxy", ..., degrees=True)`, multiplied out because
    the CEM builds 64 of them per iteration and scipy's per-call cost was a fifth of it.
    """
    a = np.deg2rad(np.atleast_2d(np.asarray(eta, dtype=float))[:, 0:3])
    (cz, cx, cy), (sz, sx, sy) = np.cos(a).T, np.sin(a).T
    return np.stack([cy * cz + sy * sx * sz, sy * sx * cz - cy * sz, sy * cx,
                     cx * sz, cx * cz, -sx,
                     cy * sx * sz - sy * cz, sy * sz + cy * sx * cz, cy * cx], axis=-1).reshape(-1, 3, 3)


@dataclass
class CalibrationResult:
    """eta*, the optimized readings and the loss trace."""

    eta: dict[str, float]
    gravity_included: bool  # the target's convention, or the searched one
    readings: np.ndarray  # (T, 6) X_opt in the simulator sensor frame, gravity included
    gravity: np.ndarray  # (T, 3) gravity part of the specific force in the sensor frame
    loss_nominal: float
    loss_final: float
    loss_history: list[float] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            "eta": self.eta,
            "gravity_included": self.gravity_included,
            "loss_nominal": self.loss_nominal,
            "loss_final": self.loss_final,
            "iterations": len(self.loss_history),
        }


def cem_candidates(mean: np.ndarray, std: np.ndarray, low: np.ndarray, high: np.ndarray, n: int,
                   rng: np.random.Generator) -> np.ndarray:
    """One CEM population: n draws of N(mean, std) clipped to [low, high] (N, D)."""
    return np.clip(mean + std * rng.standard_normal((n, len(mean))), low, high)


def cem_update(candidates: np.ndarray, losses: np.ndarray, n_elite: int,
               floor: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The CEM update: (candidates by loss, stable order), the elite's mean and its std (>= floor)."""
    order = np.argsort(losses, kind="stable")
    elite = candidates[order[:n_elite]]
    return order, elite.mean(0), np.maximum(elite.std(0), floor)


class StreamObjective:
    """L_sim of one simulated stream against a D_stat target, for candidate eta rows.

    The segment kinematics are simulated once; each call only re-mixes them
    (`LinearMoments`), in the target's axis convention.
    """

    def __init__(self, kin: SegmentKinematics, target: StatSummary, convention: Convention,
                 base_mounting: np.ndarray | None = None, noise: ImuNoise | None = None) -> None:
        self.base = np.eye(3) if base_mounting is None else np.asarray(base_mounting, dtype=float)
        self.target = target
        self.with_noise = noise is not None
        self.features = reading_features(kin, noise)
        self.moments = LinearMoments.of_sequence(self.features, kin.fs_hz)
        self.to_target = np.kron(np.eye(2), axes_matrix(convention.axes)).T  # aligned = readings @ to_target
        # a signed permutation: aligned channel c is sign[c] x readings channel source[c]
        self.source = np.abs(self.to_target).argmax(axis=0)
        self.sign = self.to_target[self.source, np.arange(6)]

    def weights(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        """(N, F, 6) weights of the aligned readings."""
        return SimInTheLoopCalibrator._weights(self.base, eta, grav, self.with_noise) @ self.to_target

    def channels(self, eta: np.ndarray, grav: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`weights` channel by channel without their zeros (`LinearMoments.summarize_channels`)."""
        cols, features = channel_weights(eta_rotation(eta) @ self.base, eta[:, 3:6], eta[:, 6:9], eta[:, 9],
                                         eta[:, 10], grav, self.with_noise)
        return cols[self.source] * self.sign[:, None, None], features[self.source]

    def __call__(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        return sim_loss(self.moments.summarize_channels(*self.channels(eta, grav)), self.target)

    def mean_acc(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        """(N, 3) mean accelerometer reading of each candidate, in the target's axes."""
        return self.features.mean(axis=0) @ self.weights(eta, grav)[..., :3]


@dataclass(eq=False, repr=False)
class SimInTheLoopCalibrator:
    """Bounded CEM over eta for one sensor stream.

    `search_gravity=True` adds the gravity convention to the search (used when
    the target dataset does not declare it); otherwise the target's convention
    is used as given.
    """

    n_iterations: int = 30
    n_candidates: int = 64
    elite_fraction: float = 0.20
    search_gravity: bool = False

    @staticmethod
    def _weights(base, eta, gravity, with_noise) -> np.ndarray:
        mounting = eta_rotation(eta) @ base
        return fill_weights(mounting, eta[:, 3:6], eta[:, 6:9], eta[:, 9], eta[:, 10], gravity, with_noise)

    def calibrate(
        self,
        kin: SegmentKinematics,
        target: StatSummary,
        convention: Convention,
        rng: np.random.Generator,
        base_mounting: np.ndarray | None = None,
        noise: ImuNoise | None = None,
    ) -> CalibrationResult:
        """Search eta for one stream; returns eta*, X_opt and the loss trace."""
        loss = StreamObjective(kin, target, convention, base_mounting, noise)
        base = loss.base
        n_elite = max(2, int(round(self.elite_fraction * self.n_candidates)))
        mean, std = ETA_NOMINAL.copy(), ETA_INIT_STD.copy()
        p_grav = 0.5 if self.search_gravity else float(convention.gravity_included)
        floor = MIN_STD_FRACTION * (ETA_HIGH - ETA_LOW)

        nominal, nominal_grav = ETA_NOMINAL[None], np.array([convention.gravity_included])
        loss_nominal = float(loss(nominal, nominal_grav)[0])
        best_eta, best_grav, best_loss = nominal[0], bool(nominal_grav[0]), loss_nominal
        history = []
        for _ in range(self.n_iterations):
            eta = cem_candidates(mean, std, ETA_LOW, ETA_HIGH, self.n_candidates, rng)
            if self.search_gravity:
                grav = rng.random(self.n_candidates) < p_grav
            else:
                grav = np.full(self.n_candidates, convention.gravity_included)
            losses = loss(eta, grav)
            order, mean, std = cem_update(eta, losses, n_elite, floor)
            if self.search_gravity:
                p_grav = float(np.clip(grav[order[:n_elite]].mean(), 0.05, 0.95))
            if losses[order[0]] < best_loss:
                best_eta, best_grav, best_loss = eta[order[0]], bool(grav[order[0]]), float(losses[order[0]])
            history.append(best_loss)
        weights = self._weights(base, best_eta[None], np.array([True]), noise is not None)[0]
        readings = loss.features @ weights
        gravity = kin.grav_seg @ (eta_rotation(best_eta[None])[0] @ base).T
        return CalibrationResult(
            eta={name: float(v) for name, v in zip(ETA_NAMES, best_eta, strict=True)},
            gravity_included=best_grav,
            readings=readings,
            gravity=gravity,
            loss_nominal=loss_nominal,
            loss_final=best_loss,
            loss_history=history,
        )
