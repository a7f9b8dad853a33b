"""Motion-level simulation-in-the-loop: per class, fit the motion's free parameters to D_stat.

The sensor-level CEM (`grounding.calibrate`) fits eta for each sample. This
stage runs once per class and fold, before synthesis: a bounded CEM over the
motion's free parameters phi (tempo and amplitude levels within the SMP's
variant range, pelvis pitch and roll posture offsets) scores each candidate
motion of the class's base SMP, simulated at the class's locations with the
nominal mounting and eta = 0, by the same L_sim against the class's D_stat
(`StreamObjective`) plus the angle between the simulated and the real mean
accelerometer direction (the mean gravity direction, where the location
includes gravity). Fields the SMP lists as invariant are never touched, and
tempo / amplitude move only when the SMP lists them as variant fields.

The result is a distribution, not a point: the mean and spread of the best
quarter of all candidates scored. Each sample of the class draws its own phi from N(mean, spread) (spread at
least DRAW_MIN_STD), clipped to the bounds and seeded by the sample, so
variants still vary. A
class with fewer than `MIN_FIT_WINDOWS` D_stat windows (or a source that is
not an SMP, or a backend without motion parameters) keeps the SMP's defaults,
and its fit record says why.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding import floors
from vsmp_imu.grounding.align import Convention
from vsmp_imu.grounding.calibrate import (
    ETA_NOMINAL,
    MIN_STD_FRACTION,
    StreamObjective,
    cem_candidates,
    cem_update,
)
from vsmp_imu.imu import VirtualSensor, simulate_kinematics
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import SMP

PARAMS = ("tempo", "amplitude", "root_pitch_deg", "root_roll_deg")
POSTURE_DOFS = {"root_pitch_deg": "root_pitch", "root_roll_deg": "root_roll"}
LEVEL_RADIUS = 1.0  # tempo / amplitude: +-1 level on the 0..2 scale (the augmenter's range)
POSTURE_RANGE_DEG = 15.0
INIT_STD = np.array([0.5, 0.5, 5.0, 5.0])
# smallest spread a sample's draw uses (a sharp optimum would otherwise make every variant alike)
DRAW_MIN_STD = np.array([0.25, 0.25, 2.0, 2.0])
N_ITERATIONS, N_CANDIDATES, ELITE_FRACTION = 5, 8, 0.25
LAMBDA_GRAVITY = 1.0  # per radian between the mean accelerometer directions
MIN_FIT_WINDOWS = floors.MOTION_FIT.floor  # D_stat windows a class needs (TargetStatistics' per-class floor)
FIT_BACKENDS = ("procedural",)


@dataclass(frozen=True)
class MotionFitJob:
    """One class's fit: its base SMP, locations (with D_stat targets) and real mean accelerations."""

    label: str
    smp_json: str  # empty: the class's source is not an SMP
    backend: str
    library_dirs: tuple[str, ...]
    fs_hz: float
    locations: tuple[Any, ...]  # LocationTask with the class's target
    mean_acc: tuple[tuple[float, float, float] | None, ...]  # per location, target axes (None: no gravity)
    n_windows: int
    seed: int


def bounds(smp: SMP) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(nominal, low, high) of phi; a level the SMP does not list as a variant field stays fixed."""
    variant = set(smp.constraints.variant_fields)
    nominal, low, high = [], [], []
    for name, level in (("tempo", smp.tempo_level()), ("amplitude", smp.amplitude_level())):
        value = 1.0 if level is None else float(level)
        free = name in variant and level is not None
        nominal.append(value)
        low.append(max(0.0, value - LEVEL_RADIUS) if free else value)
        high.append(min(2.0, value + LEVEL_RADIUS) if free else value)
    nominal += [0.0, 0.0]
    low += [-POSTURE_RANGE_DEG] * 2
    high += [POSTURE_RANGE_DEG] * 2
    return np.array(nominal), np.array(low), np.array(high)


def realize(smp: SMP, phi: dict[str, float]) -> tuple[SMP, dict[str, float]]:
    """The SMP with phi's tempo and amplitude levels, and the posture offsets for the backend."""
    d = smp.model_dump(mode="json")
    ea = d["execution_attributes"]
    for name in ("tempo", "amplitude"):
        if name in phi and float(phi[name]) != smp_level(smp, name):
            ea[name] = round(float(phi[name]), 4)
    offsets = {dof: float(phi[p]) for p, dof in POSTURE_DOFS.items() if p in phi}
    return SMP.model_validate(d), offsets


def smp_level(smp: SMP, name: str) -> float:
    level = smp.tempo_level() if name == "tempo" else smp.amplitude_level()
    return 1.0 if level is None else float(level)


def draw(fit: dict[str, Any], seed: int) -> dict[str, float]:
    """A sample's phi: N(mean, spread >= DRAW_MIN_STD), clipped to the bounds, seeded by the sample."""
    mean, low, high = np.array(fit["mean"]), np.array(fit["low"]), np.array(fit["high"])
    std = np.where(high > low, np.maximum(np.array(fit["std"]), DRAW_MIN_STD), 0.0)
    values = np.clip(mean + std * rng_for(seed, "motion-fit").standard_normal(len(mean)), low, high)
    return {name: round(float(v), 4) for name, v in zip(fit["params"], values, strict=True)}


