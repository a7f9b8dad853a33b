"""MM-Fit (Strömbäck et al. 2020), from its published per-workout files.

Layout: `mm-fit/w00/ .. w20/`, each with `wNN_labels.csv` (no header: start
frame, end frame, repetitions, activity) and one `.npy` per device and
sensor, `wNN_{device}_{acc|gyr}.npy`, shape (N, 5): camera frame, timestamp
(ms), x, y, z. Devices: `sw_l`/`sw_r` smartwatches on the left/right wrist
(100 Hz), `sp_l`/`sp_r` smartphones in the left/right trouser pocket (210 or
500 Hz), `eb_l` earbud in the left ear (90 Hz). Every stream is resampled
onto one grid at `fs_hz` over the time span all requested devices cover;
each grid sample takes the label of the exercise set whose frame range holds
its (interpolated) camera frame. Workouts are mapped to the 10 participants
with the mapping published in the MM-Fit starter code (EDA notebook).
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.dataset import (
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    found,
    imu_channel_names,
    inner_root,
)
from vsmp_imu.har.datasets.resample import common_grid

MMFIT_ACTIVITIES = (
    "squats",
    "lunges",
    "bicep_curls",
    "situps",
    "pushups",
    "tricep_extensions",
    "dumbbell_rows",
    "jumping_jacks",
    "dumbbell_shoulder_press",
    "lateral_shoulder_raises",
)
# Workout -> participant, from the MM-Fit starter code (KDMStromback/mm-fit, EDA.ipynb).
WORKOUT_SUBJECT = {
    "w00": 2,
    "w01": 0,
    "w02": 1,
    "w03": 0,
    "w04": 1,
    "w05": 2,
    "w06": 0,
    "w07": 1,
    "w08": 0,
    "w09": 1,
    "w10": 0,
    "w11": 1,
    "w12": 3,
    "w13": 4,
    "w14": 0,
    "w15": 1,
    "w16": 5,
    "w17": 6,
    "w18": 7,
    "w19": 8,
    "w20": 9,
}
DEVICE_PLACEMENT = {
    "sw_l": "left_wrist",
    "sw_r": "right_wrist",
    "sp_l": "left_thigh",
    "sp_r": "right_thigh",
    "eb_l": "head",
}
DEVICE_NOTE = {
    "sw_l": "Mobvoi TicWatch Pro on the left wrist, 100 Hz",
    "sw_r": "Mobvoi TicWatch Pro on the right wrist, 100 Hz",
    "sp_l": "smartphone in the left trouser pocket (Samsung S7 210 Hz or Huawei P20 500 Hz)",
    "sp_r": "smartphone in the right trouser pocket (Samsung S7 210 Hz or Huawei P20 500 Hz)",
    "eb_l": "eSense earbud in the left ear, 90 Hz",
}
DEFAULT_DEVICES = ("sw_l", "sw_r", "sp_r", "eb_l")


def read_labels(path: Path) -> list[tuple[int, int, int, str]]:
    """(start frame, end frame, repetitions, activity) rows of a `wNN_labels.csv`."""
    rows = []
    try:
        text = Path(path).read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputFileError(f"not UTF-8 text (byte {exc.start})", file=path) from None
    with io.StringIO(text, newline="") as fh:
        for i, row in enumerate(csv.reader(fh), start=1):
            if not row:
                continue
            try:
                rows.append((int(row[0]), int(row[1]), int(row[2]), row[3].strip()))
            except (ValueError, IndexError):
                raise InputFileError(
                    f"line {i}: expected start_frame,end_frame,reps,activity", file=path
                ) from None
    return rows


def read_stream(path: Path) -> np.ndarray:
    """A `(N, 5)` MM-Fit sensor array (frame, timestamp ms, x, y, z)."""
    try:
        arr = np.load(path, allow_pickle=False)
    except Exception as exc:  # a damaged header raises ValueError, SyntaxError or tokenize.TokenError
        raise InputFileError(f"not a numpy array file ({type(exc).__name__}: {str(exc)[:200]})",
                             file=path) from exc
    if arr.ndim != 2 or arr.shape[1] != 5:
        raise InputFileError(
            f"expected shape (N, 5), found {arr.shape}",
            file=path,
            allowed="frame, timestamp, x, y, z",
        )
    return arr.astype(np.float64)


class MMFit(HarDataset):
    """MM-Fit exercises from the wearables in `devices` (accelerometer + gyroscope)."""

    def __init__(
        self, data_dir: str | Path, devices: tuple[str, ...] = DEFAULT_DEVICES, fs_hz: float = 100.0
    ) -> None:
        super().__init__()
        bad = [d for d in devices if d not in DEVICE_PLACEMENT]
        if bad:
            raise ConfigError(
                f"unknown MM-Fit device(s) {', '.join(bad)}",
                field="devices",
                allowed=", ".join(DEVICE_PLACEMENT),
            )
        self.data_dir = Path(data_dir)
        self.devices = tuple(devices)
        self.fs_hz = fs_hz
        self._folders = self._workouts()  # fail early when the folder holds no data
        locations = tuple(
            SensorLocation(
                name=DEVICE_PLACEMENT[d],
                channels=imu_channel_names(DEVICE_PLACEMENT[d]),
                axes=None,
                axes_source="unknown",
                gravity_included=True,
                acc_unit="m/s^2",
                gyr_unit="rad/s",
                note=DEVICE_NOTE[d] + "; Android sensor units assumed (m/s², rad/s), "
                "axis directions not documented",
            )
            for d in self.devices
        )
        self.info = DatasetInfo(
            name="mmfit",
            fs_hz=fs_hz,
            label_names=MMFIT_ACTIVITIES,
            channel_names=tuple(c for loc in locations for c in loc.channels),
            locations=locations,
            description="MM-Fit: 21 workouts of 10 participants, 10 exercises",
            source="https://mmfit.github.io/",
        )

    def _workouts(self) -> list[Path]:
        root = inner_root(self.data_dir, "mm-fit")
        folders = sorted(p for p in root.glob("w[0-9][0-9]") if p.is_dir())
        return found(folders, "no MM-Fit workout folders found (expected w00/ .. w20/)", root)

    def _load(self) -> list[Recording]:
        recs = []
        for folder in self._folders:
            wid = folder.name
            paths = {
                (d, s): folder / f"{wid}_{d}_{s}.npy" for d in self.devices for s in ("acc", "gyr")
            }
            missing = [p.name for p in paths.values() if not p.exists()]
            label_path = folder / f"{wid}_labels.csv"
            if not label_path.exists():
                missing.append(label_path.name)
            if missing:
                self.skipped.append(f"{wid}: missing {', '.join(missing)}")
                continue
            streams = [read_stream(p) for p in paths.values()]
            frames_stream = streams[0]
            grid, values = common_grid(
                [(s[:, 1] / 1000.0, s[:, 2:]) for s in streams]
                + [(frames_stream[:, 1] / 1000.0, frames_stream[:, :1])],
                self.fs_hz,
                str(folder),
            )
            data, frame = values[:, :-1], values[:, -1]
            labels = np.full(len(grid), -1, np.int64)
            for start, end, _reps, activity in read_labels(label_path):
                if activity in MMFIT_ACTIVITIES:
                    labels[(frame >= start) & (frame <= end)] = MMFIT_ACTIVITIES.index(activity)
            subject = str(WORKOUT_SUBJECT.get(wid, wid))
            recs.append(Recording(wid, subject, wid, data, labels))
        return recs
