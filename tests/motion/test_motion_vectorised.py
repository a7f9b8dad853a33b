"""The vectorised motion kinematics equal their straightforward forms to the bit (same seed, same
bytes): the all-joints `dofs_to_local_quats` against the joint-by-joint `local_quats_reference`, the
component-first quaternion product, rotation and forward kinematics against `multiply`, `rotate`
and the per-depth kinematics on (T, J, 4) arrays."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.motion import quat
from vsmp_imu.motion.dofs import (
    N_DOFS,
    dofs_to_local_quats,
    local_quats_components,
    local_quats_reference,
)
from vsmp_imu.motion.skeleton import smpl22_skeleton


def _fk_per_depth(offsets, parents, local, root):
    """The forward kinematics as it was written before the component-first form: the joints of
    one depth together, on (T, J, 4) arrays with `multiply` and `rotate`."""
    t, j = local.shape[:2]
    glob = np.empty((t, j, 4))
    pos = np.empty((t, j, 3))
    for k in (k for k, p in enumerate(parents) if p < 0):
        glob[:, k] = local[:, k]
        pos[:, k] = root
    for joints, parent in quat._levels(tuple(parents)):
        glob[:, joints] = quat.multiply(glob[:, parent], local[:, joints])
        offset = np.broadcast_to(offsets[joints], (t, len(joints), 3))
        pos[:, joints] = pos[:, parent] + quat.rotate(glob[:, parent], offset)
    glob = glob / np.linalg.norm(glob, axis=-1, keepdims=True)
    return pos, np.where(glob[..., 3:4] < 0, -glob, glob)


def _with_specials(x: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """x with some exact zeros of both signs (their signs must survive as the reference's do)."""
    x = x.copy()
    x[rng.random(x.shape) < 0.1] = 0.0
    x[rng.random(x.shape) < 0.1] = -0.0
    return x


def _same_bytes(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@pytest.mark.parametrize("frames", [0, 1, 7, 240])
def test_local_quats_equal_the_joint_by_joint_form(frames):
    rng = np.random.default_rng(frames)
    values = _with_specials(rng.uniform(-200.0, 200.0, size=(frames, N_DOFS)), rng)
    fast = dofs_to_local_quats(values)
    assert _same_bytes(fast, local_quats_reference(values)) and fast.flags.c_contiguous
    assert np.array_equal(local_quats_components(values), fast.transpose(2, 1, 0))


def test_component_product_and_rotation_equal_multiply_and_rotate():
    rng = np.random.default_rng(1)
    a, b = (_with_specials(rng.normal(size=(5, 9, 4)), rng) for _ in range(2))
    assert _same_bytes(quat.multiply_components(a.transpose(2, 0, 1), b.transpose(2, 0, 1)).transpose(1, 2, 0),
                       quat.multiply(a, b))
    v = _with_specials(rng.normal(size=(5, 9, 3)), rng)
    assert _same_bytes(quat._rotate_components(a.transpose(2, 0, 1), v.transpose(2, 0, 1)).transpose(1, 2, 0),
                       quat.rotate(a, v))


@pytest.mark.parametrize("frames", [1, 60])
def test_forward_kinematics_equals_the_per_depth_form(frames):
    rng = np.random.default_rng(frames + 10)
    sk = smpl22_skeleton(1.63, rng.uniform(0.97, 1.03, 22))
    root = rng.normal(size=(frames, 3))
    for local in (dofs_to_local_quats(rng.uniform(-200.0, 200.0, size=(frames, N_DOFS))),
                  _with_specials(rng.normal(size=(frames, 22, 4)), rng)):  # not unit, some zeros
        with np.errstate(invalid="ignore", divide="ignore"):
            fast = quat.forward_kinematics(sk.offsets, sk.parents, local, root)
            ref = _fk_per_depth(sk.offsets, sk.parents, local, root)
        assert all(_same_bytes(x, y) and x.flags.c_contiguous for x, y in zip(fast, ref, strict=True))
