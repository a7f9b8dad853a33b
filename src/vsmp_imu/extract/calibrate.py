"""What a typical execution of an activity measures like, through the same pose pipeline.

Pose measurements are raw numbers (cycles per second, radians); the SMP
wants levels relative to a typical execution of the same activity (paper,
appendix "SMP audit annotation guide": tempo and amplitude "relative to
typical executions of the same activity class"). The reference is the
activity's library SMP animated by the procedural backend (a few seeds),
rendered as MediaPipe landmarks (`motion_landmarks`), retargeted and measured
exactly like a video. Its levels are the library SMP's, so a clip measured
at 1.5x the reference cycle frequency is one tempo step faster than the
library's tempo.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.extract.landmarks import LM, MP_TO_YUP, N_LANDMARKS, PoseTrack
from vsmp_imu.motion import measure
from vsmp_imu.motion.motion import Motion

REFERENCE_SEEDS = (0, 1, 2)
DEFAULT_PRINCIPAL = ("left_shoulder", "right_shoulder", "left_elbow", "right_elbow", "left_hip",
                     "right_hip", "left_knee", "right_knee")
DEFAULT_SYMMETRY = ("left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_knee",
                    "right_knee", "left_ankle", "right_ankle")

# Landmarks fixed to a joint: (joint, offset in the joint's rest frame, metres), left side;
# the right side mirrors x. Approximate adult head, hand and heel geometry.
_ATTACHED = {
    "nose": ("head", (0.0, -0.01, 0.10)),
    "left_eye_inner": ("head", (0.015, 0.015, 0.085)), "left_eye": ("head", (0.03, 0.015, 0.08)),
    "left_eye_outer": ("head", (0.045, 0.015, 0.075)), "left_ear": ("head", (0.075, 0.0, 0.0)),
    "mouth_left": ("head", (0.025, -0.05, 0.09)),
    "left_pinky": ("left_wrist", (0.08, 0.0, -0.025)),
    "left_index": ("left_wrist", (0.09, 0.0, 0.025)),
    "left_thumb": ("left_wrist", (0.05, 0.0, 0.05)),
    "left_heel": ("left_ankle", (0.0, -0.06, -0.05)),
}
_AT_JOINT = {"left_shoulder": "left_shoulder", "left_elbow": "left_elbow", "left_wrist": "left_wrist",
             "left_hip": "left_hip", "left_knee": "left_knee", "left_ankle": "left_ankle",
             "left_foot_index": "left_foot"}


def _right(name: str) -> str:
    return name.replace("left", "right")


def motion_landmarks(motion: Motion) -> np.ndarray:
    """(T, 33, 3) landmarks of an SMPL-22 motion in MediaPipe's world convention
    (metres, hip-centred, x right, y down, z away from a camera the body faces)."""
    pos = motion.positions
    out = np.full((motion.n_frames, N_LANDMARKS, 3), np.nan)
    for lm, joint in _AT_JOINT.items():
        out[:, LM[lm]] = pos[:, motion.joint_index(joint)]
        out[:, LM[_right(lm)]] = pos[:, motion.joint_index(_right(joint))]
    for lm, (joint, offset) in _ATTACHED.items():
        sides = [(lm, joint, np.array(offset))]
        if "left" in lm:
            sides.append((_right(lm), _right(joint), np.array(offset) * [-1.0, 1.0, 1.0]))
        for name, jname, off in sides:
            j = motion.joint_index(jname)
            out[:, LM[name]] = pos[:, j] + Rotation.from_quat(motion.rotations[:, j]).apply(off)
    mid_hip = 0.5 * (out[:, LM["left_hip"]] + out[:, LM["right_hip"]])
    return (out - mid_hip[:, None, :]) * MP_TO_YUP


def motion_track(motion: Motion, px_per_m: float = 200.0, size: tuple[int, int] = (640, 480),
                 hip_px: np.ndarray | None = None, visibility: float = 0.95,
                 detected: np.ndarray | None = None) -> PoseTrack:
    """A PoseTrack that sees `motion` through an orthographic camera in front of it.

    hip_px: (T, 2) pixel position of the mid-hip (default: the frame centre);
    frames where `detected` is False carry no pose.
    """
    world = motion_landmarks(motion)
    t = motion.n_frames
    centre = np.tile([size[0] / 2.0, size[1] / 2.0], (t, 1)) if hip_px is None else np.asarray(hip_px, float)
    image = np.empty_like(world)
    image[..., 0] = (world[..., 0] * px_per_m + centre[:, None, 0]) / size[0]
    image[..., 1] = (world[..., 1] * px_per_m + centre[:, None, 1]) / size[1]
    image[..., 2] = world[..., 2]
    det = np.ones(t, dtype=bool) if detected is None else np.asarray(detected, dtype=bool)
    vis = np.full((t, N_LANDMARKS), float(visibility))
    world[~det] = np.nan
    image[~det] = np.nan
    vis[~det] = 0.0
    return PoseTrack(world, image, vis, det, np.arange(t), motion.fps, size,
                     {"path": "<synthetic>", "sha256": motion.meta.get("smp_id", "")})


@dataclass(frozen=True)
class Reference:
    """A typical execution of one activity, measured through the pose pipeline."""

    activity: str
    periodic: bool
    alternate: bool  # the right side runs half a cycle behind (gait)
    principal_joints: tuple[str, ...]
    symmetry_joints: tuple[str, ...]
    frequency_hz: float  # cycle frequency (nan for discrete activities)
    mean_speed_rad_s: float
    rom_rad: float
    tempo_level: float  # the library SMP's levels (0..2)
    amplitude_level: float

    def to_dict(self) -> dict[str, Any]:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.__dict__.items()}


def joints_for(entry: Any) -> tuple[tuple[str, ...], tuple[str, ...], bool, bool]:
    """(principal, symmetry, periodic, alternate) from an entry's recipe, else defaults."""
    from vsmp_imu.errors import ValidationError
    from vsmp_imu.motion.recipe import recipe_for_entry

    periodic = bool(entry.smp.temporal_structure.is_repetitive) if entry is not None else False
    if entry is None:
        return DEFAULT_PRINCIPAL, DEFAULT_SYMMETRY, periodic, False
    try:
        recipe = recipe_for_entry(entry)
    except ValidationError:
        return DEFAULT_PRINCIPAL, DEFAULT_SYMMETRY, periodic, False
    principal = tuple(recipe.principal_joints)
    symmetry = tuple(recipe.symmetry_joints or recipe.principal_joints)
    alternate = bool(recipe.cycle.alternate) if recipe.cycle is not None else False
    return principal, symmetry, recipe.kind == "periodic", alternate


