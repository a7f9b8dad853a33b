"""Outputs of the realism study: report.md, results.json, realism_pca.png and
realism_distance.png.

realism_pca.png: one panel per method (and one for the held-out subject's
real windows) on the first two PCA axes of the real training embeddings: the
fold's real training embeddings as faint dots, the panel's windows as
crosses, both coloured by class, and per class a line from the real centroid
(circle) to the panel's centroid (square). realism_distance.png: the
per-class centroid distance d_a of every method and of the two references,
and below it the per-class AUC of the two-sample test on the RF's features.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from vsmp_imu.studies.methods import method_display
from vsmp_imu.studies.realism import (
    C2ST_FOLDS,
    C2ST_MAX_PER_SIDE,
    REFERENCE,
    REFERENCES,
    SHUFFLED,
    RealismResults,
)
from vsmp_imu.studies.report import (
    describer_lines,
    fmt_num,
    markdown_table,
    save_figure,
    write_report,
)

PCA_FIGURE = "realism_pca.png"
DISTANCE_FIGURE = "realism_distance.png"
# Paper, "Distribution Analysis and Realism": mean class-wise centroid distance on UTD-MHAD
# (27 classes, HY-Motion, the paper's encoder); a different feature scale from any run here.
PAPER = {"vsmp": 0.056, "imutube": 0.143, "imugpt": 0.313}
NAMES = {REFERENCE: "Real, held-out subject", SHUFFLED: "Real, held-out, labels shuffled"}
LAYER_TEXT = {"conv": "the final convolutional layer's features averaged over time (the paper's choice)",
              "lstm": "the last LSTM state (the input of the classification layer)"}
# 12 well-separated hues first; more classes continue with tab20b / tab20c
BASE_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
               "#bcbd22", "#17becf", "#000000", "#f0c000")


def _name(method: str) -> str:
    return NAMES.get(method) or method_display(method)


def _short(labels: list[str]) -> list[str]:
    """Class names for a few classes, A1..An (the paper's style) for many."""
    return labels if len(labels) <= 12 else [f"A{i + 1}" for i in range(len(labels))]


def distance_table(r: RealismResults) -> str:
    """Per method and reference: windows, classes, mean d_a, d_a / spread, coverage, mean KS."""
    rows = []
    for m in r.methods:
        rows.append([_name(m["method"]), str(m["n_windows"]), str(m["classes"]), fmt_num(m["mean_distance"], 3),
                     fmt_num(m["mean_relative_distance"], 2), fmt_num(m["mean_coverage"], 2),
                     fmt_num(m["ks_mean"], 3)])
    return markdown_table(["Windows", "n", "classes", "mean d_a", "mean d_a / spread", "coverage",
                           "mean KS"], rows)


def class_distance_table(r: RealismResults) -> str:
    """d_a per class (rows, in the dataset's order) and method or reference (columns)."""
    present = [lab for lab in r.label_names if any(lab in m["per_class"] for m in r.methods)]
    headers = ["Class"] + [_name(m["method"]) for m in r.methods]
    rows = [[lab] + [fmt_num(m["per_class"].get(lab, {}).get("distance"), 3) for m in r.methods]
            for lab in present]
    return markdown_table(headers, rows)


def _c2st_sets(r: RealismResults) -> list[dict]:
    return [m for m in r.methods if m.get("c2st")]  # records written before the test lack it


def c2st_table(r: RealismResults) -> str:
    """The two-sample test's AUC per class (rows) and set (columns), their mean last."""
    sets = _c2st_sets(r)
    present = [lab for lab in r.label_names if any(lab in m["c2st"] for m in sets)]
    rows = [[lab] + [fmt_num(m["c2st"].get(lab, {}).get("auc"), 2) for m in sets] for lab in present]
    rows.append(["mean"] + [fmt_num(m["c2st_mean_auc"], 2) for m in sets])
    return markdown_table(["Class"] + [_name(m["method"]) for m in sets], rows)


def c2st_features_table(r: RealismResults) -> str:
    """Per class, the features the two-sample test's forest leans on most, per synthetic method."""
    sets = [m for m in _c2st_sets(r) if m["method"] not in REFERENCES]
    present = [lab for lab in r.label_names if any(lab in m["c2st"] for m in sets)]
    rows = [[lab] + [", ".join(m["c2st"].get(lab, {}).get("top_features", [])) or "–" for m in sets]
            for lab in present]
    return markdown_table(["Class"] + [_name(m["method"]) for m in sets], rows)


def _c2st_section(r: RealismResults) -> list[str]:
    if not _c2st_sets(r):
        return []
    return ["## Two-sample test on the RF's features", "",
            "Per class, a Random Forest on the ECDF features (the RF backbone's own) learns to tell the "
            "set's windows from the class's real training windows: as many from each side (at most "
            f"{C2ST_MAX_PER_SIDE}), stratified {C2ST_FOLDS}-fold cross-validation, ROC AUC (0.5 = "
            "indistinguishable, 1 = every window gives itself away). The held-out subject's row is how "
            "far a new person's real windows are; a class with fewer than "
            f"{C2ST_FOLDS} windows on a side is left out.", "", c2st_table(r), "",
            "What gives the windows away (the forest's most important features; `acc_x q0.25`: the "
            "window's 25 % quantile of acc_x):", "", c2st_features_table(r), ""]


def realism_markdown(r: RealismResults) -> str:
    s, e = r.settings, r.encoder
    p = e["params"]
    subset = (f"a class-stratified {e['train_windows']} of the fold's {e['fit_windows_of_fold']} real training "
              "windows" if e["train_windows"] < e["fit_windows_of_fold"] else
              f"all {e['train_windows']} real training windows of the fold")
    val = (f"{e['val_windows']} of the {e['val_windows_of_fold']} windows" if e["val_windows"] <
           e.get("val_windows_of_fold", e["val_windows"]) else f"{e['val_windows']} windows")
    acc = e["test_accuracy"]
    out = ["# Feature-space realism", "", "## What was run", "",
           f"- **Dataset** {s['dataset']}, LOPO fold **{s['fold']}** (held-out subject), seed {s['seed']}; "
           "real windows of the fold's training split (validation subjects excluded) are the reference R.",
           f"- **Encoder** DeepConvLSTM ({p['n_conv']} conv layers x {p['n_filters']} filters, "
           f"{p['n_lstm']} LSTM layers x {p['hidden']} units; AdamW lr {p['lr']:g}, batch {p['batch_size']}) "
           f"trained on {subset}, early stopping on {val} of validation subjects "
           f"{', '.join(e['val_subjects']) or '(none)'}: {e['epochs_run']} epochs run (at most "
           f"{p['max_epochs']}, patience {p['patience']}), best epoch {e['best_epoch']}, "
           f"{e['fit_seconds']:.0f} s on CPU; accuracy on the held-out subject "
           f"{fmt_num(None if acc is None else 100 * acc, 1)} %.",
           f"- **Embedding** z = {LAYER_TEXT[e.get('layer', 'lstm')]}, {_dim(r)} dimensions.",
           f"- **Synthetic windows** per class: round(alpha x real training windows), alpha = {s['alpha']:g}, "
           f"at most {s['max_per_class']} per class; the same budget and `FoldContext` for every method. "
           f"Backend `{s['generation']['backend']}`, source `{s['generation']['source']}`.",
           f"- Wall time {r.elapsed_s / 60:.1f} min."]
    out += describer_lines(s)
    out += [f"- Note: {n}." for n in s.get("dataset_notes", [])]
    for m, reason in r.skipped.items():
        out.append(f"- **Skipped {method_display(m)}**: {reason}.")
    paper = ", ".join(f"{method_display(k)} {v:.3f}" for k, v in PAPER.items())
    out += ["", "## Class-wise centroid distance", "",
            "d_a = ||mean synthetic embedding − mean real embedding|| of class a (Euclidean, original "
            "feature space), averaged over the classes the method produced; d / spread divides d_a by "
            "the real class's mean distance to its own centroid; coverage = synthetic spread / real "
            "spread (1 = as wide as the real class). The first two rows are references through the same "
            "computation: the held-out subject's real windows (the distance a new person's real data "
            "has) and the same windows with shuffled labels (right sensor domain, wrong classes).", "",
            distance_table(r), "",
            f"Paper (UTD-MHAD, its encoder, 27 classes): {paper}. Distances depend on the encoder's "
            "feature scale: compare methods within one run, and against the two references.", ""]
    out += ["### d_a per class", "", class_distance_table(r), ""]
    headers = ["Windows"] + r.channel_names
    rows = [[_name(m["method"])] + [fmt_num(m["ks_per_channel"][c], 3) for c in r.channel_names]
            for m in r.methods if m["method"] != SHUFFLED]
    out += ["## Per-channel marginals (secondary)", "",
            "Two-sample Kolmogorov–Smirnov statistic between the synthetic (or held-out real) samples "
            "and the real training samples of the same class, per channel, averaged over classes "
            "(0 = identical marginals). Rank grounding maps each class with enough real windows onto "
            "that class's own marginals (the default; a smaller class, or `--pooled-rank`, takes the "
            "pooled, class-balanced ones), so small per-channel differences are partly by "
            "construction, as for classical augmentation, which perturbs real training windows: "
            "the embedding distances above also see the channels' joint and temporal structure.", "",
            markdown_table(headers, rows), "", *_c2st_section(r),
            "## Deviations from the paper", "",
            "- The paper reports UTD-MHAD (27 classes, HY-Motion, VLM-extracted SMPs); this run's dataset, "
            "fold and generators are listed above.",
            f"- One fold and one seed; the encoder is trained for at most {p['max_epochs']} epochs with batch "
            f"{p['batch_size']} on CPU (paper: batch 1024, up to 500 epochs, to convergence on a GPU)"
            + (", on a class-stratified subset of the training windows" if e["train_windows"] <
               e["fit_windows_of_fold"] else "")
            + (f", with {p['n_filters']} filters and {p['hidden']} LSTM units instead of 64 and 128"
               if (p["n_filters"], p["hidden"]) != (64, 128) else "") + ".",
            "- Two reference rows (held-out real, shuffled labels) are added to read the distances; the "
            "paper reports methods only.", "",
            f"![pca]({PCA_FIGURE})", "", f"![distance]({DISTANCE_FIGURE})"]
    return "\n".join(out)


def _dim(r: RealismResults) -> str:
    p = r.encoder["params"]
    if r.encoder.get("layer", "lstm") == "lstm":
        return str(p["hidden"])
    return f"{p['n_filters']} x {len(r.channel_names)} = {p['n_filters'] * len(r.channel_names)}"


def _colors(n: int) -> list:
    import matplotlib.pyplot as plt

    extra = list(plt.get_cmap("tab20b").colors) + list(plt.get_cmap("tab20c").colors)
    palette = list(BASE_COLORS) + extra
    return [palette[i % len(palette)] for i in range(n)]


def pca_figure(r: RealismResults):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    sets = r.pca["sets"]
    panels = [REFERENCE] + [m["method"] for m in r.methods if m["method"] not in REFERENCES]
    n = len(panels)
    cols = 2 if n <= 4 else 3
    rows = int(np.ceil(n / cols))
    real = sets["real"]
    rx, ry = np.asarray(real["xy"]), np.asarray(real["y"])
    present = sorted(set(ry.tolist()) | {int(c) for k in panels for c in np.asarray(sets[k]["y"]).tolist()})
    short = r.label_names if len(present) <= 12 else _short(r.label_names)
    palette = _colors(len(present))  # distinct colours for the classes that occur
    colors = {c: palette[i] for i, c in enumerate(present)}
    handles = [Line2D([], [], marker="o", linestyle="", color=colors[c], label=short[c]) for c in present]
    handles += [Line2D([], [], marker="o", linestyle="", color="grey", alpha=0.4, label="real training window"),
                Line2D([], [], marker="x", linestyle="", color="black", label="panel's window"),
                Line2D([], [], marker="o", linestyle="-", color="grey", markeredgecolor="black",
                       label="real centroid -> panel's centroid (square)")]
    ncol = min(6, len(handles))
    legend_in = 0.25 + 0.2 * int(np.ceil(len(handles) / ncol))
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows + legend_in), squeeze=False)
    xy_all = np.concatenate([np.asarray(sets[k]["xy"]) for k in sets if len(sets[k]["xy"])])
    lo, hi = np.percentile(xy_all, 0.5, axis=0), np.percentile(xy_all, 99.5, axis=0)
    pad = 0.08 * (hi - lo)
    rows_by_method = {m["method"]: m for m in r.methods}
    for ax, name in zip(axes.ravel(), panels, strict=False):
        ax.scatter(rx[:, 0], rx[:, 1], c=[colors[int(c)] for c in ry], s=10, alpha=0.25, linewidths=0)
        px, py = np.asarray(sets[name]["xy"]), np.asarray(sets[name]["y"])
        if len(px):
            ax.scatter(px[:, 0], px[:, 1], c=[colors[int(c)] for c in py], s=18, marker="x", linewidths=0.9)
        # class centroids: real (circle) -> this panel's (square), joined by a line
        for a, (cx, cy) in sets[name]["centroids"].items():
            rc = real["centroids"].get(int(a))
            if rc is None:
                continue
            a = int(a)
            ax.plot([rc[0], cx], [rc[1], cy], color=colors[a], linewidth=1.2, zorder=3)
            ax.scatter([rc[0]], [rc[1]], color=colors[a], s=55, marker="o", edgecolors="black",
                       linewidths=0.8, zorder=4)
            ax.scatter([cx], [cy], color=colors[a], s=55, marker="s", edgecolors="black", linewidths=0.8,
                       zorder=4)
        row = rows_by_method[name]
        ax.set_title(f"{_name(name)}: mean d_a = {fmt_num(row['mean_distance'], 3)} "
                     f"(d/spread {fmt_num(row['mean_relative_distance'], 2)})", fontsize=9)
        ax.set_xlim(lo[0] - pad[0], hi[0] + pad[0])
        ax.set_ylim(lo[1] - pad[1], hi[1] + pad[1])
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.2)
    for ax in axes.ravel()[n:]:
        ax.axis("off")
    ev = r.pca.get("explained_variance_ratio") or [np.nan, np.nan]
    for ax in axes[:, 0]:
        ax.set_ylabel(f"PC2 ({100 * ev[1]:.0f} % of variance)", fontsize=8)
    for ax in axes[-1, :]:
        ax.set_xlabel(f"PC1 ({100 * ev[0]:.0f} % of variance)", fontsize=8)
    fig.legend(handles=handles, loc="lower center", ncol=ncol, fontsize=7, frameon=False)
    s = r.settings
    layer = "conv features" if r.encoder.get("layer") == "conv" else "last LSTM state"
    fig.suptitle(f"DeepConvLSTM embeddings ({layer}), {s['dataset']} fold {s['fold']}: PCA of the real "
                 "training embeddings, for display only", fontsize=10)
    fig.tight_layout(rect=(0, legend_in / fig.get_figheight(), 1, 0.97))
    return fig


