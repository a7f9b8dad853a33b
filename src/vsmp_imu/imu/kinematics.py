"""Step 1 of the simulation: splined segment kinematics, evaluated once.

For a sensor on segment j with attachment r_j (segment frame), the sensor's
world position is p(t) = p_j(t) + R_j(t) r_j. The motion is splined before it
is differentiated (IMUSim's method):

- p(t): quintic smoothing spline per axis (`spline.smoothing_spline`), giving
  the linear acceleration a(t) = p''(t);
- R_j(t): scipy `RotationSpline` (C2: continuous angular rate and angular
  acceleration). Its first derivative is the angular rate in the BODY frame,
  i.e. omega_j = R_j^T omega_world, already in the segment frame.

Everything is expressed in the segment frame:

    acc_lin_seg = R_j^T a          (linear acceleration)
    grav_seg    = -R_j^T g         (g = (0, -g_n, 0): +g_n along "up" when upright)
    gyr_seg     = R_j^T omega_world

so the specific force is acc_lin_seg + grav_seg = R_j^T (a - g). Samples are
taken at the output rate from `trim_s` after the first frame to `trim_s`
before the last one, which drops the spline edge effects.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation, RotationSpline

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.channels import GRAVITY_WORLD
from vsmp_imu.imu.placement import Placement
from vsmp_imu.imu.sensor import VirtualSensor, as_sensor
from vsmp_imu.imu.spline import smoothing_spline
from vsmp_imu.motion.motion import Motion

# Position-spline cutoff: human movement sits well below it; biomechanics
# practice low-passes marker trajectories at 6-10 Hz before differentiating.
DEFAULT_SMOOTHING_HZ = 8.0
# Samples within this margin of either end are dropped (spline edge effects: at
# 8 Hz cutoff, sinusoids up to 3 Hz show <= 0.3 % acceleration error beyond 0.2 s).
DEFAULT_TRIM_S = 0.2


@dataclass(frozen=True)
class SegmentKinematics:
    """Sensor-point kinematics in the segment frame at the output sample times."""

    times: np.ndarray  # (T,) seconds, motion clock
    fs_hz: float
    acc_lin_seg: np.ndarray  # (T, 3) m/s^2
    grav_seg: np.ndarray  # (T, 3) m/s^2, -R^T g
    gyr_seg: np.ndarray  # (T, 3) rad/s
    location: str
    segment: str
    attachment_m: tuple[float, float, float]
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def n_samples(self) -> int:
        return int(self.times.shape[0])

    def specific_force_seg(self) -> np.ndarray:
        """R^T (a - g) in the segment frame, (T, 3)."""
        return self.acc_lin_seg + self.grav_seg


def output_times(duration_s: float, fs_hz: float, trim_s: float) -> np.ndarray:
    """Sample times k / fs_hz + trim_s that stay `trim_s` away from the end."""
    span = duration_s - 2.0 * trim_s
    if span < 0:
        raise ValidationError(
            f"motion of {duration_s:.3f} s is shorter than the trimmed margins (2 x {trim_s} s)",
            field="trim_s")
    n = int(np.floor(span * fs_hz + 1e-9)) + 1
    return np.minimum(trim_s + np.arange(n) / fs_hz, duration_s - trim_s)


def check_settings(fs_hz: float, smoothing_hz: float | None, trim_s: float) -> None:
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValidationError(f"must be a positive rate, got {fs_hz}", field="fs_hz")
    if smoothing_hz is not None and not (np.isfinite(smoothing_hz) and smoothing_hz > 0):
        raise ValidationError(f"must be a positive frequency or None, got {smoothing_hz}",
                              field="smoothing_hz")
    if not (np.isfinite(trim_s) and trim_s >= 0):
        raise ValidationError(f"must be >= 0, got {trim_s}", field="trim_s")


def simulate_kinematics(
    motion: Motion,
    placement: VirtualSensor | Placement | str,
    fs_hz: float,
    *,
    smoothing_hz: float | None = DEFAULT_SMOOTHING_HZ,
    trim_s: float = DEFAULT_TRIM_S,
) -> SegmentKinematics:
    """Spline the sensor's trajectory once and evaluate it at `fs_hz` (see module doc)."""
    check_settings(fs_hz, smoothing_hz, trim_s)
    sensor = as_sensor(placement)
    if not motion.is_finite():
        raise ValidationError("motion has non-finite positions or rotations", field="motion")
    j = motion.joint_index(sensor.segment)
    attach = sensor.attachment(motion)
    frame_times = motion.times
    rot_frames = Rotation.from_quat(motion.rotations[:, j])
    sensor_pos = motion.positions[:, j] + rot_frames.apply(attach)

    times = output_times(motion.duration_s, fs_hz, trim_s)
    acc_world = smoothing_spline(sensor_pos, motion.fps, smoothing_hz)(times, 2)
    rot_spline = RotationSpline(frame_times, rot_frames)
    rot = rot_spline(times)
    gyr_seg = rot_spline(times, 1)
    acc_lin_seg = rot.apply(acc_world, inverse=True)
    grav_seg = rot.apply(-GRAVITY_WORLD, inverse=True)
    meta = {
        "motion_fps": motion.fps,
        "motion_frames": motion.n_frames,
        "smoothing_hz": smoothing_hz,
        "trim_s": trim_s,
        "position_spline": "quintic P-spline, knots at frames, 3rd-difference penalty",
        "rotation_spline": "scipy RotationSpline (C2)",
    }
    return SegmentKinematics(
        times=times, fs_hz=float(fs_hz), acc_lin_seg=acc_lin_seg, grav_seg=grav_seg,
        gyr_seg=np.asarray(gyr_seg), location=sensor.name, segment=sensor.segment,
        attachment_m=tuple(float(v) for v in attach), meta=meta,
    )
