"""Put several sensor streams with their own timestamps on one common time grid."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vsmp_imu.errors import InputFileError

# the common grid may hold at most this many samples per reading of the longest stream
MAX_UPSAMPLING = 100


def clean_times(t: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sort by time and drop repeated timestamps (first kept) and non-finite rows."""
    t = np.asarray(t, dtype=np.float64)
    values = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(t) & np.isfinite(values).all(axis=1)
    t, values = t[ok], values[ok]
    order = np.argsort(t, kind="stable")
    t, values = t[order], values[order]
    keep = np.concatenate([[True], np.diff(t) > 0]) if len(t) else np.zeros(0, bool)
    return t[keep], values[keep]


def common_grid(
    streams: Sequence[tuple[np.ndarray, np.ndarray]], fs_hz: float, source: str = ""
) -> tuple[np.ndarray, np.ndarray]:
    """Linear interpolation of every stream onto `t0 + k / fs_hz` over the time span all
    streams cover. Returns the grid (s) and the stacked `(T, sum of columns)` values."""
    cleaned = [clean_times(t, v) for t, v in streams]
    if any(len(t) < 2 for t, _ in cleaned):
        raise InputFileError("a sensor stream has fewer than 2 valid samples", file=source or None)
    start = max(t[0] for t, _ in cleaned)
    end = min(t[-1] for t, _ in cleaned)
    if end <= start:
        raise InputFileError("the sensor streams do not overlap in time", file=source or None)
    n_grid = int(np.floor((end - start) * fs_hz)) + 1
    readings = max(len(t) for t, _ in cleaned)
    if n_grid > MAX_UPSAMPLING * readings:
        raise InputFileError(
            f"the timestamps span {end - start:.6g} s, {n_grid} samples at {fs_hz:g} Hz from at most "
            f"{readings} readings per stream (a damaged or mis-scaled time column?)",
            file=source or None,
        )
    grid = start + np.arange(n_grid) / fs_hz
    columns = [np.interp(grid, t, v[:, j]) for t, v in cleaned for j in range(v.shape[1])]
    return grid, np.column_stack(columns)
