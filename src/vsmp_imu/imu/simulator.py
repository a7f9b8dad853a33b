"""`ImuSimulator`: virtual accelerometer and gyroscope readings from a Motion.

The simulation is IMUSim's: spline the motion, differentiate, rotate into the
sensor frame (paper, "IMU Synthesis"):

    acc = R_{s<-j} R_j^T (a - g) + b_a + n_a,     g = (0, -g_n, 0), g_n = 9.80665 m/s^2
    gyr = R_{s<-j} R_j^T omega   + b_w + n_w

It runs in two steps, so a calibration can repeat only the cheap second one:
`simulate_kinematics` (splines evaluated once) and `sensor_readings`
(mounting, bias, noise for any number of candidates).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import KW_ONLY, dataclass
from typing import Any

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.channels import CHANNELS, prefixed
from vsmp_imu.imu.kinematics import (
    DEFAULT_TRIM_S,
    PLACEMENT_CUTOFF,
    SegmentKinematics,
    SmoothingHz,
    check_settings,
    simulate_kinematics,
)
from vsmp_imu.imu.placement import Placement
from vsmp_imu.imu.readings import sensor_readings
from vsmp_imu.imu.recording import ImuRecording
from vsmp_imu.imu.sensor import VirtualSensor, as_sensor, draw_noise
from vsmp_imu.motion.motion import Motion
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

SensorLike = VirtualSensor | Placement | str


@dataclass(eq=False, repr=False)
class ImuSimulator:
    """Virtual IMUs on a motion.

    fs_hz: output rate; noise: add white noise and bias random walk (False gives
    exact kinematics plus the nominal bias, zero by default); seed: noise seed
    (drawn with `rng_for(seed, 'imu_noise', location)`); smoothing_hz: cutoff of
    the smoothing splines of positions and rotations ('placement': the
    placement's own, `Placement.smoothing_hz`; None: interpolate); trim_s:
    margin dropped at each end. After `simulate`, `kinematics_` holds the last SegmentKinematics.
    """

    fs_hz: float = 50.0
    _: KW_ONLY
    noise: bool = True
    seed: int = 0
    smoothing_hz: SmoothingHz = PLACEMENT_CUTOFF
    trim_s: float = DEFAULT_TRIM_S

    def settings(self) -> dict[str, Any]:
        return {
            "simulator": type(self).__name__,
            "fs_hz": self.fs_hz,
            "noise": bool(self.noise),
            "seed": int(self.seed),
            "smoothing_hz": self.smoothing_hz,
            "trim_s": self.trim_s,
            "gravity_m_s2": STANDARD_GRAVITY_M_S2,
        }

    def _readings(self, motion: Motion, sensor: VirtualSensor) -> tuple[np.ndarray, SegmentKinematics]:
        kin = simulate_kinematics(motion, sensor, self.fs_hz, smoothing_hz=self.smoothing_hz,
                                  trim_s=self.trim_s)
        noise = draw_noise(sensor, kin.n_samples, self.fs_hz, self.seed, sensor.name) if self.noise else None
        data = sensor_readings(kin, sensor.mounting_matrix(), sensor.acc_bias, sensor.gyr_bias,
                               noise=noise)[0]
        self.kinematics_ = kin
        return data, kin

    def simulate(self, motion: Motion, sensor: SensorLike = "waist") -> ImuRecording:
        """One sensor: (T, 6) channels acc_x..gyr_z in m/s^2 and rad/s."""
        check_settings(self.fs_hz, self.smoothing_hz, self.trim_s)
        sensor = as_sensor(sensor)
        data, kin = self._readings(motion, sensor)
        meta = {
            "kind": "imu_recording",
            "location": sensor.name,
            "sensor": sensor.theta(attachment_m=kin.attachment_m),
            "motion": motion.meta,
            **self.settings(),
        }
        return ImuRecording(data, CHANNELS, self.fs_hz, meta, start_s=float(kin.times[0]))

    def simulate_many(self, motion: Motion, sensors: Sequence[SensorLike]) -> ImuRecording:
        """Several sensors side by side, channels prefixed by location (`right_wrist_acc_x`)."""
        check_settings(self.fs_hz, self.smoothing_hz, self.trim_s)
        resolved = [as_sensor(s) for s in sensors]
        if not resolved:
            raise ValidationError("need at least one sensor location", field="location")
        names = [s.name for s in resolved]
        if len(set(names)) != len(names):
            raise ValidationError(f"duplicate sensor locations in {', '.join(names)}", field="location")
        blocks, thetas, start = [], {}, 0.0
        for sensor in resolved:
            data, kin = self._readings(motion, sensor)
            blocks.append(data)
            thetas[sensor.name] = sensor.theta(attachment_m=kin.attachment_m)
            start = float(kin.times[0])
        channel_names = tuple(c for s in resolved for c in prefixed(s.name))
        meta = {
            "kind": "imu_recording",
            "locations": names,
            "sensors": thetas,
            "motion": motion.meta,
            **self.settings(),
        }
        return ImuRecording(np.hstack(blocks), channel_names, self.fs_hz, meta, start_s=start)


def simulate_many(motion: Motion, placements: Sequence[SensorLike], **settings: Any) -> ImuRecording:
    """`ImuSimulator(**settings).simulate_many(motion, placements)`."""
    return ImuSimulator(**settings).simulate_many(motion, placements)
