"""Outputs of the activity-granularity study: report.md, results.json, granularity.png.

The figure: (a) group Macro-F1 per method (bars, mean ± std over folds x
seeds), (b) per-class F1 of every method as a heat map, classes ordered by
group.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.studies.granularity import GranularityResults
from vsmp_imu.studies.methods import method_display
from vsmp_imu.studies.report import (
    NA,
    describer_lines,
    fmt_num,
    markdown_table,
    save_figure,
    write_report,
)

FIGURE_NAME = "granularity.png"
METHOD_COLORS = {"real": "#c05621", "classical": "#718096", "imutube": "#38a169", "imugpt": "#805ad5",
                 "vsmp": "#2b6cb0"}


def _pct(mean: Any, std: Any = None) -> str:
    if mean is None:
        return NA
    return f"{100 * mean:.2f}" + (f" ± {100 * std:.2f}" if std is not None else "")


def _group_order(r: GranularityResults) -> list[str]:
    """The taxonomy's group order (kept by the result rows; results.json sorts mapping keys)."""
    return list(dict.fromkeys([x["group"] for x in r.groups] + list(r.taxonomy)))


def group_table(r: GranularityResults) -> str:
    """Group Macro-F1 per method (mean ± std, paired difference to Real-only) and the overall row."""
    methods = r.settings["methods"]
    overall = {o["method"]: o for o in r.overall}
    headers = ["Group"] + [method_display(m) for m in methods]
    rows = []
    for g in _group_order(r):
        row = [g]
        for m in methods:
            cell = next(x for x in r.groups if x["method"] == m and x["group"] == g)
            text = _pct(cell["macro_f1_mean"], cell["macro_f1_std"])
            d = cell.get("delta_vs_real")
            if d and d["mean"] is not None:
                text += f" ({100 * d['mean']:+.2f})"
            row.append(text)
        rows.append(row)
    rows.append(["All classes (Macro-F1)"] + [_pct(overall[m]["macro_f1_mean"], overall[m]["macro_f1_std"])
                                              for m in methods])
    return markdown_table(headers, rows)


def class_table(r: GranularityResults) -> str:
    """Per class (grouped): support and each method's precision / recall / F1 (%)."""
    methods = r.settings["methods"]
    headers = ["Group", "Class", "Support"] + [f"{method_display(m)} P / R / F1" for m in methods]
    rows = []
    for g, classes in [*((g, r.taxonomy[g]) for g in _group_order(r)), ("(ungrouped)", r.ungrouped)]:
        for c in classes:
            cells = [next(x for x in r.per_class if x["method"] == m and x["class"] == c) for m in methods]
            if cells[0]["support"] == 0 and all(x["f1_mean"] is None for x in cells):
                continue
            rows.append([g, c, str(cells[0]["support"])] + [
                " / ".join(fmt_num(None if x[k] is None else 100 * x[k], 1)
                           for k in ("precision_mean", "recall_mean", "f1_mean")) for x in cells])
    return markdown_table(headers, rows, align=["l", "l"] + ["r"] * (len(headers) - 2))


def granularity_markdown(r: GranularityResults) -> str:
    s = r.settings
    budget = "full training data" if s["label_budget_percent"] is None else \
        f"{s['label_budget_percent']:g} % label budget"
    methods = s["methods"]
    out = ["# Activity-granularity study", "", "## What was run", "",
           f"- **Dataset** {s['dataset']}, protocol **{s['protocol']}** ({budget}), folds "
           f"({len(s['folds'])}): {', '.join(s['folds'])}; seeds {', '.join(map(str, s['seeds']))}.",
           f"- **Backbone** {s['backbone']}" + (f" {s['backbone_params']}" if s["backbone_params"] else "")
           + f"; alpha = {s['alpha']:g} (same synthetic budget for every method).",
           f"- **Methods run**: {', '.join(method_display(m) for m in methods)}.",
           f"- **Taxonomy**: `{s['taxonomy_file']}`.",
           f"- Generation: backend `{s['generation']['backend']}`, source `{s['generation']['source']}`. "
           f"Wall time {r.elapsed_s / 60:.1f} min."]
    out += describer_lines(s)
    out += [f"- Note: {n}." for n in s.get("dataset_notes", [])]
    for m, reason in r.skipped.items():
        out.append(f"- **Skipped {method_display(m)}**: {reason}.")
    out += ["", "## Taxonomy", "",
            markdown_table(["Group", "Classes", "n"], [[g, ", ".join(r.taxonomy[g]), str(len(r.taxonomy[g]))]
                                                       for g in _group_order(r)], align=["l", "l", "r"]), ""]
    if r.ungrouped:
        out += [f"Classes in no group (left out of the group table): {', '.join(r.ungrouped)}.", ""]
    out += ["## Group Macro-F1 (%)", "",
            "Mean ± std over folds x seeds of the mean F1 of a group's classes (those in the held-out "
            "subject's truth or predictions); in brackets the paired difference to Real-only.", "",
            group_table(r), ""]
    out += ["## Per-class precision, recall and F1 (%)", "",
            "Means over folds x seeds (a class absent from a held-out subject's truth and predictions "
            "is not counted for that fold); support = test windows summed over folds x seeds.", ""]
    out += [class_table(r), "",
            "## Deviations from the paper", "",
            "- The paper evaluates UTD-MHAD under standard LOPO with DeepConvLSTM, five seeds, all eight "
            "subjects; the settings of this run are listed above (RF-ECDF is the CPU default).",
            "- Synthetic data come from the procedural motion backend and the activity library's SMPs "
            "(IMUGPT-style prompts from library captions), not HY-Motion and VLM-extracted SMPs.",
            "- A method that cannot run is skipped with its reason (IMUTube needs source clips).", "",
            f"![granularity]({FIGURE_NAME})"]
    return "\n".join(out)


