"""Algorithm 1 for one LOPO fold: from base SMPs to the filtered synthetic set.

Everything fitted here (D_stat, D_rank, the texture ratios, plausibility
thresholds, the validator, tau_cls, tau_nn) comes from the fold's real training windows
only; the held-out subject is never passed in.

Stages:
1. stratified D_stat / D_rank split of the real training windows;
2. per class, K constrained SMP variants S(k) ~ A(S) of each base SMP, each
   realized with its own seed (as many slots as the budget needs); with
   `event_durations`, every other round of a discrete event's variants timed to
   one of its class's real events (grounding.durations);
3. per sample (executor, cached): verbalize, motion, theta ~ p(theta),
   kinematics, eta* by CEM against the class's D_stat, A_gamma; alongside,
   from the fold's start (`executor.start`: one worker of the pool the rounds
   share), one executor job fits the filter's real-data models (plausibility
   thresholds, validator, tau_nn);
4. movement texture (the 3-12 Hz content a smooth motion lacks, by ratios
   fitted on D_stat), then rank grounding per location with F_v from all the
   fold's synthetic samples and G_r from D_rank;
5. windows, then the quality filter (motion plausibility, class faithfulness
   with tau_cls chosen by validation Macro-F1, redundancy); with
   `event_durations`, per such class its timed windows, its untimed ones or
   both, by a synthetic-only forest scored on the real training windows;
6. the per-class budget taken from the retained windows;
7. with `unseen_intensity`, an intensity factor for each selected window of a
   class without real training windows (grounding.intensity);
8. with `seen_intensity`, an intensity factor for each selected window of a
   class with real training windows, so that the windows' spread of intensity
   is as wide as the real windows' (grounding.intensity).
"""

from __future__ import annotations

import hashlib
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from sklearn.ensemble import RandomForestClassifier
from threadpoolctl import threadpool_limits

from vsmp_imu.errors import ValidationError, VsmpError
from vsmp_imu.executor import Started
from vsmp_imu.filtering.faithfulness import (
    TAU_DEFAULT,
    class_verdicts,
    macro_f1,
    nn_thresholds,
    redundancy_verdicts,
    select_tau,
)
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter
from vsmp_imu.filtering.validator import HarValidator
from vsmp_imu.filtering.verdict import Verdict
from vsmp_imu.grounding import cadence, floors
from vsmp_imu.grounding.align import Convention, axes_matrix
from vsmp_imu.grounding.durations import draw_duration, event_durations, window_hop
from vsmp_imu.grounding.durations import summary as duration_summary
from vsmp_imu.grounding.intensity import (
    match_factors,
    missing_spread,
    scale_deviations,
    spread_channels,
    spread_intensity,
)
from vsmp_imu.grounding.levels import LevelMap
from vsmp_imu.grounding.mounting import estimate_mounting, mounting_classes
from vsmp_imu.grounding.rank import RankGrounder
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.grounding.stats import TargetStatistics
from vsmp_imu.grounding.texture import TextureModel
from vsmp_imu.har.dataset import DatasetInfo, SensorLocation
from vsmp_imu.har.features import ecdf_features
from vsmp_imu.har.synthetic import take_budget
from vsmp_imu.har.windows import Windows
from vsmp_imu.imu import simulate_kinematics
from vsmp_imu.motion import Motion
from vsmp_imu.pipeline.motionfit import MotionFitJob, fit_class_motion, fit_text
from vsmp_imu.pipeline.records import Provenance, WindowRecord
from vsmp_imu.pipeline.sample import (
    LocationTask,
    SampleResult,
    SampleTask,
    backend_for,
    cached_synthesize,
    cached_synthesize_many,
)
from vsmp_imu.pipeline.side import (
    SIDES,
    SideEvidence,
    mean_rates,
    probe_seed,
    side_is_free,
    with_side,
)
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import SMP
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.refine import Refiner
from vsmp_imu.smp.verbalize import verbalize

MAX_SLOTS_PER_CLASS_ROUND = 96
REFILL_MAX_SAMPLES = 2048  # new samples per class and refill pass
# What a class's samples are made from: an SMP (augmented), a free-text prompt, or a recorded motion.
Base = SMP | str | Path
FIRST_ROUND_WINDOWS_PER_SAMPLE = 3.0


@dataclass
class FoldOutput:
    """The synthetic windows of one fold and the record of every generated window."""

    windows: Windows  # the selected windows (the budget)
    generated: np.ndarray  # every generated window, (N, T, C); records[:N] describe them
    records: list[WindowRecord] = field(default_factory=list)
    samples: list[SampleResult] = field(default_factory=list)
    tasks: list[SampleTask] = field(default_factory=list)
    summary: dict[str, Any] = field(default_factory=dict)


def location_plan(info: DatasetInfo) -> dict[str, list[SensorLocation]]:
    """Locations a class's samples are simulated at (UTD-MHAD moves the sensor per class)."""
    for loc in info.locations:
        if len(loc.channels) != 6:
            raise ValidationError(
                f"location '{loc.name}' has {len(loc.channels)} channels; synthesis needs acc + gyro (6)",
                field="locations")
    by_name = {loc.name: loc for loc in info.locations}
    plan = {}
    for label in info.label_names:
        if info.location_by_label and label in info.location_by_label:
            plan[label] = [by_name[info.location_by_label[label]]]
        else:
            plan[label] = list(info.locations)
    return plan


def _convention(loc: SensorLocation) -> tuple[dict[str, Any], bool]:
    axes = loc.axes or ("left", "up", "forward")
    conv = Convention(axes=tuple(axes), gravity_included=loc.gravity_included)
    return conv.as_dict(), loc.axes is not None


def channel_index(info: DatasetInfo, loc: SensorLocation) -> np.ndarray:
    return np.array([info.channel_names.index(c) for c in loc.channels])


def worn_windows(info: DatasetInfo, loc: SensorLocation, d_rank: Windows, plan) -> Windows:
    """D_rank's windows of the classes whose samples are worn at `loc` (the plan's locations)."""
    classes = [i for i, n in enumerate(info.label_names) if loc in plan[n]]
    return d_rank[np.isin(d_rank.y, classes)]


def fit_rank_grounders(info: DatasetInfo, samples: list[SampleResult], d_rank: Windows, plan,
                       spec: GenerationSpec, threads: int = 1,
                       unseen: frozenset[int] = frozenset()) -> dict[str, RankGrounder]:
    """Stage 4's rank grounders, one per location: F_v from the samples' signals there, G_r from
    D_rank's windows of the classes worn there (pooled or per class as `spec` says). Locations no
    sample uses, or without any real window, get none. `unseen`: the classes with no real training
    window, left as they are. `threads` fit the channels side by side (same result)."""
    grounders = {}
    for loc in info.locations:
        users = [r for r in samples if loc.name in r.signals]
        if not users:
            continue
        real = worn_windows(info, loc, d_rank, plan)
        if len(real) == 0:
            continue
        cols = channel_index(info, loc)
        syn = np.concatenate([r.signals[loc.name] for r in users])
        labels = np.concatenate([np.full(len(r.signals[loc.name]), r.label_index) for r in users])
        grounders[loc.name] = RankGrounder(per_class=spec.per_class_rank, threads=threads).fit(
            syn, real.X[..., cols].astype(np.float64), labels, real.y, unseen=unseen)
    return grounders


def _summary_lists(summary) -> dict[str, list]:
    return {k: getattr(summary, k).tolist() for k in ("cov", "psd", "norms", "acf")}


