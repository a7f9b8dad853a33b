"""`vsmp-imu cache info | clear`: the project's folders of the on-disk cache (parsed datasets,
generated samples, VLM answers); anything else under the cache root is left alone."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from vsmp_imu.cli.common import console
from vsmp_imu.errors import ConfigError
from vsmp_imu.har.cache import (
    CACHE_FOLDERS,
    KEPT_UNLESS_ASKED,
    MAX_GB_ENV,
    SAMPLES,
    cache_contents,
    cache_dir,
    clear_cache,
    max_cache_bytes,
)

FOLDERS = ", ".join(CACHE_FOLDERS)
KEPT = ", ".join(KEPT_UNLESS_ASKED)

cache_app = typer.Typer(help="The on-disk cache: parsed datasets, generated samples, VLM answers.", no_args_is_help=True)


def _size(n: int) -> str:
    for unit in ("B", "KB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} GB"


def _entry(path: Path) -> str:
    """An entry's name, marked '/' for a folder or '(link)' for a link."""
    if path.is_symlink():
        return f"{path.name} (link)"
    return f"{path.name}/" if path.is_dir() else path.name


def _left_alone(others: list[Path]) -> None:
    if others:
        console.print("not the project's, left alone: " + ", ".join(_entry(p) for p in others),
                      highlight=False, soft_wrap=True)


@cache_app.command("info")
def info_cmd() -> None:
    """Where the cache is, what each of the project's folders holds, and the size cap of the samples."""
    cap = max_cache_bytes()
    contents = cache_contents()
    console.print(f"cache: {cache_dir()}", highlight=False, soft_wrap=True)
    table = Table()
    for col, justify in (("folder", "left"), ("files", "right"), ("size", "right"), ("holds", "left")):
        table.add_column(col, justify=justify)
    for u in contents.folders:
        table.add_row(u.name, str(u.files), _size(u.bytes), CACHE_FOLDERS[u.name])
    folders = contents.folders
    table.add_row("[bold]total[/]", str(sum(u.files for u in folders)), _size(sum(u.bytes for u in folders)), "")
    console.print(table)
    console.print(f"'{SAMPLES}' is kept under {_size(cap)} (${MAX_GB_ENV}); the least recently used "
                  f"samples go first. `vsmp-imu cache clear` removes these folders but {KEPT} (`--all`: these too) "
                  "and nothing else.",
                  highlight=False)
    _left_alone(contents.others)


@cache_app.command("clear", help=f"Remove the project's cache folders ({FOLDERS}) but {KEPT} (paid VLM "
                   f"answers: --all removes them too), or one of them; they are remade when needed. Other "
                   "files and folders under the cache, and links, are left alone.")
def clear_cmd(only: str = typer.Option(None, "--only", help=f"remove only this folder: {FOLDERS}"),
              everything: bool = typer.Option(False, "--all", help=f"remove {KEPT} too")) -> None:
    if only is not None and everything:
        raise ConfigError("--only and --all ask for different things", field="--all",
                          allowed="one of them, or neither")
    kept = [] if only or everything else [u for u in cache_contents().folders if u.name in KEPT_UNLESS_ASKED]
    removed, others = clear_cache(only=only, everything=everything)
    root = cache_dir()
    for u in removed:
        console.print(f"removed {u.files} files ({_size(u.bytes)}) from {root / u.name}", highlight=False,
                      soft_wrap=True)
    if not removed and not kept:
        console.print(f"nothing to remove: {root} holds no folder " + (f"'{only}'" if only else "of the project"),
                      highlight=False, soft_wrap=True)
    for u in kept:
        console.print(f"kept {u.files} files ({_size(u.bytes)}) in {root / u.name}: "
                      f"{CACHE_FOLDERS[u.name]}; --all or --only {u.name} removes them",
                      highlight=False, soft_wrap=True)
    _left_alone(others)


def register(app: typer.Typer) -> None:
    app.add_typer(cache_app, name="cache")
