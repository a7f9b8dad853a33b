"""Figures of a metric against the label budget (`kind: curve` in results/tables.yaml).

A curve joins several record sets of one protocol and backbone (e.g. the 1 %, the 2-3 % and the
5 % grids, and Real-only's learning curve): for each method and budget the mean of the metric
over the runs of the first set, in the spec's order, that has that method at that budget. The
document gets the picture and, below it, a table of the plotted means, so `vsmp-imu report
--check` compares the figures with the records as it compares any table; `--write` redraws the
PNG (its pixels are not compared: they depend on the matplotlib version).
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsmp_imu.har.metrics import mean_std
from vsmp_imu.har.records import RecordSet

# where the figures of the documents live, relative to the repository root
FIGURE_DIR = Path("docs", "img")


@dataclass(frozen=True)
class Point:
    budget: float
    mean: float
    std: float
    n: int
    source: str  # the record set it came from


def figure_path(table_id: str) -> Path:
    """The PNG of a curve, relative to the repository root (`docs/img/<set>-<name>.png`)."""
    return FIGURE_DIR / (table_id.replace(":", "-") + ".png")


class CurveFigure:
    """One curve spec over its record sets: the points, their Markdown table, the picture."""

    def __init__(self, spec, sets: Sequence[RecordSet], names: dict[str, str]) -> None:
        self.spec = spec
        self.sets = list(sets)
        self.names = names  # method -> display name

    def points(self, method: str, metric) -> list[Point]:
        out = []
        for budget in self.spec.budgets:
            for records in self.sets:
                runs = records.select(method=method, budget=budget, backbone=self.spec.backbone)
                if runs:
                    mean, std, n = mean_std([metric.value(r) for r in runs])
                    if mean is not None:
                        out.append(Point(budget, mean, std or 0.0, n, records.name))
                    break
        return out

    def table(self) -> tuple[list[str], list[list[str]], list[RecordSet]]:
        """What the picture plots: a header, a row per budget (each method's mean in % and its
        number of runs, per metric) and the record sets the points came from."""
        s = self.spec
        header = ["Budget"] + [f"{m.label}: {self.names.get(x, x)}" for m in s.metrics for x in s.methods]
        cells = {(m.label, x): {p.budget: p for p in self.points(x, m)} for m in s.metrics for x in s.methods}
        rows = []
        for budget in s.budgets:
            row = [f"{budget:g} %"]
            for m in s.metrics:
                for x in s.methods:
                    p = cells[(m.label, x)].get(budget)
                    row.append("–" if p is None else f"{100 * p.mean:.2f} ({p.n})")
            rows.append(row)
        used = {p.source for c in cells.values() for p in c.values()}
        return header, rows, [r for r in self.sets if r.name in used]

    def png(self) -> bytes:
        """The figure: one panel per metric, the budget on a log axis, a line per method with a
        band of ± one standard error over its runs."""
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        s = self.spec
        fig, axes = plt.subplots(1, len(s.metrics), figsize=(5.2 * len(s.metrics), 3.8), squeeze=False)
        for ax, metric in zip(axes[0], s.metrics, strict=True):
            for method in s.methods:
                pts = self.points(method, metric)
                if not pts:
                    continue
                x = np.array([p.budget for p in pts])
                y = np.array([100 * p.mean for p in pts])
                err = np.array([100 * p.std / np.sqrt(max(p.n, 1)) for p in pts])
                (line,) = ax.plot(x, y, marker="o", ms=4, label=self.names.get(method, method))
                ax.fill_between(x, y - err, y + err, color=line.get_color(), alpha=0.15, lw=0)
            ax.set_xscale("log")
            ax.set_xticks(list(s.budgets), labels=[f"{b:g}" for b in s.budgets])
            ax.minorticks_off()
            ax.set_xlabel("labelled training windows (%)")
            ax.set_ylabel(f"{metric.label}, Macro-F1 (%)")
            ax.grid(alpha=0.3)
        axes[0][0].legend(fontsize=8)
        fig.tight_layout()
        buffer = io.BytesIO()
        fig.savefig(buffer, dpi=100, format="png", metadata={"Software": None})
        plt.close(fig)
        return buffer.getvalue()