def _fallback(reason: str, n_windows: int) -> dict[str, Any]:
    return {"fitted": False, "reason": reason, "d_stat_windows": n_windows}


class _Objective:
    """phi rows -> loss: the class's base motion with phi, each location's L_sim + gravity angle."""

    def __init__(self, job: MotionFitJob, smp: SMP) -> None:
        from vsmp_imu.pipeline.sample import backend_for

        self.job, self.smp = job, smp
        self.backend = backend_for(job.backend, job.library_dirs)
        self.seed = int(rng_for(job.seed, "motion-fit", job.label).integers(2**31))

    def __call__(self, phis: np.ndarray) -> np.ndarray:
        return np.array([self.one(dict(zip(PARAMS, row, strict=True))) for row in phis])

    def one(self, phi: dict[str, float]) -> float:
        smp, offsets = realize(self.smp, phi)
        motion = self.backend.generate(smp, self.seed, offsets_deg=offsets)
        total = 0.0
        for loc, mean_acc in zip(self.job.locations, self.job.mean_acc, strict=True):
            sensor = VirtualSensor.at(loc.name)
            base = Rotation.from_quat(loc.nominal_mounting_xyzw).as_matrix() @ sensor.mounting_matrix()
            kin = simulate_kinematics(motion, sensor, self.job.fs_hz)
            conv = Convention(**loc.convention)
            objective = StreamObjective(kin, loc.stat_summary(), conv, base)
            grav = np.array([conv.gravity_included])
            total += float(objective(ETA_NOMINAL[None], grav)[0])
            if mean_acc is not None:
                sim = objective.mean_acc(ETA_NOMINAL[None], grav)[0]
                total += LAMBDA_GRAVITY * _angle(sim, np.asarray(mean_acc))
        return total


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    cos = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b) + 1e-12))
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))


def fit_class_motion(job: MotionFitJob) -> dict[str, Any]:
    """The class's phi distribution (JSON-ready), or the reason it keeps the SMP's defaults."""
    if not job.smp_json:
        return _fallback("the class's source is not an SMP", job.n_windows)
    if job.backend not in FIT_BACKENDS:
        return _fallback(f"the {job.backend} backend has no motion parameters", job.n_windows)
    if job.n_windows < MIN_FIT_WINDOWS or any(loc.target is None for loc in job.locations):
        return _fallback(f"{job.n_windows} D_stat window(s), fewer than {MIN_FIT_WINDOWS}", job.n_windows)
    smp = SMP.model_validate_json(job.smp_json)
    nominal, low, high = bounds(smp)
    loss = _Objective(job, smp)
    rng = rng_for(job.seed, "motion-fit-cem", job.label)
    n_elite = max(2, int(round(ELITE_FRACTION * N_CANDIDATES)))
    floor = MIN_STD_FRACTION * (high - low)
    mean, std = nominal.copy(), np.where(high > low, INIT_STD, 0.0)
    seen, scores = [nominal[None]], [loss(nominal[None])]
    elite, elite_loss = seen[0], scores[0]
    for _ in range(N_ITERATIONS):
        phis = cem_candidates(mean, std, low, high, N_CANDIDATES, rng)
        losses = loss(phis)
        # elitist: the last elites (the nominal first) compete with the new candidates, so a
        # population that is all worse than them cannot drag the search away from them
        pool, pool_loss = np.concatenate([elite, phis]), np.concatenate([elite_loss, losses])
        order, mean, std = cem_update(pool, pool_loss, n_elite, floor)
        elite, elite_loss = pool[order[:n_elite]], pool_loss[order[:n_elite]]
        seen.append(phis)
        scores.append(losses)
    phis, losses = np.concatenate(seen), np.concatenate(scores)
    # the kept distribution: the best ELITE_FRACTION of every candidate scored (the last population's
    # two elites alone have collapsed onto a point)
    order, mean, std = cem_update(phis, losses, max(2, int(round(ELITE_FRACTION * len(phis)))), floor)
    return {"fitted": True, "params": list(PARAMS), "mean": _r(mean), "std": _r(std), "low": _r(low),
            "high": _r(high), "nominal": _r(nominal), "best": _r(phis[order[0]]),
            "loss_nominal": round(float(losses[0]), 6), "loss_best": round(float(losses[order[0]]), 6),
            "evaluations": len(phis), "d_stat_windows": job.n_windows}


def _r(values: np.ndarray) -> list[float]:
    return [round(float(v), 6) for v in values]


def fit_text(fit: dict[str, Any] | None) -> str:
    """The fit as the sample task carries it (canonical JSON; empty when not fitted)."""
    return json.dumps(fit, sort_keys=True) if fit and fit.get("fitted") else ""
