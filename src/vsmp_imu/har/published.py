"""The measured tables of README.md and docs/, rebuilt from the committed records.

`results/tables.yaml` declares each table (which record set, which kind,
which methods, groups and budgets). A document holds a generated table
between `<!-- report:ID -->` and `<!-- /report -->`; `Publication.write`
rewrites those blocks from the records and `Publication.check` lists the
blocks that differ. A table whose records are not committed yet is declared
under `unbacked` with the reason and the cost of its run: its block is left
as written and reported as a warning. A `study` table renders one table of a
committed `vsmp-imu study` run with the study's own report builder
(`har.study_records`); a `benchmark` table is the table a benchmark script
writes from its committed JSON (`har.bench_records`). A table under `targets`
answers the project's targets row by row from several record sets, with the
verdict computed (`har.targets`).
"""

from __future__ import annotations

import difflib
import os
import re
import stat
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.bench_records import BenchTable
from vsmp_imu.har.curves import CurveFigure, figure_path
from vsmp_imu.har.measures import (
    Metric,
    markdown,
    method_name,
    paired_test,
    pct,
    run_key,
    several_per_run,
    shared_runs,
)
from vsmp_imu.har.metrics import mean_std
from vsmp_imu.har.noharm import unjudged
from vsmp_imu.har.records import RecordSet, load_run
from vsmp_imu.har.study_records import VIEWS, StudyRecord, StudyTable, load_study
from vsmp_imu.har.targets import TargetsBuilder, TargetTable
from vsmp_imu.io import read_structured, read_text, write_bytes, write_text

SPEC_FILE = "tables.yaml"
DOC_GLOBS = ("README.md", "BENCHMARKS.md", "docs/*.md")
# a mark stands alone on its line, from its first column (so that prose may quote one in
# backticks); trailing whitespace and the line end (LF or CRLF) are no part of it
OPEN_MARK = re.compile(r"<!-- report:(?P<id>[^ >]+) -->")
CLOSE_MARK = "<!-- /report -->"
# a line that any reader would take for a mark: it must be one (a typo is not skipped silently)
MARK_LIKE = re.compile(r"\s*<!--\s*/?\s*report\b")
MARK_FORM = "'<!-- report:ID -->' and '<!-- /report -->', each alone on its line from its first column"
LINE = re.compile(r"[^\n]*\n?")
# a paired table's baseline that pairs each method with itself (in baseline_records or on baseline_backbone)
SAME = "same"


class TableSpec(BaseModel):
    """A table rebuilt from one record set."""

    model_config = ConfigDict(extra="forbid")
    id: str = Field(pattern=r"^[a-z0-9_-]+:[a-z0-9_-]+$")
    records: str
    kind: Literal["groups", "paired", "classes", "synthetic", "shares", "unseen_each", "study", "benchmark",
                  "curve"]
    # kind curve: more record sets the curve joins (a method's point at a budget comes from the
    # first of `records` and these that has it; har.curves)
    extra_records: list[str] = Field(default_factory=list)
    methods: list[str] = Field(default_factory=list)
    metrics: list[Metric] = Field(default_factory=list)
    budgets: list[float] | None = None
    backbone: str | None = None
    baseline: str | None = None  # a method, or `same` (each method against itself in the other runs)
    # paired: the baseline's runs from another record set (the same method before a change)
    baseline_records: str | None = None
    # paired: the baseline's runs on another backbone (the same windows, another model)
    baseline_backbone: str | None = None
    # paired: the baseline's runs at another budget (e.g. twice the labels against the budget)
    baseline_budget: float | None = None
    bold: bool = False
    per_seed: bool = False  # paired: a row per seed under each method's row over all seeds
    digits: int = Field(2, ge=0, le=4)
    row_header: str = "Group"
    # kind study: a table of the study's report (har.study_records.VIEWS); kind benchmark: one of
    # the benchmark script's VIEWS (none: the script's own table)
    view: str | None = None
    source: str | None = None  # kind benchmark: the committed benchmark JSON (har.bench_records)
    # a subset of the record set's runs (e.g. the three held-out subjects and the seed of `make demo`)
    folds: list[str] | None = None
    seeds: list[int] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> TableSpec:
        if self.kind == "study":
            if self.view not in VIEWS:
                raise ValueError(f"a study table needs a view, one of {', '.join(VIEWS)}")
            return self
        if self.kind == "benchmark":
            if self.source is None:
                raise ValueError("a benchmark table needs the source JSON, e.g. benchmarks/results/run_all.json")
            return self
        if not self.methods:
            raise ValueError(f"a {self.kind} table needs methods")
        if self.extra_records and self.kind != "curve":
            raise ValueError("extra_records is an option of curves")
        if self.kind == "curve" and not (self.metrics and self.budgets and self.backbone):
            raise ValueError("a curve needs metrics, budgets and a backbone")
        if self.kind == "paired" and self.baseline is None:
            raise ValueError("a paired table needs a baseline method")
        if self.baseline == SAME and self.baseline_records is None and self.baseline_backbone is None:
            raise ValueError("baseline 'same' pairs each method with itself in baseline_records or on "
                             "baseline_backbone; it needs one of them")
        if self.kind in ("groups", "paired", "unseen_each") and not self.metrics:
            raise ValueError(f"a {self.kind} table needs metrics")
        if self.per_seed and self.kind != "paired":
            raise ValueError("per_seed is an option of paired tables")
        if self.baseline_backbone is not None and (self.kind != "paired" or self.backbone is None):
            raise ValueError("baseline_backbone is an option of paired tables that name their backbone")
        if self.baseline_budget is not None and (self.kind != "paired" or not self.budgets):
            raise ValueError("baseline_budget is an option of paired tables that name their budgets")
        return self


