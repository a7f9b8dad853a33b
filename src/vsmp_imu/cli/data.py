"""`vsmp-imu data check`: the user's activity files simulated against the user's real windows."""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

import typer
from rich import box
from rich.table import Table

from vsmp_imu.cli.common import (
    LIBRARY_OPTION,
    OVERLAP,
    WINDOW_S,
    console,
    library_dirs,
    option_names,
    output_dir,
    print_warnings,
)

data_app = typer.Typer(help="Your own data: check it against the activity files before an evaluation.",
                       no_args_is_help=True)


def _num(value: float | None, fmt: str) -> str:
    return "–" if value is None or (isinstance(value, float) and math.isnan(value)) else format(value, fmt)


def _pair(real: float | None, simulated: float | None) -> str:
    return f"{_num(real, '.1f')}/{_num(simulated, '.1f')}"


def _sources(source: str, library, info):
    """Base SMPs per class; with the library, classes it cannot link are reported, not fatal."""
    from vsmp_imu.errors import ConfigError
    from vsmp_imu.pipeline.method import make_smp_source
    from vsmp_imu.pipeline.sources import entries_for

    try:
        return make_smp_source(source, library).smps(info.name, info.label_names), []
    except ConfigError as exc:
        if source.strip().lower() != "library":
            raise
        found = entries_for(info.name, info.label_names, library)
        return {n: [(f"library:{e.name}", e.smp)] for n, e in found.items()}, [exc.render()]


@data_app.command("check")
@option_names({"source": "--source", "backend": "--backend"})
def check_cmd(
    dataset: str = typer.Argument(..., help="dataset .yaml file (or a registered dataset name)"),
    data_dir: Path = typer.Option(None, "--data-dir", help="folder of a downloaded dataset"),
    source: str = typer.Option("library", "--source", help="activity files: library | smp:DIR"),
    library: list[Path] = LIBRARY_OPTION,
    backend: str = typer.Option("procedural", "--backend", help="motion backend: procedural | compiled | hymotion"),
    samples: int = typer.Option(3, "--samples", min=1, max=50, help="simulated executions per class"),
    window_s: float = WINDOW_S,
    overlap: float = OVERLAP,
    output: Path = typer.Option(..., "--output", "-o", help="folder for check.json and check.png"),
    mounting: bool = typer.Option(True, "--mounting/--no-mounting",
                                  help="turn the simulated windows by the sensor mounting estimated from the "
                                       "class means, as grounding does (--no-mounting: the declared axes alone)"),
) -> None:
    """Per class: the activity file simulated in the declared convention, turned by the estimated
    mounting, against the real windows (D_stat loss, where gravity points, dominant frequency, how
    much it moves) and a plot."""
    output_dir(output)
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.io import write_json
    from vsmp_imu.motion.backends import check_backend
    from vsmp_imu.pipeline.check import DataCheck
    from vsmp_imu.pipeline.sources import check_source
    from vsmp_imu.smp.library import ActivityLibrary

    check_backend(backend, "--backend")  # before the dataset loads
    check_source(source, "--source")
    dirs = tuple(str(p) for p in library_dirs(library))
    ds = load_dataset(dataset, data_dir)
    print_warnings(ds.warnings)
    sources, unlinked = _sources(source, ActivityLibrary.load([Path(d) for d in dirs]), ds.info)
    print_warnings(unlinked)
    check = DataCheck(backend=backend, samples=samples, window_s=window_s, overlap=overlap, library_dirs=dirs,
                      mounting=mounting)
    results = check.run(ds, sources)
    output.mkdir(parents=True, exist_ok=True)
    write_json(output / "check.json", {"dataset": ds.info.name, "source": source, "backend": backend,
                                       "samples": samples, "warnings": list(ds.warnings) + unlinked,
                                       "mountings": [asdict(m) for m in check.mountings_],
                                       "classes": check.to_json(),
                                       "pairs": [asdict(p) for p in check.pairs_],
                                       "pairs_skipped": check.pairs_skipped_})
    check.plot(output / "check.png", ds.info.fs_hz)
    pairs_png = check.plot_pairs(output / "check_pairs.png")
    taken_png = check.plot_taken(output / "check_taken.png")
    places = sorted({r.location for r in results})
    one_place = len(places) == 1  # the location goes into the title, its column away (80 columns)
    title = f"{ds.info.name}: activity files vs real windows" + (f" ({places[0]})" if one_place else "")
    table = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, padding=(0, 0, 0, 0),
                  caption="pairs are real/simulated; angle: between real and simulated mean acc (gravity); "
                          "tempo: dominant frequency of |acc| in Hz, or for a single execution (a transition) how long it "
                          "moves, in s; rms: m/s² around the window mean; turn: rad/s "
                          "around it; skew: of |acc| within a window (impacts make it positive); own: % of the "
                          "simulated windows a forest trained on the real ones takes for the class; !: see below")
    columns = ("class", *(() if one_place else ("at",)), "real", "L_sim", "angle", "tempo", "rms", "turn", "skew",
               "own", "")
    for col in columns:
        table.add_column(col, overflow="fold", no_wrap=col != "class", min_width=12 if col == "class" else None)
    for r in results:
        table.add_row(r.label, *(() if one_place else (r.location,)), str(r.n_real), _num(r.l_sim, ".1f"),
                      _num(r.gravity_angle_deg, ".0f"),
                      _pair(r.real_frequency_hz, r.synthetic_frequency_hz) if r.n_real_executions is None
                      else _pair(r.real_duration_s, r.synthetic_duration_s) + "s",
                      _pair(r.real_motion_rms, r.synthetic_motion_rms),
                      _pair(r.real_turn_rms, r.synthetic_turn_rms),
                      _pair(r.real_acc_skew, r.synthetic_acc_skew), _num(r.recognised_pct, ".0f"),
                      "[yellow]![/]" if r.flags else "")
    console.print(table)
    for m in check.mountings_ if mounting else ():
        console.print(m.describe(), highlight=False)
        for flag in m.flags:
            console.print(f"[yellow]{m.location}[/]: {flag}", highlight=False)
    for r in results:
        for flag in r.flags:
            console.print(f"[yellow]{r.label}[/] ({r.location}, {r.source}): {flag}", highlight=False)
    if check.pairs_skipped_:
        console.print(f"pairs of classes: not compared ({check.pairs_skipped_})", highlight=False)
    for p in check.pairs_:
        for flag in p.flags:
            console.print(f"[yellow]{p.first} vs {p.second}[/] ({p.location}): {flag}", highlight=False)
    written = ", ".join(str(p) for p in (output / "check.json", output / "check.png", pairs_png, taken_png) if p)
    console.print(f"[green]wrote[/] {written}", highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(data_app, name="data")
