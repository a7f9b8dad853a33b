"""The main job on the embedded default, end to end (`make demo`, `vsmp-imu demo`).

HAPT12 (waist phone: 6 activities + 6 postural transitions), activity-library
SMPs, the procedural motion backend, leave-one-subject-out over a few held-out
subjects, low-resource (1 % of the labelled training windows), two forests
with balanced class weights (the paper's RF on ECDF features, and `rf-seg`,
which also sees the window's course); Real-only vs Classical Aug vs VSMP-IMU
under each. Writes the evaluation, the
synthetic set of the first fold with its provenance, real-vs-synthetic IMU
traces per activity, a skeleton animation and the filter statistics.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.executor import LocalExecutor
from vsmp_imu.har.backbones import DISPLAY_NAMES, option_params
from vsmp_imu.har.cache import max_cache_bytes, prune_cache, samples_dir
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.protocols import split_fold
from vsmp_imu.har.report import write_report
from vsmp_imu.har.synthetic import synthetic_budget
from vsmp_imu.har.weights import DEFAULT_SYNTHETIC_WEIGHT
from vsmp_imu.io import write_text
from vsmp_imu.methods import register_all
from vsmp_imu.output_folder import OutputFolder
from vsmp_imu.pipeline.fold import FoldGenerator, FoldOutput
from vsmp_imu.pipeline.method import fold_key
from vsmp_imu.pipeline.output import write_output
from vsmp_imu.pipeline.sources import LibrarySmpSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary

RUN_FILE = "demo.json"  # {"command": "vsmp-imu demo"}, written before any work
# What the demo writes at the top of its folder (cache/: an older demo's samples, before they moved
# to the cache directory); a folder it wrote holds one of MARKERS (evaluation/ comes first).
MARKERS = frozenset({"evaluation", "synthetic", "traces.png", "filter_stats.png", "skeleton.gif",
                     "skeleton_keyframes.png"})
FOLDER = OutputFolder("vsmp-imu demo", RUN_FILE, names=MARKERS | {"report.md", "summary.json", "cache"},
                      markers=MARKERS)


@dataclass(frozen=True)
class DemoConfig:
    """What the demo runs (the defaults finish in a few minutes on 2 cores)."""

    dataset: str = "hapt12"
    folds: tuple[str, ...] = ("1", "2", "3")
    budget_percent: float = 1.0
    alpha: float = 2.0
    # HAPT12's transitions are its natural long tail: the synthetic budget goes to
    # the scarce classes (the harness's `scarcity` policy; `uniform` is the other choice)
    policy: str = "scarcity"
    seed: int = 0
    workers: int = 2
    # the forests and weights that the 1 % runs over 10 held-out subjects x 3 seeds support
    # (docs/results.md, "Synthetic windows that never outweigh the real ones"): classes balanced,
    # a class's synthetic windows together half its real ones; every method weighted alike
    backbones: tuple[str, ...] = ("rf", "rf-seg")
    class_weight: str = "balanced"
    synthetic_weight: float | None = DEFAULT_SYNTHETIC_WEIGHT


def run_evaluation(cfg: DemoConfig, out: Path, progress=None) -> dict[str, Any]:
    """Real-only, Classical Aug and VSMP-IMU under the same folds, budget and backbones."""
    register_all()
    ds = load_dataset(cfg.dataset)
    vsmp = {"variant": "vsmp", "workers": cfg.workers, "cache_dir": str(samples_dir())}
    forests = {b: option_params(b, class_weight=cfg.class_weight) for b in cfg.backbones}
    config = EvalConfig(
        dataset=ds.info.name, protocol="low-resource", budgets=(cfg.budget_percent,), backbones=cfg.backbones,
        methods=("real", "classical", "vsmp"), folds=cfg.folds, seeds=(cfg.seed,), alpha=cfg.alpha,
        policy=cfg.policy, method_params={"vsmp": vsmp}, backbone_params=forests,
        synthetic_weight=cfg.synthetic_weight,
    )
    results = Evaluation(config, ds, out / "evaluation").run(progress).to_json()
    write_report(results, out / "evaluation")
    return results


def first_fold_synthetic(cfg: DemoConfig, out: Path) -> tuple[FoldOutput, Any, Any]:
    """The first fold's synthetic set again (from the cache), written with its provenance."""
    ds = load_dataset(cfg.dataset)
    info = ds.info
    split = split_fold(ds.windows(), cfg.folds[0], "low-resource", cfg.seed, budget_percent=cfg.budget_percent)
    budget = synthetic_budget(split.fit.class_counts(), cfg.alpha, cfg.policy, split.tail)
    spec = GenerationSpec(alpha=cfg.alpha, policy=cfg.policy, workers=cfg.workers, cache_dir=str(samples_dir()))
    library = ActivityLibrary.load()
    generator = FoldGenerator(spec, LocalExecutor(cfg.workers, show_progress=False),
                              samples_dir(), out / "synthetic" / "motions", library=library)
    from vsmp_imu.har.synthetic import FoldContext

    context = FoldContext(dataset=info, fold=split.fold, held_out_subject=split.fold, train=split.fit,
                          train_subjects=tuple(split.fit.unique_subjects()), seed=cfg.seed,
                          budget={}, alpha=cfg.alpha, protocol="low-resource",
                          label_budget=cfg.budget_percent)
    fold_out = generator.generate(info, split.fit, LibrarySmpSource(library).smps(info.name, info.label_names),
                                  budget, cfg.seed, fold_key(context))
    write_output(out / "synthetic", fold_out, {"dataset": info.name, "fold": split.fold,
                                               "label_budget_percent": cfg.budget_percent, "alpha": cfg.alpha,
                                               "policy": cfg.policy, "config": spec.pipeline_dict()})
    return fold_out, split, info