class Unbacked(BaseModel):
    """A measured table in the docs whose records are not committed (yet)."""

    model_config = ConfigDict(extra="forbid")
    id: str = Field(pattern=r"^[a-z0-9_-]+:[a-z0-9_-]+$")
    reason: str


class Catalogue(BaseModel):
    model_config = ConfigDict(extra="forbid")
    tables: list[TableSpec] = Field(default_factory=list)
    targets: list[TargetTable] = Field(default_factory=list)  # har.targets
    unbacked: list[Unbacked] = Field(default_factory=list)

    @model_validator(mode="after")
    def _unique(self) -> Catalogue:
        ids = [t.id for t in self.tables] + [t.id for t in self.targets] + [u.id for u in self.unbacked]
        twice = sorted({i for i in ids if ids.count(i) > 1})
        if twice:
            raise ValueError(f"table ids declared twice: {', '.join(twice)}")
        return self


def load_catalogue(path: str | Path) -> Catalogue:
    path = Path(path)
    data = read_structured(path)
    try:
        return Catalogue.model_validate(data or {})
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first["loc"])
        raise ConfigError(first["msg"], file=path, field=where or None) from exc


# -- tables -------------------------------------------------------------------------------
def _budget_name(budget: float | None) -> str:
    return "" if budget is None else f"{budget:g} %"


