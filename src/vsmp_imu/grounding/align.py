"""Target-format convention alignment A_gamma and the grounding prior p(gamma).

Paper, "Rank-based sensor grounding" and appendix "Rank-Based Sensor
Grounding". gamma = {P_axis, c_sign, g_conv, s_unit, C_map} is a representation
transform applied after simulation: axis permutation and sign flips, gravity
included or removed, unit conversion and the target channel layout. It never
changes physical simulator parameters.

Axis conventions are written as anatomical words: a dataset declares its
device axes (x, y, z) as directions of the body standing in a T-pose
(`left right up down forward backward`). A simulated sensor's frame at rest is
its segment frame, (x, y, z) = (left, up, forward).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.units import DEG_PER_RAD, STANDARD_GRAVITY_M_S2

AXIS_WORDS: dict[str, tuple[int, int]] = {
    "left": (0, 1),
    "right": (0, -1),
    "up": (1, 1),
    "down": (1, -1),
    "forward": (2, 1),
    "backward": (2, -1),
}
SIM_AXES = ("left", "up", "forward")
UNIT_SCALE = {"m/s^2": 1.0, "m/s2": 1.0, "g": 1.0 / STANDARD_GRAVITY_M_S2,
              "rad/s": 1.0, "deg/s": DEG_PER_RAD}

# Appendix table "Grounding prior p(gamma)": bounded Euler perturbations (degrees).
WRIST_PERTURBATION_DEG = (30.0, 30.0, 30.0)  # roll, pitch, yaw
OTHER_PERTURBATION_DEG = (15.0, 15.0, 30.0)


def axes_matrix(axes: tuple[str, str, str] | list[str]) -> np.ndarray:
    """P with device = P @ simulated, for device axes given as anatomical words."""
    axes = tuple(a.strip().lower() for a in axes)
    if len(axes) != 3 or any(a not in AXIS_WORDS for a in axes):
        raise ValidationError(
            f"axes must be three anatomical words, got {list(axes)}",
            field="axes",
            allowed=", ".join(AXIS_WORDS),
        )
    dims = [AXIS_WORDS[a][0] for a in axes]
    if sorted(dims) != [0, 1, 2]:
        raise ValidationError(f"axes {list(axes)} name the same body direction twice", field="axes")
    p = np.zeros((3, 3))
    for row, word in enumerate(axes):
        dim, sign = AXIS_WORDS[word]
        p[row, dim] = sign
    return p


def signed_permutations() -> list[np.ndarray]:
    """All 48 axis permutations with sign flips (the prior's 6 x 8 candidates)."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            p = np.zeros((3, 3))
            for row, (col, s) in enumerate(zip(perm, signs, strict=True)):
                p[row, col] = s
            out.append(p)
    return out


@dataclass(frozen=True)
class Convention:
    """gamma for one sensor location: device axes, gravity, units, channel names."""

    axes: tuple[str, str, str] = SIM_AXES
    gravity_included: bool = True
    acc_unit: str = "m/s^2"
    gyr_unit: str = "rad/s"
    channel_names: tuple[str, ...] = ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")

    def __post_init__(self) -> None:
        axes_matrix(self.axes)
        for field, unit in (("acc_unit", self.acc_unit), ("gyr_unit", self.gyr_unit)):
            if unit not in UNIT_SCALE:
                raise ValidationError(f"unknown unit '{unit}'", field=field, allowed=", ".join(UNIT_SCALE))
        if len(self.channel_names) != 6:
            raise ValidationError("a location has exactly 6 channels (acc xyz, gyr xyz)", field="channel_names")

    def as_dict(self) -> dict:
        return {
            "axes": list(self.axes),
            "gravity_included": self.gravity_included,
            "acc_unit": self.acc_unit,
            "gyr_unit": self.gyr_unit,
            "channel_names": list(self.channel_names),
        }


class ConventionAlignment:
    """A_gamma: simulated (acc, gyr) in the sensor frame -> the target layout.

    transform(x, gravity) takes x (..., T, 6) with gravity included (specific
    force) and, when the target removes gravity, the gravity part of the
    specific force in the sensor frame (..., T, 3).
    """

    def __init__(self, convention: Convention) -> None:
        self.convention = convention

    def transform(self, x: np.ndarray, gravity: np.ndarray | None = None) -> np.ndarray:
        conv = self.convention
        x = np.asarray(x, dtype=np.float64)
        acc, gyr = x[..., 0:3], x[..., 3:6]
        if not conv.gravity_included:
            if gravity is None:
                raise ValidationError(
                    "the target removes gravity, so the sensor-frame gravity is needed", field="gravity"
                )
            acc = acc - gravity
        p = axes_matrix(conv.axes)
        acc = acc @ p.T * UNIT_SCALE[conv.acc_unit]
        gyr = gyr @ p.T * UNIT_SCALE[conv.gyr_unit]
        return np.concatenate([acc, gyr], axis=-1)


def is_wrist(location: str) -> bool:
    return "wrist" in location or "hand" in location or "watch" in location


def sample_mounting_perturbation(location: str, rng: np.random.Generator) -> Rotation:
    """R_target perturbation from p(gamma): uniform roll/pitch/yaw within the prior's bounds.

    Sensor frame at rest is (left, up, forward): roll is about forward (z),
    pitch about left (x), yaw about up (y).
    """
    bounds = WRIST_PERTURBATION_DEG if is_wrist(location) else OTHER_PERTURBATION_DEG
    roll, pitch, yaw = (rng.uniform(-b, b) for b in bounds)
    return Rotation.from_euler("zxy", [roll, pitch, yaw], degrees=True)


def infer_axes(synthetic: np.ndarray, real: np.ndarray) -> tuple[np.ndarray, float]:
    """Pick the signed permutation that best matches real data when a dataset declares no axes.

    Compares the mean accelerometer vector (gravity direction) and the
    accelerometer/gyroscope covariance of synthetic (N, T, 6) and real (M, T, 6)
    windows. Returns (P, score); lower is better.
    """
    syn = np.asarray(synthetic, dtype=np.float64).reshape(-1, 6)
    rea = np.asarray(real, dtype=np.float64).reshape(-1, 6)
    r_mean = rea[:, :3].mean(0)
    r_cov_a, r_cov_g = np.cov(rea[:, :3].T), np.cov(rea[:, 3:].T)
    scale_a = np.linalg.norm(r_cov_a) + 1e-9
    scale_g = np.linalg.norm(r_cov_g) + 1e-9
    best, best_score = None, np.inf
    for p in signed_permutations():
        a, g = syn[:, :3] @ p.T, syn[:, 3:] @ p.T
        score = (
            np.linalg.norm(a.mean(0) - r_mean) / STANDARD_GRAVITY_M_S2
            + np.linalg.norm(np.cov(a.T) - r_cov_a) / scale_a
            + np.linalg.norm(np.cov(g.T) - r_cov_g) / scale_g
        )
        if score < best_score:
            best, best_score = p, float(score)
    return best, best_score
