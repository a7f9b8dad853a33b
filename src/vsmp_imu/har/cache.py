"""The on-disk cache: parsed datasets (keyed by the source file's hash) and the per-sample
results of synthetic generation (keyed by each sample's content hash).

The cache lives under `cache_dir()` (`$VSMP_IMU_CACHE`, else `$XDG_CACHE_HOME/vsmp-imu`, else
`~/.cache/vsmp-imu`), never in an evaluation's output folder, in the folders named in
`CACHE_FOLDERS` and nowhere else (the VLM answers too, unless `--cache-dir` names another
folder). The generation samples are kept below a size cap (`$VSMP_IMU_CACHE_MAX_GB`, default 10): after an
evaluation the least recently used samples are removed until the cache fits. `vsmp-imu cache
info` and `cache clear` show and remove these folders; anything else under the root (the user
may point `$VSMP_IMU_CACHE` at a folder of their own) is not the project's and is left alone,
and links are never followed.
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

__all__ = ["CACHE_FOLDERS", "KEPT_UNLESS_ASKED", "cache_dir", "cache_folder", "file_sha256", "load_npz", "save_npz", "samples_dir",
           "vlm_dir", "max_cache_bytes", "cache_contents", "prune_cache", "prune_files", "clear_cache"]

SAMPLES = "samples"  # samples_dir()
HAPT_CACHE = "hapt"  # the HAPT loader's parsed arrays (har/datasets/hapt.py)
VLM = "vlm"  # vlm_dir()
# Every folder the project makes under cache_dir(), and what it holds: `cache clear` removes
# these and nothing else. A new cache folder is made with cache_folder(), which refuses a name
# missing here.
CACHE_FOLDERS = {
    SAMPLES: "generated samples of `evaluate` and `demo`; remade, with the same result, when needed",
    HAPT_CACHE: "the parsed HAPT dataset; parsed again when needed",
    VLM: "VLM answers of `smp extract`, `video pool` and the imugpt describer; asked again (new requests) when needed",
}
# Folders a plain `cache clear` keeps: VLM answers are paid requests whose answers may not come
# back the same; `cache clear --all` or `--only vlm` removes them.
KEPT_UNLESS_ASKED = (VLM,)
MAX_GB_ENV = "VSMP_IMU_CACHE_MAX_GB"
DEFAULT_MAX_GB = 10.0


def cache_dir() -> Path:
    """`$VSMP_IMU_CACHE`, else `$XDG_CACHE_HOME/vsmp-imu`, else `~/.cache/vsmp-imu`."""
    root = os.environ.get("VSMP_IMU_CACHE")
    if root:
        return Path(root)
    base = os.environ.get("XDG_CACHE_HOME")
    return (Path(base) if base else Path.home() / ".cache") / "vsmp-imu"


def cache_folder(name: str) -> Path:
    """The project's cache folder `name` under cache_dir(); `name` must be in CACHE_FOLDERS."""
    if name not in CACHE_FOLDERS:
        raise ValueError(f"'{name}' is not in CACHE_FOLDERS; list it there to cache under {cache_dir()}")
    return cache_dir() / name


def samples_dir() -> Path:
    """Where evaluations cache their generated samples unless told otherwise."""
    return cache_folder(SAMPLES)


def vlm_dir() -> Path:
    """The default VLM response cache: the `vlm` folder under cache_dir()."""
    return cache_folder(VLM)


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


@dataclass(frozen=True)
class CacheContents:
    folders: list[FolderUsage]  # the project's folders: real folders named in CACHE_FOLDERS
    others: list[Path]  # every other entry under the root (links included): not the project's


def _files(folder: Path) -> list[Path]:
    """The regular files below `folder`; links are neither followed nor counted."""
    out = []
    for parent, _, names in os.walk(folder):
        out += [p for p in (Path(parent) / n for n in names) if p.is_file() and not p.is_symlink()]
    return out


def _usage(folder: Path) -> FolderUsage:
    files = _files(folder)
    return FolderUsage(folder.name, len(files), sum(_size(p) for p in files))


def _is_project_folder(path: Path) -> bool:
    return path.name in CACHE_FOLDERS and not path.is_symlink() and path.is_dir()


def cache_contents(root: Path | None = None) -> CacheContents:
    """What lies directly under the cache (`root`, default cache_dir()): the project's folders
    with their files and bytes, and the other entries."""
    root = cache_dir() if root is None else Path(root)
    entries = sorted(root.iterdir()) if root.is_dir() else []
    return CacheContents([_usage(p) for p in entries if _is_project_folder(p)],
                         [p for p in entries if not _is_project_folder(p)])


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
    return prune_files(_files(Path(folder)), max_bytes)


def prune_files(files: list[Path], max_bytes: int) -> tuple[int, int]:
    """`prune_cache` of these files alone (a folder of the user's: only the cache's own files)."""
    files = sorted(files, key=lambda p: (_mtime(p), str(p)))
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


def clear_cache(root: Path | None = None, only: str | None = None,
                everything: bool = False) -> tuple[list[FolderUsage], list[Path]]:
    """Remove the project's cache folders but those in KEPT_UNLESS_ASKED (all of them with
    `everything`; only the folder `only`, one of CACHE_FOLDERS, when given).

    Returns what was removed, counted before removal (a file that could not be removed is not
    counted), and the entries left alone: every other entry (with `only`: one named `only`
    that is not a project folder, e.g. a link). Links are never followed.
    """
    if only is not None and only not in CACHE_FOLDERS:
        raise ConfigError(f"'{only}' is not one of the project's cache folders", field="--only",
                          allowed=", ".join(CACHE_FOLDERS))
    contents = cache_contents(root)
    root = cache_dir() if root is None else Path(root)
    chosen = [u for u in contents.folders if u.name == only or
              (only is None and (everything or u.name not in KEPT_UNLESS_ASKED))]
    removed = [_remove(root / u.name, u) for u in chosen]
    return removed, [p for p in contents.others if only in (None, p.name)]


def _remove(folder: Path, before: FolderUsage) -> FolderUsage:
    shutil.rmtree(folder, ignore_errors=True)
    after = _usage(folder) if folder.is_dir() else FolderUsage(folder.name, 0, 0)
    return FolderUsage(folder.name, before.files - after.files, before.bytes - after.bytes)


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
