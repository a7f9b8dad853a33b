"""`vsmp-imu study ...`: the paper's studies (controllability, extraction audit, case study)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from vsmp_imu.cli.common import console, console_err, library_dirs, parse_csv
from vsmp_imu.errors import ConfigError

study_app = typer.Typer(help="Studies of the paper: end-to-end controllability, SMP extraction "
                        "audit, qualitative case study.", no_args_is_help=True)
LIBRARY_OPTION = typer.Option(None, "--library", help="Extra activity-library folder (repeatable).")


@contextmanager
def _progress(description: str) -> Iterator:
    """A rich progress bar on stderr; yields a callback(done, total, stage)."""
    with Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                  TimeElapsedColumn(), console=console_err, transient=True) as bar:
        task = bar.add_task(description, total=None)

        def update(done: int, total: int, stage: str) -> None:
            bar.update(task, completed=done, total=total, description=f"{description}: {stage}")

        yield update


def _library(library: list[Path] | None):
    from vsmp_imu.smp.library import ActivityLibrary

    return ActivityLibrary.load(library_dirs(library))


@study_app.command("control")
def control_cmd(
    output: Path = typer.Option(..., "-o", "--output", help="Output folder (report.md, results.json, "
                                "cases.csv, control_results.png; cache/ makes a rerun fast)"),
    seeds: int = typer.Option(5, "--seeds", help="Generation seeds per level: 0..N-1"),
    backend: str = typer.Option("procedural", "--backend", help="Motion backend: procedural | hymotion"),
    data_dir: Path | None = typer.Option(None, "--data-dir", help="UTD-MHAD inertial files: ground "
                                         "to them and validate labels with them (default: ground "
                                         "to HAPT)"),
    activities: str | None = typer.Option(None, "--activities", help="Comma-separated UTD-MHAD "
                                          "activities (default: the paper's 12)"),
    controls: str | None = typer.Option(None, "--controls", help="Comma-separated subset of tempo, "
                                        "amplitude, repetitions, duration, symmetry"),
    no_noise: bool = typer.Option(False, "--no-noise", help="Noise-free virtual IMU"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """End-to-end SMP controllability: motion, raw IMU and grounded IMU checkpoints."""
    from vsmp_imu.studies.control import ATTRIBUTES, ControlStudy
    from vsmp_imu.studies.control_report import write_control_outputs

    if seeds < 1:
        raise ConfigError(f"{seeds} is out of range", field="--seeds", allowed="an integer >= 1")
    study = ControlStudy(
        seeds=range(seeds),
        activities=parse_csv(activities, option="--activities") if activities else None,
        attributes=parse_csv(controls, ATTRIBUTES, "--controls") if controls else None,
        backend=backend, library=_library(library), noise=not no_noise, data_dir=data_dir)
    with _progress("controllability") as update:
        results = study.run(output, progress=update)
    paths = write_control_outputs(results, output)
    for attribute, s in results.summary.items():
        cp = s["checkpoints"]
        if attribute == "symmetry":
            text = f"accuracy {cp['motion']['accuracy']:.1%}"
        elif attribute == "duration":
            text = ", ".join(f"{k} MAPE {v['mape']:.1%}" for k, v in cp.items())
        else:
            text = ", ".join(f"{k} rho {v['rho_per_set']:.2f}" for k, v in cp.items())
        console.print(f"{attribute}: {text}", highlight=False)
    console.print(f"wrote {paths['report']} ({len(results.cases)} motions, {results.elapsed_s:.1f} s)",
                  highlight=False)


@study_app.command("audit")
def audit_cmd(
    pred: Path = typer.Option(..., "--pred", help="Folder of clips: CLIP.raw/ (as `smp extract` "
                              "writes it) or CLIP/ with raw response .txt files; optional clips.csv"),
    ref: Path = typer.Option(..., "--ref", help="Folder of reference SMPs CLIP.json or CLIP.yaml"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    groups: Path | None = typer.Option(None, "--groups", help="CSV clip,group (default: "
                                       "PRED/clips.csv when present)"),
    min_valid: int = typer.Option(3, "--min-valid", help="Valid responses needed to aggregate"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """SMP extraction audit: field accuracy, failure accounting, uncertainty calibration."""
    from vsmp_imu.studies.audit import ExtractionAudit, load_audit_inputs
    from vsmp_imu.studies.audit_report import write_audit_outputs

    if min_valid < 1:
        raise ConfigError(f"{min_valid} is out of range", field="--min-valid", allowed="an integer >= 1")
    clips = load_audit_inputs(pred, ref, groups)
    results = ExtractionAudit(_library(library), min_valid).run(clips)
    paths = write_audit_outputs(results, output)
    f = results.failures["overall"]
    refined = results.fields["refined"]
    console.print(f"{f['clips']} clips ({f['evaluated_clips']} aggregated): label accuracy "
                  f"{refined['activity_label']['value']:.1%}, primitive sequence "
                  f"{refined['primitive_sequence']['value']:.1%}, residual error "
                  f"{f['residual_error']:.1%}", highlight=False)
    console.print(f"wrote {paths['report']}", highlight=False)


@study_app.command("case")
def case_cmd(
    activity: str = typer.Option(..., "--activity", help="Library activity"),
    output: Path = typer.Option(..., "-o", "--output", help="Output folder"),
    video: Path | None = typer.Option(None, "--video", help="Source clip (frames and the pose "
                                      "extractor's SMP; needs the video extra)"),
    seed: int = typer.Option(0, "--seed", help="Motion and IMU noise seed"),
    location: str | None = typer.Option(None, "--location", help="Sensor location (default: the "
                                        "activity's dataset location)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Qualitative case study: source frames, SMP, three controlled variants, motions, IMU."""
    from vsmp_imu.studies.case import CaseStudy, write_case_outputs

    if location is not None:
        from vsmp_imu.imu.placement import get_placement

        location = get_placement(location).name
    result = CaseStudy(activity, video=video, seed=seed, library=_library(library),
                       location=location).run()
    paths = write_case_outputs(result, output)
    for k, var in enumerate(result.variants, start=1):
        console.print(f"variant {k}: {var.variant.title}", highlight=False)
    console.print(f"wrote {paths['figure']}", highlight=False)


def register(app: typer.Typer) -> None:
    """Attach the `study` group to the main app."""
    app.add_typer(study_app, name="study")
