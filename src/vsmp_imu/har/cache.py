"""A small on-disk cache for parsed datasets, keyed by the source file's hash."""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np

from vsmp_imu.io import atomic_path, file_sha256

__all__ = ["cache_dir", "file_sha256", "load_npz", "save_npz"]


def cache_dir() -> Path:
    """`$VSMP_IMU_CACHE`, else `~/.cache/vsmp-imu`."""
    root = os.environ.get("VSMP_IMU_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "vsmp-imu"


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
