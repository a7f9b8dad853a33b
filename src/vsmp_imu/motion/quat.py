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


def multiply_components(a: np.ndarray, b: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """`multiply` on component-first quaternions (4, ...): a[0] is x, a[3] is w.

    The 16 products a_i * b_j in one call, then the sums of `multiply` in its order and with its
    signs (x = aw bx + ax bw + ay bz - az by, ...), two components per call: every element sees
    the operations of `multiply`, so the values are equal to the bit. `out` may be `a` or `b`.
    """
    p = np.asarray(a)[:, None] * np.asarray(b)[None]  # p[i, j] = a_i * b_j
    res = np.empty(p.shape[:1] + p.shape[2:], dtype=p.dtype)
    np.add(p[3, 0::2], p[0, 3::-2], out=res[0::2])  # x = aw bx + ax bw, z = aw bz + ax by
    np.subtract(p[3, 1::2], p[0, 2::-2], out=res[1::2])  # y = aw by - ax bz, w = aw bw - ax bx
    res[0:2] += p[1, 2:4]  # x + ay bz, y + ay bw
    res[2:4] -= p[1, 0:2]  # z - ay bx, w - ay by
    res[1:3] += p[2, 0::3]  # y + az bx, z + az bw
    res[0::3] -= p[2, 1:3]  # x - az by, w - az bz
    if out is None:
        return res
    out[...] = res
    return out


def _rotate_components(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`rotate` on component-first quaternions q (4, ...) and vectors v (3, ...), equal to the bit.

    Component i of a cross product a x b is a[i+1] b[i+2] - a[i+2] b[i+1] (indices mod 3), as in
    `_cross`; the doubled arrays give the shifted components as views.
    """
    u, w = q[:3], q[3]
    uu, vv = np.concatenate([u, u]), np.concatenate([v, v])
    t = 2.0 * (uu[1:4] * vv[2:5] - uu[2:5] * vv[1:4])
    tt = np.concatenate([t, t])
    return v + w * t + (uu[1:4] * tt[2:5] - uu[2:5] * tt[1:4])


def _index(idx: np.ndarray) -> slice | np.ndarray:
    """A slice for a run of consecutive indices (a view, no gather), else the indices."""
    if len(idx) and np.array_equal(idx, np.arange(idx[0], idx[0] + len(idx))):
        return slice(int(idx[0]), int(idx[0]) + len(idx))
    return idx


@lru_cache(maxsize=32)
def _level_index(parents: tuple[int, ...]) -> tuple[tuple[slice | np.ndarray, slice | np.ndarray], ...]:
    return tuple((_index(joints), _index(parent)) for joints, parent in _levels(parents))


def forward_kinematics(offsets: np.ndarray, parents: tuple[int, ...], local: np.ndarray,
                       root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (T, J, 3) and global quaternions (T, J, 4) from local quaternions (T, J, 4).

    Same contract as `vsmp_imu.motion.skeleton.forward_kinematics`, in plain numpy; the joints
    of one depth are composed together (each with its parent, already done), on component-first
    arrays (4, J, T) so each component is one contiguous block. Every element sees the
    operations of `multiply` and `rotate` in their order (equal to the bit to the per-depth form
    on (T, J, 4) arrays; tests/motion/test_motion_vectorised.py).
    """
    local = np.asarray(local)
    return forward_kinematics_components(offsets, parents, np.ascontiguousarray(local.transpose(2, 1, 0)), root)


def forward_kinematics_components(offsets: np.ndarray, parents: tuple[int, ...], local: np.ndarray,
                                  root: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`forward_kinematics` of component-first local quaternions (4, J, T).

    The global rotations go depth by depth; the bone offsets are then rotated by the parents'
    rotations for all joints in one call, and summed down the tree depth by depth.
    """
    j, t = local.shape[1:]
    glob = np.empty((4, j, t))
    pos = np.empty((3, j, t))
    roots = [k for k, p in enumerate(parents) if p < 0]
    glob[:, roots] = local[:, roots]
    pos[:, roots] = np.broadcast_to(root, (t, 3)).T[:, None, :]
    levels = _level_index(tuple(parents))
    for joints, parent in levels:
        glob[:, joints] = multiply_components(glob[:, parent], local[:, joints])
    children = np.array([k for k, p in enumerate(parents) if p >= 0], dtype=int)
    bones = np.empty((3, j, t))
    # the offsets spelled out over the frames: contiguous operands take numpy's fast loops
    offset = np.repeat(np.asarray(offsets)[children].T[:, :, None], t, axis=2)
    bones[:, children] = _rotate_components(glob[:, np.asarray(parents)[children]], offset)
    for joints, parent in levels:
        pos[:, joints] = pos[:, parent] + bones[:, joints]
    # unit length: the sum of squares of np.linalg.norm over the 4 components, in its order (x, y, z,
    # w; the test against the per-depth form holds this numpy to it)
    glob /= np.sqrt(glob[0] * glob[0] + glob[1] * glob[1] + glob[2] * glob[2] + glob[3] * glob[3])
    # canonical sign (w >= 0), as scipy returns
    np.negative(glob, out=glob, where=glob[3] < 0)
    return np.ascontiguousarray(pos.transpose(2, 1, 0)), np.ascontiguousarray(glob.transpose(2, 1, 0))