def plot_traces(fold_out: FoldOutput, real, info, path: Path) -> Path:
    """One real and one synthetic window per class: accelerometer and gyroscope."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = info.label_names
    fig, axes = plt.subplots(len(names), 2, figsize=(11, 1.55 * len(names)), sharex=True)
    t = np.arange(real.n_timesteps) / info.fs_hz
    colors = ("tab:red", "tab:green", "tab:blue")
    syn = fold_out.windows
    for i, name in enumerate(names):
        r_idx = np.flatnonzero(real.y == i)
        s_idx = np.flatnonzero(syn.y == i)
        for col, (lo, unit) in enumerate(((0, "m/s²"), (3, "rad/s"))):
            ax = axes[i, col]
            for c in range(3):
                if len(r_idx):
                    ax.plot(t, real.X[r_idx[0], :, lo + c], color=colors[c], lw=1.0)
                if len(s_idx):
                    ax.plot(t, syn.X[s_idx[0], :, lo + c], color=colors[c], lw=1.0, ls="--")
            ax.set_ylabel(unit, fontsize=7)
            ax.tick_params(labelsize=7)
            if col == 0:
                ax.set_title(f"{name}  (real: solid, synthetic: dashed)" if len(s_idx) else
                             f"{name}  (real only: no synthetic window selected)", fontsize=8, loc="left")
    from matplotlib.lines import Line2D

    axis_keys = [Line2D([], [], color=colors[c], lw=1.0, label=axis) for c, axis in enumerate("xyz")]
    axes[0, 0].legend(handles=axis_keys, fontsize=6, loc="upper right", ncols=3)
    axes[-1, 0].set_xlabel("time (s)")
    axes[-1, 1].set_xlabel("time (s)")
    fig.suptitle("Accelerometer (left) and gyroscope (right), one window per activity")
    fig.tight_layout(rect=(0, 0, 1, 0.985))  # room for the title above the first panel
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_filter_stats(summary: dict[str, Any], path: Path) -> Path:
    """Generated windows per class: kept, and rejected by each filter."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    per = summary["per_class"]
    names = list(per)
    filters = sorted({f for c in per.values() for f in c["rejected_by"]})
    fig, ax = plt.subplots(figsize=(10, 4))
    bottom = np.zeros(len(names))
    kept = np.array([per[n]["kept"] for n in names])
    ax.bar(names, kept, color="tab:green", label="kept")
    bottom += kept
    for f, color in zip(filters, ("tab:orange", "tab:red", "tab:purple", "tab:gray"), strict=False):
        vals = np.array([per[n]["rejected_by"].get(f, 0) for n in names])
        ax.bar(names, vals, bottom=bottom, color=color, label=f"rejected: {f}")
        bottom += vals
    ax.plot(names, [per[n]["budget"] for n in names], "k_", markersize=18, label="budget")
    ax.set_ylabel("synthetic windows")
    ax.tick_params(axis="x", rotation=45, labelsize=8)
    ax.legend(fontsize=8)
    ax.set_title("Quality filter, first fold")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def render_example(fold_out: FoldOutput, out: Path, label: str = "STAND_TO_SIT") -> list[Path]:
    """A GIF and keyframes of one synthetic motion (a postural transition by default)."""
    from vsmp_imu.motion import Motion
    from vsmp_imu.motion.render import render_gif, render_keyframes

    motions = sorted((out / "synthetic" / "motions").glob(f"*{label}*.npz")) or \
        sorted((out / "synthetic" / "motions").glob("*.npz"))
    if not motions:
        return []
    motion = Motion.load(motions[0])
    return [render_gif(motion, out / "skeleton.gif"), render_keyframes(motion, out / "skeleton_keyframes.png")]


def summary_rows(results: dict[str, Any]) -> list[dict[str, Any]]:
    """Per backbone and method: Macro-F1 and the activities / transitions groups (percent)."""
    rows = []
    for s in results["summary"]:
        groups = s.get("group_macro_f1") or {}
        rows.append({
            "backbone": s["backbone"], "method": s["method"],
            "macro_f1": 100 * s["macro_f1_mean"], "macro_f1_std": 100 * s["macro_f1_std"],
            **{f"{g}": 100 * v["mean"] for g, v in groups.items()}, "n": s["n"],
        })
    order = {"real": 0, "classical": 1, "vsmp": 2}
    backbones = list(dict.fromkeys(r["backbone"] for r in rows))
    return sorted(rows, key=lambda r: (backbones.index(r["backbone"]), order.get(r["method"], 9)))