class TableBuilder:
    """Render one `TableSpec` from its record set."""

    def __init__(self, spec: TableSpec, records: RecordSet, baseline_records: RecordSet | None = None) -> None:
        self.spec = spec
        self.records = self._subset(records)
        self.baseline_records = None if baseline_records is None else self._subset(baseline_records)

    def _subset(self, records: RecordSet) -> RecordSet:
        """The runs of the spec's folds and seeds (all runs where it names none)."""
        folds, seeds = self.spec.folds, self.spec.seeds
        if folds is None and seeds is None:
            return records
        kept = tuple(r for r in records.records
                     if (folds is None or str(r["fold"]) in folds) and (seeds is None or r["seed"] in seeds))
        if not kept:
            raise ConfigError(
                f"table '{self.spec.id}': record set '{records.name}' has no run of the folds and seeds it names",
                field="folds/seeds",
                allowed="the folds and seeds the records hold",
            )
        return replace(records, records=kept)

    def _subset_note(self) -> str:
        parts = []
        if self.spec.folds is not None:
            parts.append(f"held-out subject{'s' if len(self.spec.folds) > 1 else ''} {', '.join(self.spec.folds)}")
        if self.spec.seeds is not None:
            parts.append(f"seed{'s' if len(self.spec.seeds) > 1 else ''} {', '.join(map(str, self.spec.seeds))}")
        return f": {' and '.join(parts)} of its runs" if parts else ""

    def runs(self, method: str, budget: float | None, records: RecordSet | None = None,
             backbone: str | None = None) -> list[dict]:
        where = {"method": method}
        if budget is not None:
            where["budget"] = budget
        backbone = backbone or self.spec.backbone
        if backbone is not None:
            where["backbone"] = backbone
        records = records or self.records
        found = records.select(**where)
        if not found:
            what = f"method '{method}'" + ("" if budget is None else f", budget {budget:g}")
            raise ConfigError(
                f"table '{self.spec.id}': record set '{records.name}' has no record of {what}",
                field="methods/budgets",
                allowed="the methods, budgets and backbone the records hold",
            )
        return self._one_per_run(found, method, records.name)

    def _one_per_run(self, found: list[dict], method: str, set_name: str) -> list[dict]:
        """`found`, after checking that it holds one record per run (fold, seed)."""
        mixed = several_per_run(found)
        if mixed is None:
            return found
        raise ConfigError(
            f"table '{self.spec.id}': method '{method}' has several records per fold and seed in record set "
            f"'{set_name}'"
            + (f" ({mixed})" if mixed else ""),
            field="budgets/backbone",
            allowed="name the budgets (`budgets`) and the backbone (`backbone`) the table shows",
        )

    def same_runs(self, runs: dict[str, list[dict]], budget: float | None) -> dict[str, list[dict]]:
        """`runs` per method, after checking that every method has the same (fold, seed) runs:
        a table's columns must compare the same runs."""
        keys = {m: sorted(run_key(r) for r in rs) for m, rs in runs.items()}
        first = next(iter(keys.values()))
        uneven = [m for m, k in keys.items() if k != first]
        if uneven:
            counts = ", ".join(f"{m} {len(k)}" for m, k in keys.items())
            where = "" if budget is None else f" at budget {budget:g}"
            raise ConfigError(
                f"table '{self.spec.id}': the methods do not have the same runs{where} ({counts})",
                file=f"results/{self.records.name}/records.jsonl",
                allowed="a record set with every method on the same folds and seeds",
            )
        return runs

    def budgets(self) -> list[float | None]:
        return list(self.spec.budgets) if self.spec.budgets else [None]

    def render(self) -> str:
        table = getattr(self, f"_{self.spec.kind}")()
        n = self._n_runs()
        source = (f"Records: `results/{self.records.name}/` ({n} run{'' if n == 1 else 's'}{self._subset_note()}), from "
                  f"`{self.records.command}`")
        if self.records.code_commit:
            source += f" at commit {self.records.code_commit[:7]}"
        if self.baseline_records is not None:
            other = self.baseline_records
            source += (f"; against `results/{other.name}/`, from `{other.command}`"
                       + (f" at commit {other.code_commit[:7]}" if other.code_commit else ""))
        return f"{table}\n\n{self._floor_note()}{source}; rebuilt by `vsmp-imu report --write`.\n"

    def _floor_note(self) -> str:
        """Under the unseen protocol: the table's methods that cannot make an unseen class."""
        floor = [m for m in self.spec.methods
                 if any(r.get("unseen_capable") is False for r in self.records.select(method=m))]
        if not floor:
            return ""
        names = " and ".join(method_name(m) for m in floor)
        whose = "their" if len(floor) > 1 else "its"
        return (f"{names} cannot make windows of a class without real windows: {whose} unseen-class "
                "figures are the floor (the model never sees those classes). ")

    def _n_runs(self) -> int:
        return len({(str(r["fold"]), r["seed"]) for r in self.records.records})

    def _lead(self, budget: float | None) -> list[str]:
        return [_budget_name(budget)] if self.spec.budgets else []

    def _lead_header(self) -> list[str]:
        return ["Budget"] if self.spec.budgets else []

    def _groups(self) -> str:
        s = self.spec
        rows = []
        for budget in self.budgets():
            runs = self.same_runs({m: self.runs(m, budget) for m in s.methods}, budget)
            for metric in s.metrics:
                stats = [mean_std([metric.value(r) for r in runs[m]]) for m in s.methods]
                cells = [f"{pct(mu, s.digits)} ± {pct(sd, s.digits)}" if mu is not None else "–"
                         for mu, sd, _ in stats]
                if s.bold:
                    cells = _bold_best(cells, [mu for mu, _, _ in stats])
                rows.append(self._lead(budget) + [metric.label] + cells)
        header = self._lead_header() + [s.row_header] + [method_name(m) for m in s.methods]
        return markdown(header, rows)

    def _paired(self) -> str:
        s = self.spec
        rows = []
        for budget in self.budgets():
            for method in s.methods:
                base = self.runs(self._baseline(method), s.baseline_budget or budget, self.baseline_records,
                                 s.baseline_backbone)
                mine = self.runs(method, budget)
                if self.baseline_records is not None:  # another set: the runs both have
                    mine, base = shared_runs(mine, base)
                runs = self.same_runs({f"baseline {s.baseline}": base, method: mine}, budget)[method]
                name = self._paired_name(method)
                rows.append(self._lead(budget) + [name] + self._paired_cells(runs, base))
                seeds = sorted({r["seed"] for r in runs}) if s.per_seed else []
                for seed in seeds:
                    cells = self._paired_cells([r for r in runs if r["seed"] == seed],
                                               [r for r in base if r["seed"] == seed])
                    rows.append(self._lead(budget) + [f"{name}, seed {seed}"] + cells)
        header = self._lead_header() + ["Method"] + [m.label for m in s.metrics]
        return markdown(header, rows)

    def _baseline(self, method: str) -> str:
        """The method `method` is paired with: the spec's baseline, or with `same` itself."""
        return method if self.spec.baseline == SAME else self.spec.baseline

    def _paired_name(self, method: str) -> str:
        s = self.spec
        baseline = method_name(self._baseline(method))
        if s.baseline_backbone is not None:
            return (f"{method_name(method)} with `{s.backbone}` vs. {baseline} with `{s.baseline_backbone}`"
                    + (f" of `{self.baseline_records.name}`" if self.baseline_records is not None else ""))
        at = "" if s.baseline_budget is None else f" at {_budget_name(s.baseline_budget)}"
        if self.baseline_records is not None:
            return f"{method_name(method)} vs. {baseline} of `{self.baseline_records.name}`{at}"
        if at:
            return f"{method_name(method)} vs. {baseline}{at}"
        return method_name(method)

    def _paired_cells(self, runs: list[dict], base: list[dict]) -> list[str]:
        return [paired_test(runs, base, m).cell(self.spec.digits) for m in self.spec.metrics]

    def _classes(self) -> str:
        s = self.spec
        rows = []
        for budget in self.budgets():
            runs = {m: self.runs(m, budget) for m in s.methods}
            for metric in s.metrics or self._every_class():
                means = [mean_std([metric.value(r) for r in runs[m]])[0] for m in s.methods]
                cells = ["–" if mu is None else pct(mu, s.digits) for mu in means]
                if s.bold:
                    cells = _bold_best(cells, means)
                rows.append(self._lead(budget) + [metric.label] + cells)
        header = self._lead_header() + ["Class"] + [method_name(m) for m in s.methods]
        return markdown(header, rows)

    def _unseen_each(self) -> str:
        """Leave-one-class-out (`--unseen each`): a row per class left out, each method's figures
        over the runs that left it out, and a last row with their mean over the classes."""
        s = self.spec
        runs = {m: self.runs(m, None) for m in s.methods}
        left_out = {tuple(r.get("unseen_classes") or ()) for rs in runs.values() for r in rs}
        classes = [c for c in self.records.label_names if (c,) in left_out]
        rows, means = [], []
        for cls in classes:
            mine = {m: [r for r in rs if tuple(r.get("unseen_classes") or ()) == (cls,)] for m, rs in runs.items()}
            mine = self.same_runs(mine, None)
            cells = [mean_std([metric.value(r) for r in mine[m]])[0] for m in s.methods for metric in s.metrics]
            means.append(cells)
            rows.append([cls] + [pct(v, s.digits) if v is not None else "–" for v in cells])
        overall = np.nanmean(np.array(means, dtype=float), axis=0)
        rows.append([f"mean over the {len(classes)} classes"] + [pct(v, s.digits) for v in overall])
        header = ["Class left out"] + [f"{method_name(m)}: {metric.label}" for m in s.methods for metric in s.metrics]
        return markdown(header, rows)

    def _every_class(self) -> list[Metric]:
        return [Metric(label=name, metric=f"class:{name}") for name in self.records.label_names]

    def _synthetic(self) -> str:
        rows = []
        for budget in self.budgets():
            for method in self.spec.methods:
                runs = self.runs(method, budget)
                got = np.array([r.get("n_synthetic") or 0 for r in runs], dtype=float)
                asked = np.array([r.get("n_synthetic_requested") or 0 for r in runs], dtype=float)
                share = got.sum() / asked.sum() if asked.sum() else float("nan")
                rows.append(self._lead(budget) + [
                    method_name(method), f"{got.mean():.0f}", f"{np.median(got):.0f}",
                    f"{asked.mean():.0f}", f"{100 * share:.0f} %"])
        header = self._lead_header() + ["Method", "Synthetic windows per run (mean)",
                                        "median", "asked for (mean)", "delivered"]
        return markdown(header, rows)

    def _shares(self) -> str:
        """The do-no-harm choice: per method, the synthetic windows kept of those offered, the
        classes that got none (in how many runs) and those kept unjudged (`noharm.unjudged`)."""
        rows = []
        for budget in self.budgets():
            for method in self.spec.methods:
                runs = self.runs(method, budget)
                choices = [r.get("synthetic_shares") or {} for r in runs]
                offered = sum(s["offered"] for c in choices for s in c.values())
                kept = sum(s["kept"] for c in choices for s in c.values())
                rows.append(self._lead(budget) + [
                    method_name(method), f"{100 * kept / offered:.0f} %" if offered else "–",
                    _class_counts(choices, lambda s: s["share"] == 0, len(runs)),
                    _class_counts(choices, unjudged, len(runs))])
        header = self._lead_header() + ["Method", "synthetic windows kept", "classes that got none (runs)",
                                        "not judged: too few validation windows (runs)"]
        return markdown(header, rows)


