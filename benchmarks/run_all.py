"""Every speed figure of the project in one run (`make bench`).

Measured here, each stage in its own subprocess (so its peak memory is its own):

- per-sample stages on one core (BLAS/OpenMP pinned to 1 thread): SMP
  augmentation, procedural motion, IMU simulation (kinematics + readings, one
  location), CEM (simulation-in-the-loop, vectorized over the 64 candidates
  vs the same CEM scoring each candidate in a Python loop: ratio), convention
  alignment + rank grounding;
- the post-motion stages of one fold on one core (IMU simulation, CEM,
  alignment, rank grounding, windowing, quality filter with its per-fold
  model fits: the fold's wall time minus the time spent making the motions);
- the whole embedded chain (Algorithm 1 for one HAPT12 LOPO fold: library
  SMPs, procedural backend, 2 local workers, no cache) with its breakdown
  (synthesis, rank grounding, windowing, filters, selection) from the same run;
- worker scaling 1 -> 2 on generation, with the local process pool and with a
  local Ray instance;
- HAR training: HAPT 30-fold LOPO RF-ECDF (all folds; `--quick`: 2 folds,
  extrapolated) and one DeepConvLSTM fold with an epoch cap;
- the paper's cost comparison: seconds per synthetic sample of Classical Aug,
  IMUTube-style, IMUGPT-2.0-style and VSMP-IMU on one HAPT12 fold, 1 worker.

Peak memory: the peak resident set (VmHWM, as `ru_maxrss` reports it) of the
stage's subprocess (the whole process: interpreter, imports, inputs and the
work; pool workers reported apart as RUSAGE_CHILDREN ru_maxrss, Ray workers not
included) and the `tracemalloc` peak of one
untimed extra pass of the stage's unit of work (Python and NumPy allocations
of that work only).

Usage:  .venv/bin/python benchmarks/run_all.py [--quick] [--stages a,b] [--update]
        [--json PATH] [--markdown PATH] [--report]
Writes the figures as JSON (default benchmarks/results/run_all[_quick].json)
and the table as Markdown (same name, .md), and prints the table. A run with a
scaling stage (not `--quick`) also adds one line to the scaling history
(benchmarks/results/scaling_history.jsonl; `--history PATH`, `--no-history`).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
import tracemalloc
from collections import defaultdict
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from unittest import mock

import numpy as np

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
VIDEO_DIR = REPO.parent / "shared" / "data" / "videos"
HISTORY = HERE / "results" / "scaling_history.jsonl"  # one line per run with a scaling stage
HOLDOUT = "1"  # the HAPT12 fold used by every generation figure
CORES = 2
STAGES = ("smp_augment", "procedural_motion", "imu_simulation", "cem", "align_rank", "post_motion", "chain",
          "chain_motion_fit",
          "chain_memory", "scaling_local", "scaling_ray", "scaling_ray_nice0", "har_rf", "har_dclstm", "har_guard", "cost")
# Targets of the issue "Speed, scale and reliability, measured".
CHAIN_TARGET = 50.0  # synthetic samples/s, whole embedded chain, 2 cores
MOTION_FIT_CHAIN_TARGET = 40.0  # the same with motion-level simulation-in-the-loop (issue 21)
MOTION_FIT_CLASS_TARGET_S = 3.0  # motion fitting per class and fold, one core
POST_MOTION_TARGET = 50.0  # samples/s per core, IMU simulation + CEM + alignment + grounding + filter
RF_TARGET_S = 300.0  # HAPT 30-fold RF-ECDF LOPO
SCALING_TARGET = 1.8  # 1 -> 2 workers
PAPER_S_PER_SAMPLE = {"classical": 0.01, "imutube": 2.0, "imugpt": 5.0, "vsmp": 10.0}  # A6000 Ada


# --------------------------------------------------------------------------------------------
# helpers (run inside a stage subprocess)
# --------------------------------------------------------------------------------------------
def one_thread() -> None:
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


def timed(fn: Callable[[], object]) -> tuple[float, object]:
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def traced_peak_mb(fn: Callable[[], object]) -> float:
    """tracemalloc peak (MB) of one call of `fn`."""
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()


def maxrss_mb() -> dict[str, float]:
    """Peak resident memory (MB) of this process and of its largest waited-for child.

    The process's own peak is VmHWM (reset at exec); `ru_maxrss` of RUSAGE_SELF
    would carry the driver's peak over the fork + exec that started the stage.
    """
    status = Path("/proc/self/status")
    own = None
    if status.exists():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                own = int(line.split()[1]) / 1024
    if own is None:
        own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {"maxrss_mb": own,
            "children_maxrss_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}


def hapt12_fold(alpha: float):
    """(info, train windows, library, SMP sources, budget) of the HAPT12 fold HOLDOUT."""
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.synthetic import synthetic_budget
    from vsmp_imu.pipeline.sources import LibrarySmpSource
    from vsmp_imu.smp.library import ActivityLibrary

    ds = load_dataset("hapt12")
    train = ds.windows().where_subjects([HOLDOUT], keep=False)
    library = ActivityLibrary.load()
    sources = LibrarySmpSource(library).smps("hapt12", ds.info.label_names)
    budget = synthetic_budget(train.class_counts(), alpha)
    return ds.info, train, library, sources, budget


def class_smps(library, info):
    """The library SMP of every HAPT12 class, refined as the pipeline does."""
    from vsmp_imu.pipeline.sources import LibrarySmpSource
    from vsmp_imu.smp.refine import Refiner

    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    return [(label, Refiner(library).refine(sources[label][0][1]).smp) for label in info.label_names]


def variants(smps, k: int = 4):
    from vsmp_imu.smp.augment import SMPAugmenter

    return [(label, v) for i, (label, smp) in enumerate(smps) for v in SMPAugmenter().augment(smp, k, i)]


def motions_of(library, items, seed0: int = 0):
    from vsmp_imu.motion.procedural import ProceduralBackend

    backend = ProceduralBackend(library)
    return [(label, backend.generate(smp, seed0 + i)) for i, (label, smp) in enumerate(items)]


class TimedExecutor:
    """Wraps an executor; adds the wall time of its `map` calls."""

    def __init__(self, inner) -> None:
        self.inner = inner
        self.seconds = 0.0
        self.tasks = 0
        self.batches: list[list] = []

    def map(self, fn, tasks, desc: str = "working"):
        start = time.perf_counter()
        out = self.inner.map(fn, tasks, desc)
        self.seconds += time.perf_counter() - start
        self.tasks += len(tasks)
        self.batches.append(list(tasks))
        return out

    def __getattr__(self, name):
        # the fold asks its executor how many workers it has (threads for its own steps)
        return getattr(self.inner, name)


# The fold's stages (functions of vsmp_imu.pipeline.fold) under the names the figures use.
# The movement texture is fitted here and added in the sample workers (inside `synthesize`).
FOLD_STEPS = {"nominal_mountings": "nominal_mountings", "fit_textures": "texture", "ground": "ground",
              "window": "window", "filter_windows": "filter", "select": "select"}


def patched_steps(wrap: Callable) -> ExitStack:
    """The fold's stage functions replaced by `wrap(function, name)` while the stack is open."""
    from vsmp_imu.pipeline import fold

    stack = ExitStack()
    for attr, name in FOLD_STEPS.items():
        stack.enter_context(mock.patch.object(fold, attr, wrap(getattr(fold, attr), name)))
    return stack


def timed_generator(config, executor, library):
    """A FoldGenerator whose fold-level steps add their wall time to `.times_`."""
    from vsmp_imu.pipeline.fold import FoldGenerator

    times: dict[str, float] = defaultdict(float)

    def timing(fn, name):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                times[name] += time.perf_counter() - start
        return wrapper

    class Timed(FoldGenerator):
        times_ = times

        def generate(self, *args, **kwargs):
            with patched_steps(timing):
                return super().generate(*args, **kwargs)

        def synthesize(self, *args, **kwargs):
            return timing(super().synthesize, "synthesize")(*args, **kwargs)

        def fit_motions(self, *args, **kwargs):
            return timing(super().fit_motions, "motion_fit")(*args, **kwargs)

        def sides_from_evidence(self, *args, **kwargs):
            return timing(super().sides_from_evidence, "side_evidence")(*args, **kwargs)

    return Timed(config, TimedExecutor(executor), None, library=library)


def run_fold(executor, alpha: float, config=None, batches: list | None = None) -> dict:
    """Algorithm 1 on the HAPT12 fold; wall time, counts and the per-step breakdown.

    The executor's task lists are appended to `batches` when given."""
    from vsmp_imu.pipeline.spec import GenerationSpec

    info, train, library, sources, budget = hapt12_fold(alpha)
    gen = timed_generator(config or GenerationSpec(), executor, library)
    wall, out = timed(lambda: gen.generate(info, train, sources, budget, 0, f"holdout-{HOLDOUT}"))
    if batches is not None:
        batches.extend(gen.executor.batches)
    return {"alpha": alpha, "wall_s": wall, "samples": len(out.samples), "windows": len(out.generated),
            "selected": len(out.windows), "budget": int(budget.sum()),
            "failed_samples": sum(1 for r in out.samples if r.error),
            "synthesis_map_s": gen.executor.seconds, "steps_s": dict(gen.times_),
            "samples_per_s": len(out.samples) / wall}


