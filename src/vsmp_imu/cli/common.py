"""Shared pieces of the command line: consoles and option helpers."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console

from vsmp_imu.errors import ConfigError

console = Console()
console_err = Console(stderr=True)


def parse_csv(value: str, allowed: tuple[str, ...] | None = None, option: str = "") -> list[str]:
    """Split 'a,b,c' and check every item against `allowed`."""
    items = [v.strip() for v in value.split(",") if v.strip()]
    if not items:
        raise ConfigError("must name at least one value", field=option)
    if allowed is not None:
        bad = [v for v in items if v not in allowed]
        if bad:
            raise ConfigError(f"unknown value(s) {', '.join(bad)}", field=option, allowed=", ".join(allowed))
    return items


def library_dirs(library: list[Path] | None) -> list[Path]:
    """The user's extra activity-library folders given by --library (repeatable)."""
    return list(library or [])