def backbone_title(name: str, class_weight: str, synthetic_weight: float | None = None) -> str:
    """'RF (balanced)' for a table heading: the forest and its weights ('balanced, synthetic
    0.5' where a class's synthetic windows weigh half its real ones)."""
    weights = [class_weight] if class_weight != "none" else []
    if synthetic_weight is not None:
        weights.append(f"synthetic {synthetic_weight:g}")
    return f"{DISPLAY_NAMES.get(name, name)}" + (f" ({', '.join(weights)})" if weights else "")


def weighed_text(synthetic_weight: float | None) -> str:
    """The report's words for the synthetic weight."""
    if synthetic_weight is None:
        return ""
    return f" per source (a class's synthetic windows together weigh {synthetic_weight:g} times its real ones)"


def report_markdown(cfg: DemoConfig, rows, fold_out: FoldOutput, elapsed_s: float) -> str:
    names = {"real": "Real-only", "classical": "Classical Aug.", "vsmp": "VSMP-IMU"}
    lines = [
        "# VSMP-IMU demo",
        "",
        f"HAPT12 (waist phone, 6 activities + 6 postural transitions), leave-one-subject-out over held-out "
        f"subjects {', '.join(cfg.folds)}, low-resource {cfg.budget_percent:g} % of the labelled training "
        f"windows, seed {cfg.seed}. Backbones {', '.join(f'`{b}`' for b in cfg.backbones)} (`rf`: the paper's "
        f"RF on ECDF features; `rf-seg`: the same features and each channel's means over 8 parts of the "
        f"window), class weights `{cfg.class_weight}`"
        f"{weighed_text(cfg.synthetic_weight)}, alike for every method. Synthetic budget: alpha = {cfg.alpha:g} x the real training windows, "
        f"distributed by the `{cfg.policy}` policy. Activity-library SMPs, procedural motion backend. "
        f"Run time {elapsed_s / 60:.1f} min.",
        "",
        "| Backbone | Method | Macro-F1 (%) | Activities | Transitions | folds |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {backbone_title(r['backbone'], cfg.class_weight, cfg.synthetic_weight)} | {names.get(r['method'], r['method'])} | "
                     f"{r['macro_f1']:.2f} ± {r['macro_f1_std']:.2f} | {r.get('activities', float('nan')):.2f} | "
                     f"{r.get('transitions', float('nan')):.2f} | {r['n']} |")
    s = fold_out.summary
    lines += [
        "",
        "Files: `evaluation/` (results.json, results.md, confusion matrices), `synthetic/` (the first fold's "
        "synthetic set: `synthetic.parquet` with one row per generated window and its provenance and filter "
        "verdicts, the SMP variants, prompts and motions), `traces.png`, `filter_stats.png`, `skeleton.gif`, "
        "`skeleton_keyframes.png`.",
        "",
        f"## Quality filter (first fold, tau_cls = {s['tau_cls']})",
        "",
        "| class | budget | generated | kept | selected | rejected by |",
        "|---|---|---|---|---|---|",
    ]
    for name, c in s["per_class"].items():
        rejected = ", ".join(f"{k} {v}" for k, v in sorted(c["rejected_by"].items())) or "-"
        lines.append(f"| {name} | {c['budget']} | {c['windows']} | {c['kept']} | {c['selected']} | {rejected} |")
    lines += ["", "![traces](traces.png)", "", "![filters](filter_stats.png)", "",
              "![skeleton](skeleton_keyframes.png)", ""]
    return "\n".join(lines)


def run_demo(output: Path, cfg: DemoConfig = DemoConfig(), progress=None) -> dict[str, Any]:
    """Everything `make demo` does; returns the summary rows. `output`: a new or empty folder, or an
    earlier demo's (rerun: its files are replaced); another one is refused before any work."""
    start = time.perf_counter()
    FOLDER.claim(output)
    results = run_evaluation(cfg, output, progress)
    fold_out, split, info = first_fold_synthetic(cfg, output)
    plot_traces(fold_out, split.fit, info, output / "traces.png")
    plot_filter_stats(fold_out.summary, output / "filter_stats.png")
    render_example(fold_out, output)
    rows = summary_rows(results)
    elapsed = time.perf_counter() - start
    write_text(output / "report.md", report_markdown(cfg, rows, fold_out, elapsed))
    write_text(output / "summary.json", json.dumps({"rows": rows, "elapsed_s": elapsed}, indent=2) + "\n")
    prune_cache(samples_dir(), max_cache_bytes())
    return {"rows": rows, "elapsed_s": elapsed}
