"""`vsmp-imu smp ...`: Semantic Motion Program commands."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from vsmp_imu.cli.common import console
from vsmp_imu.smp import load_smp, smp_json_schema

smp_app = typer.Typer(help="Semantic Motion Programs: schema, validation, library, repair, "
                      "augmentation, interventions, verbalization.", no_args_is_help=True)


@smp_app.command("schema")
def schema_cmd() -> None:
    """Print the SMP JSON Schema."""
    typer.echo(json.dumps(smp_json_schema(), indent=2))


@smp_app.command("validate")
def validate_cmd(file: Path = typer.Argument(..., help="SMP file (.json, .yaml)")) -> None:
    """Check an SMP file; exit 0 when valid, 2 with a field-level message when not."""
    smp = load_smp(file)
    console.print(f"[green]valid[/] {file}: '{smp.activity_label}', "
                  f"{len(smp.primitive_sequence)} primitives, id {smp.smp_id}")


def register(app: typer.Typer) -> None:
    app.add_typer(smp_app, name="smp")
