"""A small UTD-MHAD folder in the published file format (`Inertial/a{a}_s{s}_t{t}_inertial.mat`,
variable `d_iner`: acceleration in g, angular velocity in deg/s), for the ablation,
granularity and realism smoke tests.

The recordings are virtual: the procedural backend performs each action (a different body
and style per subject and trial) and a virtual IMU at the action's UTD-MHAD location
(right wrist for a1-a21, right thigh for a22-a27) records it with noise, rotated into a
fixed device frame. No real UTD-MHAD data ships with the project.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.io import savemat
from scipy.spatial.transform import Rotation

from vsmp_imu.har.datasets.utd_mhad import UTD_MHAD_ACTIONS
from vsmp_imu.imu import ImuSimulator
from vsmp_imu.motion.backends import get_backend
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G

ACTIONS = ("right_hand_wave", "two_arm_curl", "jogging_in_place", "sit_to_stand")
DEVICE = Rotation.from_euler("xyz", [90, 0, 30], degrees=True).as_matrix()  # segment -> device axes


def write_utd_mhad(root: Path, actions=ACTIONS, subjects=(1, 2, 3), trials=(1, 2)) -> Path:
    """Write the folder and return it (files already there are kept)."""
    folder = Path(root) / "Inertial"
    folder.mkdir(parents=True, exist_ok=True)
    library = ActivityLibrary.load()
    backend = get_backend("procedural", library=library)
    for name in actions:
        a = UTD_MHAD_ACTIONS.index(name) + 1
        location = "right_wrist" if a <= 21 else "right_thigh"
        for s in subjects:
            for t in trials:
                path = folder / f"a{a}_s{s}_t{t}_inertial.mat"
                if path.exists():
                    continue
                seed = 100 * s + t
                motion = backend.generate(library.get(name).smp, seed)
                data = ImuSimulator(50.0, seed=seed).simulate(motion, location).data
                acc, gyr = data[:, :3] @ DEVICE.T / G, np.degrees(data[:, 3:] @ DEVICE.T)
                savemat(path, {"d_iner": np.column_stack([acc, gyr])})
    return Path(root)
