"""Posture anchors: how each seen posture sits in the real sensor, lent to a class without windows.

The nominal mounting (`grounding.mounting`) is one rotation for every class.
What it leaves per posture shows as the angle between a held posture's
synthetic mean specific force and its real one: on HAPT12 the real waist
phone tilts back about 10 degrees more when its wearer sits than the
procedural seat puts it, and a little less when they stand. A class with real
windows gets that back from its rank map; a class without them (the unseen
protocol) keeps it, so a synthetic stand-to-sit starts and ends where no real
one does.

An anchor is one seen posture's residual: the synthetic mean direction (unit
vector, target frame) and the rotation vector that turns it onto the real mean
direction. A sample of a class without real windows is turned, at each instant,
by a blend of the anchors' rotations weighted by how close its own gravity
direction (the 1 Hz low-passed accelerometer) is to each anchor's synthetic
direction (inverse squared angle): a stand-to-sit gets the standing residual
at its start, the sitting one at its end, a mix between. The gyroscope gets
the same rotation plus the rate at which the rotation itself turns, so the
signals stay those of one rigid body.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding.mounting import MIN_MEAN_NORM

GRAVITY_CUTOFF_HZ = 1.0
SOFT_ANGLE_RAD = np.radians(3.0)  # keeps the inverse-square weights finite at an anchor


@dataclass(frozen=True)
class PostureAnchor:
    """One seen posture's residual rotation in the target frame."""

    label: str
    direction: tuple[float, float, float]  # unit synthetic mean specific force
    rotvec: tuple[float, float, float]  # rotation (rad) taking it onto the real mean direction

    @property
    def angle_deg(self) -> float:
        return float(np.degrees(np.linalg.norm(self.rotvec)))

    def as_dict(self) -> dict:
        return {"label": self.label, "direction": list(self.direction), "rotvec": list(self.rotvec)}


def fit_anchor(label: str, synthetic_mean: np.ndarray, real_mean: np.ndarray) -> PostureAnchor | None:
    """The anchor of one posture, or None when either mean is too weak to carry gravity."""
    syn, real = np.asarray(synthetic_mean, dtype=float), np.asarray(real_mean, dtype=float)
    if min(np.linalg.norm(syn), np.linalg.norm(real)) <= MIN_MEAN_NORM:
        return None
    a, b = syn / np.linalg.norm(syn), real / np.linalg.norm(real)
    axis = np.cross(a, b)
    angle = np.arctan2(np.linalg.norm(axis), float(a @ b))
    rotvec = np.zeros(3) if np.linalg.norm(axis) < 1e-12 else axis / np.linalg.norm(axis) * angle
    return PostureAnchor(label, tuple(float(v) for v in a), tuple(float(v) for v in rotvec))


def gravity_direction(acc: np.ndarray, fs_hz: float) -> np.ndarray:
    """(T, 3) unit vectors along the low-passed accelerometer."""
    sos = butter(2, GRAVITY_CUTOFF_HZ, fs=fs_hz, output="sos")
    low = sosfiltfilt(sos, acc, axis=0) if len(acc) > 3 * (2 * len(sos) + 1) else np.repeat(
        acc.mean(axis=0, keepdims=True), len(acc), axis=0)
    return low / np.maximum(np.linalg.norm(low, axis=1, keepdims=True), 1e-9)


def blend_weights(directions: np.ndarray, anchors: list[PostureAnchor]) -> np.ndarray:
    """(T, A) weights summing to 1: inverse squared angle to each anchor's direction."""
    dirs = np.array([a.direction for a in anchors])
    angle = np.arccos(np.clip(directions @ dirs.T, -1.0, 1.0))
    w = 1.0 / (angle ** 2 + SOFT_ANGLE_RAD ** 2)
    return w / w.sum(axis=1, keepdims=True)


def frame_rate(rot: Rotation, fs_hz: float) -> np.ndarray:
    """(T, 3) the angular rate a sensor shows when its readings are turned by D(t): vee(D dD/dt^T)."""
    d = rot.as_matrix()
    dot = np.gradient(d, axis=0) * fs_hz
    s = d @ dot.transpose(0, 2, 1)
    return 0.5 * np.stack([s[:, 2, 1] - s[:, 1, 2], s[:, 0, 2] - s[:, 2, 0], s[:, 1, 0] - s[:, 0, 1]], axis=1)


def anchor(signal: np.ndarray, anchors: list[PostureAnchor], fs_hz: float) -> np.ndarray:
    """The (T, 6) [acc, gyr] signal turned by the anchors' blended rotations (unchanged without any)."""
    if not anchors or len(signal) < 2:
        return signal
    acc, gyr = signal[:, 0:3], signal[:, 3:6]
    w = blend_weights(gravity_direction(acc, fs_hz), anchors)
    rot = Rotation.from_rotvec(w @ np.array([a.rotvec for a in anchors]))
    return np.concatenate([rot.apply(acc), rot.apply(gyr) + frame_rate(rot, fs_hz)], axis=1)
