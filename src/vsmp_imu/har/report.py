"""Paper-style result tables (Markdown) and confusion-matrix figures (PNG)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.har.backbones import DISPLAY_NAMES
from vsmp_imu.har.measures import Metric, paired_test
from vsmp_imu.har.synthetic import METHOD_DISPLAY
from vsmp_imu.io import atomic_path, file_name_part, write_text


def _pct(mean: float | None, std: float | None) -> str:
    if mean is None:
        return "–"
    return f"{100 * mean:.2f} ± {100 * (std or 0.0):.2f}"


def _bold_best(cells: list[str], values: list[float | None]) -> list[str]:
    """Bold every cell holding the best (highest) value of the list."""
    present = [v for v in values if v is not None]
    if len(present) < 2:
        return cells
    best = max(present)
    return [
        f"**{c}**" if v is not None and np.isclose(v, best) else c
        for c, v in zip(cells, values, strict=True)
    ]


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


def _method(name: str) -> str:
    return METHOD_DISPLAY.get(name, name)


def _backbone(name: str) -> str:
    return DISPLAY_NAMES.get(name, name)


def _ordered(values: Sequence[Any], order: Sequence[Any] | None) -> list[Any]:
    seen = list(dict.fromkeys(values))
    if not order:
        return seen
    return [v for v in order if v in seen] + [v for v in seen if v not in order]


def weights_text(config: dict[str, Any]) -> str:
    """How the training windows were weighted (`--class-weight`, `--synthetic-weight`)."""
    params = config.get("backbone_params") or {}
    weights = {(params.get(b) or {}).get("class_weight") or "none" for b in config.get("backbones") or ()}
    text = f"class weights {' / '.join(sorted(weights)) or 'none'}"
    share = config.get("synthetic_weight")
    if share is not None:
        text += f" (per source: a class's synthetic windows together {share:g} times its real ones)"
    return text


def results_markdown(results: dict[str, Any]) -> str:
    """The Markdown report of a `results.json` object: one section per dataset/protocol."""
    summary = results["summary"]
    config = results.get("config", {})
    parts = ["# HAR evaluation results", ""]
    if config:
        parts.append(
            f"Window {config.get('window_s')} s, overlap {config.get('overlap')}, "
            f"alpha {config.get('alpha')} ({config.get('policy')} budget), "
            f"seeds {config.get('seeds')}, folds {config.get('folds')}, {weights_text(config)}. "
            "Values: Macro-F1 (%) mean ± std over folds and seeds; best per block in bold."
        )
        parts.append("")
    for dataset in dict.fromkeys(r["dataset"] for r in summary):
        for protocol in dict.fromkeys(r["protocol"] for r in summary if r["dataset"] == dataset):
            rows = [r for r in summary if r["dataset"] == dataset and r["protocol"] == protocol]
            parts.append(f"## {dataset} — {protocol}")
            parts.append("")
            if protocol == "low-resource":
                parts.append(_low_resource(rows, config))
            elif protocol == "long-tail":
                parts.append(_long_tail(rows, config))
            elif protocol == "unseen":
                parts.append(_unseen(rows, config))
            else:
                parts.append(_by_budget(rows, config))
            parts.append("")
            delivered = _synthetic_counts(rows, config)
            if delivered:
                parts += [delivered, ""]
            paired = _paired([r for r in results.get("records", ())
                              if r["dataset"] == dataset and r["protocol"] == protocol], config)
            if paired:
                parts += [paired, ""]
    return "\n".join(parts)


# what each method is paired with: Real-only, and Classical Aug for the methods that make windows
PAIRED_BASELINES = ("real", "classical")


def _paired(records: list[dict[str, Any]], config: dict[str, Any]) -> str:
    """`paired_rows` as a Markdown table with its caption ("" when nothing pairs)."""
    metrics, out = paired_rows(records, config)
    if not out:
        return ""
    header = ["Backbone", "Budget", "Pair"] + [m.label for m in metrics]
    return ("Paired differences (points of F1; runs won of the runs both have, same fold and seed; "
            "two-sided Wilcoxon signed-rank p; n/a with one run):\n\n" + _table(header, out))


def paired_rows(records: list[dict[str, Any]], config: dict[str, Any]) -> tuple[list[Metric], list[list[str]]]:
    """Each method against Real-only, and each other method against Classical Aug, per backbone
    and budget: the mean difference over the runs both have (same fold, seed and unseen set),
    the runs it wins, and the two-sided Wilcoxon signed-rank p (`published.paired_test`).
    Returns the metrics (columns after backbone, budget and pair) and the rows."""
    methods = _ordered([r["method"] for r in records], config.get("methods"))
    metrics = _paired_metrics(records)
    out = []
    for backbone in _ordered([r["backbone"] for r in records], config.get("backbones")):
        for budget in dict.fromkeys(r["budget"] for r in records if r["backbone"] == backbone):
            runs = {m: [r for r in records if r["backbone"] == backbone and r["budget"] == budget
                        and r["method"] == m] for m in methods}
            for baseline in (b for b in PAIRED_BASELINES if runs.get(b)):
                done = PAIRED_BASELINES[:PAIRED_BASELINES.index(baseline) + 1]  # paired already
                for method in (m for m in methods if runs[m] and m not in done):
                    cells = [paired_test(runs[method], runs[baseline], metric).cell(2) for metric in metrics]
                    out.append([_backbone(backbone), "" if budget is None else f"{budget:g}%",
                                f"{_method(method)} vs. {_method(baseline)}"] + cells)
    return metrics, out


def _paired_metrics(records: list[dict[str, Any]]) -> list[Metric]:
    """Macro-F1, the tail or unseen classes' where the protocol has them, and each report group."""
    metrics = [Metric(label="Macro-F1", metric="macro_f1")]
    if any(r.get("tail_macro_f1") is not None for r in records):
        metrics.append(Metric(label="Tail Macro-F1", metric="tail"))
    if any(r.get("unseen_macro_f1") is not None for r in records):
        metrics.append(Metric(label="Unseen Macro-F1", metric="unseen"))
    groups = dict.fromkeys(g for r in records for g in (r.get("group_macro_f1") or {}))
    return metrics + [Metric(label=f"{g} Macro-F1", metric=f"group:{g}") for g in groups]


