"""Mutation testing of the core numerics with mutmut, one module group at a time.

    python tools/mutation.py run [GROUP ...]   # mutate each group against its own tests
    python tools/mutation.py resume GROUP      # go on with a stopped run
    python tools/mutation.py rerun GROUP       # re-test the survivors after adding tests
    python tools/mutation.py collect GROUP     # write the record of a finished (or stopped) run
    python tools/mutation.py pin [GROUP ...]   # store the diff each argued survivor has now in excluded.json
    python tools/mutation.py remap [GROUP ...] # follow renumbered argued mutants by their pinned diffs
    python tools/mutation.py report            # rebuild docs/mutation-report.md from the records

`run` copies src/ and tests/ into build/mutation/GROUP/, writes a pyproject.toml
there whose [tool.mutmut] section mutates only the group's files and selects only
the group's tests, runs `mutmut run` with one worker, and writes the per-mutant
outcome to docs/mutation/GROUP.json (the committed record). `report` turns the
records into the markdown summary, with the mutants excluded in
docs/mutation/excluded.json (equivalent, import-time or layout, argued there) counted apart.

mutmut numbers a function's mutants in order, so editing a function renumbers them and a rule's
mutant name can come to mean another mutant. A rule's `diffs` (written by `pin`, after checking
that each argued mutant is the one its rule describes) holds the diff each name was argued for;
a survivor whose diff differs is not excluded by that rule, and the report flags it. After an edit
and a new run, `remap` renames each pinned name to the survivor of the same function that has its
diff now, and drops a name whose diff no survivor has (the mutant is gone or now killed).
"""

from __future__ import annotations

import argparse
import collections
import datetime as dt
import fnmatch
import json
import os
import shutil
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from importlib.metadata import version
from pathlib import Path

from mutmut.stats import status_by_exit_code

ROOT = Path(__file__).resolve().parents[1]
BUILD = ROOT / "build" / "mutation"
RECORDS = ROOT / "docs" / "mutation"
REPORT = ROOT / "docs" / "mutation-report.md"
EXCLUDED = RECORDS / "excluded.json"

@dataclass(frozen=True)
class Group:
    """Files mutated together and the tests that guard them."""

    name: str
    files: tuple[str, ...]  # globs under src/vsmp_imu
    tests: tuple[str, ...]  # pytest paths


GROUPS = (
    Group("grounding", ("grounding/cadence.py", "grounding/durations.py", "grounding/floors.py",
                        "grounding/gravity.py", "grounding/intensity.py", "grounding/levels.py",
                        "grounding/mounting.py", "grounding/split.py", "grounding/texture.py"),
          ("tests/grounding",)),
    # the grounding objective: D_stat and its loss, the CEM, the rank map, convention alignment
    Group("objective", ("grounding/stats.py", "grounding/calibrate.py", "grounding/rank.py",
                        "grounding/align.py"), ("tests/grounding",)),
    Group("imu", ("imu/*",), ("tests/imu",)),
    Group("filtering", ("filtering/*",), ("tests/filtering",)),
    Group("har", ("har/features.py", "har/protocols.py", "har/synthetic.py"),
          ("tests/har/test_har_protocols.py", "tests/har/test_har_synthetic_features.py",
           "tests/har/test_har_unseen.py", "tests/har/test_har_tstr.py")),  # the unseen and tstr splits
    Group("smp", ("smp/augment.py", "smp/schema.py"),
          ("tests/smp/test_smp_augment.py", "tests/smp/test_smp_exact_draws.py",
           "tests/smp/test_smp_library.py")),
    Group("motion", ("motion/compiler.py", "motion/lexicon.py", "motion/anatomy.py"),
          ("tests/motion/test_motion_compiler.py", "tests/motion/test_motion_compiler_rules.py",
           "tests/motion/test_motion_compiler_content.py",
           "tests/motion/test_motion_lexicon.py",
           "tests/motion/test_motion_procedural.py")),
    Group("motionfit", ("pipeline/motionfit.py",), ("tests/pipeline/test_motionfit.py",)),
    Group("noharm", ("har/noharm.py",), ("tests/har/test_har_noharm.py",)),
)


def _pyproject(group: Group) -> str:
    """The project's pyproject.toml plus a [tool.mutmut] section for one group."""
    lines = [
        (ROOT / "pyproject.toml").read_text(),
        "",
        "[tool.mutmut]",
        'source_paths = ["src/vsmp_imu"]',
        "only_mutate = " + json.dumps([f"src/vsmp_imu/{f}" for f in group.files]),
        "pytest_add_cli_args_test_selection = " + json.dumps([t for t in group.tests if (ROOT / t).exists()]),
        'pytest_add_cli_args = ["-m", "not slow", "-p", "no:cacheprovider", "-q"]',
        # mutants run in processes forked from a server that has only collected the tests,
        # so no cache filled by the unmutated stats run (compile_recipe, the SMP library) is inherited
        'process_isolation = "forkserver"',
        "use_git_change_detection = false",
        # tests that check a doc's table against the code read docs/ beside tests/
        'also_copy = ["docs"]',
        "",
    ]
    return "\n".join(lines)


