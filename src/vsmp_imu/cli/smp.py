"""`vsmp-imu smp ...`: Semantic Motion Program commands.

A FILE argument that is not an existing path but names a library activity
(e.g. `jumping_jacks`) stands for that activity's library SMP.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Iterator
from pathlib import Path

import typer
from rich import box
from rich.table import Table
from rich.text import Text

from vsmp_imu.cli.common import (
    LIBRARY_OPTION,
    console,
    distinct_files,
    int_range,
    library_dirs,
    output_file,
    output_suffix,
    safe_text,
    shown,
)
from vsmp_imu.errors import ExtractionError, InputFileError, ValidationError, VsmpError
from vsmp_imu.io import atomic_text, check_regular_file, write_json
from vsmp_imu.smp import load_smp, save_smp, smp_json_schema
from vsmp_imu.smp.aggregate import aggregate, library_activity
from vsmp_imu.smp.augment import SMPAugmenter, check_output_size
from vsmp_imu.smp.intervene import ATTRIBUTES, intervene
from vsmp_imu.smp.io import SMP_SUFFIXES
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import Refiner, RefineResult
from vsmp_imu.smp.repair import RepairReport, parse_response
from vsmp_imu.smp.schema import SMP
from vsmp_imu.smp.verbalize import attribute_phrase, verbalize

smp_app = typer.Typer(help="Semantic Motion Programs: schema, validation, library, repair, "
                      "augmentation, interventions, verbalization.", no_args_is_help=True)
library_app = typer.Typer(help="The activity library.", no_args_is_help=True)
smp_app.add_typer(library_app, name="library")

SMP_ARG_HELP = "SMP file (.json, .yaml) or the name of a library activity"


def _library(library: list[Path] | None) -> ActivityLibrary:
    return ActivityLibrary.load(library_dirs(library))


def _smp_arg(value: str, library: list[Path] | None = None) -> SMP:
    """An SMP from a file, or from the library when `value` names an activity."""
    path = Path(value)
    if path.exists() or path.suffix.lower() in (".json", ".yaml", ".yml") or "/" in value:
        return load_smp(path)
    lib = _library(library)
    if value in lib:
        return lib.get(value).smp
    raise InputFileError("neither an existing SMP file nor a library activity "
                         "(`vsmp-imu smp library list` shows the activities)", file=value)


def _read_raw(path: Path) -> bytes:
    if not path.exists():
        raise InputFileError("file not found", file=path)
    if path.is_dir():
        raise InputFileError("expected a file, found a directory", file=path)
    check_regular_file(path)
    return path.read_bytes()


def _print_repair(name: str, report: RepairReport) -> None:
    status = "[red]rejected[/]" if report.rejected else (
        "[yellow]repaired[/]" if report.repaired else "[green]valid[/]")
    console.print(f"{status} {shown(name)}: malformed_json={report.malformed_json}, "
                  f"json_found={report.json_found}, {len(report.repairs)} repair(s), "
                  f"{len(report.invalid_values)} invalid value(s)", highlight=False)
    if report.missing_mandatory:
        console.print(f"  missing mandatory: {', '.join(report.missing_mandatory)}", highlight=False)
    for line in report.repairs:
        console.print(f"  - {line}", highlight=False, markup=False)
    if report.reason:
        console.print(f"  reason: {report.reason}", highlight=False, markup=False)


def _print_refine(result: RefineResult) -> None:
    where = f"library entry '{shown(result.entry)}'" if result.entry else "no library entry"
    console.print(f"refinement ({where}): {len(result.corrections)} correction(s)", highlight=False)
    for c in result.corrections:
        console.print(f"  - [{c.check}] {c.action} {c.field}: {c.before!r} -> {c.after!r}",
                      highlight=False, markup=False)


def smp_suffix(output: Path | None) -> None:
    """-o of a command that writes one SMP: a file named for its format, .json or .yaml
    (None: the SMP is printed)."""
    output_suffix(output, SMP_SUFFIXES, "an SMP")


def _write_or_print(smp: SMP, output: Path | None) -> None:
    if output is None:
        typer.echo(json.dumps(smp.model_dump(mode="json"), indent=2, sort_keys=True))
    else:
        save_smp(smp, output)
        console.print(f"wrote {shown(output)}", highlight=False)


@smp_app.command("schema")
def schema_cmd() -> None:
    """Print the SMP JSON Schema."""
    typer.echo(json.dumps(smp_json_schema(), indent=2))


@smp_app.command("validate")
def validate_cmd(file: Path = typer.Argument(..., help="SMP file (.json, .yaml)")) -> None:
    """Check an SMP file; exit 0 when valid, 2 with a field-level message when not."""
    smp = load_smp(file)
    console.print(f"[green]valid[/] {shown(file)}: '{shown(smp.activity_label)}', "
                  f"{len(smp.primitive_sequence)} primitives, id {shown(smp.smp_id)}")


@library_app.command("list")
def library_list_cmd(
    library: list[Path] = LIBRARY_OPTION,
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table"),
) -> None:
    """List the activities: name, datasets, repetitive, primitives."""
    lib = _library(library)
    if as_json:
        typer.echo(json.dumps([{"name": e.name, "datasets": e.datasets,
                                "repetitive": e.smp.temporal_structure.is_repetitive,
                                "primitives": e.smp.primitive_sequence, "path": str(e.path)}
                               for e in lib], indent=2))
        return
    # fits an 80-column terminal: light borders, whole names, and per activity its primitives
    # with the labels datasets give it below them, wrapped at spaces
    table = Table(title=f"Activity library ({len(lib)} activities)", box=box.SIMPLE_HEAD, pad_edge=False,
                  caption="rep. = repetitive; (dataset) the label a dataset gives the activity")
    table.add_column("name", no_wrap=True)
    table.add_column("rep.", width=4)
    table.add_column("primitives, then dataset labels", overflow="fold", ratio=1)
    for entry in lib:
        datasets = "; ".join(f"{label} ({ds})" for ds, label in sorted(entry.datasets.items()))
        cell = Text(safe_text(" > ".join(entry.smp.primitive_sequence)))
        if datasets:
            cell.append("\n" + safe_text(datasets), style="dim")
        table.add_row(shown(entry.name), "yes" if entry.smp.temporal_structure.is_repetitive else "no", cell)
    console.print(table)


@library_app.command("show")
def library_show_cmd(
    name: str = typer.Argument(..., help="Activity name or alias"),
    output: Path | None = typer.Option(None, "-o", "--output", help="Write the SMP here (.json/.yaml)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Print (or write) an activity's library SMP."""
    output_file(output)
    smp_suffix(output)
    _write_or_print(_library(library).get(name).smp, output)