def _synthetic_counts(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    """Synthetic windows mixed in per run against those the budget asked for: a generator
    whose filter rejects much can fall short, and then it is compared on fewer windows."""
    asked = [r for r in rows if r.get("n_synthetic_requested_mean")]
    if not asked:
        return ""
    methods = _ordered([r["method"] for r in asked], config.get("methods"))
    out = []
    for backbone in _ordered([r["backbone"] for r in asked], config.get("backbones")):
        for r in sorted((r for r in asked if r["backbone"] == backbone),
                        key=lambda r: (r["budget"] or 0, methods.index(r["method"]))):
            share = r["n_synthetic_mean"] / r["n_synthetic_requested_mean"]
            out.append([_backbone(backbone), "" if r["budget"] is None else f"{r['budget']:g}%",
                        _method(r["method"]), f"{r['n_synthetic_mean']:.0f}",
                        f"{r['n_synthetic_requested_mean']:.0f}", f"{100 * share:.0f} %"])
    header = ["Backbone", "Budget", "Method", "Synthetic windows per run", "Asked for", "Delivered"]
    return "Synthetic windows mixed in (mean per run):\n\n" + _table(header, out)


def _by_budget(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    """`_standard`, one table per label budget where rows have one (tstr with `--budgets`)."""
    budgets = list(dict.fromkeys(r.get("budget") for r in rows))
    if budgets == [None]:
        return _standard(rows, config)
    return "\n\n".join(f"### {'all labels' if b is None else f'{b:g} % of the labels'}\n\n"
                         + _standard([r for r in rows if r.get("budget") == b], config) for b in budgets)


def _standard(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    groups = sorted({g for r in rows for g in r.get("group_macro_f1", {})})
    header = (
        ["Backbone", "Method", "Macro-F1", "Accuracy"] + [f"{g} Macro-F1" for g in groups] + ["n"]
    )
    out = []
    for backbone in _ordered([r["backbone"] for r in rows], config.get("backbones")):
        block = [r for r in rows if r["backbone"] == backbone]
        block = sorted(
            block,
            key=lambda r: _ordered([b["method"] for b in block], config.get("methods")).index(
                r["method"]
            ),
        )
        columns = [("macro_f1_mean", "macro_f1_std"), ("accuracy_mean", "accuracy_std")]
        cells = [[_pct(r[m], r[s]) for r in block] for m, s in columns]
        values = [[r[m] for r in block] for m, _ in columns]
        for g in groups:
            cells.append(
                [
                    _pct(
                        r["group_macro_f1"].get(g, {}).get("mean"),
                        r["group_macro_f1"].get(g, {}).get("std"),
                    )
                    for r in block
                ]
            )
            values.append([r["group_macro_f1"].get(g, {}).get("mean") for r in block])
        cells = [_bold_best(c, v) for c, v in zip(cells, values, strict=True)]
        for i, r in enumerate(block):
            out.append(
                [_backbone(backbone), _method(r["method"])] + [c[i] for c in cells] + [str(r["n"])]
            )
    return _table(header, out)


def _low_resource(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    methods = _ordered([r["method"] for r in rows], config.get("methods"))
    header = ["Backbone", "Budget"] + [_method(m) for m in methods]
    out = []
    for backbone in _ordered([r["backbone"] for r in rows], config.get("backbones")):
        budgets = sorted({r["budget"] for r in rows if r["backbone"] == backbone})
        for budget in budgets:
            cells, values = [], []
            for m in methods:
                match = [
                    r
                    for r in rows
                    if r["backbone"] == backbone and r["budget"] == budget and r["method"] == m
                ]
                cells.append(
                    _pct(match[0]["macro_f1_mean"], match[0]["macro_f1_std"]) if match else "–"
                )
                values.append(match[0]["macro_f1_mean"] if match else None)
            out.append([_backbone(backbone), f"{budget:g}%"] + _bold_best(cells, values))
    return _table(header, out)


def _long_tail(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    header = ["Backbone", "Method", "Head Macro-F1", "Tail Macro-F1", "All Macro-F1", "n"]
    out = []
    for backbone in _ordered([r["backbone"] for r in rows], config.get("backbones")):
        block = [r for r in rows if r["backbone"] == backbone]
        columns = [
            ("head_macro_f1_mean", "head_macro_f1_std"),
            ("tail_macro_f1_mean", "tail_macro_f1_std"),
            ("macro_f1_mean", "macro_f1_std"),
        ]
        cells = [
            _bold_best([_pct(r[m], r[s]) for r in block], [r[m] for r in block]) for m, s in columns
        ]
        for i, r in enumerate(block):
            out.append(
                [_backbone(backbone), _method(r["method"])] + [c[i] for c in cells] + [str(r["n"])]
            )
    return _table(header, out)


def _unseen(rows: list[dict[str, Any]], config: dict[str, Any]) -> str:
    """The unseen protocol: per unseen set and backbone, unseen- and seen-class Macro-F1 and the
    share of seen-class windows taken for an unseen class (and the reverse)."""
    header = ["Unseen", "Backbone", "Method", "Unseen Macro-F1", "Seen Macro-F1",
              "Seen → unseen", "Unseen → seen", "All Macro-F1", "n"]
    out = []
    methods = config.get("methods")
    for unseen in dict.fromkeys(tuple(r["unseen_classes"]) for r in rows):
        for backbone in _ordered([r["backbone"] for r in rows], config.get("backbones")):
            block = [r for r in rows if tuple(r["unseen_classes"]) == unseen and r["backbone"] == backbone]
            order = _ordered([r["method"] for r in block], methods)
            block.sort(key=lambda r: order.index(r["method"]))
            for r in block:
                star = "" if r["unseen_capable"] else " *"
                out.append([", ".join(unseen), _backbone(backbone), _method(r["method"]) + star]
                           + [_pct(r[f"{m}_mean"], r[f"{m}_std"]) for m in
                              ("unseen_macro_f1", "seen_macro_f1", "seen_as_unseen", "unseen_as_seen",
                               "macro_f1")] + [str(r["n"])])
    note = ("\n\nSeen → unseen: share of the seen-class test windows predicted as an unseen class "
            "(%); unseen → seen: the reverse. * cannot make windows of a class without real "
            "windows: the floor.")
    return _table(header, out) + note


def confusion_figure(
    confusion: np.ndarray, label_names: Sequence[str], title: str, path: str | Path
) -> Path:
    """A row-normalised confusion matrix (percent of each true class) with counts of
    windows per true class in the row labels."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    confusion = np.asarray(confusion, dtype=float)
    n = len(label_names)
    totals = confusion.sum(axis=1, keepdims=True)
    share = np.divide(confusion, totals, out=np.zeros_like(confusion), where=totals > 0) * 100
    size = max(4.5, 0.62 * n + 2.2)
    fig, ax = plt.subplots(figsize=(size + 1.0, size))
    image = ax.imshow(share, cmap="Blues", vmin=0, vmax=100)
    ax.set_xticks(
        range(n),
        labels=list(label_names),
        rotation=45,
        ha="right",
        rotation_mode="anchor",
        fontsize=9,
    )
    ax.set_yticks(
        range(n),
        labels=[f"{name} ({int(t)})" for name, t in zip(label_names, totals[:, 0], strict=True)],
        fontsize=9,
    )
    ax.set_xlabel("predicted class")
    ax.set_ylabel("true class (windows)")
    ax.set_title(title, fontsize=10)
    font = 9 if n <= 12 else 7 if n <= 20 else 5
    for i in range(n):
        for j in range(n):
            if totals[i, 0] == 0 or (share[i, j] < 0.5 and i != j):
                continue
            ax.text(
                j,
                i,
                f"{share[i, j]:.0f}",
                ha="center",
                va="center",
                fontsize=font,
                color="white" if share[i, j] > 55 else "black",
            )
    fig.colorbar(image, ax=ax, fraction=0.046, pad=0.04, label="% of true class")
    fig.tight_layout()
    path = Path(path)
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    return path


def write_report(results: dict[str, Any], output_dir: str | Path) -> list[Path]:
    """`results.md` and one confusion PNG per (protocol, budget, backbone, method)."""
    output_dir = Path(output_dir)
    written = [write_text(output_dir / "results.md", results_markdown(results))]
    labels = results["label_names"]
    for block in results["class_summary"]:
        budget = "full" if block["budget"] is None else f"{block['budget']:g}pct"
        unseen = block.get("unseen_classes")
        hidden = () if unseen is None else ("unseen-" + "+".join(unseen),)
        parts = (block["dataset"], block["protocol"], budget, *hidden, block["backbone"], block["method"])
        # a dataset or class name is the user's text ('sit/stand', '../x'): `file_name_part`
        name = "confusion_" + "_".join(file_name_part(p) for p in parts) + ".png"
        title = (
            f"{block['dataset']} {block['protocol']}"
            + ("" if block["budget"] is None else f" {block['budget']:g}%")
            + ("" if unseen is None else f" ({len(unseen)} unseen)")
            + f" — {_backbone(block['backbone'])}, {_method(block['method'])}"
        )
        written.append(
            confusion_figure(np.asarray(block["confusion"]), labels, title, output_dir / name)
        )
    return written