def reference_for(entry: Any, library: Any = None) -> Reference | None:
    """The reference of a library entry; None when it has no procedural recipe."""
    if entry is None or "procedural" not in entry.extras:
        return None
    key = (entry.name, str(entry.path), entry.smp.smp_id)
    return _reference_cached(key, entry, library)


# in-process cache: (name, file, smp_id) -> reference (the library SMP defines it)
_CACHE: dict[tuple[str, str, str], Reference | None] = {}


def _reference_cached(key: tuple[str, str, str], entry: Any, library: Any) -> Reference | None:
    if key not in _CACHE:
        _CACHE[key] = _measure_reference(entry, library)
    return _CACHE[key]


def _measure_reference(entry: Any, library: Any) -> Reference | None:
    from vsmp_imu.errors import ValidationError
    from vsmp_imu.extract.retarget import track_to_motion
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.schema import AMPLITUDE_LEVELS, TEMPO_LEVELS, ordinal_level

    principal, symmetry, periodic, alternate = joints_for(entry)
    backend = ProceduralBackend(library)
    freqs, speeds, roms = [], [], []
    for seed in REFERENCE_SEEDS:
        try:
            motion = backend.generate(entry.smp, seed=seed)
        except ValidationError:
            return None
        seen = track_to_motion(motion_track(motion))
        if seen is None:
            return None
        if periodic:
            freqs.append(measure.cycle_frequency_hz(seen, principal))
        speeds.append(measure.mean_joint_speed(seen, principal))
        roms.append(measure.range_of_motion(seen, principal))
    freq = float(np.nanmedian(freqs)) if freqs and not all(math.isnan(f) for f in freqs) else float("nan")
    tempo = ordinal_level(entry.smp.execution_attributes.tempo, TEMPO_LEVELS)
    amp = ordinal_level(entry.smp.execution_attributes.amplitude, AMPLITUDE_LEVELS)
    return Reference(entry.name, periodic, alternate, principal, symmetry, freq,
                     float(np.median(speeds)), float(np.median(roms)),
                     1.0 if tempo is None else tempo, 1.0 if amp is None else amp)
