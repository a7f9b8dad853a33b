"""Step 1 of the simulation: splined segment kinematics, evaluated once.

For a sensor on segment j with attachment r_j (segment frame), the sensor's
world position is p(t) = p_j(t) + R_j(t) r_j. The motion is splined before it
is differentiated (IMUSim's method):

- p(t): quintic smoothing spline per axis (`spline.smoothing_spline`), giving
  the linear acceleration a(t) = p''(t);
- R_j(t): the same smoothing spline, with the same cutoff, through the unit
  quaternions q_j made sign-continuous, renormalized where evaluated. The
  angular rate in the BODY frame (omega_j = R_j^T omega_world, already in the
  segment frame) is omega = 2 Im(conj(q) q') / |q|^2. Smoothing the rotations
  as the positions keeps frame-to-frame noise of a recorded trajectory out of
  the gyroscope (exact interpolation differentiates that noise).

The cutoff follows the placement (`Placement.smoothing_hz`: 8 Hz, 15 Hz on
the feet, whose heel strikes carry more high-frequency motion) unless a
number is given.

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
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.channels import GRAVITY_WORLD
from vsmp_imu.imu.placement import Placement
from vsmp_imu.imu.sensor import VirtualSensor, as_sensor
from vsmp_imu.imu.spline import smoothing_spline
from vsmp_imu.motion.motion import Motion

# `smoothing_hz` value meaning "the placement's cutoff" (DEFAULT_SMOOTHING_HZ unless the placement says).
PLACEMENT_CUTOFF = "placement"
SmoothingHz = float | str | None
# Frames added at each end of the rotation spline (`reflect_ends`), in seconds.
ROTATION_PAD_S = 0.5
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


def check_settings(fs_hz: float, smoothing_hz: SmoothingHz, trim_s: float) -> None:
    if not (np.isfinite(fs_hz) and fs_hz > 0):
        raise ValidationError(f"must be a positive rate, got {fs_hz}", field="fs_hz")
    if smoothing_hz == PLACEMENT_CUTOFF:
        pass
    elif smoothing_hz is not None and (isinstance(smoothing_hz, str) or not (
            np.isfinite(smoothing_hz) and smoothing_hz > 0)):
        raise ValidationError(f"must be a positive frequency, '{PLACEMENT_CUTOFF}' or None, got {smoothing_hz!r}",
                              field="smoothing_hz")
    if not (np.isfinite(trim_s) and trim_s >= 0):
        raise ValidationError(f"must be >= 0, got {trim_s}", field="trim_s")


def simulate_kinematics(
    motion: Motion,
    placement: VirtualSensor | Placement | str,
    fs_hz: float,
    *,
    smoothing_hz: SmoothingHz = PLACEMENT_CUTOFF,
    trim_s: float = DEFAULT_TRIM_S,
) -> SegmentKinematics:
    """Spline the sensor's trajectory once and evaluate it at `fs_hz` (see module doc)."""
    check_settings(fs_hz, smoothing_hz, trim_s)
    sensor = as_sensor(placement)
    if smoothing_hz == PLACEMENT_CUTOFF:
        smoothing_hz = sensor.placement.smoothing_hz
    if not motion.is_finite():
        raise ValidationError("motion has non-finite positions or rotations", field="motion")
    if motion.n_frames < 3:  # the smoothing spline's minimum
        raise ValidationError(f"motion has {motion.n_frames} frame(s); the simulator needs at least 3",
                              field="motion")
    j = motion.joint_index(sensor.segment)
    attach = sensor.attachment(motion)
    rot_frames = Rotation.from_quat(motion.rotations[:, j])
    sensor_pos = motion.positions[:, j] + rot_frames.apply(attach)

    times = output_times(motion.duration_s, fs_hz, trim_s)
    acc_world = smoothing_spline(sensor_pos, motion.fps, smoothing_hz)(times, 2)
    rot, gyr_seg = smooth_rotations(rot_frames.as_quat(), motion.fps, smoothing_hz, times)
    acc_lin_seg = rot.apply(acc_world, inverse=True)
    grav_seg = rot.apply(-GRAVITY_WORLD, inverse=True)
    meta = {
        "motion_fps": motion.fps,
        "motion_frames": motion.n_frames,
        "smoothing_hz": smoothing_hz,
        "trim_s": trim_s,
        "position_spline": "quintic P-spline, knots at frames, 3rd-difference penalty",
        "rotation_spline": "quintic P-spline through sign-continuous quaternions, same cutoff, renormalized",
    }
    return SegmentKinematics(
        times=times, fs_hz=float(fs_hz), acc_lin_seg=acc_lin_seg, grav_seg=grav_seg,
        gyr_seg=np.asarray(gyr_seg), location=sensor.name, segment=sensor.segment,
        attachment_m=tuple(float(v) for v in attach), meta=meta,
    )


def continuous_quaternions(quats: np.ndarray) -> np.ndarray:
    """(T, 4) quaternions with signs flipped so consecutive ones lie in the same hemisphere."""
    quats = np.asarray(quats, dtype=float)
    dots = np.sum(quats[1:] * quats[:-1], axis=1)
    signs = np.concatenate([[1.0], np.cumprod(np.where(dots < 0, -1.0, 1.0))])
    return quats * signs[:, None]


def reflect_ends(quats: np.ndarray, pad: int) -> np.ndarray:
    """`pad` frames added before and after by point reflection of the rotations,
    R(-k) = R(0) R(k)^-1 R(0) (and likewise at the end): a rotation at a constant rate
    continues exactly, any other keeps its angle and rate, so the spline has no edge."""
    rots = Rotation.from_quat(quats)
    pad = min(pad, len(quats) - 1)
    if pad < 1:
        return np.asarray(quats, dtype=float)
    first, last = rots[0], rots[-1]
    head = first * rots[pad:0:-1].inv() * first
    tail = last * rots[-2:-pad - 2:-1].inv() * last
    return np.concatenate([head.as_quat(), rots.as_quat(), tail.as_quat()])


def smooth_rotations(quats: np.ndarray, fps: float, cutoff_hz: float | None,
                     times: np.ndarray) -> tuple[Rotation, np.ndarray]:
    """(R(times), body angular rate (T, 3)) from frame quaternions (x, y, z, w) splined at `cutoff_hz`."""
    pad = int(np.ceil(ROTATION_PAD_S * fps))
    padded = reflect_ends(quats, pad)
    spline = smoothing_spline(continuous_quaternions(padded), fps, cutoff_hz)
    shifted = times + (len(padded) - len(quats)) / 2 / fps
    q, dq = spline(shifted), spline(shifted, 1)
    v, w = q[:, :3], q[:, 3:]
    dv, dw = dq[:, :3], dq[:, 3:]
    # 2 Im(conj(q) * q'), conj(q) = (-v, w)
    rate = 2.0 * (w * dv - dw * v - np.cross(v, dv)) / np.sum(q * q, axis=1, keepdims=True)
    return Rotation.from_quat(q), rate
