"""Does a motion backend realize the SMP controls? Matched interventions and their measurements.

The protocol of the paper's "End-to-End SMP Controllability Protocol" at the
motion level: for an activity and a seed, one SMP field changes at a time
(`vsmp_imu.smp.intervene`), the backend generates a motion per level with the
same seed, and `measure` reads the realized value. Summaries give the
paper's numbers: Spearman rho between requested level and measured value,
ordering compliance of matched triplets, repetitions within +-1, primitive
duration MAPE, symmetry accuracy. Plausibility checks follow the quality
filter's motion rules (finite, no frame-to-frame jump above 0.20 x body
height) plus floor contact and constant bone lengths.

Primitive duration: the central primitive is the one the library entry
names (`central_primitive`: the release of a throw, the forward extension of
a push, ...); the `duration` intervention multiplies its value in
`primitive_durations.values` by the factor and the others keep theirs.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.stats import spearmanr

from vsmp_imu.motion import measure
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.recipe import recipe_for_entry
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.schema import SMP

TEMPO_LEVELS = ("slow", "medium", "fast")
AMPLITUDE_LEVELS = ("small", "medium", "large")
REPETITION_LEVELS = (3, 6, 9)
DURATION_LEVELS = (0.75, 1.0, 1.25)
SYMMETRY_LEVELS = ("symmetric", "asymmetric")
MAX_STEP_FRACTION = 0.20  # quality filter: max frame-to-frame joint displacement / body height
FLOOR_TOLERANCE_M = 0.03


@dataclass(frozen=True)
class Case:
    """One generated motion of a matched intervention set."""

    activity: str
    attribute: str
    level: Any
    seed: int
    measured: float


def joints_of(entry: Any) -> dict[str, list[str]]:
    """Measurement joints of an activity from its recipe: principal, symmetry, duration."""
    recipe = recipe_for_entry(entry)
    return {
        "principal": list(recipe.principal_joints),
        "symmetry": list(recipe.symmetry_joints or recipe.principal_joints),
        "duration": list(recipe.duration_joints or recipe.principal_joints),
    }


def _variant(entry: Any, attribute: str, level: Any) -> SMP:
    return intervene(entry.smp, attribute, level, entry.central_primitive)


def _measure(motion: Motion, attribute: str, joints: dict[str, list[str]], periodic: bool) -> float:
    if attribute == "tempo":
        return measure.tempo_measure(motion, joints["principal"], periodic)
    if attribute == "amplitude":
        return measure.range_of_motion(motion, joints["principal"])
    if attribute == "repetitions":
        return float(measure.count_repetitions(motion, joints["principal"]).count)
    if attribute == "duration":
        return measure.phase_duration(motion, joints["duration"]).duration_s
    if attribute == "symmetry":
        return measure.symmetry_score(motion, joints["symmetry"])
    raise ValueError(f"unknown attribute {attribute}")


LEVELS = {"tempo": TEMPO_LEVELS, "amplitude": AMPLITUDE_LEVELS, "repetitions": REPETITION_LEVELS,
          "duration": DURATION_LEVELS, "symmetry": SYMMETRY_LEVELS}


def run_cases(backend: Any, library: Any, activities: Iterable[str], attribute: str,
              seeds: Sequence[int], levels: Sequence[Any] | None = None) -> list[Case]:
    """Generate and measure every (activity, level, seed) of one attribute."""
    cases = []
    for name in activities:
        entry = library.get(name)
        joints = joints_of(entry)
        periodic = recipe_for_entry(entry).kind == "periodic"
        for level in levels or LEVELS[attribute]:
            smp = _variant(entry, attribute, level)
            for seed in seeds:
                motion = backend.generate(smp, seed=seed)
                cases.append(Case(entry.name, attribute, level, seed,
                                  _measure(motion, attribute, joints, periodic)))
    return cases


def _rank(level: Any, attribute: str) -> float:
    levels = LEVELS[attribute]
    return float(levels.index(level)) if level in levels else float(level)


def _groups(cases: Sequence[Case]) -> dict[tuple[str, int], list[Case]]:
    groups: dict[tuple[str, int], list[Case]] = {}
    for c in cases:
        groups.setdefault((c.activity, c.seed), []).append(c)
    return groups


def spearman(cases: Sequence[Case]) -> float:
    """Spearman rho between requested level and measured value in each matched (activity, seed)
    set, averaged over the sets (a set whose measurements are all equal counts 0)."""
    rhos = []
    for group in _groups(cases).values():
        x = [_rank(c.level, c.attribute) for c in group]
        y = [c.measured for c in group]
        finite = np.isfinite(y).all()
        rhos.append(float(spearmanr(x, y).statistic) if finite and len(set(y)) > 1 else 0.0)
    return float(np.mean(rhos)) if rhos else float("nan")


def pooled_spearman(cases: Sequence[Case]) -> float:
    """Spearman rho over all motions of each activity (levels x seeds), averaged over activities.

    With several seeds per level the tied levels cap it below 1 (0.945 for 3 levels x 5 seeds
    even when every measurement is perfectly ordered).
    """
    rhos = []
    for name in sorted({c.activity for c in cases}):
        sub = [c for c in cases if c.activity == name]
        y = [c.measured for c in sub]
        ok = np.isfinite(y).all() and len(set(y)) > 1
        rhos.append(float(spearmanr([_rank(c.level, c.attribute) for c in sub], y).statistic) if ok else 0.0)
    return float(np.mean(rhos)) if rhos else float("nan")


def ordering_compliance(cases: Sequence[Case]) -> float:
    """Fraction of matched (activity, seed) groups whose measurements increase with the level."""
    groups = _groups(cases)
    ok = 0
    for group in groups.values():
        values = [c.measured for c in sorted(group, key=lambda c: _rank(c.level, c.attribute))]
        ok += all(b > a for a, b in zip(values, values[1:], strict=False))
    return ok / len(groups) if groups else float("nan")


def within_one(cases: Sequence[Case]) -> float:
    """Fraction of repetition cases within +-1 of the requested count."""
    return float(np.mean([abs(c.measured - float(c.level)) <= 1 for c in cases]))


def duration_mape(cases: Sequence[Case]) -> float:
    """Mean absolute percentage error of measured duration ratios (vs the 1.00 level) to the factors."""
    ref = {(c.activity, c.seed): c.measured for c in cases if float(c.level) == 1.0}
    errors = []
    for c in cases:
        base = ref.get((c.activity, c.seed))
        if base and float(c.level) != 1.0:
            errors.append(abs(c.measured / base - float(c.level)) / float(c.level))
    return float(np.mean(errors)) if errors else float("nan")


def symmetry_accuracy(cases: Sequence[Case], threshold: float = measure.SYMMETRY_THRESHOLD) -> float:
    """Fraction of symmetry requests classified correctly with C_sym."""
    return float(np.mean([measure.classify_symmetry(c.measured, threshold) == c.level for c in cases]))


def plausibility(motion: Motion) -> dict[str, float]:
    """finite (1/0), lowest foot joint height (m), largest frame step / body height, bone-length spread (m)."""
    names = motion.joint_names
    feet = [names.index(n) for n in ("left_foot", "right_foot", "left_ankle", "right_ankle") if n in names]
    step = np.linalg.norm(np.diff(motion.positions, axis=0), axis=-1).max() if motion.n_frames > 1 else 0.0
    bones = [np.linalg.norm(motion.positions[:, j] - motion.positions[:, p], axis=-1)
             for j, p in enumerate(motion.parents) if p >= 0]
    spread = max(float(np.ptp(b)) for b in bones) if bones else 0.0
    return {
        "finite": float(motion.is_finite()),
        "min_foot_y_m": float(motion.positions[:, feet, 1].min()) if feet else float("nan"),
        "max_step_fraction": float(step / motion.body_height_m()),
        "bone_spread_m": spread,
    }


def is_plausible(motion: Motion) -> bool:
    """All plausibility rules hold."""
    p = plausibility(motion)
    return bool(p["finite"] == 1.0 and p["min_foot_y_m"] >= -FLOOR_TOLERANCE_M
                and p["max_step_fraction"] <= MAX_STEP_FRACTION and p["bone_spread_m"] < 1e-6)
