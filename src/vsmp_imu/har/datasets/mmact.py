"""MMAct trimmed inertial clips (Kong et al. 2019), from the published CSV files.

Layout: `acc_phone_clip/`, `acc_watch_clip/`, `gyro_clip/` (and
`orientation_clip/`, not used), each as
`subject{n}/scene{k}/session{m}/{action}.csv`. A CSV has no header; each row
is a timestamp (`YYYYMMDD_HH:MM:SS.fff`), x, y, z. The smartphone (in the
trouser pocket) gives acceleration (100 Hz) and angular velocity (50 Hz), the
smartwatch acceleration (100 Hz). Timestamps are coarse and repeat, so each
stream is placed on its nominal rate starting at its first timestamp, and all
streams of a clip are resampled onto one grid at `fs_hz` over their common
span. Action names are lower-cased file stems (the release mixes cases).
"""

from __future__ import annotations

import re
from datetime import datetime
from pathlib import Path

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError
from vsmp_imu.har.dataset import (
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    imu_channel_names,
)
from vsmp_imu.har.datasets.resample import common_grid
from vsmp_imu.har.windows import natural_key

STREAMS = {  # folder -> (location, kind, nominal rate Hz)
    "acc_phone_clip": ("right_thigh", "acc", 100.0),
    "gyro_clip": ("right_thigh", "gyr", 50.0),
    "acc_watch_clip": ("right_wrist", "acc", 100.0),
}
TIME_FORMATS = ("%Y%m%d_%H:%M:%S.%f", "%Y%m%d_%H:%M:%S")
PATH_PATTERN = re.compile(r"subject(\d+)/scene(\d+)/session(\d+)/([^/]+)\.csv$", re.IGNORECASE)


def parse_start_time(text: str) -> float | None:
    """Seconds of a MMAct timestamp string, None when it is not one."""
    for fmt in TIME_FORMATS:
        try:
            return datetime.strptime(text.strip(), fmt).timestamp()
        except ValueError:
            continue
    try:
        return float(text)
    except ValueError:
        return None


def read_clip(path: Path, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(times s, (N, 3) values) of one MMAct CSV, times on the nominal rate."""
    try:
        frame = pd.read_csv(path, header=None)
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
        raise InputFileError(f"not a MMAct sensor CSV ({exc})", file=path) from exc
    if frame.shape[1] < 4:
        raise InputFileError(
            f"expected 4 columns (time, x, y, z), found {frame.shape[1]}", file=path
        )
    values = frame.iloc[:, 1:4].apply(pd.to_numeric, errors="coerce").to_numpy(np.float64)
    start = parse_start_time(str(frame.iloc[0, 0])) if len(frame) else None
    times = (start or 0.0) + np.arange(len(values)) / rate_hz
    return times, values


class MMAct(HarDataset):
    """MMAct: phone (pocket) accelerometer + gyroscope and watch accelerometer."""

    def __init__(self, data_dir: str | Path, fs_hz: float = 50.0) -> None:
        super().__init__()
        self.data_dir = Path(data_dir)
        self.fs_hz = fs_hz
        phone = SensorLocation(
            name="right_thigh",
            channels=imu_channel_names("right_thigh"),
            axes=None,
            axes_source="unknown",
            gravity_included=True,
            acc_unit="m/s^2",
            gyr_unit="rad/s",
            note="smartphone in the trouser pocket (side not documented); axes not documented",
        )
        watch = SensorLocation(
            name="right_wrist",
            channels=imu_channel_names("right_wrist", gyro=False),
            axes=None,
            axes_source="unknown",
            gravity_included=True,
            acc_unit="m/s^2",
            gyr_unit=None,
            note="smartwatch (wrist side not documented); accelerometer only",
        )
        self._clips, labels = self._scan()
        self.info = DatasetInfo(
            name="mmact",
            fs_hz=fs_hz,
            label_names=labels,
            channel_names=phone.channels + watch.channels,
            locations=(phone, watch),
            description="MMAct trimmed inertial clips: 20 subjects, 4 scenes, 37 actions",
            source="https://mmact19.github.io/2019/",
            pad_short=True,
        )

    def _root(self) -> Path:
        root = self.data_dir
        for sub in ("Sensor_trimmed", "sensors", "trimmed"):
            if (root / sub / "acc_phone_clip").is_dir():
                return root / sub
        return root

    def _scan(self) -> tuple[dict[tuple, dict[str, Path]], tuple[str, ...]]:
        """Clips found: (subject, scene, session, action) -> {stream folder: file}."""
        root = self._root()
        clips: dict[tuple, dict[str, Path]] = {}
        for folder in STREAMS:
            for path in sorted((root / folder).rglob("*.csv")):
                match = PATH_PATTERN.search(path.relative_to(root / folder).as_posix())
                if not match:
                    continue
                subject, scene, session, action = match.groups()
                key = (subject, scene, session, action.strip().lower())
                clips.setdefault(key, {})[folder] = path
        if not clips:
            raise InputFileError(
                "no MMAct clips found (expected acc_phone_clip/subject*/scene*/session*/*.csv)",
                file=root,
            )
        return clips, tuple(sorted({k[3] for k in clips}))

    def _load(self) -> list[Recording]:
        clips, labels = self._clips, self.info.label_names
        recs = []
        for (subject, scene, session, action), files in sorted(
            clips.items(), key=lambda kv: tuple(natural_key(x) for x in kv[0])
        ):
            name = f"subject{subject}/scene{scene}/session{session}/{action}"
            missing = [f for f in STREAMS if f not in files]
            if missing:
                self.skipped.append(f"{name}: missing {', '.join(missing)}")
                continue
            streams = [read_clip(files[f], STREAMS[f][2]) for f in STREAMS]
            try:
                _, data = common_grid(streams, self.fs_hz, name)
            except InputFileError as exc:
                self.skipped.append(f"{name}: {exc.message}")
                continue
            recs.append(
                Recording(
                    name,
                    subject,
                    f"scene{scene}_session{session}",
                    data,
                    np.full(len(data), labels.index(action)),
                )
            )
        return recs
