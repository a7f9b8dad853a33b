"""UTD-MHAD inertial data (Chen et al. 2015), from its published `.mat` files.

Layout: a folder (e.g. `Inertial/`) of `a{action}_s{subject}_t{trial}_inertial.mat`
files, each holding `d_iner`, a (T, 6) array: 3-axis acceleration in g and
3-axis angular velocity in deg/s from one wearable inertial sensor (InvenSense
50 Hz). The sensor is worn on the right wrist for actions 1-21 and
on the right thigh for actions 22-27. 27 actions, 8 subjects, 4 trials.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

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
from vsmp_imu.har.datasets.matfile import MatFileError, load_mat

# Canonical activity-library names in dataset order a1..a27.
UTD_MHAD_ACTIONS = (
    "right_arm_swipe_left",
    "right_arm_swipe_right",
    "right_hand_wave",
    "two_hand_front_clap",
    "right_arm_throw",
    "cross_arms_in_chest",
    "basketball_shoot",
    "right_hand_draw_x",
    "right_hand_draw_circle_clockwise",
    "right_hand_draw_circle_counter_clockwise",
    "draw_triangle",
    "bowling",
    "front_boxing",
    "baseball_swing",
    "tennis_forehand_swing",
    "two_arm_curl",
    "tennis_serve",
    "two_hand_push",
    "right_hand_knock",
    "right_hand_catch",
    "pick_up_and_throw",
    "jogging_in_place",
    "walking_in_place",
    "sit_to_stand",
    "stand_to_sit",
    "forward_lunge",
    "squat_arms_extended",
)
FS_HZ = 50.0
FILE_PATTERN = re.compile(r"^a(\d+)_s(\d+)_t(\d+)_inertial\.mat$")


def _location(name: str) -> SensorLocation:
    return SensorLocation(
        name=name,
        channels=imu_channel_names(None),
        axes=None,
        axes_source="unknown",
        gravity_included=True,
        acc_unit="g",
        gyr_unit="deg/s",
        note="one wearable inertial sensor; worn on the right wrist for actions 1-21 and the right "
        "thigh for actions 22-27; axis directions not documented",
    )


class UTDMHAD(HarDataset):
    """UTD-MHAD inertial clips: one recording per clip, windows padded when a clip is
    shorter than one window."""

    def __init__(self, data_dir: str | Path) -> None:
        super().__init__()
        self.data_dir = Path(data_dir)
        self._paths = self._files()  # fail early when the folder holds no data
        self.info = DatasetInfo(
            name="utd-mhad",
            fs_hz=FS_HZ,
            label_names=UTD_MHAD_ACTIONS,
            channel_names=imu_channel_names(None),
            locations=(_location("right_wrist"), _location("right_thigh")),
            description="UTD-MHAD inertial: 8 subjects, 27 actions, 4 trials, 50 Hz",
            source="https://personal.utdallas.edu/~kehtar/UTD-MHAD.html",
            pad_short=True,
            location_by_label={
                a: ("right_wrist" if i < 21 else "right_thigh")
                for i, a in enumerate(UTD_MHAD_ACTIONS)
            },
        )

    def _files(self) -> list[Path]:
        root = inner_root(self.data_dir, "Inertial")
        files = sorted(p for p in root.glob("*_inertial.mat") if FILE_PATTERN.match(p.name))
        return found(files, "no UTD-MHAD files found (expected a*_s*_t*_inertial.mat)", root)

    def _load(self) -> list[Recording]:
        recs = []
        for path in self._paths:
            action, subject, trial = (int(g) for g in FILE_PATTERN.match(path.name).groups())
            if not 1 <= action <= len(UTD_MHAD_ACTIONS):
                self.skipped.append(f"{path.name}: action {action} out of range 1..27")
                continue
            try:
                mat = load_mat(path)
            except MatFileError as exc:  # refused before scipy's reader could crash on it
                self.skipped.append(f"{path.name}: unreadable ({exc})")
                continue
            except Exception as exc:  # scipy raises several types for broken files
                self.skipped.append(f"{path.name}: unreadable ({type(exc).__name__})")
                continue
            if "d_iner" not in mat or np.ndim(mat["d_iner"]) != 2 or mat["d_iner"].shape[1] != 6:
                raise InputFileError(
                    "expected variable d_iner of shape (T, 6)", file=path, field="d_iner"
                )
            raw = np.asarray(mat["d_iner"], dtype=np.float64)
            data = np.concatenate(
                [acc_to_si(raw[:, :3], "g"), gyr_to_si(raw[:, 3:], "deg/s")], axis=1
            )
            if not np.isfinite(data).all() or len(data) == 0:
                self.skipped.append(f"{path.name}: empty or non-finite values")
                continue
            recs.append(
                Recording(
                    f"a{action}_s{subject}_t{trial}",
                    str(subject),
                    str(trial),
                    data,
                    np.full(len(data), action - 1),
                )
            )
        return recs
