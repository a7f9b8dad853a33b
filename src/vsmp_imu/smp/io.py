"""Load and save SMPs as JSON or YAML."""

from __future__ import annotations

from pathlib import Path

from vsmp_imu.io import read_structured, write_structured
from vsmp_imu.smp.schema import SMP
from vsmp_imu.validation import validate_model

# The names an SMP file is written under: JSON, or YAML (`write_structured` picks by the suffix).
SMP_SUFFIXES = (".json", ".yaml", ".yml")


def smp_from_dict(data: object, file: str | Path | None = None) -> SMP:
    """Validate a parsed mapping into an SMP (errors name the file and field)."""
    return validate_model(SMP, data, file)


def is_activity_file(data: object) -> bool:
    """An activity (library) file: a mapping whose SMP sits under `smp`, beside name and captions."""
    return isinstance(data, dict) and isinstance(data.get("smp"), dict) and "activity_label" not in data


def load_smp(path: str | Path) -> SMP:
    """Read an SMP from a .json, .yaml or .yml file: an SMP, or an activity file (its `smp`, the whole
    file validated as the library validates it)."""
    return load_smp_or_activity(path)[0]


def load_smp_or_activity(path: str | Path):
    """(SMP, the activity file's library entry or None for a plain SMP file), the file read once."""
    data = read_structured(path)
    if is_activity_file(data):
        # imported here: the library reads SMPs through this module
        from vsmp_imu.smp.library import entry_from_data

        entry = entry_from_data(data, path)
        return entry.smp, entry
    return smp_from_dict(data, path), None


def save_smp(smp: SMP, path: str | Path) -> Path:
    """Write an SMP atomically; the extension picks JSON or YAML."""
    return write_structured(path, smp.model_dump(mode="json"))