def _class_counts(choices: Sequence[dict], test, n_runs: int) -> str:
    """'WALKING 12, SITTING 3' (of n_runs): classes by how many runs pass `test`, most first."""
    counts: dict[str, int] = {}
    for choice in choices:
        for name, share in choice.items():
            if test(share):
                counts[name] = counts.get(name, 0) + 1
    if not counts:
        return "none"
    ranked = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))
    return ", ".join(f"{name} {n}/{n_runs}" for name, n in ranked)


def _bold_best(cells: list[str], values: Sequence[float | None]) -> list[str]:
    present = [v for v in values if v is not None]
    if len(present) < 2:
        return cells
    best = max(present)
    return [f"**{c}**" if v is not None and np.isclose(v, best) else c
            for c, v in zip(cells, values, strict=True)]


# -- documents ----------------------------------------------------------------------------
@dataclass(frozen=True)
class Block:
    """One marked table in a document; `newline` ends its opening mark's line (a table is
    written back with it, so a CRLF document stays CRLF)."""

    path: Path
    table_id: str
    body: str
    start: int
    end: int
    newline: str = "\n"

    def text(self) -> str:
        """The body with LF line ends, as tables are rendered."""
        return self.body.replace("\r\n", "\n")


def find_blocks(path: Path, text: str) -> list[Block]:
    """The marked blocks of a document, line by line: a mark without its partner, nested marks
    and a line that looks like a mark but is not one are errors (never skipped)."""
    blocks: list[Block] = []
    opened: tuple[str, int, str, int] | None = None  # table id, body start, newline, line number
    offset = 0
    for number, match in enumerate(LINE.finditer(text), start=1):
        line, start, offset = match[0], offset, match.end()
        mark = line.rstrip()
        open_mark = OPEN_MARK.fullmatch(mark)
        if open_mark is not None and opened is None:
            opened = (open_mark["id"], offset, "\r\n" if line.endswith("\r\n") else "\n", number)
        elif mark == CLOSE_MARK and opened is not None:
            blocks.append(Block(path, opened[0], text[opened[1]:start], opened[1], start, opened[2]))
            opened = None
        elif open_mark is not None or mark == CLOSE_MARK or MARK_LIKE.match(line):
            raise InputFileError(f"line {number}: {_misplaced(mark, opened and opened[3])}", file=path,
                                 allowed=MARK_FORM)
    if opened is not None:
        raise InputFileError(f"line {opened[3]}: a '<!-- report:ID -->' mark has no '{CLOSE_MARK}' after it",
                             file=path, allowed=MARK_FORM)
    return blocks


