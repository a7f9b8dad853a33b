"""`ImuRecording`: an IMU array with its channel names, rate and provenance.

CSV format (written atomically):

    # vsmp-imu imu recording
    # fs_hz: 50
    # meta: {"location": "waist", ...}        (one line of JSON, sorted keys)
    time_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z
    0.200000,0.0123,9.81,...

The comment lines are optional when reading (a plain CSV with a `time_s`
column and channel columns works; fs_hz is then taken from the time column).
"""

from __future__ import annotations

import csv
import io
import json
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError, ValidationError, some_of
from vsmp_imu.imu.channels import TIME_COLUMN, split_channel
from vsmp_imu.io import read_text, write_text

HEADER = "# vsmp-imu imu recording"
VALUE_FORMAT = "%.10g"
TIME_FORMAT = "%.6f"


@dataclass
class ImuRecording:
    """data (T, C) in SI units (m/s^2, rad/s); channel names travel with it."""

    data: np.ndarray
    channel_names: tuple[str, ...]
    fs_hz: float
    meta: dict[str, Any] = field(default_factory=dict)
    start_s: float = 0.0

    def __post_init__(self) -> None:
        self.data = np.asarray(self.data, dtype=np.float64)
        self.channel_names = tuple(str(c) for c in self.channel_names)
        self.fs_hz = float(self.fs_hz)
        self.start_s = float(self.start_s)
        if self.data.ndim != 2:
            raise ValidationError(f"data must be (T, C), got shape {self.data.shape}", field="data")
        if len(self.channel_names) != self.data.shape[1]:
            raise ValidationError(f"{self.data.shape[1]} columns but {len(self.channel_names)} channel names",
                                  field="channel_names")
        if len(set(self.channel_names)) != len(self.channel_names):
            raise ValidationError("channel names must be unique", field="channel_names")
        if not (np.isfinite(self.fs_hz) and self.fs_hz > 0):
            raise ValidationError(f"fs_hz must be positive, got {self.fs_hz}", field="fs_hz")

    # -- views ---------------------------------------------------------------
    @property
    def n_samples(self) -> int:
        return int(self.data.shape[0])

    @property
    def duration_s(self) -> float:
        return self.n_samples / self.fs_hz

    @property
    def times(self) -> np.ndarray:
        return self.start_s + np.arange(self.n_samples) / self.fs_hz

    @property
    def locations(self) -> tuple[str, ...]:
        """Location prefixes in channel order ('' for unprefixed channels)."""
        seen: dict[str, None] = {}
        for name in self.channel_names:
            seen.setdefault(split_channel(name)[0], None)
        return tuple(seen)

    def channels(self, names: list[str] | tuple[str, ...]) -> np.ndarray:
        """Columns by name, (T, len(names))."""
        missing = [n for n in names if n not in self.channel_names]
        if missing:
            raise ValidationError(f"no channel(s) {', '.join(missing)}", field="channels",
                                  allowed=", ".join(self.channel_names))
        return self.data[:, [self.channel_names.index(n) for n in names]]

    def at_location(self, location: str) -> ImuRecording:
        """The channels of one location, without the prefix."""
        idx = [i for i, n in enumerate(self.channel_names) if split_channel(n)[0] == location]
        if not idx:
            raise ValidationError(f"no channels for location '{location}'", field="location",
                                  allowed=", ".join(self.locations))
        names = tuple(split_channel(self.channel_names[i])[1] for i in idx)
        return ImuRecording(self.data[:, idx], names, self.fs_hz, dict(self.meta), self.start_s)

    def to_dataframe(self) -> pd.DataFrame:
        """Channels as columns, indexed by `time_s`."""
        index = pd.Index(self.times, name=TIME_COLUMN)
        return pd.DataFrame(self.data, columns=list(self.channel_names), index=index)

    # -- files -----------------------------------------------------------------
    def to_csv_text(self) -> str:
        buf = io.StringIO()
        buf.write(f"{HEADER}\n# fs_hz: {self.fs_hz:.10g}\n")
        buf.write("# meta: " + json.dumps(self.meta, sort_keys=True, default=str) + "\n")
        table = np.column_stack([self.times, self.data])
        np.savetxt(buf, table, fmt=[TIME_FORMAT] + [VALUE_FORMAT] * self.data.shape[1], delimiter=",",
                   header=",".join((TIME_COLUMN,) + self.channel_names), comments="")
        return buf.getvalue()

    def save_csv(self, path: str | Path) -> Path:
        """Write the CSV atomically."""
        return write_text(path, self.to_csv_text())

    @classmethod
    def read_csv(cls, path: str | Path) -> ImuRecording:
        return read_imu_csv(path)


def _parse_comments(lines: list[str], path: Path) -> tuple[float | None, dict[str, Any]]:
    fs_hz, meta = None, {}
    for line in lines:
        body = line[1:].strip()
        key, _, value = body.partition(":")
        try:
            if key.strip() == "fs_hz":
                fs_hz = float(value)
            elif key.strip() == "meta":
                meta = json.loads(value)
        except ValueError as exc:
            raise InputFileError(f"bad header line '{line[:60]}' ({exc})", file=path) from exc
    return fs_hz, meta


def _check_unique_columns(header: str, path: Path) -> None:
    """A name twice in the header: pandas reads the second as 'acc_x.1', so either column could
    be taken for the channel."""
    counts = Counter(next(csv.reader([header]), []))
    repeated = [f"'{name}'" for name, n in counts.items() if n > 1]
    if repeated:
        raise InputFileError(f"column(s) named more than once in the header: {some_of(repeated)}", file=path,
                             allowed="one column per channel name")


def read_imu_csv(path: str | Path) -> ImuRecording:
    """Read a recording CSV (see the module docstring for the format)."""
    path = Path(path)
    text = read_text(path)
    lines = text.splitlines()
    n_comments = 0
    while n_comments < len(lines) and lines[n_comments].startswith("#"):
        n_comments += 1
    fs_hz, meta = _parse_comments(lines[:n_comments], path)
    try:
        frame = pd.read_csv(io.StringIO(text), skiprows=n_comments)
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputFileError(f"not a readable CSV ({exc})", file=path) from exc
    _check_unique_columns(lines[n_comments], path)
    if TIME_COLUMN not in frame.columns:
        raise InputFileError(f"no '{TIME_COLUMN}' column", file=path,
                             allowed=f"a header '{TIME_COLUMN},<channels...>'")
    channels = [c for c in frame.columns if c != TIME_COLUMN]
    if not channels or len(frame) < 1:
        raise InputFileError("no channels or no rows", file=path)
    try:
        values = frame[channels].to_numpy(dtype=np.float64)
        times = frame[TIME_COLUMN].to_numpy(dtype=np.float64)
    except ValueError as exc:
        raise InputFileError(f"non-numeric values ({exc})", file=path) from exc
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1) | ~np.isfinite(times))
    if len(bad):
        raise InputFileError(f"NaN or inf values in {len(bad)} row(s), the first at data row {bad[0] + 1}",
                             file=path)
    if fs_hz is None:
        steps = np.diff(times)
        if len(steps) == 0 or not np.all(steps > 0):
            raise InputFileError("cannot infer fs_hz: time_s must increase (or give '# fs_hz:')",
                                 file=path)
        fs_hz = 1.0 / float(np.median(steps))
    try:
        return ImuRecording(values, tuple(channels), fs_hz, meta, start_s=float(times[0]))
    except ValidationError as exc:
        raise InputFileError(exc.message, file=path) from exc
