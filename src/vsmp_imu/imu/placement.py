"""Named sensor placements: where on the body a virtual sensor sits.

A placement names the target segment j (the joint whose GLOBAL rotation orients
the segment, e.g. `left_hip` orients the left thigh) and a rule for the
attachment point r_j in that segment's frame:

    r_j = fraction * bone_j + surface_m * height_m / 1.70

`bone_j` is the rest vector from the segment joint to the `toward` joint,
expressed in the segment frame (read off the motion, so it follows the body's
proportions); `surface_m` moves the sensor off the bone onto the skin, in metres
for a 1.70 m body, scaled with body height.

Frames: a segment's frame at rest (T-pose) is x = left, y = up, z = forward.
Every placement's nominal mounting R0_{s<-j} is the identity, so a sensor's
axes are its segment's axes. Matching a dataset's axis convention is done later
by the grounding room (gamma), not here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M

IDENTITY_XYZW = (0.0, 0.0, 0.0, 1.0)
# Cutoff of the simulator's smoothing splines (positions and rotations): human
# movement sits well below it; biomechanics practice low-passes marker
# trajectories at 6-10 Hz before differentiating.
DEFAULT_SMOOTHING_HZ = 8.0
# Feet: heel strike and toe-off carry more high-frequency motion; on a foot
# recording with motion capture and a shoe sensor, 15 Hz matched the real
# sensor better than 8 Hz.
FOOT_SMOOTHING_HZ = 15.0


@dataclass(frozen=True)
class Placement:
    """Where a sensor sits on the body (see the module docstring for the frames)."""

    name: str
    segment: str
    toward: str | None = None
    fraction: float = 0.0
    surface_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mounting_xyzw: tuple[float, float, float, float] = IDENTITY_XYZW
    description: str = ""
    smoothing_hz: float = DEFAULT_SMOOTHING_HZ  # the simulator's spline cutoff here

    def attachment_m(self, motion: Motion) -> np.ndarray:
        """r_j (3,) in metres in the segment frame, for this motion's body."""
        j = motion.joint_index(self.segment)
        r = np.zeros(3)
        if self.toward is not None and self.fraction != 0.0:
            c = motion.joint_index(self.toward)
            bone_world = motion.positions[:, c] - motion.positions[:, j]
            bone_seg = Rotation.from_quat(motion.rotations[:, j]).apply(bone_world, inverse=True)
            r += self.fraction * bone_seg.mean(axis=0)
        return r + np.asarray(self.surface_m) * _height_scale(motion)

    def rule(self) -> str:
        """The attachment rule in words, e.g. '0.9 toward left_wrist, skin (0, 0.03, 0) m'."""
        parts = []
        if self.toward is not None and self.fraction != 0.0:
            parts.append(f"{self.fraction:g} toward {self.toward}")
        if any(self.surface_m):
            parts.append("skin (" + ", ".join(f"{v:g}" for v in self.surface_m) + ") m")
        return ", ".join(parts) or "at the joint"


def _height_scale(motion: Motion) -> float:
    try:
        return motion.body_height_m() / DEFAULT_HEIGHT_M
    except ValidationError:  # not an SMPL-22 joint set: keep the nominal offsets
        return 1.0


def _pair(side: str, name: str, segment: str, toward: str, fraction: float,
          surface: tuple[float, float, float], description: str,
          smoothing_hz: float = DEFAULT_SMOOTHING_HZ) -> Placement:
    """A left or right placement; `surface` is given for the left side (x = left)."""
    sx = surface[0] if side == "left" else 0.0 - surface[0]
    return Placement(f"{side}_{name}", f"{side}_{segment}", f"{side}_{toward}", fraction,
                     (sx, surface[1], surface[2]), description=description.format(side=side),
                     smoothing_hz=smoothing_hz)


def _placements() -> dict[str, Placement]:
    items = [
        Placement("waist", "pelvis", None, 0.0, (0.0, 0.05, 0.12),
                  description="front of the belt (phone on the waist)"),
        Placement("chest", "spine3", None, 0.0, (0.0, 0.05, 0.12),
                  description="sternum (chest strap)"),
        Placement("back", "spine1", None, 0.0, (0.0, 0.0, -0.10),
                  description="lower back, lumbar"),
        Placement("head", "head", None, 0.0, (0.0, 0.08, 0.09),
                  description="forehead (headband)"),
    ]
    for side in ("left", "right"):
        items += [
            _pair(side, "wrist", "elbow", "wrist", 0.9, (0.0, 0.03, 0.0),
                  "{side} forearm just before the wrist, back of the wrist (watch)"),
            _pair(side, "upper_arm", "shoulder", "elbow", 0.5, (0.0, 0.045, 0.0),
                  "{side} upper arm, outer side (arm band)"),
            _pair(side, "thigh", "hip", "knee", 0.4, (0.0, 0.0, 0.08),
                  "{side} thigh, front (trouser pocket)"),
            _pair(side, "lower_leg", "knee", "ankle", 0.5, (0.0, 0.0, 0.05),
                  "{side} shin, front"),
            _pair(side, "ankle", "knee", "ankle", 0.9, (0.04, 0.0, 0.0),
                  "{side} shank above the ankle, outer side (strap)"),
            _pair(side, "foot", "ankle", "foot", 0.5, (0.0, 0.04, 0.0),
                  "{side} foot, top (shoe)", smoothing_hz=FOOT_SMOOTHING_HZ),
        ]
    return {p.name: p for p in items}


PLACEMENTS: dict[str, Placement] = _placements()

# Dataset words and the body-part vocabulary of SMP annotations, mapped to
# placements. Unsided words take the right (dominant) side.
ALIASES: dict[str, str] = {
    "pelvis": "waist", "hip": "waist", "belt": "waist",
    "torso": "chest", "lower_back": "back",
    "wrist": "right_wrist", "dominant_wrist": "right_wrist", "non_dominant_wrist": "left_wrist",
    "hand": "right_wrist", "left_hand": "left_wrist", "right_hand": "right_wrist",
    "forearm": "right_wrist", "left_forearm": "left_wrist", "right_forearm": "right_wrist",
    "upper_arm": "right_upper_arm", "arm": "right_upper_arm",
    "left_shoulder": "left_upper_arm", "right_shoulder": "right_upper_arm",
    "thigh": "right_thigh", "pocket": "right_thigh",
    "lower_leg": "right_lower_leg", "shin": "right_lower_leg",
    "left_shin": "left_lower_leg", "right_shin": "right_lower_leg",
    "ankle": "right_ankle", "foot": "right_foot",
}  # fmt: skip


def location_names() -> tuple[str, ...]:
    """Every accepted location word: placements first, then aliases."""
    return tuple(PLACEMENTS) + tuple(ALIASES)


def normalize_location(name: str) -> str:
    return name.strip().lower().replace("-", "_").replace(" ", "_")


def get_placement(name: str | Placement) -> Placement:
    """The placement for a location name or alias; unknown names raise ValidationError."""
    if isinstance(name, Placement):
        return name
    key = normalize_location(str(name))
    key = ALIASES.get(key, key)
    if key not in PLACEMENTS:
        raise ValidationError(f"unknown sensor location '{name}'", field="location",
                              allowed=", ".join(location_names()))
    return PLACEMENTS[key]


def aliases_of(name: str) -> tuple[str, ...]:
    return tuple(a for a, target in ALIASES.items() if target == name)
