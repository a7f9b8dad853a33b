"""PAMAP2 Physical Activity Monitoring (Reiss & Stricker 2012), from its published
`.dat` files.

Layout (the UCI archive `PAMAP2_Dataset/`): `Protocol/subject101.dat` ..
`subject109.dat` (and `Optional/` with extra sessions of some subjects). Each
line: timestamp (s), activityID, heart rate (bpm, mostly NaN: ~9 Hz), then
3 IMUs (hand, chest, ankle) of 17 columns each: temperature, 3D acceleration
±16 g (m/s²), 3D acceleration ±6 g (m/s², saturates), 3D gyroscope (rad/s),
3D magnetometer (µT), 4 orientation values (invalid). 100 Hz. Activity 0
marks transient periods (unlabelled). Dropped IMU packets appear as NaN and
are linearly interpolated (gaps longer than `max_gap_s` split the recording).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError
from vsmp_imu.har.dataset import (
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    found,
    imu_channel_names,
    inner_root,
)

PAMAP2_ACTIVITIES = {
    1: "lying",
    2: "sitting",
    3: "standing",
    4: "walking",
    5: "running",
    6: "cycling",
    7: "nordic_walking",
    9: "watching_tv",
    10: "computer_work",
    11: "car_driving",
    12: "walking_upstairs",
    13: "walking_downstairs",
    16: "vacuum_cleaning",
    17: "ironing",
    18: "folding_laundry",
    19: "house_cleaning",
    20: "playing_soccer",
    24: "rope_jumping",
}
N_COLUMNS = 54
FS_HZ = 100.0
# first column (0-based) of each IMU block; within a block: +1..+3 acc16, +7..+9 gyro
IMU_BLOCKS = {"hand": 3, "chest": 20, "ankle": 37}
PLACEMENT = {"hand": "right_wrist", "chest": "chest", "ankle": "right_ankle"}
WHERE = {"hand": "dominant wrist", "chest": "chest", "ankle": "dominant ankle"}


def _location(part: str) -> SensorLocation:
    return SensorLocation(
        name=PLACEMENT[part],
        channels=imu_channel_names(PLACEMENT[part]),
        axes=None,
        axes_source="unknown",
        gravity_included=True,
        acc_unit="m/s^2",
        gyr_unit="rad/s",
        note=f"Colibri IMU, {WHERE[part]}; axis directions not documented; "
        "subject 108 is left-handed",
    )


def read_dat(path: Path) -> pd.DataFrame:
    """One PAMAP2 `.dat` file as a frame of 54 float columns."""
    try:
        frame = pd.read_csv(
            path, sep=r"\s+", header=None, dtype=float, engine="c", na_values=["NaN", "nan"]
        )
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputFileError(f"not a PAMAP2 .dat file ({exc})", file=path) from exc
    if frame.shape[1] != N_COLUMNS:
        raise InputFileError(
            f"expected {N_COLUMNS} columns, found {frame.shape[1]}",
            file=path,
            allowed="timestamp, activityID, heart rate, 3 x 17 IMU columns",
        )
    return frame


class PAMAP2(HarDataset):
    """PAMAP2 with the three IMUs (acc ±16 g + gyro), 18 activities, 9 subjects.

    `parts` picks IMUs (hand, chest, ankle); `include_optional` adds the
    `Optional/` sessions; `include_heart_rate` appends a `heart_rate` channel
    (bpm, forward-filled).
    """

    def __init__(
        self,
        data_dir: str | Path,
        parts: tuple[str, ...] = ("hand", "chest", "ankle"),
        include_optional: bool = False,
        include_heart_rate: bool = False,
        max_gap_s: float = 1.0,
    ) -> None:
        super().__init__()
        self.data_dir = Path(data_dir)
        self.parts = tuple(parts)
        self.include_optional = include_optional
        self.include_heart_rate = include_heart_rate
        self.max_gap_s = max_gap_s
        self._paths = self._files()  # fail early when the folder holds no data
        channels = [c for p in self.parts for c in imu_channel_names(PLACEMENT[p])]
        if include_heart_rate:
            channels.append("heart_rate")
        self.info = DatasetInfo(
            name="pamap2",
            fs_hz=FS_HZ,
            label_names=tuple(PAMAP2_ACTIVITIES.values()),
            channel_names=tuple(channels),
            locations=tuple(_location(p) for p in self.parts),
            description="PAMAP2: 9 subjects, IMUs on the dominant wrist, chest and dominant "
            "ankle, 100 Hz",
            source="https://archive.ics.uci.edu/dataset/231/pamap2+physical+activity+monitoring",
        )

    def _files(self) -> list[tuple[Path, str]]:
        root = inner_root(self.data_dir, "PAMAP2_Dataset")
        folders = [("Protocol", "protocol")] + (
            [("Optional", "optional")] if self.include_optional else []
        )
        files = [
            (f, kind)
            for folder, kind in folders
            for f in sorted((root / folder).glob("subject*.dat"))
        ]
        return found(files, "no PAMAP2 files found (expected Protocol/subject1NN.dat)", root)

    def _load(self) -> list[Recording]:
        recs = []
        ids = list(PAMAP2_ACTIVITIES)
        for path, kind in self._paths:
            frame = read_dat(path).to_numpy()
            subject = path.stem.replace("subject", "")
            cols = []
            for p in self.parts:
                b = IMU_BLOCKS[p]
                cols += list(range(b + 1, b + 4)) + list(range(b + 7, b + 10))
            data = frame[:, cols]
            if self.include_heart_rate:
                hr = pd.Series(frame[:, 2]).ffill().bfill().to_numpy()
                data = np.column_stack([data, hr])
            activity = frame[:, 1].astype(int)
            labels = np.array([ids.index(a) if a in PAMAP2_ACTIVITIES else -1 for a in activity])
            for i, (seg, lab) in enumerate(_split_gaps(data, labels, int(self.max_gap_s * FS_HZ))):
                recs.append(Recording(f"{subject}_{kind}_{i}", subject, kind, seg, lab))
        return recs


def _split_gaps(data: np.ndarray, labels: np.ndarray, max_gap: int):
    """Interpolate NaN runs up to `max_gap` samples; longer runs split the recording."""
    bad = ~np.isfinite(data).all(axis=1)
    run_id = np.cumsum(np.concatenate([[True], bad[1:] != bad[:-1]]))
    run_len = np.bincount(run_id)
    run_bad = np.bincount(run_id, weights=bad) > 0
    long_runs = np.flatnonzero(run_bad & (run_len > max_gap))
    good = ~np.isin(run_id, long_runs)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], good.astype(np.int8), [0]])))
    for start, end in zip(edges[::2], edges[1::2], strict=True):
        seg = pd.DataFrame(data[start:end]).interpolate(limit_direction="both").to_numpy()
        if np.isfinite(seg).all():
            yield seg, labels[start:end]
