"""The motion room: the `Motion` type, its files, and the motion backends.

Backends (`get_backend(name)`): `procedural` (embedded, CPU) and `hymotion`
(HY-Motion 1.0, GPU). Measurements of realized controls live in
`vsmp_imu.motion.measure`; BVH export in `vsmp_imu.motion.bvh`; drawing in
`vsmp_imu.motion.render` (imports matplotlib on use).
"""

from vsmp_imu.motion.backends import BACKENDS, MotionBackend, get_backend
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import (
    SMPL22_JOINTS,
    SMPL22_PARENTS,
    Skeleton,
    forward_kinematics,
    smpl22_skeleton,
)

__all__ = [
    "BACKENDS",
    "Motion",
    "MotionBackend",
    "SMPL22_JOINTS",
    "SMPL22_PARENTS",
    "Skeleton",
    "forward_kinematics",
    "get_backend",
    "smpl22_skeleton",
]