def _misplaced(mark: str, open_line: int | None) -> str:
    """Why a line that looks like a mark does not open or close a block."""
    if OPEN_MARK.fullmatch(mark):
        return f"a mark opens a block inside the block of line {open_line} (marks do not nest)"
    if mark == CLOSE_MARK:
        return f"a '{CLOSE_MARK}' mark has no '<!-- report:ID -->' before it"
    return f"{mark!r} looks like a report mark but is not one"


def _check_writable(path: Path) -> None:
    """Refuse to rewrite a read-only document: one whose mode has no write bit (even for
    root, who may write anything), or that this user or its folder does not let us write."""
    target = path.resolve()
    if not (target.stat().st_mode & stat.S_IWUSR and os.access(target, os.W_OK)
            and os.access(target.parent, os.W_OK | os.X_OK)):
        raise InputFileError("the document is read-only, so `report --write` leaves it (and every other "
                             "document) as it is", file=path,
                             allowed="make it writable (chmod u+w) first, or see its differences with --check")


def _rewrite(path: Path, text: str) -> Path:
    """Replace a document keeping its mode; through a symbolic link, its target."""
    target = path.resolve()
    write_text(target, text, mode=stat.S_IMODE(target.stat().st_mode))
    return path


@dataclass
class Outcome:
    """What `check` found: tables that differ (with their diffs) and warnings."""

    differing: list[str] = field(default_factory=list)
    diffs: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    checked: int = 0
    written: list[Path] = field(default_factory=list)


