"""The `vsmp-imu` command. It parses arguments, builds objects and calls them;
the logic lives in the rooms. Each sub-module registers its own commands."""

from __future__ import annotations

import sys

import typer

from vsmp_imu.cli import demo, generate, har, imu, motion, report, smp, study, video
from vsmp_imu.cli.common import console_err
from vsmp_imu.errors import VsmpError

app = typer.Typer(
    name="vsmp-imu",
    help="Turn activity videos or activity names into synthetic wearable IMU data, "
    "and measure honestly how much it helps HAR models.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

for module in (smp, motion, imu, har, generate, video, study, demo, report):
    module.register(app)


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: user mistakes exit 2 with a one-paragraph message."""
    try:
        app(args=argv, standalone_mode=True)
    except VsmpError as exc:
        console_err.print(f"[bold red]error:[/] {exc.render()}", highlight=False, soft_wrap=True)
        sys.exit(2)
