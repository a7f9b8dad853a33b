"""`vsmp-imu cache info | clear`: the on-disk cache (parsed datasets, generated samples)."""

from __future__ import annotations

import typer
from rich.table import Table

from vsmp_imu.cli.common import console

cache_app = typer.Typer(help="The on-disk cache: parsed datasets and generated samples.", no_args_is_help=True)


def _size(n: int) -> str:
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} GB"


@cache_app.command("info")
def info_cmd() -> None:
    """Where the cache is, what each folder holds, and the size cap of the samples."""
    from vsmp_imu.har.cache import MAX_GB_ENV, SAMPLES, cache_dir, cache_usage, max_cache_bytes

    cap = max_cache_bytes()
    usage = cache_usage()
    console.print(f"cache: {cache_dir()}", highlight=False)
    table = Table()
    for col, justify in (("folder", "left"), ("files", "right"), ("size", "right")):
        table.add_column(col, justify=justify)
    for u in usage:
        table.add_row(u.name, str(u.files), _size(u.bytes))
    table.add_row("[bold]total[/]", str(sum(u.files for u in usage)), _size(sum(u.bytes for u in usage)))
    console.print(table)
    console.print(f"'{SAMPLES}' is kept under {_size(cap)} (${MAX_GB_ENV}); the least recently used "
                  "samples go first. Removing any of it is safe: it is recomputed when needed.",
                  highlight=False)


@cache_app.command("clear")
def clear_cmd(only: str = typer.Option(None, "--only", help="clear only this folder, e.g. samples")) -> None:
    """Remove the cache (or one of its folders); everything is recomputed when needed."""
    from vsmp_imu.har.cache import cache_dir, clear_cache

    removed = clear_cache(only=only)
    console.print(f"removed {removed.files} files ({_size(removed.bytes)}) from {cache_dir()}"
                  + (f"/{only}" if only else ""), highlight=False)


def register(app: typer.Typer) -> None:
    app.add_typer(cache_app, name="cache")
