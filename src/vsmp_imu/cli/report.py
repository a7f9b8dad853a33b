"""`vsmp-imu report`: the measured tables of the docs, rebuilt from the records in results/."""

from __future__ import annotations

import subprocess
from pathlib import Path

import typer

from vsmp_imu.cli.common import console, console_err, output_dir, parse_csv, shown

report_app = typer.Typer(
    help="Rebuild the measured tables of README.md and docs/ from the records in results/ "
    "(--write rewrites them, --check fails where they differ); `report import` adds a run.",
    invoke_without_command=True,
)


@report_app.callback()
def report_cmd(
    ctx: typer.Context,
    write: bool = typer.Option(False, "--write", help="rewrite the marked tables in place"),
    check: bool = typer.Option(
        False, "--check", help="exit 1 where a marked table differs from its records"
    ),
    root: Path = typer.Option(Path("."), "--root", help="repository root (results/, README.md, docs/)"),
    table: str | None = typer.Option(None, "--table", help="print one table, e.g. lr_rf:main"),
) -> None:
    """Without an option: list the tables and whether they match their records."""
    if ctx.invoked_subcommand is not None:
        return
    from vsmp_imu.errors import ConfigError
    from vsmp_imu.har.published import Publication

    if write and check:
        raise ConfigError("--write and --check exclude each other", field="--write/--check")
    publication = Publication(root)
    if table is not None:
        console.print(publication.render(table), markup=False, highlight=False, soft_wrap=True)
        return
    outcome = publication.check(write=write)
    for line in outcome.warnings:
        console_err.print(f"warning: {line}", markup=False, highlight=False, soft_wrap=True)
    if write:
        for path in outcome.written:
            console.print(f"rewrote {shown(path)}", highlight=False)
        console.print(f"{outcome.checked} tables from records, {len(outcome.written)} files rewritten",
                      highlight=False)
        return
    for diff in outcome.diffs:
        console.print(diff, markup=False, highlight=False, soft_wrap=True)
    for line in outcome.differing:
        console_err.print(f"differs from its records: {line}", markup=False, highlight=False)
    console.print(f"{outcome.checked} tables from records, {len(outcome.differing)} differ, "
                  f"{len(outcome.warnings)} warnings", highlight=False)
    if check and outcome.differing:
        raise typer.Exit(1)


def _head_commit() -> str | None:
    """The commit of the checkout this command runs from, if it is a git work tree."""
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                             cwd=Path(__file__).parent, timeout=10, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    if out.returncode != 0:
        return None
    return out.stdout.strip() or None


@report_app.command("import", help=(
    "Copy a run's records into results/NAME/: records.jsonl + run.json for an evaluation, study.json + "
    "run.json for a study (told by the command, `vsmp-imu study NAME ...`). Several evaluation folders "
    "of one experiment (e.g. one per --only-seeds) join into one set when they ran the same settings. "
    "A record set of that name is not overwritten unless --replace."))
def import_cmd(
    run_dirs: list[Path] = typer.Argument(
        ..., metavar="run_dir", help="a `vsmp-imu evaluate` or `vsmp-imu study` output folder; several "
                                        "`evaluate` folders of one experiment (e.g. one per --only-seeds) "
                                        "make one record set"),
    name: str = typer.Option(..., "--name", help="record-set name, e.g. lr_rf"),
    command: str = typer.Option(..., "--command", help="the command that produced the run"),
    commit: str | None = typer.Option(
        None, "--commit", help="code commit of the run (default: this checkout's HEAD)"
    ),
    note: str | None = typer.Option(None, "--note", help="how the run was made, if not by the command alone"),
    root: Path = typer.Option(Path("."), "--root", help="repository root (writes root/results/NAME/)"),
    labels: str | None = typer.Option(
        None, "--labels", help="CLASS,CLASS,...: the confusion matrices' class order, for record files "
                               "that do not say it (an unfinished run of an older version)"),
    every_record: bool = typer.Option(
        False, "--every-record", help="also the records of earlier runs into the folder (records/*.json; "
                                      "results.json holds the last run's only, e.g. one --only-seeds)"),
    replace: bool = typer.Option(False, "--replace", help="overwrite a record set NAME that exists"),
) -> None:
    """`report import`: the run folders' records into results/NAME/ (import_run, import_study)."""
    from vsmp_imu.errors import ConfigError
    from vsmp_imu.har.records import import_run
    from vsmp_imu.har.study_records import import_study, study_of

    output_dir(root / "results", "--root")  # root/results/NAME/ can be written, before any record is read
    if (root / "results" / name).exists() and not replace:
        raise ConfigError(f"record set '{name}' exists ({shown(root / 'results' / name)}/): other tables may "
                          "read it; choose another --name, or --replace to overwrite it", field="--name")
    if study_of(command):
        if len(run_dirs) > 1:
            raise ConfigError("a study is imported from one folder", field="run_dir")
        folder = import_study(run_dirs[0], name, command, root / "results", commit or _head_commit(), note)
    else:
        folder = import_run(run_dirs, name, command, root / "results", commit or _head_commit(), note,
                            tuple(parse_csv(labels, option="--labels")) if labels else (), every_record)
    console.print(f"wrote {shown(folder)}/", highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(report_app, name="report")
