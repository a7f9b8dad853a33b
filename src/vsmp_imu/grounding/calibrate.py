"""Simulation-in-the-loop calibration of the residual simulator parameters eta.

Paper, "Simulation-in-the-loop optimization" and appendix
"Simulation-in-the-Loop Optimization": eta = {dR_s, db_a, db_w, k_a, k_w}
(+ the gravity convention when the target does not declare it) is found by a
bounded cross-entropy method (30 iterations, 64 candidates, elite fraction
0.20, initial std 5 deg / 0.25 m/s^2 / 0.02 rad/s / 0.10) minimizing L_sim
against D_stat. The segment kinematics are simulated once; every candidate
only re-mixes them (`vsmp_imu.imu.sensor_readings`), vectorized over the
population, and over the streams of a batch (`calibrate_many`: their CEMs in
lockstep, each with its own generator and its own result).

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
from vsmp_imu.grounding.stats import LinearMoments, MomentsBatch, StatSummary, sim_loss
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
                   rng: np.random.Generator | list[np.random.Generator]) -> np.ndarray:
    """One CEM population: n draws of N(mean, std) clipped to [low, high] (N, D). With a list
    of S generators and mean, std (S, D): S populations (S, N, D), each from its own generator."""
    d = np.shape(mean)[-1]
    z = np.stack([r.standard_normal((n, d)) for r in rng]) if isinstance(rng, list) else \
        rng.standard_normal((n, d))
    return np.clip(np.expand_dims(mean, -2) + np.expand_dims(std, -2) * z, low, high)


def cem_update(candidates: np.ndarray, losses: np.ndarray, n_elite: int,
               floor: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The CEM update: (candidates by loss, stable order), the elite's mean and its std (>= floor).
    Candidates (..., N, D) with losses (..., N): leading axes are populations updated side by side."""
    order = np.argsort(losses, axis=-1, kind="stable")
    elite = np.take_along_axis(candidates, order[..., :n_elite, None], axis=-2)
    return order, elite.mean(axis=-2), np.maximum(elite.std(axis=-2), floor)


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
        self._batch: BatchObjective | None = None  # this stream alone, built when first scored

    def weights(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        """(N, F, 6) weights of the aligned readings."""
        return SimInTheLoopCalibrator._weights(self.base, eta, grav, self.with_noise) @ self.to_target

    def __call__(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        """L_sim of N candidates: eta (N, 11), gravity flags (N,)."""
        if self._batch is None:
            self._batch = BatchObjective([self])
        return self._batch(eta[None], np.asarray(grav)[None])[0]

    def mean_acc(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        """(N, 3) mean accelerometer reading of each candidate, in the target's axes."""
        return self.features.mean(axis=0) @ self.weights(eta, grav)[..., :3]


@dataclass
class CemProblem:
    """One stream for `SimInTheLoopCalibrator.calibrate_many`: the arguments of `calibrate`."""

    kin: SegmentKinematics
    target: StatSummary
    convention: Convention
    rng: np.random.Generator
    base_mounting: np.ndarray | None = None
    noise: ImuNoise | None = None


class BatchObjective:
    """L_sim of the candidates of S streams on the same features (each a `StreamObjective`),
    scored together: eta (S, N, 11) and gravity flags (S, N) give losses (S, N), the values
    each stream's own objective gives."""

    def __init__(self, objectives: list[StreamObjective]) -> None:
        self.moments = MomentsBatch([o.moments for o in objectives])
        self.base = np.stack([o.base for o in objectives])[:, None]  # (S, 1, 3, 3)
        self.source = np.stack([o.source for o in objectives])  # (S, 6)
        self.sign = np.stack([o.sign for o in objectives])[:, :, None, None]
        self.with_noise = objectives[0].with_noise
        self.target = StatSummary(*(np.stack([getattr(o.target, f) for o in objectives])[:, None]
                                    for f in ("cov", "psd", "norms", "acf")))

    def __call__(self, eta: np.ndarray, grav: np.ndarray) -> np.ndarray:
        s, n = grav.shape
        flat = eta.reshape(s * n, -1)
        mounting = (eta_rotation(flat).reshape(s, n, 3, 3) @ self.base).reshape(s * n, 3, 3)
        cols, features = channel_weights(mounting, flat[:, 3:6], flat[:, 6:9], flat[:, 9], flat[:, 10],
                                         grav.reshape(-1), self.with_noise)
        cols = cols.reshape(6, s, n, -1).transpose(1, 0, 2, 3)[np.arange(s)[:, None], self.source] * self.sign
        summary = self.moments.summarize_channels(cols, features[self.source])
        return np.reshape(sim_loss(summary, self.target), (s, n))


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
        return self.calibrate_many([CemProblem(kin, target, convention, rng, base_mounting, noise)])[0]

    def calibrate_many(self, problems: list[CemProblem]) -> list[CalibrationResult]:
        """`calibrate` for several streams in lockstep. Each draws from its own generator in the
        order it would alone and gets the same result; the candidates of all of them are scored
        together (one product per statistic, `BatchObjective`), which costs less than scoring
        each stream's candidates apart when there are many small arrays."""
        objectives = [StreamObjective(p.kin, p.target, p.convention, p.base_mounting, p.noise) for p in problems]
        results: list[CalibrationResult | None] = [None] * len(problems)
        for with_noise in (True, False):  # streams on the same features are scored together
            idx = [i for i, o in enumerate(objectives) if o.with_noise is with_noise]
            if idx:
                done = self._lockstep([problems[i] for i in idx], [objectives[i] for i in idx])
                for i, result in zip(idx, done, strict=True):
                    results[i] = result
        return results

    def _lockstep(self, problems: list[CemProblem], objectives: list[StreamObjective]) -> list[CalibrationResult]:
        """The bounded CEM of each stream, its iterations side by side."""
        loss = BatchObjective(objectives)
        s, n = len(problems), self.n_candidates
        rows = np.arange(s)
        n_elite = max(2, int(round(self.elite_fraction * n)))
        floor = MIN_STD_FRACTION * (ETA_HIGH - ETA_LOW)
        declared = np.array([p.convention.gravity_included for p in problems], dtype=bool)
        mean, std = np.tile(ETA_NOMINAL, (s, 1)), np.tile(ETA_INIT_STD, (s, 1))
        p_grav = np.full(s, 0.5) if self.search_gravity else declared.astype(float)
        loss_nominal = loss(np.tile(ETA_NOMINAL, (s, 1, 1)), declared[:, None])[:, 0]
        best_eta, best_grav, best_loss = np.tile(ETA_NOMINAL, (s, 1)), declared.copy(), loss_nominal.copy()
        history = np.empty((s, self.n_iterations))
        for it in range(self.n_iterations):
            eta = cem_candidates(mean, std, ETA_LOW, ETA_HIGH, n, [p.rng for p in problems])
            if self.search_gravity:
                grav = np.stack([p.rng.random(n) < p_grav[i] for i, p in enumerate(problems)])
            else:
                grav = np.repeat(declared[:, None], n, axis=1)
            losses = loss(eta, grav)
            order, mean, std = cem_update(eta, losses, n_elite, floor)
            if self.search_gravity:
                p_grav = np.clip(grav[rows[:, None], order[:, :n_elite]].mean(axis=1), 0.05, 0.95)
            top = order[:, 0]
            better = losses[rows, top] < best_loss
            best_eta = np.where(better[:, None], eta[rows, top], best_eta)
            best_grav = np.where(better, grav[rows, top], best_grav)
            best_loss = np.where(better, losses[rows, top], best_loss)
            history[:, it] = best_loss
        return [self._result(o, p, best_eta[i], bool(best_grav[i]), float(loss_nominal[i]), history[i].tolist(),
                             float(best_loss[i]))
                for i, (o, p) in enumerate(zip(objectives, problems, strict=True))]

    def _result(self, objective: StreamObjective, problem: CemProblem, eta: np.ndarray, grav: bool,
                loss_nominal: float, history: list[float], loss_final: float) -> CalibrationResult:
        """X_opt of the best eta (gravity included, plus the sensor-frame gravity) and the trace."""
        weights = self._weights(objective.base, eta[None], np.array([True]), objective.with_noise)[0]
        return CalibrationResult(
            eta={name: float(v) for name, v in zip(ETA_NAMES, eta, strict=True)},
            gravity_included=grav,
            readings=objective.features @ weights,
            gravity=problem.kin.grav_seg @ (eta_rotation(eta[None])[0] @ objective.base).T,
            loss_nominal=loss_nominal,
            loss_final=loss_final,
            loss_history=history,
        )