def _warm(_):
    """Load what a worker loads before its first sample (excluded from the timings): the
    fold module the executor's items unpickle into, and the motion backend with the
    activity library. Once per worker process in a real run, whatever the number of folds;
    a local pool's workers are forked from a driver that has all of it loaded already."""
    import vsmp_imu.pipeline.fold  # noqa: F401
    from vsmp_imu.pipeline.sample import backend_for

    backend_for("procedural", ())
    time.sleep(0.2)
    return os.nice(0)


# --------------------------------------------------------------------------------------------
# stages: each returns a dict of figures
# --------------------------------------------------------------------------------------------
def stage_smp_augment(quick: bool) -> dict:
    one_thread()
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.smp.augment import SMPAugmenter
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    smps = class_smps(library, load_dataset("hapt12").info)
    repeats, k = (5 if quick else 50), 4

    def work():
        for r in range(repeats):
            for i, (_, smp) in enumerate(smps):
                SMPAugmenter().augment(smp, k, 1000 * r + i)

    work()  # warm-up
    wall, _ = timed(work)
    n = repeats * len(smps) * k
    return {"unit": "SMP variants", "n": n, "wall_s": wall, "per_s_per_core": n / wall,
            "tracemalloc_peak_mb": traced_peak_mb(lambda: SMPAugmenter().augment(smps[0][1], k, 0)),
            "note": f"K={k} variants of each of the 12 HAPT12 library SMPs"}


def stage_procedural_motion(quick: bool) -> dict:
    one_thread()
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    items = variants(class_smps(library, load_dataset("hapt12").info), 1 if quick else 4)
    motions_of(library, items[:2])  # warm-up
    wall, motions = timed(lambda: motions_of(library, items, 100))
    seconds = sum(m.duration_s for _, m in motions)
    return {"unit": "motions", "n": len(motions), "wall_s": wall, "per_s_per_core": len(motions) / wall,
            "motion_seconds_per_s": seconds / wall, "mean_duration_s": seconds / len(motions),
            "tracemalloc_peak_mb": traced_peak_mb(lambda: motions_of(library, items[:1])),
            "note": "natural duration of each SMP variant, 30 fps SMPL-22"}


def _imu_one(motion, fs_hz: float = 50.0):
    from vsmp_imu.imu import VirtualSensor, draw_noise, sensor_readings, simulate_kinematics

    sensor = VirtualSensor.at("waist")
    kin = simulate_kinematics(motion, sensor, fs_hz)
    noise = draw_noise(sensor, kin.n_samples, fs_hz, 0, sensor.name)
    return kin, noise, sensor_readings(kin, sensor.mounting_matrix(), noise=noise)[0]


def stage_imu_simulation(quick: bool) -> dict:
    one_thread()
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    motions = motions_of(library, variants(class_smps(library, load_dataset("hapt12").info), 1 if quick else 4))
    repeats = 2 if quick else 5
    _imu_one(motions[0][1])

    def work():
        for _ in range(repeats):
            for _, m in motions:
                _imu_one(m)

    wall, _ = timed(work)
    n = repeats * len(motions)
    return {"unit": "sensor streams", "n": n, "wall_s": wall, "per_s_per_core": n / wall,
            "tracemalloc_peak_mb": traced_peak_mb(lambda: _imu_one(motions[0][1])),
            "note": "kinematics + noise + readings, waist, 50 Hz"}


def naive_calibrate(cal, kin, target, convention, rng, base, noise) -> dict:
    """The same bounded CEM as `SimInTheLoopCalibrator.calibrate`, but each candidate is
    scored on its own: its readings simulated, summarized and compared (no linear moments)."""
    from vsmp_imu.grounding.align import axes_matrix
    from vsmp_imu.grounding.calibrate import (
        ETA_HIGH,
        ETA_INIT_STD,
        ETA_LOW,
        ETA_NOMINAL,
        MIN_STD_FRACTION,
        eta_rotation,
    )
    from vsmp_imu.grounding.stats import sim_loss, summarize_sequence
    from vsmp_imu.imu import sensor_readings

    to_target = np.kron(np.eye(2), axes_matrix(convention.axes)).T
    grav = convention.gravity_included

    def loss(eta: np.ndarray) -> float:
        mounting = eta_rotation(eta[None])[0] @ base
        x = sensor_readings(kin, mounting, eta[3:6], eta[6:9], eta[9], eta[10], grav, noise)[0]
        return float(sim_loss(summarize_sequence(x @ to_target, kin.fs_hz), target))

    n_elite = max(2, int(round(cal.elite_fraction * cal.n_candidates)))
    mean, std = ETA_NOMINAL.copy(), ETA_INIT_STD.copy()
    floor = MIN_STD_FRACTION * (ETA_HIGH - ETA_LOW)
    best_eta, best_loss = ETA_NOMINAL, loss(ETA_NOMINAL)
    for _ in range(cal.n_iterations):
        eta = np.clip(mean + std * rng.standard_normal((cal.n_candidates, len(mean))), ETA_LOW, ETA_HIGH)
        losses = np.array([loss(row) for row in eta])
        order = np.argsort(losses, kind="stable")
        mean, std = eta[order[:n_elite]].mean(0), np.maximum(eta[order[:n_elite]].std(0), floor)
        if losses[order[0]] < best_loss:
            best_eta, best_loss = eta[order[0]], float(losses[order[0]])
    return {"eta": best_eta, "loss_final": best_loss}


def stage_cem(quick: bool) -> dict:
    one_thread()
    from vsmp_imu.grounding.align import Convention
    from vsmp_imu.grounding.calibrate import ETA_NAMES, CemProblem, SimInTheLoopCalibrator
    from vsmp_imu.grounding.split import stat_rank_split
    from vsmp_imu.grounding.stats import TargetStatistics
    from vsmp_imu.pipeline.fold import SAMPLES_PER_ITEM
    from vsmp_imu.seeding import rng_for

    info, train, library, _, _ = hapt12_fold(0.1)
    stat_idx, _ = stat_rank_split(train.y, 0)
    stats = TargetStatistics(info.fs_hz).fit(train[stat_idx].X.astype(np.float64), train[stat_idx].y)
    loc = info.locations[0]
    convention = Convention(axes=tuple(loc.axes), gravity_included=loc.gravity_included)
    items = variants(class_smps(library, info), 1)
    cases = []
    for i, (label, m) in enumerate(motions_of(library, items)):
        kin, noise, _ = _imu_one(m)
        cases.append((kin, noise, stats.for_class(info.label_names.index(label)), i))
    cal = SimInTheLoopCalibrator()
    base = np.eye(3)

    def vectorized(case):
        kin, noise, target, i = case
        return cal.calibrate(kin, target, convention, rng_for(0, "cem", i), base_mounting=base, noise=noise)

    vectorized(cases[0])
    repeats = 1 if quick else 3
    wall, _ = timed(lambda: [vectorized(c) for _ in range(repeats) for c in cases])
    n = repeats * len(cases)
    # the same calibrations as the pipeline's samples make them: up to SAMPLES_PER_ITEM in lockstep
    problems = [CemProblem(kin, target, convention, rng_for(0, "cem", i), base, noise)
                for _ in range(repeats) for kin, noise, target, i in cases]
    lockstep_wall, lockstep = timed(lambda: [r for k in range(0, n, SAMPLES_PER_ITEM)
                                             for r in cal.calibrate_many(problems[k:k + SAMPLES_PER_ITEM])])
    same = all(r.eta == vectorized(c).eta for r, c in zip(lockstep[: len(cases)], cases, strict=True))
    naive_cases = cases[: 1 if quick else 3]
    naive_wall, naive = timed(lambda: [naive_calibrate(cal, c[0], c[2], convention, rng_for(0, "cem", c[3]),
                                                       base, c[1]) for c in naive_cases])
    vec = [vectorized(c) for c in naive_cases]
    eta_diff = max(float(np.abs(np.array([r.eta[k] for k in ETA_NAMES]) - nv["eta"]).max())
                   for r, nv in zip(vec, naive, strict=True))
    per_vec, per_naive = wall / n, naive_wall / len(naive_cases)
    return {"unit": "calibrations", "n": n, "wall_s": wall, "per_s_per_core": n / wall,
            "vectorized_s": per_vec, "naive_loop_s": per_naive, "naive_over_vectorized": per_naive / per_vec,
            "lockstep_s": lockstep_wall / n, "lockstep_per_s_per_core": n / lockstep_wall,
            "lockstep_batch": SAMPLES_PER_ITEM, "lockstep_same_eta": same,
            "naive_n": len(naive_cases), "max_abs_eta_difference": eta_diff,
            "tracemalloc_peak_mb": traced_peak_mb(lambda: vectorized(cases[0])),
            "note": f"{cal.n_iterations} iterations x {cal.n_candidates} candidates, one waist stream "
                    "against its class's D_stat; naive = the same CEM scoring each candidate in a loop"}


