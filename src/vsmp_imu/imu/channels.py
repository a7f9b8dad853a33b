"""Channel names and physical constants shared by the imu room."""

from __future__ import annotations

import numpy as np

from vsmp_imu.units import STANDARD_GRAVITY_M_S2

ACC_CHANNELS: tuple[str, ...] = ("acc_x", "acc_y", "acc_z")
GYR_CHANNELS: tuple[str, ...] = ("gyr_x", "gyr_y", "gyr_z")
CHANNELS: tuple[str, ...] = ACC_CHANNELS + GYR_CHANNELS
TIME_COLUMN = "time_s"

# Gravity in the Y-up world frame (m/s^2). A static upright sensor measures the
# specific force a - g = +g_n along its up axis.
GRAVITY_WORLD = np.array([0.0, -STANDARD_GRAVITY_M_S2, 0.0])


def prefixed(location: str, channels: tuple[str, ...] = CHANNELS) -> tuple[str, ...]:
    """Channel names of one sensor among several: `right_wrist_acc_x`, ..."""
    return tuple(f"{location}_{c}" for c in channels)


def split_channel(name: str) -> tuple[str, str]:
    """('right_wrist', 'acc_x') from 'right_wrist_acc_x'; ('', 'acc_x') from 'acc_x'."""
    for base in CHANNELS:
        if name == base:
            return "", base
        if name.endswith("_" + base):
            return name[: -len(base) - 1], base
    return "", name
