"""The motion room: the `Motion` type, its files, and the motion backends."""

from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import (
    SMPL22_JOINTS,
    SMPL22_PARENTS,
    Skeleton,
    forward_kinematics,
    smpl22_skeleton,
)

__all__ = ["Motion", "SMPL22_JOINTS", "SMPL22_PARENTS", "Skeleton", "forward_kinematics", "smpl22_skeleton"]