def _prepare(group: Group) -> Path:
    where = BUILD / group.name
    shutil.rmtree(where, ignore_errors=True)
    where.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "src", where / "src", ignore=ignore)
    shutil.copytree(ROOT / "tests", where / "tests", ignore=ignore)
    shutil.copytree(ROOT / "docs", where / "docs", ignore=ignore)
    (where / "pyproject.toml").write_text(_pyproject(group))
    return where


def _outcomes(where: Path) -> dict[str, str]:
    """Mutant name -> status, read from mutmut's .meta files."""
    out = {}
    for meta in sorted((where / "mutants").rglob("*.meta")):
        data = json.loads(meta.read_text())
        for name, code in data.get("exit_code_by_key", {}).items():
            out[name] = status_by_exit_code[code]
    return out


def _mutmut(where: Path, names: list[str]) -> None:
    """`mutmut run` in a group's copy, one worker, on the given mutants (all when empty)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    cmd = [sys.executable, "-m", "mutmut", "run", "--max-children", "1", *names]
    with open(where / "mutmut.log", "a") as log:
        subprocess.run(cmd, cwd=where, env=env, stdout=log, stderr=subprocess.STDOUT)


def _import_time(name: str) -> bool:
    rules = json.loads(EXCLUDED.read_text()) if EXCLUDED.exists() else []
    rule = _exclusion(name, rules)
    return rule is not None and rule["kind"] == "import-time"


def run(group: Group) -> dict:
    """Mutate one group against its tests and write its record.

    A first call only generates the mutants and maps tests to functions (no mutant is
    named NOTHING); the second tests every mutant except those that run at import time
    (excluded.json), which mutmut cannot switch on."""
    where = _prepare(group)
    _mutmut(where, ["NOTHING"])
    return resume(group)


def resume(group: Group) -> dict:
    """Test the mutants of a group's copy that have no outcome yet (after a stop)."""
    where = BUILD / group.name
    todo = [n for n, s in _outcomes(where).items() if s == "not checked" and not _import_time(n)]
    if todo:
        _mutmut(where, todo)
    return collect(group)


