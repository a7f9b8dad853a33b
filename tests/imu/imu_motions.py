"""Synthetic SMPL-22 motions with known kinematics for the imu tests."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.motion import Motion, forward_kinematics, smpl22_skeleton
from vsmp_imu.motion.skeleton import SMPL22_JOINTS

RootFn = Callable[[np.ndarray], np.ndarray]  # times (T,) -> (T, 3)
RotFn = Callable[[np.ndarray], Rotation]  # times (T,) -> T rotations

SKELETON = smpl22_skeleton(1.70)
PELVIS_Y = SKELETON.pelvis_height()


def standing(t: np.ndarray) -> np.ndarray:
    return np.tile([0.0, PELVIS_Y, 0.0], (len(t), 1))


def fk_at(times: np.ndarray, root: RootFn = standing, local: dict[str, RotFn] | None = None):
    """Global positions (T, 22, 3) and rotations (T, 22, 4) at arbitrary times."""
    times = np.asarray(times, dtype=float)
    quats = np.zeros((len(times), len(SMPL22_JOINTS), 4))
    quats[..., 3] = 1.0
    for name, fn in (local or {}).items():
        quats[:, SMPL22_JOINTS.index(name)] = fn(times).as_quat()
    return forward_kinematics(SKELETON, quats, root(times))


def make_motion(duration_s: float = 4.0, fps: float = 30.0, root: RootFn = standing,
                local: dict[str, RotFn] | None = None, **meta) -> Motion:
    times = np.arange(int(round(duration_s * fps)) + 1) / fps
    pos, rot = fk_at(times, root, local)
    return Motion(pos, rot, fps, meta={"source": "imu-test", **meta})


def constant(rot: Rotation) -> RotFn:
    return lambda t: Rotation.from_quat(np.tile(rot.as_quat(), (len(t), 1)))


def spin(axis, rate_rad_s: float, offset: Rotation | None = None) -> RotFn:
    """exp(rate t axis) * offset: constant body rate offset^T axis rate."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    off = offset or Rotation.identity()
    return lambda t: Rotation.from_rotvec(np.outer(rate_rad_s * t, axis)) * off


def smooth_random(seed: int, max_hz: float = 1.5):
    """Root and joint functions made of a few random low-frequency sinusoids."""
    rng = np.random.default_rng(seed)

    def sines(n_terms: int, amp: float, dims: int):
        f = rng.uniform(0.2, max_hz, (n_terms, dims))
        a = rng.uniform(-amp, amp, (n_terms, dims))
        ph = rng.uniform(0, 2 * np.pi, (n_terms, dims))
        return lambda t: (a[None] * np.sin(2 * np.pi * f[None] * t[:, None, None] + ph[None])).sum(1)

    root_wave = sines(3, 0.15, 3)

    def root(t):
        return standing(t) + root_wave(t)

    local = {}
    for name in ("pelvis", "spine1", "left_hip", "right_knee", "right_shoulder", "right_elbow",
                 "left_shoulder", "left_elbow", "neck"):
        wave = sines(2, 0.4, 3)
        local[name] = (lambda w: lambda t: Rotation.from_rotvec(w(t)))(wave)
    return root, local


def walking(cadence_hz: float = 1.0, speed_m_s: float = 1.2):
    """A walking-like gait: legs and arms swing, the pelvis bobs and moves forward."""
    w = 2 * np.pi * cadence_hz

    def root(t):
        out = standing(t)
        out[:, 1] += 0.03 * np.cos(2 * w * t)
        out[:, 2] += speed_m_s * t
        return out

    def swing(amp, phase, axis=(1.0, 0.0, 0.0), bias=0.0):
        ax = np.asarray(axis)
        return lambda t: Rotation.from_rotvec(np.outer(bias + amp * np.sin(w * t + phase), ax))

    # arms from the T-pose down to the sides: left arm (+x) about -z, right arm (-x) about +z
    left_down = Rotation.from_euler("z", -75, degrees=True)
    local = {
        "left_hip": swing(0.45, 0.0),
        "right_hip": swing(0.45, np.pi),
        "left_knee": swing(0.35, -np.pi / 2, bias=0.35),
        "right_knee": swing(0.35, np.pi / 2, bias=0.35),
        "pelvis": swing(0.08, 0.0, axis=(0.0, 1.0, 0.0)),
        "left_shoulder": lambda t: Rotation.from_rotvec(np.outer(0.35 * np.sin(w * t + np.pi), [1, 0, 0]))
        * left_down,
        "right_shoulder": lambda t: Rotation.from_rotvec(np.outer(0.35 * np.sin(w * t), [1, 0, 0]))
        * left_down.inv(),
        "left_elbow": swing(0.2, np.pi, axis=(0.0, 1.0, 0.0), bias=0.3),
        "right_elbow": swing(0.2, 0.0, axis=(0.0, -1.0, 0.0), bias=0.3),
    }
    return root, local