@dataclass(frozen=True)
class FilterJob:
    """What the quality filter learns from the fold's real training windows: the plausibility
    thresholds per location, the validator (on the ECDF features of the non-validation
    subjects) and tau_nn. It is handed to the executor with the first synthesis round, so a
    worker fits it while the others synthesize (with one worker it simply runs first)."""

    windows: dict[str, np.ndarray]  # real training windows per location
    labels: np.ndarray
    features: np.ndarray | None  # ECDF features of all training windows (None: no learned filters)
    is_val: np.ndarray
    n_classes: int
    seed: int
    min_class_windows: int

    def validated(self) -> np.ndarray:
        """Per class: whether the validator trains on enough of its real windows to judge it."""
        return np.bincount(self.labels[~self.is_val], minlength=self.n_classes) >= self.min_class_windows


@dataclass
class FilterModels:
    plausibility: dict[str, MotionPlausibilityFilter]
    validator: HarValidator | None = None
    nn_thresholds: dict[int, float] | None = None


def fit_filters(job: FilterJob) -> FilterModels:
    # one BLAS thread wherever it runs (driver or worker): the same arithmetic, the same bytes
    with threadpool_limits(1):
        plausibility = {name: MotionPlausibilityFilter().fit(w, job.labels) for name, w in job.windows.items()}
        if job.features is None:
            return FilterModels(plausibility)
        fit = ~job.is_val
        validator = HarValidator(seed=job.seed).fit_features(job.features[fit], job.labels[fit],
                                                             n_classes=job.n_classes)
        thresholds = nn_thresholds(validator.embed_features(job.features), job.labels, job.min_class_windows)
        return FilterModels(plausibility, validator, thresholds)


def make_filter_job(info: DatasetInfo, train: Windows, seed: int, fold: str, val_fraction: float,
                    min_class_windows: int, learned: bool = True) -> FilterJob:
    """The filter job of one fold's real training windows (`learned`: with the validator and tau_nn)."""
    return FilterJob(
        windows={loc.name: train.X[..., channel_index(info, loc)] for loc in info.locations},
        labels=train.y,
        features=ecdf_features(train.X) if learned else None,
        is_val=_validation_mask(train, val_fraction, seed, fold),
        n_classes=info.n_classes,
        seed=int(rng_for(seed, fold, "validator").integers(2**31)),
        min_class_windows=min_class_windows,
    )


def start_filter_job(executor, job: FilterJob | None, fold: str):
    """The filter job begun on `executor` (its `start`, so that it runs beside the fold's own steps
    and the synthesis; an executor with only `map` runs it now); None without a job."""
    if job is None:
        return None
    desc = f"fold {fold}: fitting the quality filter's models"
    start = getattr(executor, "start", None)
    return start(run_item, job, desc) if start is not None else Started(value=executor.map(run_item, [job], desc)[0])


# samples per executor item: their CEMs run in lockstep (`synthesize_many`), which costs less per
# sample than one at a time; each sample's result is its own, whatever its neighbours
SAMPLES_PER_ITEM = 16


def run_item(item):
    """One executor item: a (SampleTask, cache folder) pair, a (tuple of SampleTasks, cache
    folder) pair (their results as a list), or the filter job."""
    if isinstance(item, FilterJob):
        return fit_filters(item)
    if isinstance(item[0], tuple):
        return cached_synthesize_many(*item)
    return cached_synthesize(item)


