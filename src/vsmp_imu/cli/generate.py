"""`vsmp-imu generate`: Algorithm 1 for one held-out subject, written to a folder."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from vsmp_imu.cli.common import (
    K_UNSEEN,
    LIBRARY_OPTION,
    OVERLAP,
    SPEC_OPTIONS,
    WINDOW_S,
    K,
    console,
    executor_options,
    finite_range,
    grounding_options,
    grounding_spec,
    library_dirs,
    option_names,
    output_dir,
    print_warnings,
)

SOURCE_HELP = "library | smp:DIR (SMP files) | video:DIR (clips per activity folder, or a pool manifest)"


@option_names(SPEC_OPTIONS)
@grounding_options
def generate_cmd(
    dataset: str = typer.Option(..., "--dataset", help="Dataset name (hapt, hapt12, ...) or a dataset YAML"),
    holdout: str = typer.Option(..., "--holdout", help="Held-out subject: none of its data is used"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder: a new or empty one, or one of an "
                                "earlier run of this dataset and held-out subject (its outputs are replaced)"),
    source: str = typer.Option("library", "--source", help=SOURCE_HELP),
    k: int = K,
    k_unseen: int = K_UNSEEN,
    backend: str = typer.Option("procedural", "--backend", help="procedural | compiled | hymotion"),
    alpha: float = typer.Option(2.0, "--alpha", help="Synthetic windows = alpha x real training windows "
                                "(the paper: 0.5)"),
    policy: str = typer.Option("scarcity", "--policy", help="Budget policy: uniform | tail | scarcity "
                               "(the paper: uniform)"),
    seed: int = typer.Option(0, "--seed"),
    window_s: float = WINDOW_S,
    overlap: float = OVERLAP,
    data_dir: Path | None = typer.Option(None, "--data-dir", help="Folder of a dataset we do not ship"),
    workers: int = typer.Option(1, "--workers", min=1, max=256, help="Parallel workers"),
    executor: str = typer.Option("local", "--executor", help="local | ray"),
    address: str | None = typer.Option(None, "--address", help="Ray cluster address (with --executor ray)"),
    gpus_per_task: float | None = typer.Option(
        None, "--gpus-per-task", callback=finite_range(0.0, 8.0),
        help="GPUs a Ray task reserves (default: 1 with --backend hymotion, else 0)"),
    cache_dir: Path | None = typer.Option(None, "--cache-dir", help="Per-sample cache (default: OUT/cache)"),
    save_motions: bool = typer.Option(True, "--save-motions/--no-save-motions", help="Keep the motions"),
    no_sim_loop: bool = typer.Option(False, "--no-sim-loop", help="Ablation: eta* = 0"),
    no_rank: bool = typer.Option(False, "--no-rank", help="Ablation: no rank grounding"),
    no_filter: bool = typer.Option(False, "--no-filter", help="Ablation: no quality filter"),
    grounding: dict | None = None,  # stands for the grounding options (`grounding_options`)
    no_refine: bool = typer.Option(False, "--no-refine", help="Ablation: no semantic refinement"),
    no_uncertainty: bool = typer.Option(False, "--no-uncertainty", help="Ablation: u = 0 in augmentation"),
    library: list[Path] = LIBRARY_OPTION,
    refill: int = typer.Option(0, "--refill", min=0, max=8,
                               help="Extra passes for classes whose kept windows fall short of the budget"),
) -> None:
    """Generate the synthetic set for one LOPO fold (Algorithm 1) and write it to OUT."""
    output_dir(output)
    executor_options(executor, address)
    output_dir(cache_dir, "--cache-dir")
    from vsmp_imu.app import FoldRequest, generate_fold, plan_fold
    from vsmp_imu.motion.backends import check_backend
    from vsmp_imu.pipeline.sources import check_source
    from vsmp_imu.pipeline.spec import GenerationSpec

    check_backend(backend, "--backend")  # before the dataset loads
    check_source(source, "--source")
    spec = GenerationSpec(
        source=source, alpha=alpha, policy=policy, k=k, k_unseen=k_unseen, backend=backend, sim_in_the_loop=not no_sim_loop,
        rank_grounding=not no_rank, quality_filter=not no_filter, **grounding_spec(grounding),
        refine=not no_refine, uncertainty_conditioned=not no_uncertainty,
        library_dirs=tuple(str(p) for p in library_dirs(library)), refill=refill, executor=executor,
        workers=workers, address=address, cache_dir=str(cache_dir) if cache_dir else None,
        gpus_per_task=gpus_per_task)
    request = FoldRequest(dataset, holdout, output, seed, window_s, overlap, data_dir, save_motions)
    plan = plan_fold(spec, request)
    print_warnings(plan.warnings)
    console.print(f"{plan.info.name}: held-out subject {holdout}; {len(plan.train)} real training windows "
                  f"from {len(plan.subjects) - 1} subjects; synthetic budget {int(plan.budget.sum())} windows",
                  highlight=False)
    t0 = time.perf_counter()
    out = generate_fold(spec, request, plan)
    elapsed = time.perf_counter() - t0
    _print_summary(out.summary)
    console.print(f"wrote {output}/synthetic.parquet: {len(out.windows)} selected of {len(out.generated)} "
                  f"generated windows in {elapsed:.1f} s", highlight=False)


def _print_summary(summary: dict) -> None:
    from rich.table import Table

    table = Table(title=f"synthetic set (tau_cls = {summary['tau_cls']})")
    for col in ("class", "budget", "samples", "windows", "kept", "selected", "rejected by"):
        table.add_column(col, justify="left" if col in ("class", "rejected by") else "right")
    for name, c in summary["per_class"].items():
        rejected = ", ".join(f"{k} {v}" for k, v in sorted(c["rejected_by"].items()))
        table.add_row(name, str(c["budget"]), str(c["samples"]), str(c["windows"]), str(c["kept"]),
                      str(c["selected"]), rejected)
    console.print(table)
    for name, fit in summary.get("motion_fit", {}).items():
        if fit["fitted"]:
            values = ", ".join(f"{p} {m:.2f} ± {s:.2f}" for p, m, s in zip(fit["params"], fit["mean"], fit["std"],
                                                                          strict=True))
            text = f"{values} (L {fit['loss_nominal']:.3f} -> {fit['loss_best']:.3f})"
        else:
            text = f"SMP defaults: {fit['reason']}"
        console.print(f"motion fit {name}: {text}", highlight=False)
    for name, tex in summary.get("texture", {}).items():
        if tex["pooled"] is not None:
            ratios = ", ".join(f"{k:.2f}" for k in tex["pooled"])
            console.print(f"movement texture at {name}: 3-12 Hz / 0.3-3 Hz ratio per channel {ratios} (all "
                          f"classes), a class's own for {len(tex['classes'])} classes", highlight=False)
        elif tex.get("reason"):
            console.print(f"movement texture at {name}: none ({tex['reason']})", highlight=False)
    for name, levels in summary.get("window_levels", {}).items():
        mapped = ", ".join(f"{c} ({v['real_windows']})" for c, v in levels["classes"].items()) or "none"
        few = ", ".join(f"{c} ({k})" for c, k in levels["too_few"].items())
        console.print(f"window levels at {name}: mapped {mapped}" + (f"; too few real windows: {few}" if few else ""),
                      highlight=False)
    for name, records in summary.get("side_evidence", {}).items():
        for rec in records:
            console.print(f"side {name}: {side_text(rec)}", highlight=False)
    for name, spread in summary.get("intensity_spread", {}).items():
        lo, hi = spread["bounds"]
        console.print(f"intensity spread {name} (no real windows): {spread['windows']} windows x U({lo:g}, {hi:g}) "
                      f"on {', '.join(spread['channels'])}, median {spread['median']:.2f}", highlight=False)
    matched = summary.get("intensity_match", {})
    if matched:
        widened = [f"{name} {m['spread']:.2f}" for name, m in matched.items() if m["spread"] > 0]
        console.print(f"intensity matched to the real windows: log spread added {', '.join(widened) or 'none'}; "
                      f"none for {len(matched) - len(widened)} (as wide already, or too few windows)", highlight=False)
    for name, found in summary.get("event_durations", {}).items():
        console.print(f"event durations {name}: {durations_text(found)}", highlight=False)
    for name, found in summary.get("cadence", {}).items():
        console.print(f"cadence {name}: {cadence_text(found)}", highlight=False)


def durations_text(found: dict) -> str:
    """One class's real event durations, in words."""
    if not found["used"]:
        return f"the SMP's timing ({found['reason']})"
    text = (f"every other round of samples timed to one of {found['events']} real events (median "
            f"{found['median_s']:.2f} s, 10-90 % {found['q10_s']:.2f}-{found['q90_s']:.2f} s)")
    if "chosen" in found:
        scores = ", ".join(f"{k} {v:.3f}" for k, v in found["scores"].items())
        text += f"; kept: {found['chosen']} (Macro-F1 on the real windows: {scores})"
    return text


def cadence_text(found: dict) -> str:
    """One gait class's real step rates, in words."""
    if not found["used"]:
        return f"the SMP's tempo ({found['reason']})"
    return (f"every sample steps at the rate of one of {found['windows']} real windows (median "
            f"{found['median_hz']:.2f} steps/s, 10-90 % {found['q10_hz']:.2f}-{found['q90_hz']:.2f})")


def side_text(rec: dict) -> str:
    """One class's side from evidence, in words."""
    if not rec["used"]:
        return f"the SMP's side, variants either way ({rec['reason']})"
    return (f"{rec['side']} (p = {rec['p_right'] if rec['side'] == 'right' else 1 - rec['p_right']:.2f}: "
            f"{rec['votes_right']} real windows turn right, {rec['votes_left']} left, of {rec['windows']})")


def register(app: typer.Typer) -> None:
    app.command("generate")(generate_cmd)
