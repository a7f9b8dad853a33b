"""The on-disk cache: parsed datasets (keyed by the source file's hash) and the per-sample
results of synthetic generation (keyed by each sample's content hash).

Everything lives under `cache_dir()` (`$VSMP_IMU_CACHE`, else `~/.cache/vsmp-imu`), never in
an evaluation's output folder. The generation samples are kept below a size cap
(`$VSMP_IMU_CACHE_MAX_GB`, default 10): after an evaluation the least recently used
samples are removed until the cache fits. `vsmp-imu cache info` and `cache clear` show and
empty it. Removing cache files is always safe: a missing entry is recomputed, with the same
result.
"""

from __future__ import annotations

import os
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vsmp_imu.errors import ConfigError
from vsmp_imu.io import atomic_path, file_sha256

__all__ = ["cache_dir", "file_sha256", "load_npz", "save_npz", "samples_dir", "max_cache_bytes",
           "cache_usage", "prune_cache", "clear_cache"]

SAMPLES = "samples"  # the generation samples' folder under cache_dir()
MAX_GB_ENV = "VSMP_IMU_CACHE_MAX_GB"
DEFAULT_MAX_GB = 10.0


def cache_dir() -> Path:
    """`$VSMP_IMU_CACHE`, else `~/.cache/vsmp-imu`."""
    root = os.environ.get("VSMP_IMU_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "vsmp-imu"


def samples_dir() -> Path:
    """Where evaluations cache their generated samples unless told otherwise."""
    return cache_dir() / SAMPLES


def max_cache_bytes() -> int:
    """The size cap of the samples cache, from `$VSMP_IMU_CACHE_MAX_GB` (default 10 GB)."""
    text = os.environ.get(MAX_GB_ENV)
    if text is None or not text.strip():
        return int(DEFAULT_MAX_GB * 1e9)
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value >= 0 or value == float("inf"):
        raise ConfigError(f"'{text}' is not a size in GB", field=MAX_GB_ENV,
                          allowed="a number of gigabytes >= 0 (0 keeps no samples)")
    return int(value * 1e9)


@dataclass(frozen=True)
class FolderUsage:
    name: str
    files: int
    bytes: int


def _files(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if p.is_file()] if folder.is_dir() else []


def cache_usage(root: Path | None = None) -> list[FolderUsage]:
    """Files and bytes of each folder directly under the cache (`root`, default cache_dir())."""
    root = cache_dir() if root is None else Path(root)
    if not root.is_dir():
        return []
    out = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir()):
        files = _files(folder)
        out.append(FolderUsage(folder.name, len(files), sum(_size(p) for p in files)))
    return out


def _size(path: Path) -> int:
    try:
        return path.stat().st_size
    except FileNotFoundError:  # removed meanwhile by another process
        return 0


def _mtime(path: Path) -> float:
    try:
        return path.stat().st_mtime
    except FileNotFoundError:
        return 0.0


def prune_cache(folder: Path, max_bytes: int) -> tuple[int, int]:
    """Remove the least recently used files of `folder` until it holds at most `max_bytes`.

    Returns (files removed, bytes removed). Cache hits refresh a file's time, so what
    recent runs use stays.
    """
    files = sorted(_files(Path(folder)), key=lambda p: (_mtime(p), str(p)))
    total = sum(_size(p) for p in files)
    removed = freed = 0
    for path in files:
        if total <= max_bytes:
            break
        size = _size(path)
        path.unlink(missing_ok=True)
        total -= size
        removed += 1
        freed += size
    return removed, freed


def clear_cache(root: Path | None = None, only: str | None = None) -> FolderUsage:
    """Empty the cache (or only its folder `only`); returns what was removed."""
    root = cache_dir() if root is None else Path(root)
    usage = {u.name: u for u in cache_usage(root)}
    if only is not None and only not in usage:
        raise ConfigError(f"the cache {root} has no folder '{only}'", field="--only",
                          allowed=", ".join(usage) or "(the cache is empty)")
    names = [only] if only is not None else list(usage)
    for name in names:
        shutil.rmtree(root / name, ignore_errors=True)
    return FolderUsage(only or "all", sum(usage[n].files for n in names), sum(usage[n].bytes for n in names))


def load_npz(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of a cached `.npz`, or None when absent or unreadable."""
    if not path.exists():
        return None
    try:
        with np.load(path, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile):  # truncated or empty
        return None


def save_npz(path: Path, arrays: dict[str, np.ndarray]) -> Path:
    """Write arrays atomically (a reader never sees a partial cache file)."""
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez(tmp, **arrays)
    return path
