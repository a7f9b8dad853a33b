"""The 22-joint SMPL body skeleton (HY-Motion's body joints) and forward kinematics.

World frame: Y up, metres. In the rest pose (T-pose) the body faces +Z and
+X points to the body's left, as in SMPL. Local joint rotations are relative
to the parent joint's frame; global rotation of joint j is
R_parent(j) * R_local(j), and joint j sits at p_parent + R_parent(j) * offset_j.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError

SMPL22_JOINTS: tuple[str, ...] = (
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
)
SMPL22_PARENTS: tuple[int, ...] = (
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19,
)  # fmt: skip

# Rest offsets from parent (metres) of the SMPL neutral body, ~1.70 m tall.
_SMPL22_OFFSETS_170 = np.array(
    [
        [0.0, 0.0, 0.0],  # pelvis (root; placed by the root translation)
        [0.0695, -0.0914, -0.0068],
        [-0.0677, -0.0905, -0.0043],
        [-0.0025, 0.1089, -0.0267],
        [0.0343, -0.3752, -0.0045],
        [-0.0383, -0.3826, -0.0089],
        [0.0055, 0.1352, 0.0011],
        [-0.0136, -0.3980, -0.0437],
        [0.0158, -0.3984, -0.0423],
        [0.0015, 0.0529, 0.0254],
        [0.0264, -0.0558, 0.1193],
        [-0.0254, -0.0481, 0.1233],
        [-0.0028, 0.2139, -0.0429],
        [0.0788, 0.1217, -0.0341],
        [-0.0818, 0.1188, -0.0386],
        [0.0052, 0.0650, 0.0513],
        [0.0910, 0.0305, -0.0089],
        [-0.0960, 0.0326, -0.0091],
        [0.2596, -0.0128, -0.0275],
        [-0.2537, -0.0134, -0.0215],
        [0.2492, 0.0090, -0.0012],
        [-0.2553, 0.0078, -0.0056],
    ]
)
SMPL22_OFFSETS_170 = _SMPL22_OFFSETS_170  # read-only use: bone directions of the default body
DEFAULT_HEIGHT_M = 1.70
SKELETON_HEIGHT_M = (0.5, 2.5)  # the body heights a skeleton may be scaled to (m)
# Height of the pelvis joint above the floor in the rest pose (ankle ~0.08 m up).
_PELVIS_HEIGHT_170 = 0.0914 + 0.3752 + 0.3980 + 0.08

# Chain used to estimate standing height from bone lengths (foot to head).
_HEIGHT_CHAIN = ("left_ankle", "left_knee", "left_hip", "pelvis", "spine1", "spine2",
                 "spine3", "neck", "head")


@dataclass(frozen=True)
class Skeleton:
    """Joint names, parent indices and rest offsets (metres)."""

    joint_names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray  # (J, 3)

    def __post_init__(self) -> None:
        if len(self.joint_names) != len(self.parents) or self.offsets.shape != (len(self.parents), 3):
            raise ValueError("joint_names, parents and offsets must agree in length")
        for j, p in enumerate(self.parents):
            if p >= j:
                raise ValueError("parents must precede their children")

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def index(self, name: str) -> int:
        return self.joint_names.index(name)

    def pelvis_height(self) -> float:
        """Rest height of the root joint above the floor."""
        return _PELVIS_HEIGHT_170 * self.height_m() / DEFAULT_HEIGHT_M

    def height_m(self) -> float:
        """Standing height estimated from the bone lengths."""
        return estimate_height(self.offsets_world(), self.joint_names)

    def offsets_world(self) -> np.ndarray:
        """Rest-pose joint positions with the root at the origin, (J, 3)."""
        return _rest_positions(self.offsets, self.parents)


def _chain_length(positions: np.ndarray, names: tuple[str, ...]) -> float:
    missing = [n for n in _HEIGHT_CHAIN if n not in names]
    if missing:
        raise ValidationError(f"the body height needs the SMPL-22 ankle-to-head joints; missing "
                              f"{', '.join(missing)}", field="joint_names")
    idx = [names.index(n) for n in _HEIGHT_CHAIN]
    seg = positions[..., idx[1:], :] - positions[..., idx[:-1], :]
    return float(np.linalg.norm(seg, axis=-1).sum(axis=-1).mean())


def estimate_height(positions: np.ndarray, joint_names: tuple[str, ...] | list[str]) -> float:
    """Standing height (m) from bone lengths of positions (..., J, 3) of SMPL-22 joints.

    Bone lengths do not depend on pose, so any frame(s) work. Calibrated so
    the default skeleton reads DEFAULT_HEIGHT_M.
    """
    names = tuple(joint_names)
    return _chain_length(positions, names) * _HEIGHT_SCALE


def _rest_positions(offsets: np.ndarray, parents: tuple[int, ...]) -> np.ndarray:
    pos = np.zeros_like(offsets)
    for j, p in enumerate(parents):
        if p >= 0:
            pos[j] = pos[p] + offsets[j]
    return pos


# ankle-to-head chain length times this factor gives standing height
_HEIGHT_SCALE = DEFAULT_HEIGHT_M / _chain_length(
    _rest_positions(_SMPL22_OFFSETS_170, SMPL22_PARENTS), SMPL22_JOINTS
)




def smpl22_skeleton(height_m: float = DEFAULT_HEIGHT_M, proportions: np.ndarray | None = None) -> Skeleton:
    """The SMPL-22 skeleton scaled to `height_m`.

    `proportions` (J,) optionally rescales each bone (1 = SMPL neutral), for
    per-seed body variation.
    """
    if not SKELETON_HEIGHT_M[0] <= height_m <= SKELETON_HEIGHT_M[1]:
        raise ValueError(f"height_m must be within {SKELETON_HEIGHT_M[0]:g}..{SKELETON_HEIGHT_M[1]:g} m, "
                         f"got {height_m}")
    offsets = _SMPL22_OFFSETS_170 * (height_m / DEFAULT_HEIGHT_M)
    if proportions is not None:
        offsets = offsets * np.asarray(proportions, dtype=float)[:, None]
    return Skeleton(SMPL22_JOINTS, SMPL22_PARENTS, offsets)


def forward_kinematics(
    skeleton: Skeleton, local_rotations: Rotation | np.ndarray, root_positions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Global joint positions (T, J, 3) and rotations (T, J, 4, xyzw).

    `local_rotations`: (T, J, 4) quaternions (xyzw) relative to the parent.
    `root_positions`: (T, 3) world positions of the root joint.
    """
    quats = np.asarray(local_rotations.as_quat() if isinstance(local_rotations, Rotation) else local_rotations)
    t, j = quats.shape[:2]
    if j != skeleton.n_joints:
        raise ValueError(f"expected {skeleton.n_joints} joints, got {j}")
    glob: list[Rotation] = [None] * j  # type: ignore[list-item]
    pos = np.zeros((t, j, 3))
    for k, p in enumerate(skeleton.parents):
        local = Rotation.from_quat(quats[:, k])
        if p < 0:
            glob[k] = local
            pos[:, k] = root_positions
        else:
            glob[k] = glob[p] * local
            pos[:, k] = pos[:, p] + glob[p].apply(skeleton.offsets[k])
    rot = np.stack([g.as_quat() for g in glob], axis=1)
    return pos, rot