def sample_items(tasks: list[SampleTask], cache: str | None,
                 workers: int = 1) -> list[tuple[tuple[SampleTask, ...], str | None]]:
    """The executor items of `tasks`: consecutive runs of up to SAMPLES_PER_ITEM, shorter towards
    the end (the remaining tasks over 4 items per worker) so the workers' last items end close
    together. The results do not depend on the cut."""
    out, start = [], 0
    while start < len(tasks):
        size = max(1, min(SAMPLES_PER_ITEM, -(-(len(tasks) - start) // (4 * max(1, workers)))))
        out.append((tuple(tasks[start:start + size]), cache))
        start += size
    return out


# -- stage 1: prepare ------------------------------------------------------------------------------
@dataclass(frozen=True)
class FoldSetup:
    """What the fold's real training windows give the samples: the D_stat / D_rank split, the
    locations each class is simulated at and, per class, its location tasks (convention,
    D_stat target, nominal mounting)."""

    plan: dict[str, list[SensorLocation]]
    d_stat: Windows
    d_rank: Windows
    locations: dict[str, tuple[LocationTask, ...]]
    nominal_sensor: tuple[str, ...] = ()  # classes that keep the nominal sensor (`unseen_postures`)


def target_statistics(info: DatasetInfo, d_stat: Windows, threads: int = 1) -> dict[str, TargetStatistics]:
    """D_stat's per-class statistics at every location."""
    return {loc.name: TargetStatistics(info.fs_hz).fit(d_stat.X[..., channel_index(info, loc)].astype(np.float64),
                                                       d_stat.y, threads)
            for loc in info.locations}


def nominal_mountings(spec: GenerationSpec, info: DatasetInfo, plan, sources, d_stat: Windows) -> dict[str, tuple]:
    """R_target per location from one default execution per class vs the real class means.

    Only the classes that hold a posture or repeat a rhythm count where at least two of them have
    evidence: a single execution's mean (a transition's) depends on how long each of its phases
    lasts, so a change to its timing would turn every class's sensor (docs/scale.md)."""
    out: dict[str, tuple] = {}
    motions: dict[str, Motion] = {}
    for loc in info.locations:
        identity = (0.0, 0.0, 0.0, 1.0)
        if not (spec.estimate_mounting and loc.gravity_included and loc.axes):
            out[loc.name] = identity
            continue
        cols = channel_index(info, loc)
        to_segment = axes_matrix(loc.axes).T  # device axes -> segment frame
        means = []  # (single execution, synthetic mean, real mean, weight) per class with evidence
        for i, label in enumerate(info.label_names):
            mask = d_stat.y == i
            if label not in sources or loc not in plan[label] or not floors.MOUNTING.met(int(mask.sum())):
                continue
            if label not in motions:
                base = sources[label][0][1]
                motions[label] = Motion.load(base) if isinstance(base, Path) else \
                    backend_for(spec.backend, tuple(spec.library_dirs)).generate(base, 0)
            kin = simulate_kinematics(motions[label], loc.name, info.fs_hz)
            means.append((motions[label].single_execution, kin.specific_force_seg().mean(axis=0),
                          to_segment @ d_stat.X[mask][..., cols[:3]].reshape(-1, 3).mean(axis=0), mask.sum()))
        used = mounting_classes(means, lambda m: m[0])
        rot, _ = estimate_mounting(*(np.array([m[k] for m in used], dtype=float) for k in (1, 2, 3))) \
            if len(used) >= 2 else (None, None)
        out[loc.name] = identity if rot is None else tuple(float(v) for v in rot.as_quat())
    return out


def location_tasks(spec: GenerationSpec, info: DatasetInfo, plan, stats: dict[str, TargetStatistics],
                   mountings: dict[str, tuple], nominal: frozenset[str] = frozenset()
                   ) -> dict[str, tuple[LocationTask, ...]]:
    """Per class, the location tasks of its samples (the D_stat target only with sim-in-the-loop;
    none for the classes in `nominal`, which keep the nominal sensor)."""
    out = {}
    for label, locs in plan.items():
        tasks = []
        for loc in locs:
            conv, declared = _convention(loc)
            target = None
            if spec.sim_in_the_loop and loc.name in stats and label not in nominal:
                target = _class_target(spec, stats[loc.name], info.label_names.index(label))
            tasks.append(LocationTask(loc.name, conv, declared, target, mountings[loc.name]))
        out[label] = tuple(tasks)
    return out


def _class_target(spec: GenerationSpec, stats: TargetStatistics, label_index: int) -> dict | None:
    """The class's D_stat summary; the pooled one for a class without its own, or None (eta
    nominal) for such a class when the spec turns pooled calibration off."""
    if label_index not in stats.per_class_ and not spec.pooled_calibration:
        return None
    return _summary_lists(stats.for_class(label_index))


def unseen_postures(spec: GenerationSpec, info: DatasetInfo, train: Windows, sources) -> frozenset[str]:
    """The classes that keep the nominal sensor: with `nominal_unseen_postures`, each class without a
    real training window whose SMP holds a posture (temporal_structure.periodicity "none"). The
    pooled statistics of the other classes, full of motion, would give a still posture motion's
    sensor noise and biases, and its mounting offsets, unconstrained by a still signal, would tilt it
    (docs/results.md, "An unseen posture keeps the nominal sensor")."""
    if not (spec.nominal_unseen_postures and spec.sim_in_the_loop):
        return frozenset()
    counts = train.class_counts()
    return frozenset(label for i, label in enumerate(info.label_names)
                     if counts[i] == 0 and holds_posture(sources, label))


def prepare(spec: GenerationSpec, info: DatasetInfo, train: Windows, sources, seed: int,
            threads: int = 1) -> FoldSetup:
    """Stage 1: split D_stat / D_rank, fit D_stat's statistics, estimate the nominal mountings."""
    plan = location_plan(info)
    stat_idx, rank_idx = stat_rank_split(train.y, seed)
    d_stat, d_rank = train[stat_idx], train[rank_idx]
    stats = target_statistics(info, d_stat, threads)
    mountings = nominal_mountings(spec, info, plan, sources, d_stat)
    nominal = unseen_postures(spec, info, train, sources)
    return FoldSetup(plan, d_stat, d_rank, location_tasks(spec, info, plan, stats, mountings, nominal),
                     tuple(sorted(nominal)))


# -- stage 2: the sample tasks ---------------------------------------------------------------------
def smp_variants(spec: GenerationSpec, base: Base, seed: int, key: str, k: int,
                 library=None) -> list[tuple[int, Base]]:
    """`k` constrained variants of an SMP; a prompt or a recorded motion is used as is."""
    if not isinstance(base, SMP):
        return [(0, base)]
    smp = Refiner(library).refine(base).smp if spec.refine else base
    augmenter = SMPAugmenter(uncertainty_conditioned=spec.uncertainty_conditioned)
    return list(enumerate(augmenter.augment(smp, k, int(rng_for(seed, key).integers(2**31)))))


def sample_tasks(spec: GenerationSpec, label: str, label_index: int, bases: list[tuple[str, Base]], slots: range,
                 seed: int, fold: str, fs_hz: float, locations: tuple[LocationTask, ...], library=None,
                 motion_dir: Path | None = None, motion_fit: str = "",
                 class_windows: int | None = None, texture: dict | None = None,
                 events: tuple[np.ndarray, float] | None = None,
                 rates: tuple[np.ndarray, frozenset[str]] | None = None) -> list[SampleTask]:
    """The SampleTasks of a class's generation slots (slot s uses variant s mod the variants, and with
    `events` rounds of the variants alternate between timed to a real event and the SMP's timing);
    `class_windows`: the class's real training windows in the fold, kept in the provenance (0: the
    class gets `spec.k_unseen` variants per base SMP); `texture`: what the worker needs to add the
    movement texture (`texture_task`); `events`: the class's real event durations and the hop in
    seconds (`class_events`), one drawn per sample of a discrete SMP; `rates`: the class's real step
    rates and its gait sources (`class_cadences`), one rate drawn per sample of those sources."""
    k = spec.variants_for(class_windows)
    variants = [(src, i, v) for src, base in bases
                for i, v in smp_variants(spec, base, seed, f"{fold}/{label}/{src}", k, library)]
    tasks = []
    for slot in slots:
        src, i, base = variants[slot % len(variants)]
        event = None
        # every other round of the variants is timed, so each variant is made both ways
        timed = (slot // len(variants)) % 2 == 0
        if events is not None and timed and isinstance(base, SMP) and is_discrete(base):
            event = draw_duration(events[0], events[1], rng_for(seed, fold, label, slot, "event-duration"))
        rate = None
        if rates is not None and src in rates[1]:
            rate = cadence.draw_rate(rates[0], rng_for(seed, fold, label, slot, "cadence"))
        tasks.append(SampleTask(
            key=f"{fold}/{label}/{slot:04d}", label=label, label_index=label_index, source=src,
            variant=i, **_payload(base),
            backend=spec.backend, seed=int(rng_for(seed, fold, label, slot).integers(2**31)),
            fs_hz=fs_hz, locations=locations, sim_in_the_loop=spec.sim_in_the_loop,
            noise=spec.noise, duration_s=spec.duration_s, library_dirs=tuple(spec.library_dirs),
            motion_dir=str(motion_dir) if motion_dir else None, motion_fit=motion_fit,
            class_windows=class_windows, texture=texture, event_duration_s=event, cadence_hz=rate,
        ))
    return tasks


def holds_posture(sources, label: str) -> bool:
    """Whether the class's first source is an SMP that holds a posture (sitting, standing, lying):
    its periodicity is "none"."""
    return bool(sources.get(label)) and isinstance(base := sources[label][0][1], SMP) \
        and base.temporal_structure.periodicity == "none"


def is_discrete(smp: SMP) -> bool:
    """A single event (a transition, one gesture), not a held posture or a repeated cycle."""
    ts = smp.temporal_structure
    return ts.periodicity == "single" and not ts.is_repetitive


def class_events(spec: GenerationSpec, info: DatasetInfo, train: Windows, sources,
                 budget: np.ndarray) -> tuple[dict[str, tuple[np.ndarray, float]], dict[str, dict]]:
    """With `spec.event_durations` and the procedural backend, per class with a budget and a discrete
    base SMP its real event durations (grounding.durations) and the real windows' hop in seconds; and
    per such class what was found."""
    if not spec.event_durations or spec.backend != "procedural":
        return {}, {}
    labels = [label for c, label in enumerate(info.label_names) if budget[c] > 0 and label in sources
              and any(isinstance(base, SMP) and is_discrete(base) for _, base in sources[label])]
    hop, length, shares = window_hop(train), train.n_timesteps, info.share_vector()
    events, found = {}, {}
    for label in labels:
        c = info.label_names.index(label)
        if hop is None:
            seconds, reason = np.zeros(0), "the real windows carry no recording and start"
        else:
            seconds, reason = event_durations(train, c, hop, length, float(shares[c]), info.fs_hz)
        found[label] = duration_summary(seconds, reason)
        if len(seconds):
            events[label] = (seconds, hop / info.fs_hz)
    return events, found


def is_gait(spec: GenerationSpec, smp: SMP) -> bool:
    """A cyclic SMP whose procedural motion walks (its recipe's locomotion is not "none")."""
    if smp.temporal_structure.periodicity != "cyclic":
        return False
    try:
        plan = backend_for(spec.backend, tuple(spec.library_dirs)).plan(smp, 0)
    except VsmpError:
        return False  # the samples report it
    return plan.recipe.locomotion != "none"


def class_cadences(spec: GenerationSpec, info: DatasetInfo, train: Windows, sources, budget: np.ndarray,
                   plan) -> tuple[dict[str, tuple[np.ndarray, frozenset[str]]], dict[str, dict]]:
    """With `spec.cadence` and the procedural backend, per class with a budget and a gait base SMP
    its real windows' step rates (grounding.cadence, from the accelerometer at its trunk location if
    it has one, else at its first) and the sources of its gait base SMPs (a class's other cyclic
    bases keep their tempo); and per such class what was found."""
    if not spec.cadence or spec.backend != "procedural":
        return {}, {}
    rates, found = {}, {}
    for c, label in enumerate(info.label_names):
        if budget[c] <= 0 or label not in sources:
            continue
        gaits = frozenset(src for src, base in sources[label] if isinstance(base, SMP) and is_gait(spec, base))
        if not gaits:
            continue
        by_name = {loc.name: loc for loc in plan[label]}
        loc = by_name[cadence.reading_location(list(by_name))]
        acc = train.X[train.y == c][..., channel_index(info, loc)[:3]]
        values, reason = cadence.class_cadence(acc, info.fs_hz)
        found[label] = cadence.summary(values, reason)
        if len(values):
            rates[label] = (values, gaits)
    return rates, found


# -- stage 2a: the side from evidence (pipeline.side) -------------------------------------------------
def side_probe_tasks(spec: GenerationSpec, info: DatasetInfo, label: str, j: int, smp: SMP, seed: int, fold: str,
                     locations: tuple[LocationTask, ...]) -> list[SampleTask]:
    """Base SMP j of a class, moved to the left and to the right: same seed, no noise, no calibration."""
    probe = probe_seed(seed, fold, f"{label}/{j}")
    return [SampleTask(key=f"{fold}/{label}/side{j}-{side}", label=label, label_index=info.label_names.index(label),
                       source="side-probe", variant=0, **_payload(with_side(smp, side)), backend=spec.backend,
                       seed=probe, fs_hz=info.fs_hz, locations=locations, sim_in_the_loop=False, noise=False,
                       duration_s=spec.duration_s, library_dirs=tuple(spec.library_dirs))
            for side in SIDES]


def free_sides(spec: GenerationSpec, info: DatasetInfo, sources, plan, budget, library=None) -> list[tuple]:
    """(class, base index, refined SMP) of each base SMP with a free side, in a class with a budget
    and a gyroscope to read the side from."""
    todo = []
    for i, label in enumerate(info.label_names):
        if budget[i] <= 0 or label not in sources or not gyro_locations(label, plan):
            continue
        for j, (_, base) in enumerate(sources[label]):
            smp = Refiner(library).refine(base).smp if isinstance(base, SMP) and spec.refine else base
            if isinstance(smp, SMP) and side_is_free(smp):
                todo.append((label, j, smp))
    return todo


def gyro_locations(label: str, plan) -> list[SensorLocation]:
    return [loc for loc in plan[label] if loc.gyr_unit is not None and len(loc.channels) >= 6]


def side_evidence(info: DatasetInfo, train: Windows, label: str, plan, probes: list[SampleResult]) -> SideEvidence:
    """The two probes' mean gyroscope vectors and the class's real training windows' (pipeline.side)."""
    locs = gyro_locations(label, plan)
    left, right = ([r.signals[loc.name] for loc in locs] for r in probes)
    rms = float(np.sqrt(np.mean(np.concatenate([np.asarray(s)[:, 3:6].ravel() for s in left + right]) ** 2)))
    X = train.X[train.y == info.label_names.index(label)]
    rates = [X[..., channel_index(info, loc)[3:6]].mean(axis=1) for loc in locs]
    return SideEvidence(mean_rates(left), mean_rates(right), rms, np.concatenate(rates, axis=1))


# -- stage 2b: motion-level simulation-in-the-loop ------------------------------------------------
def motion_fit_jobs(spec: GenerationSpec, info: DatasetInfo, sources, setup: FoldSetup, budget: np.ndarray,
                    seed: int, fold: str, library=None) -> list[MotionFitJob]:
    """One job per class with a budget: its (refined) base SMP, D_stat targets and real mean accelerations."""
    jobs = []
    for i, label in enumerate(info.label_names):
        if budget[i] <= 0 or label not in sources:
            continue
        base = sources[label][0][1]
        smp_json = ""
        if isinstance(base, SMP):
            smp_json = (Refiner(library).refine(base).smp if spec.refine else base).canonical_json()
        mask = setup.d_stat.y == i
        means = []
        for loc in setup.plan[label]:
            acc = setup.d_stat.X[mask][..., channel_index(info, loc)[:3]].reshape(-1, 3)
            means.append(tuple(float(v) for v in acc.mean(axis=0)) if loc.gravity_included and len(acc) else None)
        jobs.append(MotionFitJob(label, smp_json, spec.backend, tuple(spec.library_dirs), info.fs_hz,
                                 setup.locations[label], tuple(means), int(mask.sum()),
                                 int(rng_for(seed, fold, "motion-fit").integers(2**31))))
    return jobs


# -- stage 4: texture and ground ----------------------------------------------------------------------
def fit_textures(info: DatasetInfo, d_stat: Windows, plan, threads: int = 1) -> dict[str, TextureModel]:
    """Per location, the movement-texture ratios of D_stat's windows of the classes worn there
    (`threads` filter them side by side: same result)."""
    models = {}
    for loc in info.locations:
        real = worn_windows(info, loc, d_stat, plan)
        models[loc.name] = TextureModel(info.fs_hz).fit(real.X[..., channel_index(info, loc)], real.y, threads)
    return models


def texture_task(models: dict[str, TextureModel], label_index: int, seed: int, fold: str) -> dict | None:
    """What a class's samples need to add their movement texture in the worker (`SampleTask.texture`):
    the noise seed and the class's ratios per location; None without models."""
    if not models:
        return None
    kappa = {name: None if (k := m.kappa(label_index)) is None else tuple(float(v) for v in k)
             for name, m in models.items()}
    return {"seed": int(seed), "fold": fold, "kappa": kappa}


def texture_summary(info: DatasetInfo, models: dict[str, TextureModel], ok: list[SampleResult]) -> dict:
    """Per location: the fitted ratios and, per class generated, which ratios it got."""
    return {name: {**m.as_dict(info.label_names),
                   "mapping": {info.label_names[i]: m.mapping(i)
                               for i in sorted({r.label_index for r in ok if name in r.signals})}}
            for name, m in models.items()}


def ground(spec: GenerationSpec, info: DatasetInfo, ok: list[SampleResult], d_rank: Windows, plan,
           threads: int = 1, unseen: frozenset[int] = frozenset()) -> tuple[list[dict[str, np.ndarray]], dict]:
    """Rank grounding per location (F_v from all of `ok`, G_r from D_rank) and how each class was
    mapped there (`rank_mappings`); the signals as they are, and no mappings, without it. The
    `unseen` classes (no real training window) keep their values."""
    if not spec.rank_grounding or not ok:
        return [dict(r.signals) for r in ok], {}
    grounders = fit_rank_grounders(info, ok, d_rank, plan, spec, threads, unseen)
    grounded = apply_rank_grounders(ok, grounders)
    if spec.gravity_norm:
        grounded = keep_gravity_norm(info, ok, grounded, d_rank, plan)
    return grounded, rank_mappings(info, grounders, ok)


def keep_gravity_norm(info: DatasetInfo, ok: list[SampleResult], grounded: list[dict[str, np.ndarray]],
                      d_rank: Windows, plan) -> list[dict[str, np.ndarray]]:
    """At each location that reads gravity, the grounded accelerometer's slow part gets back the
    magnitude it had before the rank map, scaled to the real sensor's gravity reading
    (`grounding.gravity`)."""
    from vsmp_imu.grounding.gravity import gravity_scale, rescale_slow_part, slow_norm

    out = [dict(g) for g in grounded]
    for loc in info.locations:
        users = [i for i, r in enumerate(ok) if loc.name in r.signals]
        real = worn_windows(info, loc, d_rank, plan)
        if not (users and loc.gravity_included and len(real)):
            continue
        real_means = real.X[..., channel_index(info, loc)[:3]].astype(np.float64).mean(axis=1)
        slow = [slow_norm(ok[i].signals[loc.name][:, :3], info.fs_hz) for i in users]
        scale = gravity_scale(real_means, np.concatenate(slow))
        for i, norms in zip(users, slow, strict=True):
            out[i][loc.name] = rescale_slow_part(grounded[i][loc.name], scale * norms, info.fs_hz)
    return out


def rank_mappings(info: DatasetInfo, grounders: dict[str, RankGrounder], ok: list[SampleResult]) -> dict:
    """How each location's rank grounding mapped each class it saw: 'class', 'pooled' or 'none'."""
    return {name: {info.label_names[i]: g.mapping(i)
                   for i in sorted({r.label_index for r in ok if name in r.signals})}
            for name, g in grounders.items()}


def apply_rank_grounders(ok: list[SampleResult], grounders: dict[str, RankGrounder]) -> list[dict[str, np.ndarray]]:
    """The samples' signals mapped by their location's grounder (each class by its own mapping)."""
    missing = sorted({name for r in ok for name in r.signals} - set(grounders))
    if missing:
        raise ValidationError(f"D_rank has no real window at location(s) {', '.join(missing)}",
                              field="d_rank")
    out: list[dict[str, np.ndarray]] = [{} for _ in ok]
    for name, grounder in grounders.items():  # all samples of a location mapped at once
        users = [i for i, r in enumerate(ok) if name in r.signals]
        signals = [ok[i].signals[name] for i in users]
        labels = np.concatenate([np.full(len(sig), ok[i].label_index)
                                 for i, sig in zip(users, signals, strict=True)])
        mapped = grounder.transform(np.concatenate(signals), labels)
        for i, part in zip(users, np.split(mapped, np.cumsum([len(sig) for sig in signals])[:-1]), strict=True):
            out[i][name] = part
    return out


# -- stage 5: window -----------------------------------------------------------------------------------
@dataclass
class WindowSet:
    """Windows of the fold's samples: X (N, T, C), labels y and one record per window
    (records past N describe failed samples)."""

    X: np.ndarray
    y: np.ndarray
    records: list[WindowRecord]


def window(info: DatasetInfo, ok: list[SampleResult], grounded: list[dict[str, np.ndarray]], length: int,
           hop: int) -> WindowSet:
    """Windows of every sample; a class whose real windows need only a share of the
    window (transitions) keeps the synthetic windows whose share inside the motion's
    active span reaches it, like the dataset's own labelling rule."""
    shares = info.share_vector()
    xs, ys, records = [], [], []
    for r, sig in zip(ok, grounded, strict=True):
        n = min(s.shape[0] for s in sig.values())
        full = np.zeros((n, len(info.channel_names)))
        for loc in info.locations:
            if loc.name in sig:
                full[:, channel_index(info, loc)] = sig[loc.name][:n]
        starts = _starts(n, length, hop)
        if shares[r.label_index] < 1.0:
            starts = _covering(starts, length, info.fs_hz, r.provenance, shares[r.label_index])
        for w, start in enumerate(starts):
            xs.append(full[start:start + length])
            ys.append(r.label_index)
            records.append(WindowRecord(r.key, info.label_names[r.label_index], w, r.provenance,
                                        start_s=start / info.fs_hz, locations=sorted(sig)))
    if not xs:
        return WindowSet(np.zeros((0, length, len(info.channel_names)), np.float32), np.zeros(0, np.int64),
                         records)
    return WindowSet(np.stack(xs).astype(np.float32), np.array(ys, dtype=np.int64), records)


def level_classes(spec: GenerationSpec, info: DatasetInfo, sources) -> np.ndarray:
    """The classes window levels map: the events (a class whose windows need only a share of the
    window) and, with `posture_levels`, the classes whose first SMP holds a posture."""
    classes = set(np.flatnonzero(info.share_vector() < 1.0).tolist())
    if spec.posture_levels:
        classes |= {i for i, label in enumerate(info.label_names) if holds_posture(sources, label)}
    return np.array(sorted(classes), dtype=np.int64)


def level_windows(spec: GenerationSpec, info: DatasetInfo, windows: WindowSet, d_rank: Windows,
                  sources=None) -> dict:
    """Stage 5b: the windows of each class `level_classes` names shifted so that their means follow
    D_rank's windows of that class (grounding.levels), per location, in place. Returns per location
    the classes mapped (real windows, mean absolute shift per channel) and those left alone for want
    of real windows."""
    classes = level_classes(spec, info, sources or {})
    n = len(windows.X)
    if not spec.window_levels or n == 0 or len(classes) == 0:
        return {}
    X, summary = windows.X.astype(np.float64), {}
    for loc in info.locations:
        worn = np.array([loc.name in r.locations for r in windows.records[:n]], dtype=bool)
        if not worn.any():
            continue
        cols = channel_index(info, loc)
        part = X[worn]
        levels = LevelMap(parts=spec.level_parts).fit(part[..., cols], windows.y[worn], d_rank.X[..., cols], d_rank.y, classes)
        part[..., cols] = levels.transform(part[..., cols], windows.y[worn])
        X[worn] = part
        names = info.label_names
        summary[loc.name] = {"classes": {names[c]: v for c, v in levels.classes_.items()},
                             "too_few": {names[c]: k for c, k in levels.skipped_.items()}}
    windows.X = X.astype(np.float32)
    return summary


def failed_records(info: DatasetInfo, results: list[SampleResult]) -> list[WindowRecord]:
    """A record per sample that failed or gave no signal."""
    return [WindowRecord(r.key, info.label_names[r.label_index], None, r.provenance, error=r.error, kept=False)
            for r in results if r.error or not r.signals]


# -- stage 5: filter -----------------------------------------------------------------------------------
def filter_windows(spec: GenerationSpec, info: DatasetInfo, train: Windows, windows: WindowSet,
                   ok: list[SampleResult], job: FilterJob | None, models: FilterModels | None, seed: int,
                   fold: str, threads: int = 1) -> tuple[np.ndarray, float | None]:
    """The quality filter: each window's verdicts and kept flag (motion and inertial plausibility,
    class faithfulness with tau_cls chosen by validation Macro-F1, redundancy). Returns the kept
    mask and tau_cls (None: no class filter)."""
    X, y, records = windows.X, windows.y, windows.records
    keep = np.ones(len(X), dtype=bool)
    if job is None or len(X) == 0:
        return keep, None
    by_key = {r.key: r for r in ok}
    imu = {}  # location -> one verdict per window (all windows checked at once)
    for loc in info.locations:
        imu[loc.name] = models.plausibility[loc.name].check_windows(X[..., channel_index(info, loc)], y)
    for i, rec in enumerate(records[: len(X)]):
        verdicts = [by_key[rec.sample].provenance.motion_verdict, *(imu[name][i] for name in rec.locations)]
        rec.verdicts = verdicts
        keep[i] = all(v.passed for v in verdicts)
    tau = None
    validator, is_val = models.validator, job.is_val
    f_syn = ecdf_features(X) if validator is not None else None
    if spec.class_filter:
        proba = validator.predict_proba_features(f_syn)
        validated = job.validated()
        tau = choose_tau(job.features, train.y, is_val, f_syn, y, proba, keep, validated, seed, fold, threads)
        for i, v in enumerate(class_verdicts(proba, y, tau, validated)):
            records[i].verdicts.append(v)
            keep[i] &= v.passed
    if spec.redundancy_filter:
        embedded = validator.embed_features(f_syn)
        for i, v in enumerate(redundancy_verdicts(embedded, y, models.nn_thresholds, eligible=keep)):
            records[i].verdicts.append(v)
            keep[i] &= v.passed
    for i in range(len(X)):
        records[i].kept = bool(keep[i])
    return keep, tau


def choose_tau(f_train, y_train, is_val, f_syn, y, proba, keep, validated, seed, fold, threads: int = 1) -> float:
    """tau_cls by validation Macro-F1 of a quick forest on real + kept synthetic ECDF features."""
    if not is_val.any() or len(np.unique(y_train[is_val])) < 2 or is_val.all():
        return TAU_DEFAULT
    f_fit, y_fit = f_train[~is_val], y_train[~is_val]

    def score(mask: np.ndarray) -> float:
        chosen = keep & mask
        model = RandomForestClassifier(n_estimators=25, n_jobs=threads,
                                       random_state=int(rng_for(seed, fold, "tau").integers(2**31)))
        model.fit(np.concatenate([f_fit, f_syn[chosen]]), np.concatenate([y_fit, y[chosen]]))
        return macro_f1(y_train[is_val], model.predict(f_train[is_val]))

    # the distinct masks' forests on as many threads as each forest has: the last
    # forests keep both cores busy where one forest's trees end unevenly
    tau, _ = select_tau(proba, y, score, validated=validated, threads=threads)
    return tau


# -- stage 5b: the timing of each discrete event ---------------------------------------------------
TIMINGS = ("both", "timed", "untimed")


def choose_timing(info: DatasetInfo, train: Windows, job: FilterJob | None, windows: WindowSet, keep: np.ndarray,
                  found: dict[str, dict], seed: int, fold: str, threads: int = 1) -> np.ndarray:
    """Per class timed to real events (`found[label]["used"]`), which of its kept windows to use: those
    of the samples timed to a real event, those with the SMP's timing, or both. Chosen class by class
    (in label order, the others as chosen so far, starting from both) by the Macro-F1 of a quick forest
    trained on the kept synthetic windows alone and scored on every real training window, so the
    choice asks which timing makes the class's windows look like its real ones. The dropped windows
    get a failing "timing" verdict; `found[label]` gets the choice and its scores."""
    classes = [info.label_names.index(n) for n, f in found.items() if f["used"]]
    if not classes or not keep.any():
        return keep
    X, y, records = windows.X, windows.y, windows.records
    timed = np.array([bool((r.provenance.motion.controls or {}).get("event_duration"))
                      if r.provenance.motion is not None else False for r in records[: len(X)]])
    f_real = job.features if job is not None and job.features is not None else ecdf_features(train.X)
    f_syn = ecdf_features(X[keep])
    kept = np.flatnonzero(keep)

    def mask_for(choice: dict[int, str]) -> np.ndarray:
        use = keep.copy()
        for c, option in choice.items():
            if option != "both":
                use &= ~((y == c) & (timed != (option == "timed")))
        return use

    def score(use: np.ndarray) -> float:
        rows = use[kept]
        model = RandomForestClassifier(n_estimators=25, n_jobs=threads,
                                       random_state=int(rng_for(seed, fold, "timing").integers(2**31)))
        model.fit(f_syn[rows], y[kept][rows])
        return macro_f1(train.y, model.predict(f_real))

    choice = {c: "both" for c in classes}
    best = score(mask_for(choice))
    for c in classes:
        scores = {"both": best}
        for option in TIMINGS[1:]:
            scores[option] = score(mask_for({**choice, c: option}))
        choice[c] = max(TIMINGS, key=lambda o: (round(scores[o], 10), -TIMINGS.index(o)))
        best = scores[choice[c]]
        found[info.label_names[c]].update(chosen=choice[c], scores={o: round(v, 4) for o, v in scores.items()})
    use = mask_for(choice)
    for i in np.flatnonzero(keep & ~use):
        option = choice[int(y[i])]
        records[i].verdicts.append(Verdict(False, "timing", f"the class's {option} samples were chosen"))
        records[i].kept = False
    return use


# -- stage 6: select -----------------------------------------------------------------------------------
def select(info: DatasetInfo, X: np.ndarray, y: np.ndarray, keep: np.ndarray, budget: np.ndarray, seed: int,
           fold: str) -> np.ndarray:
    """The per-class budget, drawn from the kept windows (a mask over all windows)."""
    idx = np.flatnonzero(keep)
    if len(idx) == 0:
        return np.zeros(len(X), bool)
    kept = Windows(X[idx], y[idx], np.full(len(idx), "synthetic"), info.label_names, info.channel_names,
                   info.fs_hz, meta={"index": idx})
    chosen = take_budget(kept, budget, rng_for(seed, fold, "budget"))
    selected = np.zeros(len(X), bool)
    selected[chosen.meta["index"]] = True
    return selected


# -- stage 7: intensity spread of the classes without real windows ------------------------------------
def spread_unseen(spec: GenerationSpec, info: DatasetInfo, X: np.ndarray, y: np.ndarray, selected: np.ndarray,
                  records: list[WindowRecord], unseen: frozenset[int], seed: int,
                  fold: str) -> tuple[np.ndarray, dict[str, dict]]:
    """With `spec.unseen_intensity`, the selected windows of the `unseen` classes get an intensity
    factor each (grounding.intensity); the windows, and per such class its factors' summary."""
    if spec.unseen_intensity is None or not unseen or len(X) == 0:
        return X, {}
    mask = selected & np.isin(y, sorted(unseen))
    channels = spread_channels(info.channel_names)
    X, factors = spread_intensity(X, mask, spec.unseen_intensity, channels, rng_for(seed, fold, "intensity"))
    for i in np.flatnonzero(mask):
        records[i].intensity = float(factors[i])
    summary = {}
    for c in sorted(unseen):
        f = factors[mask & (y == c)]
        if len(f):
            summary[info.label_names[c]] = {"bounds": list(spec.unseen_intensity), "windows": len(f),
                                            "channels": [info.channel_names[j] for j in channels],
                                            "median": round(float(np.median(f)), 4)}
    return X, summary


# -- stage 8: the intensity spread of the classes with real windows -------------------------------------
def match_seen(spec: GenerationSpec, info: DatasetInfo, train: Windows, X: np.ndarray, y: np.ndarray,
               selected: np.ndarray, records: list[WindowRecord], unseen: frozenset[int], seed: int,
               fold: str) -> tuple[np.ndarray, dict[str, dict]]:
    """With `spec.seen_intensity`, the selected windows of each class with real windows get a factor
    each that widens their log-intensity spread to the real windows' (grounding.intensity); the
    windows, and per class its spread's summary."""
    if not spec.seen_intensity or len(X) == 0:
        return X, {}
    channels = spread_channels(info.channel_names)
    z = rng_for(seed, fold, "seen-intensity").standard_normal(len(X))  # one draw per window
    factors = np.full(len(X), np.nan)
    summary = {}
    for c in range(len(info.label_names)):
        mask = selected & (y == c)
        if c in unseen or not mask.any():
            continue
        real = train.X[train.y == c]
        spread = missing_spread(real, X[mask], channels)
        summary[info.label_names[c]] = {"spread": round(spread, 4), "real_windows": len(real),
                                        "windows": int(mask.sum())}
        if spread > 0:
            factors = np.where(mask, match_factors(mask, spread, z), factors)
    for i in np.flatnonzero(~np.isnan(factors)):
        records[i].intensity = float(factors[i])
    return scale_deviations(X, factors, channels), summary


# -- the fold ----------------------------------------------------------------------------------------
class FoldGenerator:
    """Generate the synthetic set of one fold (see module doc): the stages above, with the
    synthesis rounds and refill passes on the executor.

    `sources` maps class name -> list of (source id, base SMP). `executor` maps
    tasks (see `vsmp_imu.executor`); `cache_dir` keeps per-sample results so a
    killed run resumes where it stopped.
    """

    def __init__(self, config: GenerationSpec, executor, cache_dir: Path | None = None,
                 motion_dir: Path | None = None, library=None) -> None:
        self.config = config
        self.executor = executor
        self.cache_dir = cache_dir
        self.motion_dir = motion_dir
        self.library = library
        self.motion_fits: dict[str, dict] = {}  # per class, set by `generate` (motion_fit)
        self.sides: dict[str, list[dict]] = {}  # per class and base SMP, set by `generate` (side_evidence)
        self.class_windows_: dict[str, int] = {}  # per class, the real training windows of the fold
        self.textures: dict[str, TextureModel] = {}  # per location, set by `generate` (texture)
        self.events: dict[str, tuple] = {}  # per class, real event durations (event_durations)
        self.rates: dict[str, tuple] = {}  # per gait class, real step rates and gait sources (cadence)

    def generate(self, info: DatasetInfo, train: Windows, sources: dict[str, list[tuple[str, SMP]]],
                 budget: np.ndarray, seed: int, fold: str) -> FoldOutput:
        """The synthetic set for one fold (train: the fold's real training windows only)."""
        spec = self.config
        budget = np.asarray(budget, dtype=np.int64)
        self.class_windows_ = dict(zip(info.label_names, train.class_counts().tolist(), strict=True))
        job = None
        if spec.quality_filter:
            job = make_filter_job(info, train, seed, fold, spec.val_fraction, spec.min_validator_windows,
                                  learned=spec.class_filter or spec.redundancy_filter)
        fitting = start_filter_job(self.executor, job, fold)  # the filter models, beside what follows up to the filter
        try:
            return self._generate(info, train, sources, budget, seed, fold, job, fitting)
        finally:
            if fitting is not None:
                fitting.cancel()

    def _generate(self, info, train, sources, budget, seed, fold, job, fitting) -> FoldOutput:
        spec, threads = self.config, self.threads()
        length = train.n_timesteps
        hop = max(1, int(round(spec.hop_fraction * length)))
        setup = prepare(spec, info, train, sources, seed, threads)
        sources, self.sides = self.sides_from_evidence(info, train, sources, setup, budget, seed, fold)
        self.motion_fits = self.fit_motions(info, sources, setup, budget, seed, fold)
        self.events, events_found = class_events(spec, info, train, sources, budget)
        self.rates, rates_found = class_cadences(spec, info, train, sources, budget, setup.plan)
        self.textures = fit_textures(info, setup.d_stat, setup.plan, threads) if spec.texture else {}
        tasks, by_class = self.synthesize(info, sources, budget, seed, fold, setup.locations, length, hop)
        unseen = frozenset(np.flatnonzero(train.class_counts() == 0).tolist())  # not rank-mapped
        for attempt in range(spec.refill + 1):
            results = [r for label in info.label_names for r in by_class[label]]
            ok = [r for r in results if not r.error and r.signals]
            grounded, rank_map = ground(spec, info, ok, setup.d_rank, setup.plan, threads, unseen)  # F_v: all so far
            windows = window(info, ok, grounded, length, hop)
            levels = level_windows(spec, info, windows, setup.d_rank, sources)
            windows.records += failed_records(info, results)
            models = None if fitting is None else fitting.result()  # waits only if it has not ended
            keep, tau = filter_windows(spec, info, train, windows, ok, job, models, seed, fold, threads)
            keep = choose_timing(info, train, job, windows, keep, events_found, seed, fold, threads)
            more = [] if attempt == spec.refill else self.refill(
                info, sources, budget, windows.y, keep, by_class, seed, fold, setup.locations)
            if not more:
                break
            self.run(more, by_class, fold)
            tasks += more
        order = {n: i for i, n in enumerate(info.label_names)}
        tasks.sort(key=lambda t: (order[t.label], t.key))
        X, y, records = windows.X, windows.y, windows.records
        selected = select(info, X, y, keep, budget, seed, fold)
        for i, rec in enumerate(records[: len(X)]):
            rec.selected = bool(selected[i])
        X, spread = spread_unseen(spec, info, X, y, selected, records, unseen, seed, fold)
        X, matched = match_seen(spec, info, train, X, y, selected, records, unseen, seed, fold)
        out = Windows(X[selected], y[selected], np.full(int(selected.sum()), "synthetic"),
                      info.label_names, info.channel_names, info.fs_hz,
                      meta={"sample": np.array([records[i].sample for i in np.flatnonzero(selected)],
                                               dtype=object).astype(str)})
        summary = _summary(info, results, records, budget, out, tau, len(setup.d_stat), len(setup.d_rank))
        if rank_map:  # per location and class: its own map, the pooled one, or none (no evidence)
            summary["rank_map"] = rank_map
        if levels:  # per location: the event classes whose window means were mapped, and those without evidence
            summary["window_levels"] = levels
        if self.textures:  # per location: the ratios fitted on D_stat and which each class got
            summary["texture"] = texture_summary(info, self.textures, ok)
        if setup.nominal_sensor:  # unseen postures: no sim-in-the-loop (eta nominal)
            summary["nominal_sensor"] = list(setup.nominal_sensor)
        other_k = {n: k for n, b in zip(info.label_names, budget, strict=True)
                   if b > 0 and (k := spec.variants_for(self.class_windows_[n])) != spec.k}
        if other_k:  # classes with no real window: their SMP variants per base SMP
            summary["variants_per_smp"] = other_k
        if spread:  # classes without real windows: their windows' intensity factors
            summary["intensity_spread"] = spread
        if matched:  # classes with real windows: the log-intensity spread their windows got
            summary["intensity_match"] = matched
        if spec.motion_fit:
            summary["motion_fit"] = self.motion_fits
        if events_found:  # per class: the real event durations its samples were timed to, or why not
            summary["event_durations"] = events_found
        if rates_found:  # per gait class: the real step rates its samples were timed to, or why not
            summary["cadence"] = rates_found
        if self.sides:
            summary["side_evidence"] = self.sides
        return FoldOutput(out, X, records, results, tasks, summary)

    # -- stages 2 + 3 on the executor --------------------------------------------------------------
    def sides_from_evidence(self, info, train: Windows, sources, setup: FoldSetup, budget, seed: int,
                            fold: str) -> tuple[dict, dict[str, list[dict]]]:
        """Per class with a budget, each base SMP with a free side gets the side its real training
        windows support (`pipeline.side`); the sources with those sides and the records."""
        spec = self.config
        todo = free_sides(spec, info, sources, setup.plan, budget, self.library) if spec.side_evidence else []
        records: dict[str, list[dict]] = {}
        for label, j, _ in todo:  # a class below the floor keeps its side: no probe to run
            n = int(np.sum(train.y == info.label_names.index(label)))
            if not floors.SIDE_EVIDENCE.met(n):
                reason = "no real window of the class" if n == 0 else \
                    f"{n} real window(s), fewer than {floors.SIDE_EVIDENCE.floor}"
                records.setdefault(label, []).append({"source": sources[label][j][0], "used": False,
                                                      "reason": reason})
        todo = [t for t in todo if t[0] not in records]
        if not todo:
            return sources, records
        tasks = [t for label, j, smp in todo
                 for t in side_probe_tasks(spec, info, label, j, smp, seed, fold, setup.locations[label])]
        cache = str(self.cache_dir) if self.cache_dir else None
        done = self.executor.map(run_item, [(t, cache) for t in tasks],
                                 desc=f"fold {fold}: {len(tasks)} side probes")
        out = {label: list(bases) for label, bases in sources.items()}
        for n, (label, j, smp) in enumerate(todo):
            probes = done[2 * n: 2 * n + 2]
            source, base = out[label][j]
            failed = next((p.error for p in probes if p.error), None)
            if failed:
                record = {"used": False, "reason": f"a probe failed: {failed}"}
            else:
                _, record = side_evidence(info, train, label, setup.plan, probes).decide(smp)
                if record["used"]:
                    out[label][j] = (source, with_side(base, record["side"], record["uncertainty"]))
            records.setdefault(label, []).append({"source": source, **record})
        return out, records

    def fit_motions(self, info, sources, setup: FoldSetup, budget, seed: int, fold: str) -> dict[str, dict]:
        """Per class, the fitted motion parameters (empty without `motion_fit`)."""
        if not self.config.motion_fit:
            return {}
        jobs = motion_fit_jobs(self.config, info, sources, setup, budget, seed, fold, self.library)
        fits = self.executor.map(fit_class_motion, jobs, desc=f"fold {fold}: fitting {len(jobs)} class motions")
        return {job.label: fit for job, fit in zip(jobs, fits, strict=True)}

    def tasks(self, info: DatasetInfo, label: str, bases, slots: range, seed: int, fold: str,
              locations: tuple[LocationTask, ...]) -> list[SampleTask]:
        fit = fit_text(self.motion_fits.get(label))
        index = info.label_names.index(label)
        return sample_tasks(self.config, label, index, bases, slots, seed, fold,
                            info.fs_hz, locations, self.library, self.motion_dir, fit,
                            self.class_windows_.get(label), texture_task(self.textures, index, seed, fold),
                            self.events.get(label), self.rates.get(label))

    def synthesize(self, info, sources, budget, seed, fold, loc_tasks, length, hop):
        """Rounds of per-sample synthesis until every class has oversample x budget raw windows.
        Returns the tasks and the results per class."""
        spec = self.config
        # a class timed to real events is made both ways (stage 5b chooses): twice the windows
        need = {n: math.ceil(spec.oversample * budget[i] * (2 if n in self.events else 1))
                for i, n in enumerate(info.label_names)}
        results: dict[str, list[SampleResult]] = {n: [] for n in info.label_names}
        all_tasks: list[SampleTask] = []
        for _ in range(spec.max_rounds):
            tasks = []
            for label in info.label_names:
                if need[label] <= 0 or label not in sources:
                    continue
                have = sum(len(_starts(next(iter(r.signals.values())).shape[0], length, hop))
                           for r in results[label] if not r.error and r.signals)
                missing = need[label] - have
                if missing <= 0:
                    continue
                per = _windows_per_sample(results[label], length, hop)
                n_new = min(MAX_SLOTS_PER_CLASS_ROUND, max(1, math.ceil(missing / max(per, 0.5))))
                if not results[label]:
                    n_new = max(n_new, spec.variants_for(self.class_windows_.get(label)))
                start = len(results[label])
                tasks += self.tasks(info, label, sources[label], range(start, start + n_new), seed, fold,
                                    loc_tasks[label])
            if not tasks:
                break
            self.run(tasks, results, fold)
            all_tasks += tasks
        return all_tasks, results

    def run(self, tasks: list[SampleTask], results: dict[str, list[SampleResult]], fold: str) -> None:
        """Synthesize `tasks` and append the results per class."""
        cache = str(self.cache_dir) if self.cache_dir else None
        items = sample_items(tasks, cache, self.threads())
        done = self.executor.map(run_item, items, desc=f"fold {fold}: synthesizing {len(tasks)} samples "
                                                       f"in {len(items)} batches")
        for task, result in zip(tasks, [r for part in done for r in part], strict=True):
            results[task.label].append(result)

    def refill(self, info, sources, budget, y, keep, results, seed, fold, loc_tasks) -> list[SampleTask]:
        """One refill pass: for each class short of its budget, as many new samples as its
        observed windows per sample and pass rate need (25 % margin, at most REFILL_MAX_SAMPLES)."""
        tasks = []
        for i, label in enumerate(info.label_names):
            kept = int(np.sum(keep & (y == i)))
            if kept >= budget[i] or label not in sources or not results[label]:
                continue
            windows = int(np.sum(y == i))
            per_sample = windows / len(results[label])
            rate = max(kept, 1) / max(windows, 1)  # no kept window yet: assume one
            n_new = math.ceil(1.25 * (budget[i] - kept) / max(per_sample * rate, 1e-3))
            n_new = min(REFILL_MAX_SAMPLES, n_new)
            start = len(results[label])
            tasks += self.tasks(info, label, sources[label], range(start, start + n_new), seed, fold,
                                loc_tasks[label])
        return tasks

    def threads(self) -> int:
        """Threads for the fold-level steps: the workers of a local pool (or of a private local
        Ray instance) are idle while they run."""
        workers = getattr(self.executor, "workers", None) or getattr(self.executor, "num_cpus", None) or 1
        return max(1, min(int(workers), os.cpu_count() or 1))


def _windows_per_sample(results: list[SampleResult], length: int, hop: int) -> float:
    counts = [len(_starts(next(iter(r.signals.values())).shape[0], length, hop))
              for r in results if not r.error and r.signals]
    return float(np.mean(counts)) if counts else FIRST_ROUND_WINDOWS_PER_SAMPLE


def _payload(base: Base) -> dict[str, Any]:
    """SampleTask fields of an SMP variant, a free-text prompt or a recorded motion file."""
    if isinstance(base, SMP):
        return {"smp_json": base.canonical_json(), "prompt": verbalize(base)}
    if isinstance(base, Path):
        digest = hashlib.sha256(base.read_bytes()).hexdigest()[:24]
        return {"smp_json": "", "prompt": "", "motion_file": str(base), "motion_digest": digest}
    return {"smp_json": "", "prompt": str(base)}


def _starts(n: int, length: int, hop: int) -> range:
    return range(0, n - length + 1, hop) if n >= length else range(0)


def _covering(starts, length: int, fs_hz: float, provenance: Provenance, share: float) -> list[int]:
    """Window starts whose overlap with the motion's active span is at least `share` of the window."""
    span = provenance.active_span_s()
    if not span:
        return list(starts)
    offset = provenance.start_s()
    lo, hi = (span[0] - offset) * fs_hz, (span[1] - offset) * fs_hz
    return [s for s in starts if min(s + length, hi) - max(s, lo) >= share * length]


def _validation_mask(train: Windows, fraction: float, seed: int, fold: str) -> np.ndarray:
    """True for the windows of the validation subjects (tau_cls); the rest train the validator."""
    subjects = train.unique_subjects()
    n_val = int(round(fraction * len(subjects)))
    if n_val < 1 or len(subjects) - n_val < 1:
        return np.zeros(len(train), bool)
    order = rng_for(seed, fold, "validation").permutation(len(subjects))
    val_subjects = [subjects[i] for i in order[:n_val]]
    return np.isin(train.subjects, np.asarray(val_subjects).astype(str))


def _summary(info, results, records: list[WindowRecord], budget, windows, tau, n_stat, n_rank) -> dict[str, Any]:
    per_class = {}
    for i, name in enumerate(info.label_names):
        recs = [r for r in records if r.label == name and r.windowed]
        rejected: dict[str, int] = {}
        for r in recs:
            failed = r.first_failure()
            if failed:
                rejected[failed.filter] = rejected.get(failed.filter, 0) + 1
        per_class[name] = {
            "budget": int(budget[i]),
            "samples": sum(1 for r in results if r.label_index == i),
            "failed_samples": sum(1 for r in results if r.label_index == i and r.error),
            "windows": len(recs),
            "kept": sum(1 for r in recs if r.kept),
            "selected": int((windows.y == i).sum()),
            "rejected_by": rejected,
        }
    return {"tau_cls": tau, "d_stat_windows": n_stat, "d_rank_windows": n_rank, "per_class": per_class,
            "shortfall": {n: c["budget"] - c["selected"] for n, c in per_class.items()
                          if c["selected"] < c["budget"]}}