def stage_align_rank(quick: bool) -> dict:
    one_thread()
    from vsmp_imu.grounding.align import Convention, ConventionAlignment
    from vsmp_imu.grounding.rank import RankGrounder
    from vsmp_imu.grounding.split import stat_rank_split

    info, train, library, _, _ = hapt12_fold(0.1)
    _, rank_idx = stat_rank_split(train.y, 0)
    d_rank = train[rank_idx]
    loc = info.locations[0]
    alignment = ConventionAlignment(Convention(axes=tuple(loc.axes), gravity_included=loc.gravity_included))
    items = variants(class_smps(library, info), 2 if quick else 8)
    streams = []
    for label, m in motions_of(library, items):
        kin, _, x = _imu_one(m)
        streams.append((info.label_names.index(label), x, kin.grav_seg))

    def work():
        aligned = [alignment.transform(x, g) for _, x, g in streams]
        syn = np.concatenate(aligned)
        labels = np.concatenate([np.full(len(a), c) for (c, _, _), a in zip(streams, aligned, strict=True)])
        grounder = RankGrounder().fit(syn, d_rank.X.astype(np.float64), labels, d_rank.y)
        return [grounder.transform(a) for a in aligned]

    work()
    repeats = 1 if quick else 3
    wall, _ = timed(lambda: [work() for _ in range(repeats)])
    align_wall, _ = timed(lambda: [alignment.transform(x, g) for _ in range(repeats) for _, x, g in streams])
    n = repeats * len(streams)
    return {"unit": "sensor streams", "n": n, "wall_s": wall, "per_s_per_core": n / wall,
            "alignment_only_per_s": n / align_wall, "d_rank_windows": len(d_rank),
            "tracemalloc_peak_mb": traced_peak_mb(work),
            "note": f"{len(streams)} streams per fit: alignment, RankGrounder fit on them + D_rank, transform"}


def stage_post_motion(quick: bool) -> dict:
    """Everything of one fold after the motions, on one core: IMU simulation, CEM, alignment,
    rank grounding, windowing and the quality filter, its per-fold model fits included (the
    fold in this process with one BLAS thread, minus the time spent making the motions)."""
    one_thread()
    import vsmp_imu.pipeline.fold as fold
    import vsmp_imu.pipeline.sample as sample
    from vsmp_imu.executor import LocalExecutor

    seconds: dict[str, float] = defaultdict(float)

    def timing(fn, name):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                seconds[name] += time.perf_counter() - start
        return wrapper

    with ExitStack() as patches:
        for owner, attr, name in ((sample, "_motion", "motions"), (fold, "fit_filters", "filter_fits"),
                                  (fold, "choose_tau", "tau_selection")):
            patches.enter_context(mock.patch.object(owner, attr, timing(getattr(owner, attr), name)))
        fig = run_fold(LocalExecutor(1, show_progress=False), 0.1 if quick else 0.5)
    post = fig["wall_s"] - seconds["motions"]
    per_fold = seconds["filter_fits"] + seconds["tau_selection"]
    per_sample = fig["samples"] / (post - per_fold)
    fig.update({"motion_s": seconds["motions"], "post_motion_s": post, "per_fold_fits_s": per_fold,
                "filter_fits_s": seconds["filter_fits"], "tau_selection_s": seconds["tau_selection"],
                "per_s_per_core": fig["samples"] / post,
                "per_sample_per_s_per_core": per_sample,
                "target_samples_per_s": POST_MOTION_TARGET,
                "met": per_sample >= POST_MOTION_TARGET,
                "note": "one worker in this process, one BLAS thread; post-motion = fold wall - motion "
                        "time; per sample = post-motion minus the filter's per-fold fits (validator, "
                        "plausibility thresholds, tau_nn) and tau_cls selection"})
    return fig


def stage_chain(quick: bool) -> dict:
    from vsmp_imu.executor import LocalExecutor

    alpha = 0.1 if quick else 0.5
    fig = run_fold(LocalExecutor(CORES, show_progress=False), alpha)
    fig.update({"workers": CORES, "per_s_per_core": fig["samples_per_s"] / CORES,
                "target_samples_per_s": CHAIN_TARGET, "met": fig["samples_per_s"] >= CHAIN_TARGET,
                "note": f"HAPT12 holdout {HOLDOUT}, library SMPs, procedural, K=4, alpha {alpha}, "
                        "2 local workers, no cache"})
    return fig


def stage_chain_motion_fit(quick: bool) -> dict:
    """The chain with motion-level simulation-in-the-loop beside the chain without it: the fold
    run off, on, on, off (so drift in the machine's speed falls on both alike), rates from the
    summed walls; the fit's seconds per class on one core."""
    from vsmp_imu.executor import LocalExecutor
    from vsmp_imu.pipeline.spec import GenerationSpec

    alpha = 0.1 if quick else 0.5
    runs = [{"motion_fit": on, **run_fold(LocalExecutor(CORES, show_progress=False), alpha,
                                          GenerationSpec(motion_fit=on))}
            for on in (False, True, True, False)]
    info = hapt12_fold(alpha)[0]

    def rate(on: bool) -> float:
        chosen = [r for r in runs if r["motion_fit"] is on]
        return sum(r["samples"] for r in chosen) / sum(r["wall_s"] for r in chosen)

    fit_s = np.mean([r["steps_s"]["motion_fit"] for r in runs if r["motion_fit"]])
    per_class = float(fit_s) * CORES / info.n_classes  # the fits run on CORES workers
    return {"alpha": alpha, "runs": runs, "samples_per_s": rate(True),
            "samples_per_s_off": rate(False), "fit_s_per_class_per_core": per_class,
            "met": rate(True) >= MOTION_FIT_CHAIN_TARGET and per_class <= MOTION_FIT_CLASS_TARGET_S,
            "note": f"HAPT12 holdout {HOLDOUT}, alpha {alpha}, 2 local workers, no cache; off, on, on, off"}


def stage_chain_memory(quick: bool) -> dict:
    """tracemalloc peaks of the fold-level steps in the driver (a separate run; tracing is on
    only inside those steps, so the synthesis workers run untraced)."""
    from vsmp_imu.executor import LocalExecutor
    from vsmp_imu.pipeline.fold import FoldGenerator
    from vsmp_imu.pipeline.spec import GenerationSpec

    alpha = 0.05 if quick else 0.1
    info, train, library, sources, budget = hapt12_fold(alpha)
    peaks: dict[str, float] = {}

    def tracing(fn, name):
        if name == "nominal_mountings":
            return fn

        def wrapper(*args, **kwargs):
            tracemalloc.start()
            try:
                return fn(*args, **kwargs)
            finally:
                peaks[name] = tracemalloc.get_traced_memory()[1] / 2**20
                tracemalloc.stop()
        return wrapper

    gen = FoldGenerator(GenerationSpec(), LocalExecutor(CORES, show_progress=False), None, library=library)
    with patched_steps(tracing):
        gen.generate(info, train, sources, budget, 0, f"holdout-{HOLDOUT}")
    return {"step_tracemalloc_peak_mb": peaks, "alpha": alpha,
            "note": "driver-side allocations made during each step (inputs held before it not counted)"}


def _process_cpu_s() -> dict[int, tuple[str, float]]:
    """pid -> (role, CPU seconds so far) of this process and the processes that serve it:
    its children (pool workers, alive or exited), Ray's workers ("ray::..." titles) and
    Ray's daemons."""
    tick = os.sysconf("SC_CLK_TCK")
    me = os.getpid()
    reaped = resource.getrusage(resource.RUSAGE_CHILDREN)  # a local pool's workers, once they exit
    out = {-1: ("workers", reaped.ru_utime + reaped.ru_stime)}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
            cmd = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        comm = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        pid, ppid = int(entry.name), int(fields[1])
        cpu = (int(fields[11]) + int(fields[12])) / tick  # utime + stime
        if pid == me:
            role = "driver"
        elif comm in ("raylet", "gcs_server") or "/ray/" in cmd:  # Ray starts these as children too
            role = "ray daemons"
        elif cmd.startswith("ray::") or ppid == me:
            role = "workers"
        else:
            continue
        out[pid] = (role, cpu)
    return out


def _cpu_delta(before: dict, after: dict) -> dict[str, float]:
    """CPU seconds per role between two `_process_cpu_s` snapshots (new processes from 0)."""
    total: dict[str, float] = defaultdict(float)
    for pid, (role, cpu) in after.items():
        total[role] += cpu - before.get(pid, (role, 0.0))[1]
    return {role: round(v, 2) for role, v in sorted(total.items())}


def _started(make, workers: int, niceness: set | None = None):
    executor = make(workers)
    nice = executor.map(_warm, list(range(2 * workers)))  # start the workers outside the timings
    if niceness is not None:
        niceness.update(nice)
    return executor


def _close(executor) -> None:
    if hasattr(executor, "close"):
        executor.close()


