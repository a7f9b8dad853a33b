"""`vsmp-imu demo`: the main job on the embedded default (what `make demo` runs)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vsmp_imu.cli.common import console, finite_range, output_dir, parse_csv, shown
from vsmp_imu.progress import progress


def demo_cmd(
    output: Path = typer.Option(Path("demo_out"), "-o", "--output", help="Output folder"),
    folds: str = typer.Option("1,2,3", "--folds", help="Held-out subjects (HAPT has 1..30)"),
    budget: float = typer.Option(1.0, "--budget", callback=finite_range(0.1, 100.0),
                                 help="Label budget in percent, 0.1..100"),
    workers: int = typer.Option(2, "--workers", min=1, max=64, help="Generation workers"),
) -> None:
    """HAPT12, library SMPs, procedural backend, low-resource LOPO, two forests with balanced class
    weights, a class's synthetic windows weighing half its real ones: Real-only vs Classical Aug vs VSMP-IMU; writes the report, traces, filter statistics
    and a skeleton animation."""
    output_dir(output)
    from vsmp_imu.app import run_demo
    from vsmp_imu.demo import FOLDER as DEMO_FOLDER
    from vsmp_imu.demo import DemoConfig, backbone_title

    cfg = DemoConfig(folds=tuple(parse_csv(folds, option="--folds")), budget_percent=budget, workers=workers)
    DEMO_FOLDER.check(output)  # a folder of other files is refused before the header (run_demo takes it)
    console.print(f"VSMP-IMU demo: {cfg.dataset}, held-out subjects {', '.join(cfg.folds)}, "
                  f"{cfg.budget_percent:g} % labels, writing {shown(output)}/", highlight=False)
    with progress("evaluation", console=console, transient=False) as update:
        result = run_demo(output, cfg, lambda stage, done, total: update(done, total, stage))
    names = {"real": "Real-only", "classical": "Classical Aug.", "vsmp": "VSMP-IMU"}
    for backbone in cfg.backbones:
        title = backbone_title(backbone, cfg.class_weight, cfg.synthetic_weight)
        table = Table(title=f"Macro-F1 (%), {len(cfg.folds)} folds, {cfg.budget_percent:g} % labels, {title}")
        for col in ("method", "all 12 classes", "activities", "transitions"):
            table.add_column(col, justify="left" if col == "method" else "right")
        for r in (r for r in result["rows"] if r["backbone"] == backbone):
            table.add_row(names.get(r["method"], r["method"]), f"{r['macro_f1']:.2f} ± {r['macro_f1_std']:.2f}",
                          f"{r.get('activities', float('nan')):.2f}", f"{r.get('transitions', float('nan')):.2f}")
        console.print(table)
    console.print(f"report: {shown(output / 'report.md')} ({result['elapsed_s'] / 60:.1f} min)", highlight=False)


def register(app: typer.Typer) -> None:
    app.command("demo")(demo_cmd)
