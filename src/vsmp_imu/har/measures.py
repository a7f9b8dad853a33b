"""How a measured figure is read from a record and written in a table: a metric of a record,
a paired test between two methods' runs, and the cells and names the tables print (shared by
`har.published`, `har.targets` and `har.report`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field
from scipy.stats import wilcoxon

MINUS = "\u2212"
METHOD_NAMES = {
    "real": "Real-only",
    "classical": "Classical Aug",
    "imugpt": "IMUGPT-2.0-style",
    "imutube": "IMUTube-style",
    "vsmp": "VSMP-IMU",
    "vsmp-motion-fit": "VSMP-IMU + motion fit",
    "vsmp-no-texture": "VSMP-IMU, no texture",
    "vsmp+classical": "VSMP-IMU + Classical Aug",
    "vsmp-class-rank": "VSMP-IMU, per-class rank",
    "vsmp-rank-only": "VSMP-IMU, no sim-in-the-loop",
}


# The unseen protocol's figures: Macro-F1 over the unseen / seen classes and the share of
# seen-class test windows predicted as an unseen class (and the reverse).
UNSEEN_METRICS = {"unseen": "unseen_macro_f1", "seen": "seen_macro_f1",
                  "seen_as_unseen": "seen_as_unseen", "unseen_as_seen": "unseen_as_seen"}


class Metric(BaseModel):
    """One row (or column) of figures: `macro_f1`, `head`, `tail`, `group:NAME`, `class:NAME`,
    or of the unseen protocol `unseen`, `seen`, `seen_as_unseen`, `unseen_as_seen`."""

    model_config = ConfigDict(extra="forbid")
    label: str
    metric: str = Field(pattern=r"^(macro_f1|accuracy|head|tail|unseen|seen|seen_as_unseen|unseen_as_seen"
                                r"|group:.+|class:.+)$")

    def value(self, record: dict) -> float | None:
        if self.metric in ("macro_f1", "accuracy"):
            return record.get(self.metric)
        if self.metric in UNSEEN_METRICS:
            return record.get(UNSEEN_METRICS[self.metric])
        if self.metric in ("head", "tail"):
            return record.get(f"{self.metric}_macro_f1")
        kind, name = self.metric.split(":", 1)
        key = "group_macro_f1" if kind == "group" else "per_class_f1"
        return (record.get(key) or {}).get(name)


# -- figures ------------------------------------------------------------------------------
def pct(value: float, digits: int) -> str:
    text = f"{100 * value:.{digits}f}"
    return text.replace("-", MINUS)


def signed(value: float, digits: int) -> str:
    text = f"{100 * value:+.{digits}f}"
    return text.replace("-", MINUS)


def format_p(p: float) -> str:
    """'3e-6' below 0.001, else two significant digits ('0.013', '0.54')."""
    if not np.isfinite(p):
        return "n/a"
    if p < 1e-3:
        mantissa, exponent = f"{p:.0e}".split("e")
        return f"{mantissa}e{int(exponent)}"
    return f"{p:.2g}"


@dataclass(frozen=True)
class Paired:
    """Method minus baseline over the runs both have (same fold and seed)."""

    mean_diff: float
    won: int
    n: int
    p: float

    def cell(self, digits: int) -> str:
        return f"{signed(self.mean_diff, digits)} ({self.won}/{self.n}, p = {format_p(self.p)})"


def paired_test(method: Sequence[dict], baseline: Sequence[dict], metric: Metric) -> Paired:
    """Mean paired difference, runs won and the two-sided Wilcoxon signed-rank p."""
    base = {run_key(r): metric.value(r) for r in baseline}
    pairs = [(metric.value(r), base.get(run_key(r))) for r in method]
    diffs = np.array([a - b for a, b in pairs if a is not None and b is not None], dtype=float)
    if len(diffs) == 0:
        return Paired(float("nan"), 0, 0, float("nan"))
    if len(diffs) < 2:  # one run has no test
        p = float("nan")
    else:
        p = float(wilcoxon(diffs).pvalue) if np.any(diffs != 0) else 1.0
    return Paired(float(diffs.mean()), int(np.sum(diffs > 0)), len(diffs), p)


def markdown(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def method_name(method: str) -> str:
    return METHOD_NAMES.get(method, method)


def run_key(record: dict) -> tuple[str, int, tuple[str, ...]]:
    """What pairs two runs: fold, seed and, under leave-one-class-out, the class left out."""
    return str(record["fold"]), record["seed"], tuple(record.get("unseen_classes") or ())


def run_keys(records: Sequence[dict]) -> set[tuple[str, int, tuple[str, ...]]]:
    return {run_key(r) for r in records}


def shared_runs(mine: Sequence[dict], base: Sequence[dict]) -> tuple[list[dict], list[dict]]:
    """The runs of each side that the other side has too (same fold, seed and class left out)."""
    both = run_keys(mine) & run_keys(base)
    return [r for r in mine if run_key(r) in both], [r for r in base if run_key(r) in both]


def several_per_run(found: Sequence[dict]) -> str | None:
    """None where `found` holds one record per run; else what its records mix ('budgets 1.0,
    5.0'), or '' where they mix nothing a table can name. Records of several budgets or
    backbones would otherwise be paired and averaged as if one."""
    if len({run_key(r) for r in found}) == len(found):
        return None
    return "; ".join(f"{field}s {', '.join(sorted({str(r[field]) for r in found}))}"
                     for field in ("budget", "backbone") if len({str(r[field]) for r in found}) > 1)