def _scaling(make, alpha: float, replay_n: int) -> dict:
    """The whole fold with 1, 2, 2, then 1 workers (a drifting background load, or a VM's
    drifting CPU speed, affects both alike; the ratio is of the summed walls); then the
    synthesis of its first `replay_n` tasks replayed the same way on workers that have run
    a few samples before (warm, as in a long run)."""
    from vsmp_imu.pipeline.fold import run_item, sample_items

    out, folds, batches, niceness = {}, [], [], set()
    for workers in (1, 2, 2, 1):
        executor = _started(make, workers, niceness)
        cpu = _process_cpu_s()
        run = run_fold(executor, alpha, batches=batches if not out else None)
        run["cpu_s"] = _cpu_delta(cpu, _process_cpu_s())  # where the cores' time went
        run["load_avg_after"] = os.getloadavg()
        out.setdefault(str(workers), run)  # the first run of each count, in full
        folds.append({"workers": workers, "wall_s": run["wall_s"], "synthesis_map_s": run["synthesis_map_s"],
                      "steps_s": run["steps_s"], "cpu_s": run["cpu_s"]})
        _close(executor)
    # the samples of the fold's items (not the validator), re-cut into items as the fold cuts them
    samples = [t for batch in batches for item in batch if isinstance(item, tuple)
               for t in (item[0] if isinstance(item[0], tuple) else (item[0],))][:replay_n]  # side probes: one each
    tasks = sample_items(samples, None, 2)
    replay = []
    for workers in (1, 2, 2, 1):
        executor = _started(make, workers)
        # each worker's first samples load what the pipeline loads lazily (a pool's forked
        # workers inherit it from the driver, Ray's fresh workers do not): outside the timing
        executor.map(run_item, tasks[: 2 * workers])
        wall, _ = timed(lambda e=executor: e.map(run_item, tasks))
        replay.append({"workers": workers, "wall_s": wall, "load_avg_after": os.getloadavg()})
        _close(executor)

    def ratio(runs: list[dict], key: str) -> float:
        return sum(r[key] for r in runs if r["workers"] == 1) / sum(r[key] for r in runs if r["workers"] == 2)

    fig = {"runs": out, "fold_runs": folds, "alpha": alpha, "replay": replay, "replay_tasks": len(samples),
           "speedup_fold": ratio(folds, "wall_s"), "speedup_synthesis": ratio(folds, "synthesis_map_s"),
           "speedup_synthesis_abba": ratio(replay, "wall_s"), "target": SCALING_TARGET,
           "worker_niceness": sorted(niceness)}
    fig["met"] = fig["speedup_fold"] >= SCALING_TARGET
    fig["met_synthesis"] = fig["speedup_synthesis_abba"] >= SCALING_TARGET
    return fig


def stage_scaling_local(quick: bool) -> dict:
    """One BLAS thread in the driver too: `--workers 1` runs in-process, where NumPy would
    otherwise use both cores, while each pool worker is limited to one thread."""
    from vsmp_imu.executor import LocalExecutor

    one_thread()

    return _scaling(lambda w: LocalExecutor(w, show_progress=False), 0.05 if quick else 0.2,
                    60 if quick else 240)


class _RayPool:
    """A RayExecutor on a fresh local instance with `workers` CPUs."""

    def __init__(self, workers: int) -> None:
        import ray

        from vsmp_imu.executor import RayExecutor

        if ray.is_initialized():
            ray.shutdown()
        self.inner = RayExecutor(num_cpus=workers, show_progress=False)
        self.workers = workers  # what the fold reads to size its own steps' threads

    def map(self, fn, tasks, desc: str = "working"):
        return self.inner.map(fn, tasks, desc)

    def start(self, fn, item, desc: str = "working"):
        return self.inner.start(fn, item, desc)

    def close(self) -> None:
        import ray

        ray.shutdown()


def stage_scaling_ray(quick: bool) -> dict:
    """Ray's defaults: one CPU (and one BLAS thread) per task, workers at niceness 15."""
    one_thread()
    return _scaling(_RayPool, 0.05 if quick else 0.2, 60 if quick else 240)


def stage_scaling_ray_nice0(quick: bool) -> dict:
    """As `scaling_ray`, with Ray's workers at niceness 0 like the driver and a local pool's
    workers (`RAY_worker_niceness=0`): on a machine shared with other jobs, niceness 15
    leaves Ray's workers only the CPU time the other jobs do not take."""
    os.environ["RAY_worker_niceness"] = "0"  # noqa: SIM112 (Ray's own spelling)
    return stage_scaling_ray(quick)


def stage_har_rf(quick: bool) -> dict:
    import bench_har

    fig = bench_har.bench_rf(CORES, ("1", "2") if quick else None)
    fig.update({"target_s": RF_TARGET_S, "met": fig["thirty_fold_s"] <= RF_TARGET_S})
    return fig


def stage_har_guard(quick: bool) -> dict:
    import bench_har

    return bench_har.bench_guard(CORES, ("long-tail",) if quick else ("long-tail", "low-resource"))


def stage_har_dclstm(quick: bool) -> dict:
    import bench_har

    return bench_har.bench_dclstm("1", 1 if quick else 5, CORES, verbose=False)


def _context(alpha: float):
    from vsmp_imu.har.synthetic import FoldContext

    info, train, _, _, budget = hapt12_fold(alpha)
    names = train.label_names
    subjects = tuple(train.unique_subjects())
    return FoldContext(dataset=info, fold=HOLDOUT, held_out_subject=HOLDOUT, train=train,
                       train_subjects=subjects, seed=0, alpha=alpha, protocol="lopo",
                       budget={names[i]: int(n) for i, n in enumerate(budget) if n})


def _pose_pool(folder: Path, quick: bool) -> dict[str, float]:
    """Copies of the real clips as a source pool (walking, sitting); pose extraction timed per clip."""
    from vsmp_imu.baselines.generative import ImuTubeMethod

    clips = [("sitting", "carphone_pristine.mp4")] + ([] if quick else [("walking", "vtest.avi")])
    seconds = {}
    for activity, name in clips:
        (folder / activity).mkdir(parents=True, exist_ok=True)
        clip = shutil.copy(VIDEO_DIR / name, folder / activity / name)
        seconds[name], _ = timed(lambda c=clip, a=activity: ImuTubeMethod()._pose_motion(Path(c), a))
    return seconds


def stage_cost(quick: bool) -> dict:
    from vsmp_imu.baselines.classical import ClassicalAugmentation
    from vsmp_imu.baselines.generative import ImuGptMethod, ImuTubeMethod
    from vsmp_imu.methods import make

    alpha = 0.1 if quick else 0.2
    context = _context(alpha)
    out: dict[str, dict] = {}
    wall, windows = timed(lambda: ClassicalAugmentation().generate(context))
    out["classical"] = {"wall_s": wall, "samples": len(windows), "windows": len(windows),
                        "s_per_sample": wall / max(len(windows), 1),
                        "note": "a sample is one augmented window"}
    for name, method in (("imugpt", ImuGptMethod()), ("vsmp", make("vsmp"))):
        wall, windows = timed(lambda m=method: m.generate(context))
        fold = method.last_output_
        out[name] = {"wall_s": wall, "samples": len(fold.samples), "windows": len(fold.generated),
                     "selected": len(windows), "s_per_sample": wall / len(fold.samples),
                     "s_per_selected_window": wall / max(len(windows), 1)}
    if VIDEO_DIR.exists():
        with tempfile.TemporaryDirectory() as tmp:
            pool = Path(tmp) / "pool"
            pose = _pose_pool(pool, quick)
            method = ImuTubeMethod(source=f"video:{pool}")
            wall, windows = timed(lambda: method.generate(context))
            fold = method.last_output_
            per_clip = sum(pose.values()) / len(pose)
            out["imutube"] = {"wall_s": wall, "samples": len(fold.samples), "windows": len(fold.generated),
                              "selected": len(windows), "pose_s_per_clip": pose,
                              "pipeline_s_per_sample": wall / len(fold.samples),
                              "s_per_sample": per_clip + wall / len(fold.samples),
                              "note": "pose extraction of one clip + the pipeline, per sample "
                                      f"(classes with a clip only: {', '.join(sorted(set(np.array(context.train.label_names)[np.unique(windows.y)])))})"}
    else:
        out["imutube"] = {"skipped": f"{VIDEO_DIR} not found"}
    for name, fig in out.items():
        fig["paper_s_per_sample"] = PAPER_S_PER_SAMPLE[name]
    return {"methods": out, "alpha": alpha, "workers": 1,
            "note": "HAPT12 holdout 1, embedded default (library SMPs / offline descriptions, procedural "
                    "backend, CPU), 1 worker; paper: one A6000 Ada GPU with HY-Motion and a VLM"}


# --------------------------------------------------------------------------------------------
# driver
# --------------------------------------------------------------------------------------------
def _output(args: list[str]) -> str:
    """A command's standard output, run from the repository root ("" when it cannot run)."""
    try:
        return subprocess.run(args, cwd=REPO, capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.SubprocessError):
        return ""


def machine() -> dict:
    lscpu = {k.strip(): v.strip() for k, _, v in (line.partition(":") for line in _output(["lscpu"]).splitlines())}
    mem = _output(["free", "-g"]).splitlines()
    versions = {}
    for mod in ("numpy", "scipy", "sklearn", "torch", "ray", "pyarrow"):
        try:
            versions[mod] = __import__(mod).__version__
        except ImportError:
            versions[mod] = None
    return {"cpu": lscpu.get("Model name"), "cpus": lscpu.get("CPU(s)"),
            "threads_per_core": lscpu.get("Thread(s) per core"), "affinity_cores": len(os.sched_getaffinity(0)),
            "memory": mem[1].split()[1] + " GB" if len(mem) > 1 else None,
            "python": platform.python_version(), "platform": platform.platform(), "versions": versions}


