"""Benchmark of the motion room: procedural synthesis time per 10 s motion.

Prints, per activity family, the median time (one process, one core) to
generate a 10 s, 30 fps SMPL-22 motion with the procedural backend from the
activity's library SMP (durations set to 10 s; counted activities get the
repetitions that fill about 10 s), plus the split into planning, curves and
kinematics for one activity.

Target: <= 10 ms per 10 s motion (with IMU simulation <= 20 ms in total).
Run: .venv/bin/python benchmarks/bench_motion.py
"""

from __future__ import annotations

import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from vsmp_imu.motion import procedural  # noqa: E402
from vsmp_imu.motion.procedural import ProceduralBackend  # noqa: E402
from vsmp_imu.motion.recipe import recipe_for_entry  # noqa: E402
from vsmp_imu.smp.intervene import intervene  # noqa: E402
from vsmp_imu.smp.library import ActivityLibrary  # noqa: E402

DURATION_S = 10.0
TARGET_MS = 10.0  # per 10 s motion, one core
FAMILIES = {
    "gait (walking, stairs)": ("walking", "walking_upstairs", "walking_downstairs"),
    "static postures": ("sitting", "standing", "lying"),
    "posture transitions": ("stand_to_sit", "sit_to_stand", "sit_to_lie", "lie_to_stand"),
    "discrete gestures": ("right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge"),
    "periodic gestures": ("right_hand_wave", "two_hand_front_clap", "front_boxing", "two_arm_curl",
                          "right_hand_draw_circle_clockwise"),
    "periodic whole body": ("jumping_jacks", "jogging_in_place", "walking_in_place", "squat_arms_extended"),
}


def ten_second_smp(backend: ProceduralBackend, entry):
    """The library SMP, with about as many repetitions as fill 10 s for counted activities."""
    smp = entry.smp
    if smp.temporal_structure.is_repetitive and smp.repetition_count() is not None:
        plan = backend.plan(smp, 0)
        count = smp.repetition_count()
        per_cycle = plan.cycle_s
        extra = max(0, int((DURATION_S - plan.natural_duration_s) / per_cycle))
        smp = intervene(smp, "repetitions", count + extra)
    return smp


def median_ms(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def measure() -> dict:
    """Median ms per 10 s motion for each activity, by family; the split for walking."""
    library = ActivityLibrary.load()
    backend = ProceduralBackend(library)
    families = {}
    for family, names in FAMILIES.items():
        per = {}
        for name in names:
            entry = library.get(name)
            recipe_for_entry(entry)
            smp = ten_second_smp(backend, entry)
            counted = smp.repetition_count() is not None and smp.temporal_structure.is_repetitive
            duration = None if counted else DURATION_S
            seeds = iter(range(10_000))
            length = backend.generate(smp, 0, duration).duration_s
            ms = median_ms(lambda smp=smp, d=duration, s=seeds: backend.generate(smp, next(s), d), 30)
            per[name] = ms * DURATION_S / length  # per 10 s of motion
        families[family] = {"ms": per, "mean_ms": statistics.mean(per.values()), "max_ms": max(per.values())}
    smp = library.get("walking").smp
    plan = backend.plan(smp, 0, DURATION_S)
    t = np.arange(int(DURATION_S * 30) + 1) / 30.0
    split = {"plan": median_ms(lambda: backend.plan(smp, 0, DURATION_S), 30),
             "dof_curves": median_ms(lambda: procedural._dof_curves(plan, t, 0.0), 30),
             "generate": median_ms(lambda: backend.generate(smp, 0, DURATION_S), 30)}
    worst = max(f["max_ms"] for f in families.values())
    return {"duration_s": DURATION_S, "families": families, "worst_ms": worst, "target_ms": TARGET_MS,
            "met": worst <= TARGET_MS, "walking_split_ms": split}


def main() -> None:
    fig = measure()
    print(f"procedural synthesis, {DURATION_S:g} s at 30 fps, median ms per motion (one core)")
    for family, f in fig["families"].items():
        print(f"  {family:24s} {f['mean_ms']:6.2f} ms  (max {f['max_ms']:.2f} ms over {len(f['ms'])} activities)")
    print(f"  worst activity: {fig['worst_ms']:.2f} ms -> target <= {TARGET_MS:g} ms: "
          f"{'met' if fig['met'] else 'NOT met'}")
    split = fig["walking_split_ms"]
    print(f"split for walking (ms): plan {split['plan']:.2f}, DOF curves {split['dof_curves']:.2f}, "
          f"full generate {split['generate']:.2f}")


if __name__ == "__main__":
    main()