@smp_app.command("repair")
def repair_cmd(
    raw: Path = typer.Argument(..., help="Raw model response (any text)"),
    output: Path | None = typer.Option(None, "-o", "--output", help="Write the repaired SMP here (.json/.yaml)"),
    report_file: Path | None = typer.Option(None, "--report", help="Write the repair report (JSON)"),
) -> None:
    """Parse and repair one raw response; exit 2 with the reason when it is rejected."""
    output_file(output)
    output_file(report_file, "--report")
    distinct_files({"--output": output, "--report": report_file}, {"the raw response": raw})
    smp_suffix(output)
    output_suffix(report_file, ".json", "a report", "--report")
    result = parse_response(_read_raw(raw))
    _print_repair(str(raw), result.report)
    if report_file is not None:
        write_json(report_file, result.report.to_dict())
    if result.smp is None:
        raise ValidationError(f"response rejected: {result.report.reason}", file=raw)
    if output is not None:
        _write_or_print(result.smp, output)


@smp_app.command("aggregate")
def aggregate_cmd(
    raws: list[Path] = typer.Argument(..., help="Raw responses for one clip"),
    output: Path | None = typer.Option(None, "-o", "--output", help="Write the final SMP here (.json/.yaml)"),
    min_valid: int = typer.Option(3, "--min-valid", callback=int_range(1),
                                  help="Discard the clip below this many valid responses"),
    no_refine: bool = typer.Option(False, "--no-refine", help="Skip the four consistency checks"),
    report_file: Path | None = typer.Option(None, "--report", help="Write the full report (JSON)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Repair each response, aggregate them, then refine (the paper's extraction tail)."""
    output_file(output)
    output_file(report_file, "--report")
    distinct_files({"--output": output, "--report": report_file}, {"a raw response": raws})
    smp_suffix(output)
    output_suffix(report_file, ".json", "a report", "--report")
    lib = _library(library)
    results = [parse_response(_read_raw(p)) for p in raws]
    for path, res in zip(raws, results, strict=True):
        _print_repair(str(path), res.report)
    agg = aggregate([r.smp for r in results], min_valid=min_valid, activity_of=library_activity(lib))
    report: dict = {"responses": [r.report.to_dict() for r in results],
                    "aggregation": {k: v for k, v in agg.to_dict().items() if k != "smp"}}
    if agg.smp is None:
        if report_file is not None:
            write_json(report_file, report)
        raise ExtractionError(f"clip discarded: {agg.reason}", file=raws[0])
    disagree = {k: v for k, v in agg.disagreement.items() if v > 0}
    console.print(f"aggregated {agg.n_valid}/{agg.n_total} valid responses; sequence from "
                  f"response {agg.anchor_index}; disagreement: {disagree or 'none'}", highlight=False)
    final = agg.smp
    if not no_refine:
        refined = Refiner(lib).refine(final)
        _print_refine(refined)
        report["refinement"] = {k: v for k, v in refined.to_dict().items() if k != "smp"}
        final = refined.smp
    if report_file is not None:
        write_json(report_file, report)
    _write_or_print(final, output)


@smp_app.command("refine")
def refine_cmd(
    file: str = typer.Argument(..., help=SMP_ARG_HELP),
    output: Path | None = typer.Option(None, "-o", "--output", help="Write the refined SMP here (.json/.yaml)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Run the four consistency checks and print every correction."""
    output_file(output)
    distinct_files({"--output": output}, {"the input SMP": Path(file)})
    smp_suffix(output)
    result = Refiner(_library(library)).refine(_smp_arg(file, library))
    _print_refine(result)
    if output is not None:
        _write_or_print(result.smp, output)


@smp_app.command("augment")
def augment_cmd(
    file: str = typer.Argument(..., help=SMP_ARG_HELP),
    k: int = typer.Option(..., "-k", min=1, max=10000, help="Number of variants, 1..10000"),
    seed: int = typer.Option(0, "--seed", help="Top-level seed"),
    output: Path = typer.Option(..., "-o", "--output", help="Output .jsonl (one SMP per line)"),
    no_uncertainty: bool = typer.Option(False, "--no-uncertainty",
                                        help="Ignore field uncertainty (u = 0 everywhere)"),
    provenance: Path | None = typer.Option(None, "--provenance",
                                           help="Also write what each variant changed (.jsonl)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Draw K constrained variants; the same seed gives the same bytes."""
    output_file(output)
    output_file(provenance, "--provenance")
    distinct_files({"--output": output, "--provenance": provenance}, {"the input SMP": Path(file)})
    output_suffix(output, ".jsonl", "a file of SMP variants (one a line)")
    output_suffix(provenance, ".jsonl", "the variants' provenance (one a line)", "--provenance")
    smp = _smp_arg(file, library)
    check_output_size(smp, k, field="-k")
    augmenter = SMPAugmenter(uncertainty_conditioned=not no_uncertainty)
    n = _write_variants(augmenter.iter_variants(smp, k, seed), output, provenance)
    console.print(f"wrote {n} variant(s) of '{shown(smp.activity_label)}' to {shown(output)}",
                  highlight=False)


def _write_variants(pairs: Iterator[tuple[SMP, dict]], output: Path, provenance: Path | None) -> int:
    """Write each variant (and its change record) as one line as it is drawn; the files appear
    only when all are written. Returns the number of variants."""
    n = 0
    with contextlib.ExitStack() as stack:
        lines = stack.enter_context(atomic_text(output))
        changes = stack.enter_context(atomic_text(provenance)) if provenance is not None else None
        for variant, change in pairs:
            lines.write(variant.canonical_json() + "\n")
            if changes is not None:
                changes.write(json.dumps(change, sort_keys=True, separators=(",", ":")) + "\n")
            n += 1
    return n


@smp_app.command("intervene")
def intervene_cmd(
    file: str = typer.Argument(..., help=SMP_ARG_HELP),
    attribute: str = typer.Option(..., "--attribute", help=f"One of: {', '.join(ATTRIBUTES)}"),
    level: str = typer.Option(..., "--level", help="slow|medium|fast, small|medium|large, a count, "
                              "a duration factor, symmetric|asymmetric"),
    output: Path | None = typer.Option(None, "-o", "--output", help="Write the SMP here (.json/.yaml)"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Change exactly one attribute (controllability interventions)."""
    output_file(output)
    distinct_files({"--output": output}, {"the input SMP": Path(file)})
    smp_suffix(output)
    smp = _smp_arg(file, library)
    _write_or_print(intervene(smp, attribute, level, _central_primitive(smp, library)), output)


def _central_primitive(smp: SMP, library: list[Path] | None) -> str | None:
    """The library's principal phase of the SMP's activity, when the library knows it."""
    try:
        return _library(library).get(smp.activity_label).central_primitive
    except VsmpError:
        return None


@smp_app.command("verbalize")
def verbalize_cmd(
    file: str = typer.Argument(..., help=SMP_ARG_HELP),
    phase_durations: bool = typer.Option(False, "--phase-durations",
                                         help="Also state the central phase's share"),
    attributes_only: bool = typer.Option(False, "--attributes",
                                         help="Print only the attribute phrase A"),
    library: list[Path] = LIBRARY_OPTION,
) -> None:
    """Print the HY-Motion prompt of an SMP."""
    smp = _smp_arg(file, library)
    text = attribute_phrase(smp, phase_durations) if attributes_only else verbalize(smp, phase_durations)
    typer.echo(safe_text(text))


def register(app: typer.Typer) -> None:
    app.add_typer(smp_app, name="smp")