def run_stage(name: str, quick: bool) -> dict:
    """Run one stage in a subprocess; its figures + peak memory + load average at its start."""
    with tempfile.NamedTemporaryFile(suffix=".json", delete=False) as fh:
        result_file = Path(fh.name)
    args = [sys.executable, str(Path(__file__).resolve()), "--stage", name, "--result-file", str(result_file)]
    load = os.getloadavg()
    start = time.perf_counter()
    done = subprocess.run(args + (["--quick"] if quick else []), cwd=REPO, capture_output=True, text=True)
    wall = time.perf_counter() - start
    try:
        if done.returncode != 0:
            return {"error": done.stderr[-3000:], "load_avg_at_start": load, "stage_wall_s": wall}
        fig = json.loads(result_file.read_text())
    finally:
        result_file.unlink(missing_ok=True)
    fig.update({"load_avg_at_start": load, "stage_wall_s": wall,
                "finished": dt.datetime.now().isoformat(timespec="seconds")})
    return fig


def _fmt(value, digits: int = 2) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.{digits}f}" if abs(value) < 1e4 else f"{value:.3g}"
    return str(value)


def table_rows(res: dict) -> list[tuple[str, str, str, str, str]]:
    """(figure, value, memory, target, status) rows."""
    rows = []
    st = res["stages"]
    rows += [(f"stage {name}", "FAILED", "", "", "see the JSON") for name, fig in st.items() if "error" in fig]

    def mem(fig):
        if not fig or "maxrss_mb" not in fig:
            return "–"
        text = f"{fig['maxrss_mb']:.0f} MB rss"
        if fig.get("tracemalloc_peak_mb") is not None:
            text += f", {fig['tracemalloc_peak_mb']:.1f} MB traced"
        return text

    for key, label in (("smp_augment", "SMP augmentation"), ("procedural_motion", "procedural motion"),
                       ("imu_simulation", "IMU simulation"), ("cem", "CEM (vectorized)"),
                       ("align_rank", "alignment + rank grounding")):
        fig = st.get(key)
        if fig and "error" not in fig:
            rows.append((f"{label} [{fig['unit']}/s per core]", _fmt(fig["per_s_per_core"], 1), mem(fig), "", ""))
    cem = st.get("cem")
    if cem and "error" not in cem:
        rows.append(("CEM naive loop / vectorized [ratio]", _fmt(cem["naive_over_vectorized"], 1), "",
                     "", f"{cem['vectorized_s'] * 1e3:.0f} ms vs {cem['naive_loop_s']:.2f} s per calibration"))
        if "lockstep_per_s_per_core" in cem:
            rows.append((f"CEM, {cem['lockstep_batch']} streams in lockstep [calibrations/s per core]",
                         _fmt(cem["lockstep_per_s_per_core"], 1), "", "",
                         f"{cem['lockstep_s'] * 1e3:.1f} ms per calibration; same eta as alone: "
                         f"{'yes' if cem['lockstep_same_eta'] else 'NO'}"))
    post = st.get("post_motion")
    if post and "error" not in post:
        rows.append(("post-motion stages per sample, 1 core [samples/s per core]",
                     _fmt(post["per_sample_per_s_per_core"], 1), mem(post),
                     f">= {POST_MOTION_TARGET:g}", "met" if post["met"] else "NOT met"))
        rows.append(("  same with the fold's filter fits and tau_cls selection [samples/s per core]",
                     _fmt(post["per_s_per_core"], 1), "", "",
                     f"{post['samples']} samples; fits {post['filter_fits_s']:.1f} s, "
                     f"tau_cls {post['tau_selection_s']:.1f} s, motions {post['motion_s']:.1f} s"))
    chain = st.get("chain")
    if chain and "error" not in chain:
        rows.append(("whole embedded chain [samples/s, 2 workers]", _fmt(chain["samples_per_s"], 1),
                     mem(chain),
                     f">= {CHAIN_TARGET:g}", "met" if chain["met"] else "NOT met"))
        rows.append(("  same, per core [samples/s]", _fmt(chain["per_s_per_core"], 1), "", "", ""))
        peaks = st.get("chain_memory", {}).get("step_tracemalloc_peak_mb", {})
        for step in ("side_evidence", "synthesize", "texture", "ground", "window", "filter", "select"):
            seconds = chain["steps_s"].get(step)
            if seconds:
                rate = chain["samples"] / seconds
                peak = f"{peaks[step]:.0f} MB traced" if step in peaks else ""
                rows.append((f"  chain step {step} [samples/s; s]", f"{rate:.1f}; {seconds:.1f} s", peak, "", ""))
    fit = st.get("chain_motion_fit")
    if fit and "error" not in fit:
        rows.append(("chain with motion fit [samples/s, 2 workers]", _fmt(fit["samples_per_s"], 1), "",
                     f">= {MOTION_FIT_CHAIN_TARGET:g}", "met" if fit["samples_per_s"] >= MOTION_FIT_CHAIN_TARGET
                     else "NOT met"))
        rows.append(("  same run, chain without it [samples/s]", _fmt(fit["samples_per_s_off"], 1), "", "", ""))
        per_class = fit["fit_s_per_class_per_core"]
        rows.append(("  motion fit per class, 1 core [s]", _fmt(per_class, 2), "",
                     f"<= {MOTION_FIT_CLASS_TARGET_S:g}", "met" if per_class <= MOTION_FIT_CLASS_TARGET_S
                     else "NOT met"))
    for key, label in (("scaling_local", "local pool"), ("scaling_ray", "local Ray"),
                       ("scaling_ray_nice0", "local Ray, workers at nice 0")):
        fig = st.get(key)
        if fig and "error" not in fig:
            order = "1,2,2,1" if "fold_runs" in fig else "1,2"
            rows.append((f"1 -> 2 workers, {label}, whole fold x {order} [x]", _fmt(fig["speedup_fold"]), "",
                         f">= {SCALING_TARGET:g}", "met" if fig["met"] else "NOT met"))
            rows.append((f"1 -> 2 workers, {label}, synthesis step of that fold [x]",
                         _fmt(fig["speedup_synthesis"]), "", "", ""))
            if "speedup_synthesis_abba" in fig:
                rows.append((f"1 -> 2 workers, {label}, synthesis, {fig['replay_tasks']} tasks x 1,2,2,1 [x]",
                             _fmt(fig["speedup_synthesis_abba"]), "", f">= {SCALING_TARGET:g}",
                             "met" if fig["met_synthesis"] else "NOT met"))
    rf = st.get("har_rf")
    if rf and "error" not in rf:
        how = "extrapolated" if rf["extrapolated"] else "measured"
        rows.append((f"HAPT 30-fold RF-ECDF LOPO [s, {how}]", _fmt(rf["thirty_fold_s"], 0), mem(rf),
                     f"<= {RF_TARGET_S:g}", "met" if rf["met"] else "NOT met"))
    dcl = st.get("har_dclstm")
    if dcl and "error" not in dcl:
        rows.append((f"DeepConvLSTM fold [wall s / epochs, {dcl['epochs']} of cap {dcl['max_epochs']}]",
                     _fmt(dcl["per_epoch_s"], 1),
                     mem(dcl), "", f"{dcl['train_windows_per_s']:.0f} training windows/s"))
    guard = st.get("har_guard")
    if guard and "error" not in guard:
        for protocol, fig in guard["protocols"].items():
            where = "5 %" if protocol == "low-resource" else protocol
            rows.append((f"HAPT12 fold, RF, {where}: with the do-no-harm guard / without [x]", _fmt(fig["ratio"]),
                         "", "", f"{fig['class_s']:.1f} s / {fig['off_s']:.1f} s (Classical Aug's windows)"))
    cost = st.get("cost")
    if cost and "error" not in cost:
        for name, label in (("classical", "Classical Aug"), ("imutube", "IMUTube-style"),
                            ("imugpt", "IMUGPT-2.0-style"), ("vsmp", "VSMP-IMU")):
            fig = cost["methods"].get(name, {})
            value = _fmt(fig.get("s_per_sample"), 4 if name == "classical" else 3)
            rows.append((f"cost: {label} [s per synthetic sample]", value, "",
                         f"paper {PAPER_S_PER_SAMPLE[name]:g} s", fig.get("skipped", "")))
    return rows


# -- tables composed from some stages (`vsmp-imu report`, kind benchmark with a view) ------------
def stage_command(res: dict, stage: str) -> dict:
    """The run (the first one or an `--update`) that measured `stage` last: the latest one started
    before the stage finished whose `--stages` names it (or that ran every stage)."""
    finished = res["stages"][stage]["finished"]
    runs = [{"command": res["command"], "started": res["started"]}, *res.get("updates", [])]
    named = [r for r in runs if r["started"] <= finished and ("--stages" not in r["command"]
                                                              or stage in _stages_of(r["command"]))]
    return max(named, key=lambda r: r["started"]) if named else runs[0]


def _stages_of(command: str) -> list[str]:
    words = command.split()
    return words[words.index("--stages") + 1].split(",")


def _provenance(res: dict, stages: tuple[str, ...]) -> str:
    """Which stages of run_all.json a table shows, by which command and when."""
    by_run: dict[str, list[str]] = defaultdict(list)
    for stage in stages:
        by_run[stage_command(res, stage)["command"]].append(stage)
    parts = []
    for command, names in by_run.items():
        finished = ", ".join(f"{n} {res['stages'][n]['finished']}" for n in names)
        parts.append(f"`{command}` (finished: {finished})")
    named = ", ".join(f"`{s}`" for s in stages)
    return f"{'stage' if len(stages) == 1 else 'stages'} {named} of `benchmarks/results/run_all.json`, from " + \
        "; ".join(parts)


