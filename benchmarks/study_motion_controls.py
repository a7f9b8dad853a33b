"""Motion-level controllability of the procedural backend (paper protocol, 5 seeds).

Prints the realized-control numbers of docs/motion.md, "Measured targets":
- repetitions 3/6/9 on every periodic activity of the library files of the
  motion room: share within +-1 and exact, per-set Spearman rho on the 8
  repetition activities of the paper;
- tempo slow/medium/fast: ordering compliance on every periodic activity;
  rho (per matched set and pooled) and compliance on the 12 controllability
  activities;
- amplitude small/medium/large on the 12 activities;
- primitive duration x0.75/1.00/1.25 of the central primitive: MAPE;
- symmetry symmetric/asymmetric: accuracy with C_sym = 0.82;
- plausibility of every activity and seed.

Run: .venv/bin/python benchmarks/study_motion_controls.py
"""

from __future__ import annotations

import time

import numpy as np

from vsmp_imu.motion import selfcheck
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.motion.recipe import recipe_for_entry
from vsmp_imu.smp.library import ActivityLibrary

SEEDS = (0, 1, 2, 3, 4)
CONTROLLABILITY = ("right_hand_wave", "two_hand_front_clap", "right_arm_throw", "basketball_shoot",
                   "right_hand_draw_circle_clockwise", "front_boxing", "two_arm_curl", "two_hand_push",
                   "jogging_in_place", "walking_in_place", "forward_lunge", "squat_arms_extended")
REPETITION = ("right_hand_wave", "two_hand_front_clap", "right_hand_draw_circle_clockwise", "front_boxing",
              "two_arm_curl", "jogging_in_place", "walking_in_place", "squat_arms_extended")
DURATION = ("right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge")
SYMMETRY = ("two_hand_front_clap", "two_arm_curl", "two_hand_push", "squat_arms_extended")


def main() -> None:
    start = time.perf_counter()
    library = ActivityLibrary.load()
    backend = ProceduralBackend(library)
    periodic = [e.name for e in library if "procedural" in e.extras and recipe_for_entry(e).kind == "periodic"]
    print(f"procedural backend, seeds {list(SEEDS)}; {len(periodic)} periodic activities: {', '.join(periodic)}")

    reps = selfcheck.run_cases(backend, library, periodic, "repetitions", SEEDS)
    ctrl_reps = [c for c in reps if c.activity in REPETITION]
    exact = np.mean([c.measured == c.level for c in reps])
    print(f"repetitions 3/6/9 (all periodic, {len(reps)} motions): within +-1 {selfcheck.within_one(reps):.1%} "
          f"(target >= 98%), exact {exact:.1%}")
    print(f"repetitions (8 paper activities, {len(ctrl_reps)} motions): rho {selfcheck.spearman(ctrl_reps):.3f} "
          f"per set / {selfcheck.pooled_spearman(ctrl_reps):.3f} pooled, within +-1 "
          f"{selfcheck.within_one(ctrl_reps):.1%}")

    tempo_all = selfcheck.run_cases(backend, library, periodic, "tempo", SEEDS)
    print(f"tempo ordering slow<medium<fast (all periodic, {len(tempo_all) // 3} triplets): "
          f"{selfcheck.ordering_compliance(tempo_all):.1%} (target >= 95%)")
    for attribute in ("tempo", "amplitude"):
        cases = selfcheck.run_cases(backend, library, CONTROLLABILITY, attribute, SEEDS)
        print(f"{attribute} (12 activities, {len(cases)} motions): rho {selfcheck.spearman(cases):.3f} per set "
              f"(target >= 0.95) / {selfcheck.pooled_spearman(cases):.3f} pooled (about 0.945 at most when seeds differ within a level), "
              f"ordering {selfcheck.ordering_compliance(cases):.1%}")

    dur = selfcheck.run_cases(backend, library, DURATION, "duration", SEEDS)
    print(f"primitive duration x0.75/1.00/1.25 ({len(dur)} motions): MAPE {selfcheck.duration_mape(dur):.1%} "
          f"(target <= 5%), ordering {selfcheck.ordering_compliance(dur):.1%}")
    for name in DURATION:
        sub = [c for c in dur if c.activity == name]
        print(f"    {name:18s} MAPE {selfcheck.duration_mape(sub):.1%}")

    sym = selfcheck.run_cases(backend, library, SYMMETRY, "symmetry", SEEDS)
    by = {lvl: [c.measured for c in sym if c.level == lvl] for lvl in ("symmetric", "asymmetric")}
    print(f"symmetry ({len(sym)} motions): accuracy {selfcheck.symmetry_accuracy(sym):.1%} (target >= 95%); "
          f"C_sym symmetric {min(by['symmetric']):.2f}..{max(by['symmetric']):.2f}, "
          f"asymmetric {min(by['asymmetric']):.2f}..{max(by['asymmetric']):.2f} (threshold 0.82)")

    names = [e.name for e in library if "procedural" in e.extras]
    bad, worst = [], {"min_foot_y_m": 1.0, "max_step_fraction": 0.0, "bone_spread_m": 0.0}
    for name in names:
        for seed in SEEDS:
            m = backend.generate(library.get(name).smp, seed=seed)
            p = selfcheck.plausibility(m)
            worst["min_foot_y_m"] = min(worst["min_foot_y_m"], p["min_foot_y_m"])
            worst["max_step_fraction"] = max(worst["max_step_fraction"], p["max_step_fraction"])
            worst["bone_spread_m"] = max(worst["bone_spread_m"], p["bone_spread_m"])
            if not selfcheck.is_plausible(m):
                bad.append((name, seed))
    print(f"plausibility ({len(names)} activities x {len(SEEDS)} seeds): {len(bad)} implausible; lowest foot "
          f"joint {worst['min_foot_y_m'] * 100:.1f} cm, largest frame step {worst['max_step_fraction']:.3f} x height, "
          f"bone-length spread {worst['bone_spread_m']:.1e} m")
    print(f"({time.perf_counter() - start:.1f} s)")


if __name__ == "__main__":
    main()
