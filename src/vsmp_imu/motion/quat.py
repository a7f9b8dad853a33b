"""Vectorized quaternion helpers (scipy order x, y, z, w) for the hot synthesis path.

`scipy.spatial.transform.Rotation` is the reference; these plain-numpy
versions avoid its per-call overhead when hundreds of small arrays are
combined per motion. Tests check them against scipy and
`vsmp_imu.motion.skeleton.forward_kinematics`.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

_AXES = {"X": 0, "Y": 1, "Z": 2}


def axis_angle(axis: str, angle: np.ndarray) -> np.ndarray:
    """Quaternions (..., 4) of rotations by `angle` (rad) about a principal axis 'X', 'Y' or 'Z'."""
    angle = np.asarray(angle, dtype=float)
    q = np.zeros(angle.shape + (4,))
    q[..., _AXES[axis]] = np.sin(0.5 * angle)
    q[..., 3] = np.cos(0.5 * angle)
    return q


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b (apply b first, then a), broadcasting over leading axes."""
    ax, ay, az, aw = a[..., 0], a[..., 1], a[..., 2], a[..., 3]
    bx, by, bz, bw = b[..., 0], b[..., 1], b[..., 2], b[..., 3]
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=-1,
    )


def compose(*quats: np.ndarray) -> np.ndarray:
    """q1 * q2 * ... (intrinsic sequence: the last one applies first)."""
    out = quats[0]
    for q in quats[1:]:
        out = multiply(out, q)
    return out


def euler(seq: str, *angles: np.ndarray) -> np.ndarray:
    """Intrinsic rotation sequence, e.g. euler('YXZ', a, b, c) = Ry(a) * Rx(b) * Rz(c)."""
    return compose(*(axis_angle(axis, ang) for axis, ang in zip(seq, angles, strict=True)))


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) by unit quaternions q (..., 4)."""
    u = q[..., :3]
    w = q[..., 3:4]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """np.cross of (..., 3) vectors, term for term (the same values) without its per-call overhead."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


@lru_cache(maxsize=32)
def _levels(parents: tuple[int, ...]) -> tuple[tuple[np.ndarray, np.ndarray], ...]:
    """(joints, their parents) per depth below the roots, shallowest first."""
    depth: list[int] = []
    for p in parents:
        depth.append(0 if p < 0 else depth[p] + 1)
    return tuple((np.flatnonzero(np.array(depth) == d), np.array(parents)[np.array(depth) == d])
                 for d in range(1, max(depth, default=0) + 1))


def forward_kinematics(offsets: np.ndarray, parents: tuple[int, ...], local: np.ndarray,
                       root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, J, 3) and global quaternions (T, J, 4) from local quaternions (T, J, 4).

    Same contract as `vsmp_imu.motion.skeleton.forward_kinematics`, in plain numpy; the joints
    of one depth are composed together (each with its parent, already done).
    """
    t, j = local.shape[:2]
    glob = np.empty((t, j, 4))
    pos = np.empty((t, j, 3))
    for k in (k for k, p in enumerate(parents) if p < 0):
        glob[:, k] = local[:, k]
        pos[:, k] = root
    for joints, parent in _levels(tuple(parents)):
        glob[:, joints] = multiply(glob[:, parent], local[:, joints])
        offset = np.broadcast_to(offsets[joints], (t, len(joints), 3))
        pos[:, joints] = pos[:, parent] + rotate(glob[:, parent], offset)
    norm = np.linalg.norm(glob, axis=-1, keepdims=True)
    glob = glob / norm
    # canonical sign (w >= 0), as scipy returns
    glob = np.where(glob[..., 3:4] < 0, -glob, glob)
    return pos, glob