PALETTE = {REFERENCE: "#c05621", SHUFFLED: "#e2e8f0", "vsmp": "#2b6cb0", "imugpt": "#805ad5", "imutube": "#38a169",
           "classical": "#718096"}


def _class_bars(ax, r: RealismResults, labels: list[str], value) -> None:
    """One bar per class and set: value(method row, class) (NaN: none)."""
    width = 0.8 / max(1, len(r.methods))
    for i, m in enumerate(r.methods):
        ax.bar(np.arange(len(labels)) + (i - (len(r.methods) - 1) / 2) * width, [value(m, k) for k in labels],
               width, label=_name(m["method"]), color=PALETTE.get(m["method"]), edgecolor="black", linewidth=0.3)
    ax.set_xticks(range(len(labels)), _short(labels), rotation=35 if len(labels) <= 12 else 0, ha="right"
                  if len(labels) <= 12 else "center", fontsize=7)
    ax.grid(axis="y", alpha=0.3)


def distance_figure(r: RealismResults):
    """d_a per class and set; below it, where the records have it, the two-sample test's AUC."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [lab for lab in r.label_names if any(lab in m["per_class"] for m in r.methods)]
    panels = 2 if _c2st_sets(r) else 1
    fig, axes = plt.subplots(panels, 1, squeeze=False, figsize=(
        max(7.0, 0.16 * len(labels) * max(1, len(r.methods))) + 2.5, 4.2 * panels))
    ax = axes[0, 0]
    _class_bars(ax, r, labels, lambda m, k: m["per_class"].get(k, {}).get("distance", np.nan))
    ax.set_ylabel("centroid distance d_a")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    ax.set_title(f"Class-wise distance to the real training centroid ({r.settings['dataset']}, fold "
                 f"{r.settings['fold']})", fontsize=10)
    if panels == 2:
        ax = axes[1, 0]
        _class_bars(ax, r, labels, lambda m, k: (m.get("c2st") or {}).get(k, {}).get("auc", np.nan))
        ax.axhline(0.5, color="black", linestyle="--", linewidth=0.8)
        ax.set_ylim(0.0, 1.05)
        ax.set_ylabel("two-sample test AUC (0.5 = indistinguishable)")
        ax.set_title("How well an RF on the ECDF features tells each set from the real training windows",
                     fontsize=10)
    fig.tight_layout()
    return fig


def write_realism_outputs(results: RealismResults, out_dir: str | Path) -> dict[str, Path]:
    out = Path(out_dir)
    md, js = write_report(out, realism_markdown(results), results.to_json())
    pca = save_figure(pca_figure(results), out / PCA_FIGURE, dpi=150)
    dist = save_figure(distance_figure(results), out / DISTANCE_FIGURE, dpi=150)
    return {"report": md, "results": js, "pca": pca, "distance": dist}