def granularity_figure(r: GranularityResults):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = r.settings["methods"]
    groups = _group_order(r)
    classes = [c for g in groups for c in r.taxonomy[g]]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, max(4.5, 0.28 * len(classes) + 1.5)),
                                   gridspec_kw={"width_ratios": [1.1, 1]})
    width = 0.8 / len(methods)
    top = 100.0
    for i, m in enumerate(methods):
        cells = [next(x for x in r.groups if x["method"] == m and x["group"] == g) for g in groups]
        means = [100 * (c["macro_f1_mean"] or 0) for c in cells]
        stds = [100 * (c["macro_f1_std"] or 0) for c in cells]
        x = np.arange(len(groups)) + (i - (len(methods) - 1) / 2) * width
        ax1.bar(x, means, width, yerr=stds, capsize=2, label=method_display(m), color=METHOD_COLORS.get(m),
                edgecolor="black", linewidth=0.4)
        for xi, v, sd, c in zip(x, means, stds, cells, strict=True):  # the value above its error bar
            if c["macro_f1_mean"] is not None:
                ax1.annotate(f"{v:.0f}", (xi, v + sd), xytext=(0, 2), textcoords="offset points", ha="center",
                             va="bottom", fontsize=6)
        top = max([top, *(v + sd for v, sd in zip(means, stds, strict=True))])
    ax1.set_xticks(range(len(groups)), [g.replace(" and ", " &\n") for g in groups], fontsize=8)
    ax1.set_ylabel("group Macro-F1 (%)")
    ax1.set_ylim(0, top + 8)
    ax1.grid(axis="y", alpha=0.3)
    ax1.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=len(methods), frameon=False)
    ax1.set_title("(a) Macro-F1 per activity group", loc="left", fontsize=10)
    grid = np.full((len(classes), len(methods)), np.nan)
    for j, m in enumerate(methods):
        for i, c in enumerate(classes):
            v = next(x for x in r.per_class if x["method"] == m and x["class"] == c)["f1_mean"]
            grid[i, j] = np.nan if v is None else 100 * v
    im = ax2.imshow(grid, aspect="auto", cmap="viridis", vmin=0, vmax=100)
    for i in range(len(classes)):
        for j in range(len(methods)):
            if np.isfinite(grid[i, j]):
                ax2.text(j, i, f"{grid[i, j]:.0f}", ha="center", va="center", fontsize=7,
                         color="white" if grid[i, j] < 60 else "black")
    ax2.set_xticks(range(len(methods)), [method_display(m) for m in methods], fontsize=8, rotation=20)
    ax2.set_yticks(range(len(classes)), classes, fontsize=7)
    edge = -0.5
    for g in groups[:-1]:
        edge += len(r.taxonomy[g])
        ax2.axhline(edge, color="white", linewidth=2)
    fig.colorbar(im, ax=ax2, fraction=0.04, label="F1 (%)")
    ax2.set_title("(b) per-class F1, classes grouped", loc="left", fontsize=10)
    s = r.settings
    n_folds, n_seeds = len(s["folds"]), len(s["seeds"])
    fig.suptitle(f"{s['dataset']}, {s['protocol']}, {s['backbone']}, {n_folds} fold{'s' * (n_folds != 1)} x "
                 f"{n_seeds} seed{'s' * (n_seeds != 1)}", fontsize=10)
    fig.tight_layout()
    return fig


def write_granularity_outputs(results: GranularityResults, out_dir: str | Path) -> dict[str, Path]:
    out = Path(out_dir)
    md, js = write_report(out, granularity_markdown(results), results.to_json())
    figure = save_figure(granularity_figure(results), out / FIGURE_NAME, dpi=150)
    return {"report": md, "results": js, "figure": figure}