def rerun(group: Group) -> dict:
    """Re-test the survivors of a finished run against the current tests (new tests copied in),
    except those excluded.json argues equivalent or import-time. The record's minutes are the
    run's plus the rerun's own (not the time since the run started)."""
    where = BUILD / group.name
    before = RECORDS / f"{group.name}.json"
    run_minutes = json.loads(before.read_text())["minutes"] if before.exists() else 0.0
    began = time.time()
    rules = json.loads(EXCLUDED.read_text()) if EXCLUDED.exists() else []
    survived = [n for n, s in _outcomes(where).items() if s == "survived"]
    diffs = _diffs(where, survived)
    survivors = [n for n in survived if _exclusion(n, rules, diffs[n]) is None]
    if survivors:
        shutil.rmtree(where / "tests")
        shutil.copytree(ROOT / "tests", where / "tests", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        _select_tests(where, group)
        _mutmut(where, survivors)
    return collect(group, minutes=run_minutes + (time.time() - began) / 60)


def _select_tests(where: Path, group: Group) -> None:
    """Point the copy's test selection at the group's current tests (new test files included),
    keeping the file's time: it marks when the run started."""
    pyproject = where / "pyproject.toml"
    started = pyproject.stat().st_mtime
    pyproject.write_text(_pyproject(group))
    os.utime(pyproject, (started, started))


def collect(group: Group, minutes: float | None = None) -> dict:
    """The record of a finished run in build/mutation/GROUP (also after an interrupted `run`);
    `minutes`: the testing time, when not the span from the run's start to its log's last line."""
    where = BUILD / group.name
    outcomes = _outcomes(where) if where.exists() else {}
    if not outcomes:
        raise SystemExit(f"no mutants found for {group.name}; see {where / 'mutmut.log'}")
    started = (where / "pyproject.toml").stat().st_mtime
    ended = (where / "mutmut.log").stat().st_mtime
    selection = tomllib.loads((where / "pyproject.toml").read_text())["tool"]["mutmut"]
    record = {
        "group": group.name,
        "files": [f"src/vsmp_imu/{f}" for f in group.files],
        "tests": selection["pytest_add_cli_args_test_selection"],
        "tool": f"mutmut {version('mutmut')}",
        "date": dt.datetime.fromtimestamp(started, dt.UTC).strftime("%Y-%m-%d"),
        "minutes": round((ended - started) / 60 if minutes is None else minutes, 1),
        "outcomes": outcomes,
        "survivors": _diffs(where, [n for n, s in outcomes.items() if s == "survived"]),
    }
    RECORDS.mkdir(parents=True, exist_ok=True)
    (RECORDS / f"{group.name}.json").write_text(json.dumps(record, indent=1, sort_keys=True) + "\n")
    return record


_DIFFS = """
import json, sys
from mutmut.mutation.diff_apply import find_mutant, get_diff_for_mutant
names = json.load(sys.stdin)
print(json.dumps({n: get_diff_for_mutant(n, path=find_mutant(n).path) for n in names}))
"""


def _diffs(where: Path, names: list[str]) -> dict[str, str]:
    """The +/- lines of each mutant's diff (mutmut's own diff, one process for all)."""
    if not names:
        return {}
    proc = subprocess.run([sys.executable, "-c", _DIFFS], cwd=where, input=json.dumps(names),
                          capture_output=True, text=True, check=True)
    return {n: "\n".join(line for line in diff.splitlines()
                         if line.startswith(("-", "+")) and not line.startswith(("---", "+++")))
            for n, diff in json.loads(proc.stdout).items()}


def _exclusion(name: str, rules: list[dict], diff: str | None = None) -> dict | None:
    """The rule of docs/mutation/excluded.json that a surviving mutant falls under, if any: its
    name matches the rule, and its diff (when known) is the one the rule pinned for it, if any."""
    return next((r for r in rules if any(fnmatch.fnmatchcase(name, m) for m in r["mutants"])
                 and (diff is None or r.get("diffs", {}).get(name, diff) == diff)), None)


def _stale(name: str, rules: list[dict], diff: str) -> bool:
    """A survivor that a rule names but argued for another diff (its function was edited since)."""
    return _exclusion(name, rules) is not None and _exclusion(name, rules, diff) is None


def pin(groups: list[Group]) -> int:
    """Store in excluded.json the current diff of every argued survivor of the groups' records that
    has none yet; returns how many were pinned."""
    rules = json.loads(EXCLUDED.read_text())
    pinned = 0
    for group in groups:
        path = RECORDS / f"{group.name}.json"
        if not path.exists():
            continue
        for name, diff in json.loads(path.read_text())["survivors"].items():
            rule = _exclusion(name, rules, diff)
            if rule is not None and rule["kind"] != "import-time" and name not in rule.get("diffs", {}):
                rule.setdefault("diffs", {})[name] = diff
                pinned += 1
    EXCLUDED.write_text(json.dumps(rules, indent=1, ensure_ascii=False) + "\n")
    return pinned


def _function(name: str) -> str:
    return name.rsplit("__mutmut_", 1)[0]


def remap(groups: list[Group]) -> tuple[int, int]:
    """Rename, in excluded.json, each pinned mutant of the groups' records whose diff moved to another
    number of the same function; drop the names whose diff no survivor has; drop rules left empty.
    Returns (renamed, dropped)."""
    rules = json.loads(EXCLUDED.read_text())
    moved = dropped = 0
    for group in groups:
        path = RECORDS / f"{group.name}.json"
        if not path.exists():
            continue
        record = json.loads(path.read_text())
        survivors, functions = record["survivors"], {_function(n) for n in record["outcomes"]}
        claimed = {n for r in rules for n, d in r.get("diffs", {}).items() if survivors.get(n) == d}
        for rule in rules:
            pinned, kept = rule.get("diffs", {}), {}
            for name, diff in pinned.items():
                if _function(name) not in functions or survivors.get(name) == diff:
                    kept[name] = diff
                    continue
                new = next((n for n, d in survivors.items()
                            if d == diff and _function(n) == _function(name) and n not in claimed), None)
                if new is None:
                    dropped += 1
                    continue
                claimed.add(new)
                kept[new] = diff
                moved += 1
            if kept != pinned:
                rule["mutants"] = [m for m in rule["mutants"] if m not in pinned or m in kept]
                rule["mutants"] += [n for n in kept if n not in rule["mutants"]]
                rule["diffs"] = kept
    EXCLUDED.write_text(json.dumps([r for r in rules if r["mutants"]], indent=1, ensure_ascii=False) + "\n")
    return moved, dropped


def _counts(record: dict, rules: list[dict]) -> dict[str, int]:
    counts = {"killed": 0, "survived": 0, "equivalent": 0, "layout": 0, "import-time": 0, "other": 0}
    for name, status in record["outcomes"].items():
        if status in ("killed", "timeout"):
            counts["killed"] += 1
        elif status == "survived":
            rule = _exclusion(name, rules, record["survivors"].get(name))
            counts[rule["kind"] if rule else "survived"] += 1
        else:
            rule = _exclusion(name, rules)
            counts["import-time" if rule and rule["kind"] == "import-time" else "other"] += 1
    return counts


def report() -> str:
    rules = json.loads(EXCLUDED.read_text()) if EXCLUDED.exists() else []
    rows, details = [], []
    for group in GROUPS:
        path = RECORDS / f"{group.name}.json"
        if not path.exists():
            rows.append(f"| {group.name} | not run | | | | | | | |")
            continue
        record = json.loads(path.read_text())
        c = _counts(record, rules)
        scored = c["killed"] + c["survived"]
        score = f"{100 * c['killed'] / scored:.1f} %" if scored else "n/a"
        rows.append(f"| {record['group']} | {score} | {c['killed']} | {c['survived']} | {c['equivalent']} "
                    f"| {c['layout']} | {c['import-time']} | {c['other']} | {record['tool']}, {record['date']}, "
                    f"{record['minutes']} min |")
        details.append(_survivor_section(record, rules))
    head = [
        "# Mutation testing report",
        "",
        "Rebuilt by `python tools/mutation.py report` from the records in docs/mutation/",
        "(written by `make mutation`); see [testing.md](testing.md).",
        "Score = killed / (killed + survived), timeouts counted as killed. Left out of it:",
        "mutants argued equivalent; layout mutants, which change only how a figure looks (font",
        "and figure sizes, margins, legend placement) while what it shows (data, names, units,",
        "colours, line styles) stays scored; mutants that run at import time (mutmut cannot",
        "switch them on); and \"other\": mutants no selected test reaches or that the run did",
        "not get to (docs/mutation/excluded.json holds the arguments).",
        "",
        "| group | score | killed | survived | equivalent | layout | import-time | other | run |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    return "\n".join(head + rows + [""] + details) + "\n"


def _survivor_section(record: dict, rules: list[dict]) -> str:
    lines = [f"## {record['group']}", ""]
    unrun = {n: s for n, s in record["outcomes"].items() if s not in ("killed", "timeout", "survived")}
    # import-time mutants are never run (mutmut cannot switch them on): listed under their rule
    import_time = sorted(n for n in unrun if (rule := _exclusion(n, rules)) and rule["kind"] == "import-time")
    other = collections.Counter(s for n, s in unrun.items() if n not in import_time)
    if other:
        lines += ["Other outcomes: " + ", ".join(f"{n} {s}" for s, n in sorted(other.items())) + ".", ""]
    by_rule: dict[int, list[str]] = collections.defaultdict(list)
    plain = []
    for name in sorted(record["survivors"]) + import_time:
        rule = _exclusion(name, rules, record["survivors"].get(name))
        (by_rule[id(rule)] if rule else plain).append(name)
    stale = [n for n in plain if _stale(n, rules, record["survivors"][n])]
    lines += [f"### Survived ({len(plain)})", ""]
    if stale:
        lines += ["Argued in excluded.json for another diff (the function changed since; re-argue or "
                  "test): " + ", ".join(f"`{n.rsplit('.', 1)[-1]}`" for n in stale) + ".", ""]
    lines += _diff_lines(record, plain)
    for rule in rules:
        names = by_rule.get(id(rule), [])
        if names:
            lines += [f"### {rule['kind'].capitalize()} ({len(names)}): {rule['why']}", ""]
            lines += _diff_lines(record, names) if rule["kind"] in ("equivalent", "layout") else [
                ", ".join(f"`{n.rsplit('.', 1)[-1]}`" for n in names), ""]
    return "\n".join(lines)


def _diff_lines(record: dict, names: list[str]) -> list[str]:
    lines = []
    for name in names:
        lines += [f"- `{name}`", "", "  ```diff"]
        lines += [f"  {line}" for line in record["survivors"][name].splitlines()]
        lines += ["  ```", ""]
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("command", choices=("run", "resume", "rerun", "collect", "pin", "remap", "report"))
    parser.add_argument("groups", nargs="*", help="groups to run (default: all): "
                        + ", ".join(g.name for g in GROUPS))
    args = parser.parse_args()
    chosen = [g for g in GROUPS if not args.groups or g.name in args.groups]
    if args.command == "pin":
        print(f"pinned {pin(chosen)} diffs in {EXCLUDED.relative_to(ROOT)}")
    elif args.command == "remap":
        print("renamed {} and dropped {} argued mutants in {}".format(*remap(chosen), EXCLUDED.relative_to(ROOT)))
    elif args.command != "report":
        for group in chosen:
            record = {"run": run, "resume": resume, "rerun": rerun, "collect": collect}[args.command](group)
            print(group.name, _counts(record, []), flush=True)
    REPORT.write_text(report())
    print(f"wrote {REPORT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
