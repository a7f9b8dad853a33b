"""HAD-AW, the Apple Watch activity dataset (Ashry et al.), from per-recording CSV files.

The authors distribute HAD-AW on request; its exact file layout could not be
checked offline. This loader reads the layout of a CoreMotion export, which
names its units in the column headers:

    HAD-AW/<subject>/<activity>.csv        (or <activity>_<trial>.csv)

with a header row holding accelerometer columns `accelerometerAccelerationX(G)`
.. `Z(G)` (or `acc_x`, `accX`, ...) and gyroscope columns
`gyroRotationX(rad/s)` / `motionRotationRateX(rad/s)` (or `gyr_x`, ...), at
`fs_hz` (default 50 Hz). Units come from the header when present (G, m/s^2,
rad/s, deg/s), else g and rad/s (CoreMotion's units). CoreMotion reports
gravity as -1 g on the axis pointing up (the opposite sign of Android), so
the accelerometer is negated (`acc_sign=-1`) to follow this project's
convention (+9.81 m/s² on an axis pointing up). Any other layout can be read
with the generic YAML format (docs/har.md).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError
from vsmp_imu.har.dataset import (
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    acc_to_si,
    found,
    gyr_to_si,
    imu_channel_names,
    inner_root,
)
from vsmp_imu.har.windows import natural_key

ACC_PATTERN = re.compile(
    r"^(?:accelerometeracceleration|acceleration|acc|accel)[_ ]?([xyz])(?:\s*\((g|m/s\^2|m/s2)\))?$",
    re.IGNORECASE,
)
GYR_PATTERN = re.compile(
    r"^(?:gyrorotation|motionrotationrate|rotationrate|gyro|gyr)[_ ]?([xyz])(?:\s*\((rad/s|deg/s)\))?$",
    re.IGNORECASE,
)
TRIAL_SUFFIX = re.compile(r"_(\d+)$")


def _unit(raw: str | None, default: str) -> str:
    if raw is None:
        return default
    raw = raw.lower()
    return {"g": "g", "m/s^2": "m/s^2", "m/s2": "m/s^2", "rad/s": "rad/s", "deg/s": "deg/s"}[raw]


def find_columns(
    columns: list[str], pattern: re.Pattern, default_unit: str, path: Path
) -> tuple[list[str], str] | None:
    """The x, y, z column names matching `pattern` and their unit, or None."""
    found: dict[str, tuple[str, str]] = {}
    for col in columns:
        m = pattern.match(str(col).strip())
        if m and m.group(1).lower() not in found:
            found[m.group(1).lower()] = (col, _unit(m.group(2), default_unit))
    if not found:
        return None
    if set(found) != {"x", "y", "z"}:
        raise InputFileError(
            f"incomplete axis columns {sorted(found)}", file=path, allowed="x, y and z columns"
        )
    units = {u for _, u in found.values()}
    if len(units) > 1:
        raise InputFileError(f"mixed units {sorted(units)} across axes", file=path)
    return [found[a][0] for a in "xyz"], units.pop()


class HADAW(HarDataset):
    """HAD-AW smartwatch recordings (accelerometer + gyroscope, one wrist)."""

    def __init__(
        self,
        data_dir: str | Path,
        fs_hz: float = 50.0,
        acc_sign: float = -1.0,
        wrist: str = "left_wrist",
    ) -> None:
        super().__init__()
        self.data_dir = Path(data_dir)
        self.fs_hz = fs_hz
        self.acc_sign = acc_sign
        self.wrist = wrist
        self._files = self._scan()
        labels = tuple(sorted({a for _, a, _ in self._files}, key=natural_key))
        self.info = DatasetInfo(
            name="had-aw",
            fs_hz=fs_hz,
            label_names=labels,
            channel_names=imu_channel_names(None),
            locations=(
                SensorLocation(
                    name=wrist,
                    channels=imu_channel_names(None),
                    axes=None,
                    axes_source="unknown",
                    gravity_included=True,
                    acc_unit="g",
                    gyr_unit="rad/s",
                    note="Apple Watch (CoreMotion); accelerometer negated to read +g on the axis "
                    "pointing up; wrist and axis directions not verified",
                ),
            ),
            description="HAD-AW: Apple Watch daily and sport activities",
            source="Ashry et al., dataset available from the authors",
        )

    def _scan(self) -> list[tuple[str, str, Path]]:
        root = inner_root(self.data_dir, "HAD-AW")
        files = []
        for subject_dir in (
            sorted((p for p in root.iterdir() if p.is_dir()), key=lambda p: natural_key(p.name))
            if root.is_dir()
            else []
        ):
            for path in sorted(subject_dir.glob("*.csv")):
                activity = TRIAL_SUFFIX.sub("", path.stem).strip().lower().replace(" ", "_")
                files.append((subject_dir.name, activity, path))
        return found(files, "no HAD-AW files found (expected <subject>/<activity>.csv)", root)

    def _load(self) -> list[Recording]:
        recs = []
        labels = self.info.label_names
        for subject, activity, path in self._files:
            try:
                frame = pd.read_csv(path)
            except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
                raise InputFileError(f"not a CSV table ({exc})", file=path) from exc
            acc = find_columns(list(frame.columns), ACC_PATTERN, "g", path)
            gyr = find_columns(list(frame.columns), GYR_PATTERN, "rad/s", path)
            if acc is None or gyr is None:
                raise InputFileError(
                    "accelerometer and gyroscope columns not found",
                    file=path,
                    allowed="accelerometerAccelerationX(G).., gyroRotationX(rad/s).. "
                    "or acc_x.., gyr_x..",
                )
            a = frame[acc[0]].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
            g = frame[gyr[0]].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
            data = np.concatenate(
                [self.acc_sign * acc_to_si(a, acc[1]), gyr_to_si(g, gyr[1])], axis=1
            )
            ok = np.isfinite(data).all(axis=1)
            if not ok.all():
                self.skipped.append(
                    f"{path.name}: dropped {int((~ok).sum())} rows with missing values"
                )
                data = data[ok]
            if len(data) == 0:
                continue
            recs.append(
                Recording(
                    f"{subject}/{path.stem}",
                    subject,
                    path.stem,
                    data,
                    np.full(len(data), labels.index(activity)),
                )
            )
        return recs
