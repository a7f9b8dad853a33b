"""A command's output folder (`-o`), taken before any work so that a run never writes over a
user's files.

A command takes a folder that is new, empty (an `atomic_path` temporary does not count), or
one the same command wrote: it holds the command's run file (a JSON object naming the
command), or, a folder written before the command wrote one, only names the command writes,
one of its `markers` among them. Anything else is refused: a ConfigError (field `--output`)
naming up to five of the entries the folder holds. `vsmp-imu generate` and `evaluate` keep
their own rules (`pipeline/output.py`, `har/output.py`) and share `entries` and `listing`.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, some_of
from vsmp_imu.io import is_temp_name, write_json

MAX_RUN_FILE_BYTES = 16 * 2**20  # a larger run file is not one a command wrote
SHOWN = 5  # entries an error names


def entries(folder: Path, field: str = "--output") -> list[Path]:
    """What `folder` holds, less `atomic_path` temporaries (none when it does not exist)."""
    try:
        return [p for p in folder.iterdir() if not is_temp_name(p.name)] if folder.is_dir() else []
    except OSError as exc:  # a folder we may not list
        raise ConfigError(f"cannot list the folder ({exc.strerror})", file=folder, field=field,
                          allowed="a folder you may read and write") from exc


def listing(found: Iterable[Path]) -> str:
    """'a, b, c, d, e and 3 more': the first names in sorted order."""
    return some_of(sorted(p.name for p in found), SHOWN)


def read_json_object(path: Path, max_bytes: int = MAX_RUN_FILE_BYTES) -> dict[str, Any] | None:
    """The JSON object in `path`, or None when absent, too large, not JSON or not an object."""
    try:
        if path.stat().st_size > max_bytes:
            return None
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # absent, not JSON, or nested too deep
        return None
    return data if isinstance(data, dict) else None


@dataclass(frozen=True)
class OutputFolder:
    """The output folder of one command.

    command: as a user types it ("vsmp-imu demo"), recorded in `run_file`;
    names: what the command writes at the top of its folder (files and subfolders);
    markers: of these, the ones a folder it wrote always holds at least one of;
    patterns: further names it writes (full matches), e.g. one file per variant;
    earlier: whether a folder's run file is this command's (default: a JSON object whose
    "command" is `command`);
    allowed: what the error tells the user to do.
    """

    command: str
    run_file: str
    names: frozenset[str]
    markers: frozenset[str]
    patterns: tuple[re.Pattern[str], ...] = ()
    earlier: Callable[[Path], bool] | None = None
    allowed: str = ""

    def owns(self, names: Iterable[str]) -> bool:
        """Whether these names are only ones the command writes, one of its markers among them
        (a folder it wrote before it wrote `run_file`)."""
        names = set(names)
        return bool(names & self.markers) and all(n in self.names or n == self.run_file or
                                                  any(p.fullmatch(n) for p in self.patterns) for n in names)

    def is_earlier(self, folder: Path) -> bool:
        """Whether `folder` holds this command's run file."""
        if self.earlier is not None:
            return self.earlier(folder)
        data = read_json_object(folder / self.run_file)
        return data is not None and data.get("command") == self.command

    def check(self, folder: Path, field: str = "--output") -> None:
        """`folder` is new, empty or this command's; else a ConfigError naming what it holds."""
        found = entries(folder, field)
        if not found or self.is_earlier(folder) or self.owns(p.name for p in found):
            return
        other = read_json_object(folder / self.run_file) if self.earlier is None else None
        whose = other.get("command") if other is not None else None
        if isinstance(whose, str) and whose.startswith("vsmp-imu ") and len(whose) <= 80:
            message = f"holds the output of `{whose}`, not of `{self.command}`"
        else:
            message = f"is not empty and holds no earlier `{self.command}` run ({listing(found)})"
        raise ConfigError(message, file=folder, field=field, allowed=self.allowed or (
            f"a new or empty folder, or the folder of an earlier `{self.command}` (a rerun replaces its "
            f"outputs); give another -o, or remove the folder"))

    def claim(self, folder: Path, field: str = "--output", **record: Any) -> None:
        """`check`, then write `run_file` ({"command": ..., **record}): the folder is this
        command's from now on, before any work."""
        self.check(folder, field)
        write_json(folder / self.run_file, {"command": self.command, **record})