class Publication:
    """The repository's documents and their generated tables.

    `root` is the repository root: records in `root/results/`, the catalogue in
    `root/results/tables.yaml`, documents README.md, BENCHMARKS.md and docs/*.md.
    """

    def __init__(self, root: str | Path, results_dir: str | Path | None = None) -> None:
        self.root = Path(root)
        self.results_dir = Path(results_dir) if results_dir else self.root / "results"
        self.catalogue = load_catalogue(self.results_dir / SPEC_FILE)
        self._sets: dict[str, RecordSet] = {}
        self._studies: dict[str, StudyRecord] = {}
        self._figures: dict[str, CurveFigure] = {}  # the curves placed in the documents, by id

    def documents(self) -> list[Path]:
        found: list[Path] = []
        for pattern in DOC_GLOBS:
            found += sorted(self.root.glob(pattern))
        return [p for p in found if p.is_file()]

    def render(self, table_id: str, document: Path | None = None) -> str:
        """A table's Markdown; a curve's link (relative to `document`, default README.md) and
        table of what it plots."""
        targets = next((t for t in self.catalogue.targets if t.id == table_id), None)
        if targets is not None:
            return TargetsBuilder(targets, self._set).render()
        spec = next((t for t in self.catalogue.tables if t.id == table_id), None)
        if spec is None:
            raise ConfigError(f"no table '{table_id}' in {SPEC_FILE}", file=self.results_dir / SPEC_FILE)
        if spec.kind == "curve":
            return self._curve(spec, document or self.root / "README.md")
        if spec.kind == "benchmark":
            return BenchTable(self.root, spec.id, spec.source, spec.view).render()
        if spec.kind == "study":
            if spec.records not in self._studies:
                self._studies[spec.records] = load_study(self.results_dir, spec.records)
            return StudyTable(spec.id, spec.view, self._studies[spec.records]).render()
        baseline = self._set(spec.baseline_records) if spec.baseline_records else None
        return TableBuilder(spec, self._set(spec.records), baseline).render()

    def _set(self, name: str) -> RecordSet:
        """A committed record set, read once per publication."""
        if name not in self._sets:
            self._sets[name] = load_run(self.results_dir, name)
        return self._sets[name]

    def _curve(self, spec: TableSpec, document: Path) -> str:
        figure = CurveFigure(spec, [self._set(n) for n in (spec.records, *spec.extra_records)],
                             {m: method_name(m) for m in spec.methods})
        self._figures[spec.id] = figure
        image = Path(os.path.relpath(self.root / figure_path(spec.id), document.parent)).as_posix()
        header, rows, used = figure.table()
        sources = "; ".join(f"`results/{r.name}/` from `{r.command}`"
                            + (f" at commit {r.code_commit[:7]}" if r.code_commit else "") for r in used)
        alt = f"{' and '.join(m.label for m in spec.metrics)} against the label budget"
        return (f"![{alt}]({image})\n\n{markdown(header, rows)}\n\nMeans (%) over the runs (their number "
                f"in brackets), backbone `{spec.backbone}`. Records: {sources}; rebuilt by `vsmp-imu report "
                "--write`.\n")

    def _expected(self, block: Block, unbacked: dict[str, str], outcome: Outcome) -> str | None:
        if block.table_id in unbacked:
            rel = block.path.relative_to(self.root)
            outcome.warnings.append(f"{rel}: table '{block.table_id}' is not rebuilt from committed "
                                    f"records ({unbacked[block.table_id]})")
            return None
        return self.render(block.table_id, block.path)

    def _figures_out(self, write: bool, outcome: Outcome) -> None:
        """With `write`, draw every curve the documents place; else name the ones not drawn."""
        for table_id, figure in sorted(self._figures.items()):
            path = self.root / figure_path(table_id)
            if write:
                png = figure.png()
                if not path.is_file() or path.read_bytes() != png:
                    outcome.written.append(write_bytes(path, png))
            elif not path.is_file():
                outcome.differing.append(f"{figure_path(table_id)}: figure '{table_id}' not drawn")
                outcome.diffs.append(f"{figure_path(table_id)} is missing: run `vsmp-imu report --write`\n")

    def check(self, write: bool = False) -> Outcome:
        """Compare (or, with `write`, rewrite) every marked block with its records. Every
        document is checked before any is written: an error leaves them all as they were."""
        unbacked = {u.id: u.reason for u in self.catalogue.unbacked}
        known = {t.id for t in self.catalogue.tables} | {t.id for t in self.catalogue.targets} | set(unbacked)
        outcome, placed, rewrites = Outcome(), set(), {}
        for path in self.documents():
            text, new_text = self._document(path, known, unbacked, outcome, placed)
            if new_text != text:
                rewrites[path] = new_text
        outcome.warnings += [f"table '{i}' is declared in {SPEC_FILE} but placed in no document"
                             for i in sorted(known - placed)]
        if write:
            for path in rewrites:
                _check_writable(path)
            outcome.written += [_rewrite(path, new_text) for path, new_text in rewrites.items()]
        self._figures_out(write, outcome)
        return outcome

    def _document(self, path: Path, known: set[str], unbacked: dict[str, str], outcome: Outcome,
                  placed: set[str]) -> tuple[str, str]:
        """A document's text and the same with its blocks rebuilt; the blocks that differ go
        to `outcome`, their ids to `placed`."""
        text = read_text(path, newline="")  # line ends as written: a CRLF document stays CRLF
        new_text, last = [], 0
        for block in find_blocks(path, text):
            if block.table_id not in known:
                raise ConfigError(f"table '{block.table_id}' is not declared in {SPEC_FILE}",
                                  file=path, allowed=", ".join(sorted(known)))
            placed.add(block.table_id)
            expected = self._expected(block, unbacked, outcome)
            new_text += [text[last:block.start],
                         block.body if expected is None else expected.replace("\n", block.newline)]
            last = block.end
            if expected is None:
                continue
            outcome.checked += 1
            if expected != block.text():
                rel = str(path.relative_to(self.root))
                outcome.differing.append(f"{rel}: table '{block.table_id}'")
                outcome.diffs.append("".join(difflib.unified_diff(
                    block.text().splitlines(keepends=True), expected.splitlines(keepends=True),
                    f"{rel} [{block.table_id}] (in the document)",
                    f"{rel} [{block.table_id}] (from the records)")))
        new_text.append(text[last:])
        return text, "".join(new_text)
