"""The virtual sensor theta and its noise model.

theta = {j_target, r_j, R0_{s<-j}, b0_a, b0_w, sigma0_a, sigma0_w} (paper,
"IMU Grounding and Quality Filtering"). Here:

- j_target, r_j: `placement.segment` and the attachment point (from the
  placement's rule, or `attachment_m` when given), metres in the segment frame;
- R0_{s<-j}: `mounting_xyzw`, the rotation taking segment-frame vectors into the
  sensor frame (v_s = R0 v_j);
- b0_a, b0_w: constant biases in the sensor frame (m/s^2, rad/s), zero by default
  (a factory-calibrated phone; the grounding room searches corrections around it);
- sigma0_a, sigma0_w: white-noise densities plus bias random-walk densities.

Noise per output sample (Kalibr's discrete-time convention):
white std = density * sqrt(fs_hz); bias random-walk step std = walk / sqrt(fs_hz).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.placement import Placement, get_placement
from vsmp_imu.motion.motion import Motion
from vsmp_imu.seeding import rng_for
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

# Nominal smartphone/smartwatch-grade MEMS figures (datasheet values):
# accelerometer noise density 300 ug/sqrt(Hz) (InvenSense MPU-6500; Bosch BMI160: 180),
# gyroscope noise density 0.01 deg/s/sqrt(Hz) (MPU-6500; BMI160: 0.007).
ACC_NOISE_DENSITY = 300e-6 * STANDARD_GRAVITY_M_S2  # m/s^2/sqrt(Hz)
GYR_NOISE_DENSITY = np.deg2rad(0.01)  # rad/s/sqrt(Hz)
# Bias random walk: order of magnitude of Allan-variance fits of consumer MEMS IMUs.
ACC_BIAS_WALK = 1e-3  # m/s^2/sqrt(s)
GYR_BIAS_WALK = 1e-4  # rad/s/sqrt(s)


def _vec3(value: Any, name: str) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise ValidationError(f"must be 3 finite numbers, got {value!r}", field=name)
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class VirtualSensor:
    """One virtual IMU: the nominal simulator configuration theta."""

    placement: Placement
    attachment_m: tuple[float, float, float] | None = None
    mounting_xyzw: tuple[float, float, float, float] | None = None
    acc_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gyr_bias: tuple[float, float, float] = (0.0, 0.0, 0.0)
    acc_noise_density: float = ACC_NOISE_DENSITY
    gyr_noise_density: float = GYR_NOISE_DENSITY
    acc_bias_walk: float = ACC_BIAS_WALK
    gyr_bias_walk: float = GYR_BIAS_WALK
    name: str = field(default="")

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "placement", get_placement(self.placement))
        if not self.name:
            set_(self, "name", self.placement.name)
        if self.attachment_m is not None:
            set_(self, "attachment_m", _vec3(self.attachment_m, "attachment_m"))
        if self.mounting_xyzw is not None:
            q = np.asarray(self.mounting_xyzw, dtype=float)
            if q.shape != (4,) or not np.isfinite(q).all() or np.linalg.norm(q) < 1e-9:
                raise ValidationError(f"must be a quaternion (x, y, z, w), got {self.mounting_xyzw!r}",
                                      field="mounting_xyzw")
            set_(self, "mounting_xyzw", tuple(float(v) for v in q / np.linalg.norm(q)))
        set_(self, "acc_bias", _vec3(self.acc_bias, "acc_bias"))
        set_(self, "gyr_bias", _vec3(self.gyr_bias, "gyr_bias"))
        for key in ("acc_noise_density", "gyr_noise_density", "acc_bias_walk", "gyr_bias_walk"):
            value = float(getattr(self, key))
            if not (value >= 0 and np.isfinite(value)):
                raise ValidationError(f"must be a finite number >= 0, got {value}", field=key)
            set_(self, key, value)

    @classmethod
    def at(cls, location: str | Placement, **overrides: Any) -> VirtualSensor:
        """The nominal sensor at a named location, with optional field overrides."""
        return cls(placement=get_placement(location), **overrides)

    def with_(self, **changes: Any) -> VirtualSensor:
        return replace(self, **changes)

    @property
    def location(self) -> str:
        return self.name

    @property
    def segment(self) -> str:
        return self.placement.segment

    def mounting(self) -> Rotation:
        """R0_{s<-j}: segment-frame vectors into the sensor frame."""
        return Rotation.from_quat(self.mounting_xyzw or self.placement.mounting_xyzw)

    def mounting_matrix(self) -> np.ndarray:
        return self.mounting().as_matrix()

    def attachment(self, motion: Motion) -> np.ndarray:
        """r_j (3,) metres in the segment frame."""
        if self.attachment_m is not None:
            return np.asarray(self.attachment_m)
        return self.placement.attachment_m(motion)

    def noise_std(self, fs_hz: float) -> dict[str, float]:
        """Per-sample standard deviations at the output rate."""
        root = float(np.sqrt(fs_hz))
        return {
            "acc_white": self.acc_noise_density * root,
            "gyr_white": self.gyr_noise_density * root,
            "acc_walk": self.acc_bias_walk / root,
            "gyr_walk": self.gyr_bias_walk / root,
        }

    def theta(self, motion: Motion | None = None, attachment_m=None) -> dict[str, Any]:
        """theta as a JSON-ready dict; the attachment is resolved on `motion` unless given."""
        attach = self.attachment_m if attachment_m is None else tuple(float(v) for v in attachment_m)
        if attach is None and motion is not None:
            attach = tuple(float(v) for v in self.placement.attachment_m(motion))
        return {
            "location": self.name,
            "segment": self.segment,
            "attachment_m": list(attach) if attach is not None else None,
            "attachment_rule": self.placement.rule(),
            "mounting_xyzw": [float(v) for v in self.mounting().as_quat()],
            "acc_bias_m_s2": list(self.acc_bias),
            "gyr_bias_rad_s": list(self.gyr_bias),
            "acc_noise_density_m_s2_per_sqrt_hz": self.acc_noise_density,
            "gyr_noise_density_rad_s_per_sqrt_hz": self.gyr_noise_density,
            "acc_bias_walk_m_s2_per_sqrt_s": self.acc_bias_walk,
            "gyr_bias_walk_rad_s_per_sqrt_s": self.gyr_bias_walk,
        }


def as_sensor(sensor: VirtualSensor | Placement | str) -> VirtualSensor:
    if isinstance(sensor, VirtualSensor):
        return sensor
    return VirtualSensor.at(sensor)


@dataclass(frozen=True)
class ImuNoise:
    """Pre-drawn standard-normal noise for one sensor (common random numbers).

    The nominal noise series are `acc` and `gyr` (T, 3): white noise plus a
    bias random walk starting at zero. Candidates of a calibration scale them.
    """

    acc_white: np.ndarray
    gyr_white: np.ndarray
    acc_walk: np.ndarray
    gyr_walk: np.ndarray
    std: dict[str, float]

    @property
    def n_samples(self) -> int:
        return int(self.acc_white.shape[0])

    @cached_property
    def acc(self) -> np.ndarray:
        return self.std["acc_white"] * self.acc_white + self.std["acc_walk"] * np.cumsum(self.acc_walk, axis=0)

    @cached_property
    def gyr(self) -> np.ndarray:
        return self.std["gyr_white"] * self.gyr_white + self.std["gyr_walk"] * np.cumsum(self.gyr_walk, axis=0)


def draw_noise(sensor: VirtualSensor, n_samples: int, fs_hz: float, seed: int, *keys: object) -> ImuNoise:
    """Standard normals for `n_samples` from `rng_for(seed, 'imu_noise', *keys)`."""
    rng = rng_for(seed, "imu_noise", *keys)
    draws = rng.standard_normal((4, n_samples, 3))
    return ImuNoise(draws[0], draws[1], draws[2], draws[3], sensor.noise_std(fs_hz))
