"""Motion-level controllability of the procedural backend (paper protocol, 5 seeds).

Measures the realized controls of docs/motion.md, "Measured targets", and
writes every measurement to benchmarks/results/motion_controls.json; the
table of docs/motion.md is rebuilt from it (`markdown` below, through
`vsmp-imu report --write`):
- repetitions 3/6/9 on every periodic activity of the library: share within
  +-1 and exact, per-set Spearman rho on the 8 repetition activities of the
  paper;
- tempo slow/medium/fast: ordering compliance on every periodic activity;
  rho (per matched set and pooled) and compliance on the 12 controllability
  activities; mean joint speed of the other added activities;
- amplitude small/medium/large on the 12 activities and the added ones;
- primitive duration x0.75/1.00/1.25 of the central primitive: MAPE;
- symmetry symmetric/asymmetric: accuracy with C_sym = 0.82;
- plausibility of every activity and seed, as written and at fast tempo with
  large amplitude;
- synthesis time per 10 s motion (`bench_motion.py`, one core).
"The added activities" are those of the UTD-MHAD, MM-Fit and PAMAP2 files:
every library activity but HAPT's, the 12 controllability ones and jumping
jacks.

Run: nice .venv/bin/python benchmarks/study_motion_controls.py [--parts controls,speed]
(`--parts speed` measures the synthesis time again and keeps the controls).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "motion_controls.json"
SEEDS = (0, 1, 2, 3, 4)
CONTROLLABILITY = ("right_hand_wave", "two_hand_front_clap", "right_arm_throw", "basketball_shoot",
                   "right_hand_draw_circle_clockwise", "front_boxing", "two_arm_curl", "two_hand_push",
                   "jogging_in_place", "walking_in_place", "forward_lunge", "squat_arms_extended")
REPETITION = ("right_hand_wave", "two_hand_front_clap", "right_hand_draw_circle_clockwise", "front_boxing",
              "two_arm_curl", "jogging_in_place", "walking_in_place", "squat_arms_extended")
DURATION = ("right_arm_throw", "basketball_shoot", "two_hand_push", "forward_lunge")
SYMMETRY = ("two_hand_front_clap", "two_arm_curl", "two_hand_push", "squat_arms_extended")
FIRST = (*CONTROLLABILITY, "jumping_jacks")  # with HAPT's: the library before the added files
PARTS = ("controls", "speed")


# -- measuring ------------------------------------------------------------------------------------
def groups(library) -> dict[str, list[str]]:
    """The activity groups of the table, from the library."""
    from vsmp_imu.motion.recipe import recipe_for_entry

    entries = [e for e in library if "procedural" in e.extras]
    kind = {e.name: recipe_for_entry(e).kind for e in entries}
    added = [e for e in entries if "hapt" not in e.datasets and e.name not in FIRST]
    return {
        "all": [e.name for e in entries],
        "periodic": [e.name for e in entries if kind[e.name] == "periodic"],
        "added": [e.name for e in added],
        "added_periodic": [e.name for e in added if kind[e.name] == "periodic"],
        "added_other": [e.name for e in added if kind[e.name] != "periodic"],
        "added_duration": [e.name for e in added if kind[e.name] == "discrete" and e.central_primitive],
        "added_symmetry": [e.name for e in added if "symmetry" in e.smp.constraints.variant_fields],
    }


def _cases(backend, library, names, attribute) -> list[list]:
    from vsmp_imu.motion import selfcheck

    cases = selfcheck.run_cases(backend, library, names, attribute, SEEDS)
    return [[c.activity, c.level, c.seed, c.measured] for c in cases]


def _plausibility(backend, library, names) -> list[list]:
    """(activity, seed, variant, finite, lowest foot joint m, largest step / height, bone spread m)."""
    from vsmp_imu.motion import selfcheck
    from vsmp_imu.smp.intervene import intervene

    rows = []
    for name in names:
        smp = library.get(name).smp
        extreme = intervene(intervene(smp, "tempo", "fast"), "amplitude", "large")
        for variant, chosen in (("as written", smp), ("fast, large", extreme)):
            for seed in SEEDS:
                p = selfcheck.plausibility(backend.generate(chosen, seed=seed))
                rows.append([name, seed, variant, p["finite"], p["min_foot_y_m"], p["max_step_fraction"],
                             p["bone_spread_m"]])
    return rows


def measure_controls() -> dict:
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    backend = ProceduralBackend(library)
    g = groups(library)
    print(f"procedural backend, seeds {list(SEEDS)}; {len(g['all'])} activities, {len(g['periodic'])} periodic, "
          f"{len(g['added'])} added", flush=True)
    plan = {
        "repetitions": g["periodic"],
        "tempo": g["all"],
        "amplitude": sorted(set(g["added"]) | set(CONTROLLABILITY)),
        "duration": [*DURATION, *g["added_duration"]],
        "symmetry": [*SYMMETRY, *g["added_symmetry"]],
    }
    cases = {}
    for attribute, names in plan.items():
        start = time.perf_counter()
        cases[attribute] = _cases(backend, library, names, attribute)
        print(f"  {attribute}: {len(cases[attribute])} motions in {time.perf_counter() - start:.0f} s", flush=True)
    plausibility = _plausibility(backend, library, g["all"])
    return {"seeds": list(SEEDS), "groups": g, "cases": cases, "plausibility": plausibility,
            "plausibility_fields": ["activity", "seed", "variant", "finite", "min_foot_y_m",
                                    "max_step_fraction", "bone_spread_m"]}


def measure_speed() -> dict:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_motion

    return bench_motion.measure()


def machine() -> dict:
    import numpy

    return {"cpu": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "python": platform.python_version(), "numpy": numpy.__version__}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", default=",".join(PARTS), help="comma-separated: " + ", ".join(PARTS))
    parser.add_argument("--json", type=Path, default=OUT, help="where to write the measurements")
    args = parser.parse_args()
    parts = [p.strip() for p in args.parts.split(",") if p.strip()]
    if unknown := [p for p in parts if p not in PARTS]:
        parser.error(f"unknown part(s) {', '.join(unknown)}; choose from {', '.join(PARTS)}")
    from vsmp_imu.har.bench_records import record_parts

    record = record_parts(args.json, "benchmarks/study_motion_controls.py", sys.argv[1:], parts,
                          lambda part: measure_controls() if part == "controls" else measure_speed(), machine())
    print(markdown(record))
    print(f"written: {args.json}")


# -- the table of docs/motion.md ------------------------------------------------------------------
def _pct(value: float, digits: int = 0) -> str:
    return f"{100 * value:.{digits}f} %"


def _loaded(record: dict, attribute: str, names=None):
    from vsmp_imu.motion.selfcheck import Case

    wanted = None if names is None else set(names)
    return [Case(a, attribute, level, seed, measured) for a, level, seed, measured in
            record["cases"][attribute] if wanted is None or a in wanted]


def _misses(cases) -> str:
    """The counts that were not exact: 'activity at 3: 4 (seeds 0, 1)'."""
    seeds: dict[tuple, list[int]] = {}
    for c in cases:
        if c.measured != c.level:
            seeds.setdefault((c.activity, c.level, c.measured), []).append(c.seed)
    if not seeds:
        return "all exact"
    return "; ".join(f"{a} at {level}: {measured:g} (seed{'s' if len(s) > 1 else ''} {', '.join(map(str, s))})"
                     for (a, level, measured), s in seeds.items())


def _mapes(cases) -> str:
    from vsmp_imu.motion import selfcheck

    names = list(dict.fromkeys(c.activity for c in cases))
    return ", ".join(f"{n} {100 * selfcheck.duration_mape([c for c in cases if c.activity == n]):.1f}"
                     for n in names)


def _symmetry(cases) -> str:
    from vsmp_imu.motion import selfcheck

    by = {lvl: [c.measured for c in cases if c.level == lvl] for lvl in ("symmetric", "asymmetric")}
    return (f"accuracy {_pct(selfcheck.symmetry_accuracy(cases))} (C_sym {min(by['symmetric']):.2f}.."
            f"{max(by['symmetric']):.2f} symmetric, {min(by['asymmetric']):.2f}..{max(by['asymmetric']):.2f} "
            "asymmetric)")


def control_rows(record: dict) -> list[tuple[str, str, str]]:
    from vsmp_imu.motion import selfcheck

    g = record["groups"]
    rows = []
    reps = _loaded(record, "repetitions")
    added_reps = [c for c in reps if c.activity in g["added_periodic"]]
    paper_reps = [c for c in reps if c.activity in REPETITION]
    exact = np.mean([c.measured == c.level for c in reps])
    rows.append((f"repetitions 3/6/9, all {len(g['periodic'])} periodic activities ({len(reps)} motions)",
                 f"{_pct(selfcheck.within_one(reps))} within ±1 ({_pct(exact)} exact)", ">= 98 %"))
    added_exact = np.mean([c.measured == c.level for c in added_reps])
    rows.append((f"repetitions 3/6/9, the {len(g['added_periodic'])} added periodic activities "
                 f"({len(added_reps)} motions)",
                 f"{_pct(selfcheck.within_one(added_reps))} within ±1 ({_pct(added_exact, 1)} exact; "
                 f"{_misses(added_reps)}), rho {selfcheck.spearman(added_reps):.3f} per set", ">= 98 %"))
    rows.append((f"repetitions, the paper's {len(REPETITION)} activities",
                 f"Spearman rho {selfcheck.spearman(paper_reps):.3f} per set "
                 f"({selfcheck.pooled_spearman(paper_reps):.3f} pooled)", ">= 0.95"))
    tempo = _loaded(record, "tempo")
    periodic = [c for c in tempo if c.activity in g["periodic"]]
    added_periodic = [c for c in tempo if c.activity in g["added_periodic"]]
    added_other = [c for c in tempo if c.activity in g["added_other"]]
    rows.append((f"tempo slow < medium < fast, all {len(g['periodic'])} periodic activities "
                 f"({len(periodic) // 3} triplets)", _pct(selfcheck.ordering_compliance(periodic)), ">= 95 %"))
    rows.append((f"tempo slow < medium < fast, the {len(g['added_periodic'])} added periodic activities "
                 f"({len(added_periodic) // 3} triplets)",
                 f"{_pct(selfcheck.ordering_compliance(added_periodic))}, rho "
                 f"{selfcheck.spearman(added_periodic):.3f} per set", ">= 95 %"))
    rows.append((f"tempo (mean joint speed), the {len(g['added_other'])} added discrete and static activities "
                 f"({len(added_other) // 3} triplets)",
                 f"ordering {_pct(selfcheck.ordering_compliance(added_other))}", ""))
    amplitude = _loaded(record, "amplitude")
    added_amp = [c for c in amplitude if c.activity in g["added"]]
    rows.append((f"amplitude, the {len(g['added'])} added activities ({len(added_amp) // 3} triplets)",
                 f"ordering {_pct(selfcheck.ordering_compliance(added_amp))}, rho "
                 f"{selfcheck.spearman(added_amp):.3f} per set", ""))
    for attribute, cases in (("tempo", tempo), ("amplitude", amplitude)):
        sub = [c for c in cases if c.activity in CONTROLLABILITY]
        rows.append((f"{attribute}, {len(CONTROLLABILITY)} controllability activities ({len(sub)} motions)",
                     f"rho {selfcheck.spearman(sub):.3f} per set ({selfcheck.pooled_spearman(sub):.3f} pooled), "
                     f"ordering {_pct(selfcheck.ordering_compliance(sub))}", ">= 0.95"))
    duration = _loaded(record, "duration")
    paper_dur = [c for c in duration if c.activity in DURATION]
    added_dur = [c for c in duration if c.activity in g["added_duration"]]
    rows.append((f"primitive duration x0.75/1.00/1.25, {len(DURATION)} activities ({len(paper_dur)} motions)",
                 f"MAPE {100 * selfcheck.duration_mape(paper_dur):.1f} % ({_mapes(paper_dur)})", "<= 5 %"))
    rows.append((f"primitive duration, the {len(g['added_duration'])} added discrete activities with a "
                 f"`central_primitive` ({len(added_dur)} motions)",
                 f"MAPE {100 * selfcheck.duration_mape(added_dur):.1f} % ({_mapes(added_dur)})", "<= 5 %"))
    symmetry = _loaded(record, "symmetry")
    for label, names in ((f"{len(SYMMETRY)} activities", SYMMETRY),
                         (f"the {len(g['added_symmetry'])} added activities whose SMP varies it "
                          f"({', '.join(g['added_symmetry'])})", g["added_symmetry"])):
        sub = [c for c in symmetry if c.activity in names]
        rows.append((f"symmetry, {label} ({len(sub)} motions)", _symmetry(sub), ">= 95 %"))
    rows.append(_plausibility_row(record))
    return rows


def _plausibility_row(record: dict) -> tuple[str, str, str]:
    from vsmp_imu.motion import selfcheck

    rows = [dict(zip(record["plausibility_fields"], r, strict=True)) for r in record["plausibility"]]
    written = [r for r in rows if r["variant"] == "as written"]
    extreme = [r for r in rows if r["variant"] == "fast, large"]

    def bad(sub):
        return sum(not (r["finite"] == 1.0 and r["min_foot_y_m"] >= -selfcheck.FLOOR_TOLERANCE_M
                        and r["max_step_fraction"] <= selfcheck.MAX_STEP_FRACTION
                        and r["bone_spread_m"] < 1e-6) for r in sub)

    n_activities = len({r["activity"] for r in written})
    return (f"plausibility, {n_activities} activities x {len(record['seeds'])} seeds",
            f"{bad(written)} of {len(written)} fail ({bad(extreme)} of {len(extreme)} at fast tempo and large "
            f"amplitude); lowest foot joint {100 * min(r['min_foot_y_m'] for r in written):.1f} cm, largest "
            f"step {max(r['max_step_fraction'] for r in written):.2f} x height "
            f"({max(r['max_step_fraction'] for r in extreme):.2f} at fast tempo and large amplitude)",
            f"step <= {selfcheck.MAX_STEP_FRACTION:.2f} x height")


def speed_row(speed: dict) -> tuple[str, str, str]:
    means = [f["mean_ms"] for f in speed["families"].values()]
    return (f"synthesis time, {speed['duration_s']:g} s at 30 fps, one core",
            f"{min(means):.1f}-{max(means):.1f} ms per motion (family means; slowest activity "
            f"{speed['worst_ms']:.1f} ms)", f"<= {speed['target_ms']:g} ms")


def markdown(record: dict) -> str:
    rows = control_rows(record["controls"]) if "controls" in record else []
    if "speed" in record:
        rows.append(speed_row(record["speed"]))
    lines = ["| check | result | target |", "| --- | --- | --- |"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines) + "\n"


def _when(part: dict) -> str:
    load = part["load_avg_at_start"][0]
    return f"`{part['command']}` ({part['started']}, {part['wall_s']:.0f} s, load average {load:.1f} at its start)"


def view_controls(record: dict) -> tuple[str, str]:
    """The table of docs/motion.md and where its figures come from."""
    parts = [f"{name} from {_when(record[name])}" for name in PARTS if name in record]
    return markdown(record), "; ".join(parts)


VIEWS = {"controls": view_controls}

if __name__ == "__main__":
    main()
