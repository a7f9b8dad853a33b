"""The imu room: virtual accelerometer and gyroscope readings from a Motion.

`ImuSimulator(fs_hz, noise=, seed=).simulate(motion, "right_wrist")` gives an
`ImuRecording`. Calibrations use the two steps directly:
`simulate_kinematics` once, then `sensor_readings` for many candidates.
"""

from vsmp_imu.imu.channels import ACC_CHANNELS, CHANNELS, GYR_CHANNELS, prefixed
from vsmp_imu.imu.kinematics import SegmentKinematics, simulate_kinematics
from vsmp_imu.imu.placement import ALIASES, PLACEMENTS, Placement, get_placement, location_names
from vsmp_imu.imu.readings import reading_features, reading_weights, sensor_readings
from vsmp_imu.imu.recording import ImuRecording, read_imu_csv
from vsmp_imu.imu.sensor import ImuNoise, VirtualSensor, draw_noise
from vsmp_imu.imu.simulator import ImuSimulator, simulate_many

__all__ = [
    "ACC_CHANNELS", "ALIASES", "CHANNELS", "GYR_CHANNELS", "ImuNoise", "ImuRecording",
    "ImuSimulator", "PLACEMENTS", "Placement", "SegmentKinematics", "VirtualSensor", "draw_noise",
    "get_placement", "location_names", "prefixed", "read_imu_csv", "reading_features", "reading_weights", "sensor_readings",
    "simulate_kinematics", "simulate_many",
]
