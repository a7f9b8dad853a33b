"""`vsmp-imu generate`: Algorithm 1 for one held-out subject, written to a folder."""

from __future__ import annotations

import time
from pathlib import Path

import typer

from vsmp_imu.cli.common import console, executor_options, library_dirs, output_dir
from vsmp_imu.errors import ConfigError

SOURCE_HELP = "library | smp:DIR (SMP files) | video:DIR (clips per activity folder, or a pool manifest)"


def generation_config(k: int, backend: str, no_sim_loop: bool, no_rank: bool, no_filter: bool,
                      per_class_rank: bool, no_refine: bool, no_uncertainty: bool, library: list[Path],
                      refill: int = 0):
    from vsmp_imu.pipeline.fold import GenerationConfig

    return GenerationConfig(
        k=k, backend=backend, sim_in_the_loop=not no_sim_loop, rank_grounding=not no_rank,
        quality_filter=not no_filter, per_class_rank=per_class_rank, refine=not no_refine,
        uncertainty_conditioned=not no_uncertainty,
        library_dirs=tuple(str(p) for p in library_dirs(library)), refill=refill,
    )


def generate_cmd(
    dataset: str = typer.Option(..., "--dataset", help="Dataset name (hapt, hapt12, ...) or a dataset YAML"),
    holdout: str = typer.Option(..., "--holdout", help="Held-out subject: none of its data is used"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    source: str = typer.Option("library", "--source", help=SOURCE_HELP),
    k: int = typer.Option(4, "--k", min=1, max=64, help="SMP variants per base SMP"),
    backend: str = typer.Option("procedural", "--backend", help="procedural | compiled | hymotion"),
    alpha: float = typer.Option(0.5, "--alpha", help="Synthetic windows = alpha x real training windows"),
    policy: str = typer.Option("uniform", "--policy", help="Budget policy: uniform | tail | scarcity"),
    seed: int = typer.Option(0, "--seed"),
    window_s: float = typer.Option(2.0, "--window-s", min=0.5, max=30.0),
    overlap: float = typer.Option(0.5, "--overlap", min=0.0, max=0.95),
    data_dir: Path | None = typer.Option(None, "--data-dir", help="Folder of a dataset we do not ship"),
    workers: int = typer.Option(1, "--workers", min=1, max=256, help="Parallel workers"),
    executor: str = typer.Option("local", "--executor", help="local | ray"),
    address: str | None = typer.Option(None, "--address", help="Ray cluster address (with --executor ray)"),
    gpus_per_task: float | None = typer.Option(
        None, "--gpus-per-task", min=0.0, max=8.0,
        help="GPUs a Ray task reserves (default: 1 with --backend hymotion, else 0)"),
    cache_dir: Path | None = typer.Option(None, "--cache-dir", help="Per-sample cache (default: OUT/cache)"),
    save_motions: bool = typer.Option(True, "--save-motions/--no-save-motions", help="Keep the motions"),
    no_sim_loop: bool = typer.Option(False, "--no-sim-loop", help="Ablation: eta* = 0"),
    no_rank: bool = typer.Option(False, "--no-rank", help="Ablation: no rank grounding"),
    no_filter: bool = typer.Option(False, "--no-filter", help="Ablation: no quality filter"),
    per_class_rank: bool = typer.Option(False, "--per-class-rank", help="Rank grounding per class"),
    no_refine: bool = typer.Option(False, "--no-refine", help="Ablation: no semantic refinement"),
    no_uncertainty: bool = typer.Option(False, "--no-uncertainty", help="Ablation: u = 0 in augmentation"),
    library: list[Path] = typer.Option(None, "--library", help="Extra activity-library folder (repeatable)"),
    refill: int = typer.Option(0, "--refill", min=0, max=8,
                               help="Extra passes for classes whose kept windows fall short of the budget"),
) -> None:
    """Generate the synthetic set for one LOPO fold (Algorithm 1) and write it to OUT."""
    output_dir(output)
    executor_options(executor, address)
    output_dir(cache_dir, "--cache-dir")
    from vsmp_imu.executor import make_executor
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.synthetic import ALPHA_RANGE, synthetic_budget
    from vsmp_imu.io import remove_stale_temps
    from vsmp_imu.pipeline.fold import FoldGenerator
    from vsmp_imu.pipeline.method import make_smp_source
    from vsmp_imu.pipeline.output import write_output
    from vsmp_imu.smp.library import ActivityLibrary

    if not ALPHA_RANGE[0] <= alpha <= ALPHA_RANGE[1]:
        raise ConfigError(f"alpha {alpha} out of range", field="--alpha",
                          allowed=f"{ALPHA_RANGE[0]}..{ALPHA_RANGE[1]}")
    config = generation_config(k, backend, no_sim_loop, no_rank, no_filter, per_class_rank, no_refine,
                               no_uncertainty, library, refill)
    ds = load_dataset(dataset, data_dir)
    info = ds.info
    windows = ds.windows(window_s, overlap)
    subjects = windows.unique_subjects()
    if holdout not in subjects:
        raise ConfigError(f"subject '{holdout}' is not in {info.name}", field="--holdout",
                          allowed=", ".join(subjects))
    train = windows.where_subjects([holdout], keep=False)
    budget = synthetic_budget(train.class_counts(), alpha, policy)
    lib = ActivityLibrary.load(library_dirs(library))
    sources = make_smp_source(source, lib).smps(info.name, info.label_names)
    motion_dir = output / "motions" if save_motions else None
    cache = cache_dir or output / "cache"
    for folder in (output, cache):  # leftovers of a killed run
        remove_stale_temps(folder)
    if gpus_per_task is None:
        gpus_per_task = 1.0 if backend == "hymotion" and executor == "ray" else 0.0
    generator = FoldGenerator(config, make_executor(executor, workers, address,
                                                    num_gpus_per_task=gpus_per_task),
                              cache, motion_dir, library=lib)
    console.print(f"{info.name}: held-out subject {holdout}; {len(train)} real training windows from "
                  f"{len(subjects) - 1} subjects; synthetic budget {int(budget.sum())} windows", highlight=False)
    t0 = time.perf_counter()
    out = generator.generate(info, train, sources, budget, seed, f"holdout-{holdout}")
    elapsed = time.perf_counter() - t0
    write_output(output, out, {
        "dataset": info.name, "holdout": holdout, "alpha": alpha, "policy": policy, "seed": seed,
        "source": source, "config": config.as_dict(),
        "train_subjects": [s for s in subjects if s != holdout],
    })
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


def register(app: typer.Typer) -> None:
    app.command("generate")(generate_cmd)