COST_METHODS = (("classical", "Classical Aug"), ("imutube", "IMUTube-style"), ("imugpt", "IMUGPT-2.0-style"),
                ("vsmp", "VSMP-IMU"))
# what each method's sample is and what its time includes (the figures come from the stage)
COST_WHAT = {
    "imugpt": "one motion from an offline description (library captions × modifiers; no LLM call), procedural "
              "backend, IMU, plausibility and redundancy filters, rank grounding",
    "vsmp": "one motion from an SMP variant (library SMPs: no video extraction), procedural backend, IMU, CEM, "
            "alignment, rank grounding, all three filters",
}
PAPER_BOUND = {"classical": "< "}  # the paper gives Classical Aug's cost as a bound


def _cost_what(name: str, fig: dict) -> str:
    if name == "classical":
        return f"one augmented window ({fig['windows']:,} windows in {fig['wall_s']:.2f} s)".replace(",", " ")
    if name == "imutube":
        pose = fig["pose_s_per_clip"]
        clips = " and ".join(f"{s:.1f} s for `{clip}`" for clip, s in pose.items())
        return (f"one clip → MediaPipe pose → SMPL-22 motion → IMU → rank grounding; pose extraction {clips}, "
                f"mean {sum(pose.values()) / len(pose):.1f} s per clip, plus {fig['pipeline_s_per_sample']:.3f} s "
                f"per sample for the rest of the pipeline ({fig['samples']} samples from the {len(pose)} clips)")
    return (f"{COST_WHAT[name]} ({fig['samples']} samples in {fig['wall_s']:.1f} s; "
            f"{fig['s_per_selected_window']:.3f} s per selected window)")


def cost_view(res: dict) -> tuple[str, str]:
    """Seconds per synthetic sample of each method (stage `cost`) beside the paper's."""
    cost = res["stages"]["cost"]
    lines = ["| method | s per sample here | what a sample is and what the time includes | paper |",
             "| --- | ---: | --- | ---: |"]
    for name, label in COST_METHODS:
        fig = cost["methods"][name]
        paper = f"{PAPER_BOUND.get(name, '')}{fig['paper_s_per_sample']:g}"
        if "skipped" in fig:
            lines.append(f"| {label} | – | not measured: {fig['skipped']} | {paper} |")
            continue
        digits = 4 if name == "classical" else 3 if fig["s_per_sample"] < 1 else 2
        lines.append(f"| {label} | {fig['s_per_sample']:.{digits}f} | {_cost_what(name, fig)} | {paper} |")
    setting = (f"One HAPT12 fold (held-out subject {HOLDOUT}), α = {cost['alpha']:g}, {cost['workers']} worker, "
               "no cache.")
    return "\n".join(lines) + "\n\n" + setting + "\n", _provenance(res, ("cost",))


SCALING_EXECUTORS = (("scaling_local", "local pool"), ("scaling_ray", "Ray, local instance"),
                     ("scaling_ray_nice0", "Ray, local instance, `RAY_worker_niceness=0`"))


def _mean(runs: list[dict], workers: int, key: str) -> float:
    values = [r[key] for r in runs if r["workers"] == workers]
    return sum(values) / len(values)


def scaling_view(res: dict) -> tuple[str, str]:
    """Walls and ratios of the scaling stages: means of the runs per worker count."""
    lines = ["| executor | whole fold, 1 → 2 workers | speedup | synthesis step, "
             "1 → 2 workers | speedup | synthesis replay ({n} tasks, 1, 2, 2, 1 workers) |",
             "| --- | --- | ---: | --- | ---: | ---: |"]
    shown, tasks = [], set()
    for stage, label in SCALING_EXECUTORS:
        fig = res["stages"].get(stage)
        if not fig or "error" in fig:
            continue
        shown.append(stage)
        tasks.add(fig["replay_tasks"])
        runs = fig["fold_runs"]
        if stage == "scaling_ray":
            label += f" (workers at niceness {', '.join(map(str, fig['worker_niceness']))}, Ray's default)"
        lines.append(f"| {label} | {_mean(runs, 1, 'wall_s'):.1f} s → {_mean(runs, 2, 'wall_s'):.1f} s | "
                     f"{fig['speedup_fold']:.2f}× | {_mean(runs, 1, 'synthesis_map_s'):.1f} s → "
                     f"{_mean(runs, 2, 'synthesis_map_s'):.1f} s | {fig['speedup_synthesis']:.2f}× | "
                     f"{fig['speedup_synthesis_abba']:.2f}× |")
    lines[0] = lines[0].format(n="/".join(str(t) for t in sorted(tasks)))
    alpha = {res["stages"][s]["alpha"] for s in shown}
    setting = (f"One HAPT12 fold (held-out subject {HOLDOUT}), α = {'/'.join(f'{a:g}' for a in sorted(alpha))}, "
               "no cache; the fold with 1, 2, 2 and 1 workers (walls: the mean of the two runs per count; "
               "speedup: the ratio of the summed walls).")
    return "\n".join(lines) + "\n\n" + setting + "\n", _provenance(res, tuple(shown))


