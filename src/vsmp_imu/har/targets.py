"""The project's targets measured from the committed records (`targets` in results/tables.yaml).

A targets table has one row per target: what it asks, where its runs are (a record set, and
for a comparison the baseline's record set where it is another one), which method, metric,
backbone and budget, and the rule. The verdict is computed from the records each time the
table is rebuilt, never typed:

- `at_least: X` alone: the metric's mean over the runs reaches X points (under
  leave-one-class-out, the mean over the classes left out of each class's mean over its runs;
  with the metric `lowest_class`, the lowest class's mean);
- `at_least: X` with a `baseline`: the mean paired difference (same fold and seed) reaches X;
- `not_below: true` with a `baseline`: the method is not significantly below it (its mean
  paired difference is not negative at a two-sided Wilcoxon p < 0.05).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.measures import (
    Metric,
    markdown,
    method_name,
    paired_test,
    pct,
    several_per_run,
    shared_runs,
)
from vsmp_imu.har.records import RecordSet

SIGNIFICANCE = 0.05  # `not_below`: a loss at this two-sided p counts as significant
LOWEST_CLASS = "lowest_class"


class TargetRow(BaseModel):
    """One target and how its runs answer it."""

    model_config = ConfigDict(extra="forbid")
    target: str  # what it asks, in the words of the table
    records: str
    method: str
    metric: str = "macro_f1"  # a table metric (`har.measures.Metric`) or `lowest_class`
    backbone: str | None = None
    budget: float | None = None
    baseline: str | None = None  # a method: the target compares against its runs
    baseline_records: str | None = None  # the baseline's record set, where it is another one
    at_least: float | None = None  # points
    not_below: bool = False

    @model_validator(mode="after")
    def _consistent(self) -> TargetRow:
        if (self.at_least is None) == (not self.not_below):
            raise ValueError("a target has one rule: at_least (points) or not_below: true")
        if self.not_below and self.baseline is None:
            raise ValueError("not_below compares with a baseline method; name it")
        if self.baseline_records is not None and self.baseline is None:
            raise ValueError("baseline_records holds a baseline's runs; name the baseline method")
        if self.metric == LOWEST_CLASS:
            if self.baseline is not None:
                raise ValueError("lowest_class is a mean over classes, not a paired difference")
        else:
            Metric(label=self.target, metric=self.metric)  # a metric the tables know
        return self

    def measure(self) -> Metric:
        return Metric(label=self.target, metric=self.metric)


class TargetTable(BaseModel):
    """A table of targets (rows from any record sets)."""

    model_config = ConfigDict(extra="forbid")
    id: str = Field(pattern=r"^[a-z0-9_-]+:[a-z0-9_-]+$")
    rows: list[TargetRow] = Field(min_length=1)


class TargetsBuilder:
    """Render a `TargetTable` from the record sets `record_set(name)` reads."""

    def __init__(self, spec: TargetTable, record_set: Callable[[str], RecordSet]) -> None:
        self.spec = spec
        self.record_set = record_set

    def render(self) -> str:
        rows = [self._row(row) for row in self.spec.rows]
        header = ["Target", "Measured", "Verdict", "Records"]
        return (f"{markdown(header, rows)}\n\nPoints of Macro-F1 (%). Verdicts are computed from the records "
                f"(a paired loss counts at p < {SIGNIFICANCE:g}, two-sided Wilcoxon over the same folds and "
                "seeds); each record set's command is in its `run.json` and under its tables in "
                "docs/results.md; rebuilt by `vsmp-imu report --write`.\n")

    def _row(self, row: TargetRow) -> list[str]:
        mine = self._runs(row, row.method, row.records)
        sets = self._set_name(row.records)
        if row.baseline is None:
            measured, met, short = self._mean(row, mine)
        else:
            base = self._runs(row, row.baseline, row.baseline_records or row.records)
            mine, base = shared_runs(mine, base)
            if not mine:
                raise self._error(row, f"{method_name(row.method)} and {method_name(row.baseline)} share no run")
            measured, met, short = self._paired(row, mine, base)
            if row.baseline_records is not None:
                sets += f" against {self._set_name(row.baseline_records)}"
        verdict = "met" if met else "missed" + (f" by {short:.2f}" if short is not None else "")
        return [row.target, measured, f"**{verdict}**" if met else verdict, sets]

    def _set_name(self, name: str) -> str:
        commit = self.record_set(name).code_commit
        return f"`{name}`" + (f" at {commit[:7]}" if commit else "")

    def _mean(self, row: TargetRow, runs: list[dict]) -> tuple[str, bool, float | None]:
        if row.metric == LOWEST_CLASS:
            value, name = self._lowest_class(runs)
            text = f"{pct(value, 2)} ({name}, {len(runs)} runs)"
        else:
            value = self._mean_over_left_out(row, runs)
            text = f"{pct(value, 2)} ({len(runs)} runs)"
        return (text, *_judge(row.at_least, value))

    def _paired(self, row: TargetRow, mine: list[dict], base: list[dict]) -> tuple[str, bool, float | None]:
        test = paired_test(mine, base, row.measure())
        if test.n == 0:
            raise self._error(row, f"no run pair has the metric '{row.metric}'")
        text = f"{test.cell(2)} vs. {method_name(row.baseline)}"
        if row.not_below:
            return text, not (test.mean_diff < 0 and test.p < SIGNIFICANCE), None
        return (text, *_judge(row.at_least, test.mean_diff))

    def _mean_over_left_out(self, row: TargetRow, runs: list[dict]) -> float:
        """The mean over the runs; under leave-one-class-out the mean over the classes left out
        of each one's mean (every class counts once, however many runs it has)."""
        metric = row.measure()
        by_left_out: dict[tuple[str, ...], list[float]] = {}
        for r in runs:
            value = metric.value(r)
            if value is not None:
                by_left_out.setdefault(tuple(r.get("unseen_classes") or ()), []).append(value)
        if not by_left_out:
            raise self._error(row, f"no run has the metric '{row.metric}'")
        return float(np.mean([np.mean(v) for v in by_left_out.values()]))

    @staticmethod
    def _lowest_class(runs: list[dict]) -> tuple[float, str]:
        names = list((runs[0].get("per_class_f1") or {}).keys())
        means = {n: float(np.mean([r["per_class_f1"][n] for r in runs])) for n in names}
        name = min(means, key=means.get)
        return means[name], name

    def _runs(self, row: TargetRow, method: str, records: str) -> list[dict]:
        where: dict = {"method": method}
        if row.budget is not None:
            where["budget"] = row.budget
        if row.backbone is not None:
            where["backbone"] = row.backbone
        found = self.record_set(records).select(**where)
        if not found:
            raise self._error(row, f"record set '{records}' has no run of {method_name(method)}"
                              + ("" if row.backbone is None else f" with {row.backbone}")
                              + ("" if row.budget is None else f" at {row.budget:g} %"))
        mixed = several_per_run(found)
        if mixed is not None:
            raise self._error(row, f"record set '{records}' has several runs of {method_name(method)} per fold "
                              f"and seed{f' ({mixed})' if mixed else ''}: name the backbone and budget")
        return found

    def _error(self, row: TargetRow, message: str) -> ConfigError:
        return ConfigError(f"table '{self.spec.id}', target '{row.target}': {message}",
                           field="targets", allowed="a record set, method, backbone and budget with runs")


def _judge(at_least: float, value: float) -> tuple[bool, float | None]:
    """Whether `value` (a fraction) reaches `at_least` points as the table prints it (two
    decimals), and the points short where it does not."""
    shortfall = round(at_least - round(100 * value, 2), 2)
    return shortfall <= 0, shortfall if shortfall > 0 else None