def scaling_cpu_view(res: dict) -> tuple[str, str]:
    """Where the cores' time went in each fold of the scaling stages (CPU-seconds per role)."""
    lines = ["| executor | workers | wall | CPU-s driver | CPU-s workers | CPU-s Ray daemons | CPU-s in all | "
             "cores busy |", "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    shown = []
    for stage, label in SCALING_EXECUTORS:
        fig = res["stages"].get(stage)
        if not fig or "error" in fig:
            continue
        shown.append(stage)
        for r in fig["fold_runs"]:
            cpu = r["cpu_s"]
            total = sum(cpu.values())
            daemons = f"{cpu['ray daemons']:.1f}" if "ray daemons" in cpu else "–"
            lines.append(f"| {label} | {r['workers']} | {r['wall_s']:.1f} s | {cpu['driver']:.1f} | "
                         f"{cpu['workers']:.1f} | {daemons} | {total:.1f} | {total / r['wall_s']:.2f} |")
    note = ("The fold of each scaling stage in the order it ran (1, 2, 2, 1 workers); with one local worker the "
            "fold runs in the driver's process. Cores busy: CPU-seconds in all over the wall.")
    return "\n".join(lines) + "\n\n" + note + "\n", _provenance(res, tuple(shown))


def speed_view(res: dict) -> tuple[str, str]:
    """The headline speed figures of README.md, from the committed stages."""
    st = res["stages"]
    chain, post, rf, cost = st["chain"], st["post_motion"], st["har_rf"], st["cost"]["methods"]["vsmp"]
    ray = st.get("scaling_ray")
    scaling = f"{st['scaling_local']['speedup_fold']:.2f}× on the local pool"
    if ray and "error" not in ray:
        scaling += f", {ray['speedup_fold']:.2f}× on a local Ray instance"
    rows = [("whole embedded chain, one HAPT12 fold, 2 workers", f"{chain['samples_per_s']:.1f} synthetic samples/s"),
            ("post-motion stages (IMU simulation, CEM, alignment, grounding, filter), one core",
             f"{post['per_sample_per_s_per_core']:.1f} samples/s ({post['per_s_per_core']:.1f} counting the "
             "filter's once-per-fold fits)"),
            ("HAPT 30-fold RF-ECDF LOPO", f"{rf['thirty_fold_s']:.0f} s"),
            ("one generation fold, 1 → 2 workers", scaling),
            ("cost per synthetic sample, VSMP-IMU (procedural backend, no VLM), one worker",
             f"{cost['s_per_sample']:.3f} s")]
    fit = st.get("chain_motion_fit")
    has_fit = bool(fit) and "error" not in fit
    if has_fit:
        rows.insert(1, ("the same chain with motion-level simulation-in-the-loop, beside it without",
                        f"{fit['samples_per_s']:.1f} against {fit['samples_per_s_off']:.1f} samples/s "
                        f"({fit['samples_per_s'] / fit['samples_per_s_off']:.2f}×); fitting "
                        f"{fit['fit_s_per_class_per_core']:.2f} s per class on one core"))
    lines = ["| what | measured |", "| --- | --- |"] + [f"| {a} | {b} |" for a, b in rows]
    stages = ("chain", *(("chain_motion_fit",) if has_fit else ()), "post_motion", "har_rf", "scaling_local",
              *(("scaling_ray",) if "Ray" in scaling else ()), "cost")
    return "\n".join(lines) + "\n", _provenance(res, stages)


def imu_view(res: dict) -> tuple[str, str]:
    """The IMU simulation and CEM rates of docs/imu.md, from their stages."""
    imu, cem = res["stages"]["imu_simulation"], res["stages"]["cem"]
    rows = [(f"IMU simulation ({imu['note']}), one core",
             f"{imu['per_s_per_core']:.1f} sensor streams/s ({1e3 / imu['per_s_per_core']:.1f} ms per stream; "
             f"{imu['n']} streams)"),
            (f"CEM, vectorized ({cem['note'].split(';')[0]}), one core",
             f"{cem['per_s_per_core']:.1f} calibrations/s ({1e3 * cem['vectorized_s']:.0f} ms per calibration)"),
            ("CEM scoring each candidate in a Python loop",
             f"{cem['naive_loop_s']:.2f} s per calibration: {cem['naive_over_vectorized']:.1f}× the vectorized "
             f"one (largest difference in η* {cem['max_abs_eta_difference']:g} over {cem['naive_n']} calibrations)")]
    lines = ["| what | measured |", "| --- | --- |"] + [f"| {a} | {b} |" for a, b in rows]
    return "\n".join(lines) + "\n", _provenance(res, ("imu_simulation", "cem"))


def _thousands(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def notes_view(res: dict) -> tuple[str, str]:
    """The notes under the table of all figures: how some rows are made up, from their stages."""
    st = res["stages"]
    post, cem, dcl, rf = st["post_motion"], st["cem"], st["har_dclstm"], st["har_rf"]
    per_sample_s = post["post_motion_s"] - post["per_fold_fits_s"]
    notes = [
        f"**Post-motion stages.** The fold of the chain row (HAPT12, held-out subject {HOLDOUT}, α = "
        f"{post['alpha']:g}, {post['samples']} samples) run in the benchmark's own process with one worker and one "
        f"BLAS thread, the motion synthesis timed and subtracted ({post['motion_s']:.1f} s of the "
        f"{post['wall_s']:.1f} s). What remains, {post['post_motion_s']:.1f} s, is IMU simulation, CEM, alignment, "
        f"rank grounding, windowing and the quality filter. {post['per_fold_fits_s']:.1f} s of it does not grow "
        f"with the samples: the filter's fits on the fold's real windows (validator, plausibility thresholds, "
        f"τ_nn: {post['filter_fits_s']:.1f} s) and the τ_cls selection ({post['tau_selection_s']:.1f} s). Per "
        f"sample, then, {post['samples']} / {per_sample_s:.1f} s = {post['per_sample_per_s_per_core']:.1f} "
        f"samples/s per core; with the per-fold costs spread over this fold's samples, "
        f"{post['per_s_per_core']:.1f}. A fold with more samples (a larger α, K or refill) moves the second "
        "figure towards the first.",
        f"**CEM ratio.** The naive loop is the same bounded CEM (same random draws, same elites) scoring each of "
        "the 64 candidates on its own: its readings simulated, summarized and compared. The vectorized CEM "
        "simulates the kinematics once and scores all candidates with one set of linear moments. Both give the "
        f"same η* (largest difference {cem['max_abs_eta_difference']:g} over {cem['naive_n']} calibrations). "
        f"{1e3 * cem['vectorized_s']:.0f} ms against {cem['naive_loop_s']:.2f} s per calibration: "
        f"{cem['naive_over_vectorized']:.0f}×.",
        f"**DeepConvLSTM.** One HAPT fold (held-out subject {dcl['fold']}: {_thousands(dcl['n_train'])} training "
        f"and {_thousands(dcl['n_val'])} validation windows), AdamW, batch 1024, {dcl['threads']} threads, capped at "
        f"{dcl['max_epochs']} epochs (the default cap is 60 with patience 10): {dcl['wall_s']:.0f} s in all, "
        f"{dcl['per_epoch_s']:.1f} s per epoch including data preparation and evaluation; Macro-F1 "
        f"{100 * dcl['macro_f1']:.2f} after {dcl['epochs']} epochs.",
        f"**HAR RF.** {rf['per_fold_s']:.1f} s per fold, {rf['folds_run']} folds, n_jobs {rf['n_jobs']}.",
    ]
    text = "\n".join(f"- {n}" for n in notes) + "\n"
    return text, _provenance(res, ("post_motion", "cem", "har_dclstm", "har_rf"))


def _load_range(res: dict) -> str:
    loads = [f["load_avg_at_start"][0] for f in res["stages"].values() if "load_avg_at_start" in f]
    return f"{min(loads):.1f}–{max(loads):.1f}"


def run_view(res: dict) -> tuple[str, str]:
    """The runs behind run_all.json: commands, dates, machine, software, load."""
    runs = [{"command": res["command"], "started": res["started"]}, *res.get("updates", [])]
    m = res["machine"]
    versions = ", ".join(f"{k} {v}" for k, v in m["versions"].items() if v)
    rows = [("commands", "; ".join(f"`{r['command']}` (started {r['started']})" for r in runs)),
            ("machine", f"{m['cpu']}, {m['cpus']} CPUs ({m['threads_per_core']} thread per core, "
                        f"{m['affinity_cores']} usable), {m['memory']} RAM"),
            ("software", f"{m['platform']}, Python {m['python']}, {versions}"),
            ("load average (1 min) at each stage's start", _load_range(res))]
    lines = ["| | |", "| --- | --- |"] + [f"| {a} | {b} |" for a, b in rows]
    return "\n".join(lines) + "\n", "`benchmarks/results/run_all.json` (its `command`, `updates` and `machine`)"


def _met(ok: bool) -> str:
    return "met" if ok else "NOT met"


def _scaling_cells(fig: dict) -> tuple[str, str]:
    walls = ", ".join(f"{r['wall_s']:.1f}" for r in fig["fold_runs"])
    order = ", ".join(str(r["workers"]) for r in fig["fold_runs"])
    figures = (f"whole fold **{fig['speedup_fold']:.2f}×** ({order} workers: {walls} s), synthesis step of the "
               f"fold {fig['speedup_synthesis']:.2f}×, synthesis replay **{fig['speedup_synthesis_abba']:.2f}×**")
    status = f"whole fold {_met(fig['met'])}, synthesis replay {_met(fig['met_synthesis'])}"
    return figures, status


def targets_view(res: dict) -> tuple[str, str]:
    """The speed targets and what the committed stages measured against them."""
    st = res["stages"]
    chain, post, rf = st["chain"], st["post_motion"], st["har_rf"]
    rows = [(f"whole embedded chain ≥ {CHAIN_TARGET:g} synthetic samples/s on {CORES} cores",
             f"**{chain['samples_per_s']:.1f} samples/s** ({chain['samples']} samples of one HAPT12 fold in "
             f"{chain['wall_s']:.1f} s, {chain['workers']} workers)", _met(chain["met"])),
            (f"post-motion stages (IMU simulation + CEM + alignment + grounding + filter) ≥ "
             f"{POST_MOTION_TARGET:g} samples/s per core",
             f"**{post['per_sample_per_s_per_core']:.1f} samples/s per core** per sample ({post['samples']} "
             f"samples of one HAPT12 fold, α = {post['alpha']:g}, one core); {post['per_s_per_core']:.1f} with "
             "the fold's once-per-fold fits counted (below)",
             f"{_met(post['met'])} per sample; the per-fold fits are a fixed cost of "
             f"{post['per_fold_fits_s']:.0f} s per fold")]
    folds = "all 30 folds measured" if not rf["extrapolated"] else f"{rf['folds_run']} folds, extrapolated"
    rows.append((f"HAPT 30-fold RF-ECDF LOPO ≤ {RF_TARGET_S / 60:g} min",
                 f"**{rf['thirty_fold_s']:.0f} s** ({folds}, n_jobs {rf['n_jobs']}; Macro-F1 "
                 f"{100 * rf['macro_f1']:.2f} ± {100 * rf['macro_f1_std']:.2f})", _met(rf["met"])))
    figures, status = _scaling_cells(st["scaling_local"])
    rows.append((f"1 → 2 workers ≥ {SCALING_TARGET:g}× on generation, local pool", figures, status))
    figures, status = _scaling_cells(st["scaling_ray"])
    nice0 = st.get("scaling_ray_nice0")
    if nice0 and "error" not in nice0:
        other, other_status = _scaling_cells(nice0)
        figures += f"; with Ray's workers at niceness 0: {other.replace('**', '')}"
        status += f"; at niceness 0: {other_status}"
    rows.append((f"1 → 2 workers ≥ {SCALING_TARGET:g}× on generation, local Ray", figures, status))
    fit = st.get("chain_motion_fit")
    has_fit = bool(fit) and "error" not in fit
    if has_fit:
        rows += _motion_fit_rows(fit)
    lines = ["| target | measured | status |", "| --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    stages = ("chain", "post_motion", "har_rf", "scaling_local", "scaling_ray",
              *(("scaling_ray_nice0",) if nice0 and "error" not in nice0 else ()),
              *(("chain_motion_fit",) if has_fit else ()))
    return "\n".join(lines) + "\n", _provenance(res, stages)


def _motion_fit_rows(fit: dict) -> list[tuple[str, str, str]]:
    """The two targets of motion-level simulation-in-the-loop: the chain with it (beside the chain
    without it, same stage) and the fit's seconds per class on one core."""
    order = ", ".join("on" if r["motion_fit"] else "off" for r in fit["runs"])
    walls = ", ".join(f"{r['wall_s']:.1f}" for r in fit["runs"])
    ratio = fit["samples_per_s"] / fit["samples_per_s_off"]
    per_class = fit["fit_s_per_class_per_core"]
    return [(f"whole embedded chain with motion-level simulation-in-the-loop ≥ {MOTION_FIT_CHAIN_TARGET:g} "
             f"synthetic samples/s on {CORES} cores",
             f"**{fit['samples_per_s']:.1f} samples/s**; the chain without it in the same stage "
             f"{fit['samples_per_s_off']:.1f}: {ratio:.2f}× its rate (one fold {order}: {walls} s)",
             _met(fit["samples_per_s"] >= MOTION_FIT_CHAIN_TARGET)),
            (f"motion fitting ≤ {MOTION_FIT_CLASS_TARGET_S:g} s per class and fold on one core",
             f"**{per_class:.2f} s** (the fold's classes fitted on {CORES} workers)",
             _met(per_class <= MOTION_FIT_CLASS_TARGET_S))]


# -- the scaling history: one line per run that measured a scaling stage ---------------------------
def _git(*args: str) -> str:
    return _output(["git", *args]).strip()


def code_state() -> dict:
    """The commit the run measured, and whether tracked files differed from it."""
    return {"commit": _git("rev-parse", "HEAD") or None,
            "dirty": bool(_git("status", "--porcelain", "--untracked-files=no"))}


def scaling_entry(res: dict, stages: list[str], run: dict) -> dict:
    """The history line of one run: its command, start and code (`run`), and the figures of the
    scaling stages it measured."""
    executors = {}
    for stage in stages:
        fig = res["stages"][stage]
        executors[stage] = {
            "fold_runs": [{k: r[k] for k in ("workers", "wall_s", "synthesis_map_s")} for r in fig["fold_runs"]],
            "replay": [{k: r[k] for k in ("workers", "wall_s")} for r in fig["replay"]],
            **{k: fig[k] for k in ("replay_tasks", "alpha", "worker_niceness", "speedup_fold", "speedup_synthesis",
                                   "speedup_synthesis_abba", "load_avg_at_start", "finished")}}
    machine = res.get("machine", {})
    return {**run, "machine": {"cpu": machine.get("cpu"), "cpus": machine.get("cpus")}, "executors": executors}


def append_history(path: Path, entry: dict) -> None:
    """Add one line to the history (the file is rewritten whole, atomically)."""
    from vsmp_imu.io import read_text, write_text

    earlier = read_text(path) if path.exists() else ""
    write_text(path, earlier + json.dumps(entry, sort_keys=True, default=float) + "\n")


# -- the scaling history's tables -----------------------------------------------------------------
def _executor_label(stage: str) -> str:
    return dict(SCALING_EXECUTORS)[stage]


def _ratios(figs: list[dict], key: str) -> str:
    low, high = min(f[key] for f in figs), max(f[key] for f in figs)
    return f"{low:.2f}×" if f"{low:.2f}" == f"{high:.2f}" else f"{low:.2f}–{high:.2f}×"


def _run_label(entry: dict) -> str:
    code = f"`{entry['commit'][:7]}`{' + changes' if entry['dirty'] else ''}" if entry.get("commit") else \
        "code not recorded"
    return f"{entry['started']} ({code})"


def scaling_runs_view(history: list[dict]) -> tuple[str, str]:
    """Every recorded scaling run, oldest first: the ratios of each executor it measured."""
    lines = ["| run | executor | whole fold, 1 → 2 workers | synthesis step of the fold | synthesis replay "
             "| load average at the stage's start |", "| --- | --- | --- | ---: | --- | ---: |"]
    for entry in history:
        for stage, fig in ((s, entry["executors"][s]) for s, _ in SCALING_EXECUTORS if s in entry["executors"]):
            walls = ", ".join(f"{r['wall_s']:.1f}" for r in fig["fold_runs"])
            order = ", ".join(str(r["workers"]) for r in fig["fold_runs"])
            lines.append(f"| {_run_label(entry)} | {_executor_label(stage)} | {fig['speedup_fold']:.2f}× ({order} "
                         f"workers: {walls} s) | {fig['speedup_synthesis']:.2f}× | "
                         f"{fig['speedup_synthesis_abba']:.2f}× ({fig['replay_tasks']} tasks) | "
                         f"{fig['load_avg_at_start'][0]:.1f} |")
    return "\n".join(lines) + "\n", _history_provenance(history)


def scaling_spread_view(history: list[dict]) -> tuple[str, str]:
    """Per executor, the range of each ratio over the recorded runs."""
    lines = ["| executor | runs | whole fold | synthesis step of the fold | synthesis replay |",
             "| --- | ---: | ---: | ---: | ---: |"]
    for stage, label in SCALING_EXECUTORS:
        figs = [e["executors"][stage] for e in history if stage in e["executors"]]
        if figs:
            lines.append(f"| {label} | {len(figs)} | {_ratios(figs, 'speedup_fold')} | "
                         f"{_ratios(figs, 'speedup_synthesis')} | {_ratios(figs, 'speedup_synthesis_abba')} |")
    return "\n".join(lines) + "\n", _history_provenance(history)


def _history_provenance(history: list[dict]) -> str:
    runs = "; ".join(f"`{e['command']}` (started {e['started']})" for e in history)
    return (f"`benchmarks/results/scaling_history.jsonl`, {len(history)} "
            f"{'run' if len(history) == 1 else 'runs'} of `benchmarks/run_all.py` with a scaling stage: {runs}")


VIEWS = {"per_sample": cost_view, "scaling": scaling_view, "scaling_cpu": scaling_cpu_view, "targets": targets_view,
         "speed": speed_view, "imu": imu_view, "notes": notes_view, "run": run_view, "scaling_runs": scaling_runs_view, "scaling_spread": scaling_spread_view}


def print_table(rows) -> None:
    widths = [max(len(r[i]) for r in rows + [("figure", "value", "peak memory", "target", "status")])
              for i in range(5)]
    for r in [("figure", "value", "peak memory", "target", "status")] + rows:
        print("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)))


def markdown(rows) -> str:
    lines = ["| figure | value | peak memory | target | status |", "| --- | ---: | --- | --- | --- |"]
    lines += ["| " + " | ".join(c.replace("|", "/") for c in r) + " |" for r in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a short version (minutes): fewer repeats, "
                        "smaller folds, RF on 2 folds (extrapolated), 1 DeepConvLSTM epoch")
    parser.add_argument("--stages", default=",".join(STAGES), help="comma-separated subset of: " + ", ".join(STAGES))
    parser.add_argument("--json", type=Path, default=None, help="where to write the figures")
    parser.add_argument("--markdown", type=Path, default=None,
                        help="where to write the table as Markdown (default: the JSON path with .md)")
    parser.add_argument("--update", action="store_true", help="keep the other stages of an existing JSON")
    parser.add_argument("--report", action="store_true", help="only print (and --markdown) the table of "
                        "an existing JSON")
    parser.add_argument("--history", type=Path, default=HISTORY,
                        help="the scaling history a run with a scaling stage adds one line to (not with --quick)")
    parser.add_argument("--no-history", action="store_true", help="add nothing to the scaling history")
    parser.add_argument("--stage", help=argparse.SUPPRESS)
    parser.add_argument("--result-file", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()

    if args.stage:  # inside the subprocess of one stage
        fig = globals()[f"stage_{args.stage}"](args.quick)
        fig.update(maxrss_mb())
        args.result_file.write_text(json.dumps(fig, default=float))
        return

    chosen = [s.strip() for s in args.stages.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in STAGES]
    if unknown:
        parser.error(f"unknown stage(s) {', '.join(unknown)}; choose from {', '.join(STAGES)}")
    path = args.json or HERE / "results" / ("run_all_quick.json" if args.quick else "run_all.json")
    markdown_path = args.markdown or path.with_suffix(".md")
    if args.report:
        report(json.loads(path.read_text()), markdown_path)
        return
    results = json.loads(path.read_text()) if args.update and path.exists() else {"stages": {}}
    command = " ".join([Path(sys.executable).name, "benchmarks/run_all.py"] + sys.argv[1:])
    run = {"command": command, "started": dt.datetime.now().isoformat(timespec="seconds"), **code_state()}
    if args.update:  # the first run's command, date and load stay; this one is added
        results.setdefault("updates", []).append({"command": command, "load_avg_at_start": os.getloadavg(),
                                                  "started": run["started"]})
    else:
        results.update({"command": command, "quick": args.quick, "load_avg_at_start": os.getloadavg(),
                        "started": run["started"]})
    results["machine"] = machine()
    for name in chosen:
        print(f"[{time.strftime('%H:%M:%S')}] {name} (load average {os.getloadavg()[0]:.2f}) ...", flush=True)
        results["stages"][name] = fig = run_stage(name, args.quick)
        if "error" in fig:
            print(f"  FAILED:\n{fig['error']}", flush=True)
        else:
            print(f"  done in {fig['stage_wall_s']:.0f} s", flush=True)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(results, indent=2, default=float) + "\n")
    if not args.update:
        results["finished"] = dt.datetime.now().isoformat(timespec="seconds")
        results["load_avg_at_end"] = os.getloadavg()
    path.write_text(json.dumps(results, indent=2, default=float) + "\n")
    report(results, markdown_path)
    print(f"\nfigures: {path}, table: {markdown_path}")
    scaled = [n for n in chosen if n in dict(SCALING_EXECUTORS) and "error" not in results["stages"][n]]
    if scaled and not (args.quick or args.no_history):
        append_history(args.history, scaling_entry(results, scaled, run))
        print(f"scaling history: {args.history} (one line added)")
    failed = [name for name in chosen if "error" in results["stages"][name]]
    if failed:
        sys.exit(f"stage(s) failed: {', '.join(failed)}")


def report(results: dict, markdown_path: Path | None) -> None:
    rows = table_rows(results)
    print()
    print_table(rows)
    if markdown_path:
        markdown_path.write_text(markdown(rows))


if __name__ == "__main__":
    main()
