"""Step 2 of the simulation: sensor readings for N candidate parameter sets at once.

For candidate n with mounting M_n (sensor <- segment), biases b_a, b_w, noise
scales k_a, k_w and gravity flag g_n:

    acc_n = M_n (acc_lin_seg + g_n * grav_seg) + b_a,n + k_a,n * noise_acc
    gyr_n = M_n gyr_seg + b_w,n + k_w,n * noise_gyr

noise_acc, noise_gyr are the nominal noise series of one `ImuNoise` draw,
shared by all candidates (common random numbers): candidates differ only by
their parameters. g_n = False gives the linear-acceleration convention.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.kinematics import SegmentKinematics
from vsmp_imu.imu.sensor import ImuNoise


def _as_stack(value, tail: tuple[int, ...], name: str, default) -> np.ndarray:
    """value as (N, *tail) with N >= 1 (a single value gives N = 1)."""
    if value is None:
        value = default
    if isinstance(value, Rotation):
        value = value.as_matrix()
    arr = np.asarray(value, dtype=float)
    if arr.shape == tail:
        arr = arr[None]
    if arr.ndim != len(tail) + 1 or arr.shape[1:] != tail:
        raise ValidationError(f"expected shape {tail} or (N, {', '.join(map(str, tail))}), "
                              f"got {arr.shape}", field=name)
    return arr


def _as_vector(value, name: str, dtype) -> np.ndarray:
    """A scalar or (N,) as a 1-D array."""
    arr = np.atleast_1d(np.asarray(value, dtype=dtype))
    if arr.ndim != 1 or arr.size == 0:
        raise ValidationError(f"expected a scalar or (N,), got shape {np.shape(value)}", field=name)
    return arr


def _broadcast_n(arrays: dict[str, np.ndarray]) -> int:
    sizes = {len(a) for a in arrays.values()} - {1}
    if len(sizes) > 1:
        detail = ", ".join(f"{k}: {len(a)}" for k, a in arrays.items())
        raise ValidationError(f"candidate counts disagree ({detail})", field="candidates")
    return sizes.pop() if sizes else 1


def reading_features(kin: SegmentKinematics, noise: ImuNoise | None = None) -> np.ndarray:
    """Segment-frame features (T, F): [acc_lin(3), grav(3), gyr(3), 1, noise_acc(3), noise_gyr(3)].

    Readings are linear in them: readings = features @ weights (see `reading_weights`).
    Without noise the last six columns are absent (F = 10).
    """
    if noise is not None and noise.n_samples != kin.n_samples:
        raise ValidationError(f"noise has {noise.n_samples} samples, kinematics {kin.n_samples}",
                              field="noise")
    columns = [kin.acc_lin_seg, kin.grav_seg, kin.gyr_seg, np.ones((kin.n_samples, 1))]
    if noise is not None:
        columns += [noise.acc, noise.gyr]
    return np.concatenate(columns, axis=1)


def reading_weights(
    mounting=None,
    acc_bias=None,
    gyr_bias=None,
    acc_noise_scale=1.0,
    gyr_noise_scale=1.0,
    gravity_included=True,
    with_noise: bool = True,
) -> np.ndarray:
    """Weights (N, F, 6) mapping `reading_features` to the readings of N candidates.

    They hold M^T (v_sensor = M v_seg for row vectors), the gravity flags, the
    biases and the noise scales. Arguments as in `sensor_readings`.
    """
    mats = _as_stack(mounting, (3, 3), "mounting", np.eye(3))
    b_a = _as_stack(acc_bias, (3,), "acc_bias", np.zeros(3))
    b_w = _as_stack(gyr_bias, (3,), "gyr_bias", np.zeros(3))
    k_a = _as_vector(acc_noise_scale, "acc_noise_scale", float)
    k_w = _as_vector(gyr_noise_scale, "gyr_noise_scale", float)
    grav = _as_vector(gravity_included, "gravity_included", bool)
    _broadcast_n({"mounting": mats, "acc_bias": b_a, "gyr_bias": b_w,
                  "acc_noise_scale": k_a, "gyr_noise_scale": k_w, "gravity_included": grav})
    return fill_weights(mats, b_a, b_w, k_a, k_w, grav, with_noise)


def fill_weights(mats, b_a, b_w, k_a, k_w, grav, with_noise: bool) -> np.ndarray:
    """`reading_weights` on arrays already checked: mats (N|1, 3, 3), biases (N|1, 3),
    scales and gravity flags (N|1,). The CEM's inner loop calls this directly."""
    n = max(len(mats), len(b_a), len(b_w), len(k_a), len(k_w), len(grav))
    weights = np.zeros((n, 16 if with_noise else 10, 6))
    mt = np.broadcast_to(mats.transpose(0, 2, 1), (n, 3, 3))  # [n, j, i] = M_n[i, j]
    weights[:, 0:3, 0:3] = mt
    weights[:, 3:6, 0:3] = mt * grav[:, None, None]
    weights[:, 6:9, 3:6] = mt
    weights[:, 9, 0:3] = b_a
    weights[:, 9, 3:6] = b_w
    if with_noise:
        axis = np.arange(3)
        weights[:, 10 + axis, axis] = np.broadcast_to(k_a[:, None], (n, 3))
        weights[:, 13 + axis, 3 + axis] = np.broadcast_to(k_w[:, None], (n, 3))
    return weights


def channel_weights(mats, b_a, b_w, k_a, k_w, grav, with_noise: bool) -> tuple[np.ndarray, np.ndarray]:
    """`fill_weights` channel by channel without its zeros: (cols (6, N, k), features (6, k)), with
    cols[c, n, i] = fill_weights(...)[n, features[c, i], c]. An accelerometer channel reads the
    segment acceleration, gravity, its bias and its noise; a gyroscope channel the angular rate,
    its bias and its noise, padded to the same k with features it weights zero."""
    n = max(len(mats), len(b_a), len(b_w), len(k_a), len(k_w), len(grav))
    m = np.broadcast_to(mats, (n, 3, 3)).transpose(1, 0, 2)  # [j, n, :] = M_n[j, :]
    k = 8 if with_noise else 7
    cols = np.zeros((6, n, k))
    cols[0:3, :, 0:3] = m
    cols[0:3, :, 3:6] = m * np.asarray(grav, dtype=float)[None, :, None]
    cols[0:3, :, 6] = np.broadcast_to(b_a, (n, 3)).T
    cols[3:6, :, 0:3] = m
    cols[3:6, :, 3] = np.broadcast_to(b_w, (n, 3)).T
    if with_noise:
        cols[0:3, :, 7] = k_a
        cols[3:6, :, 4] = k_w
    return cols, _CHANNEL_FEATURES[with_noise]


# the features each channel reads, in `channel_weights`'s order (gyroscope rows padded with 0, 1, 2)
_CHANNEL_FEATURES = {
    True: np.array([[0, 1, 2, 3, 4, 5, 9, 10 + j] for j in range(3)]
                   + [[6, 7, 8, 9, 13 + j, 0, 1, 2] for j in range(3)]),
    False: np.array([[0, 1, 2, 3, 4, 5, 9]] * 3 + [[6, 7, 8, 9, 0, 1, 2]] * 3),
}


def sensor_readings(
    kin: SegmentKinematics,
    mounting=None,
    acc_bias=None,
    gyr_bias=None,
    acc_noise_scale=1.0,
    gyr_noise_scale=1.0,
    gravity_included=True,
    noise: ImuNoise | None = None,
) -> np.ndarray:
    """Readings (N, T, 6) [acc_x..z, gyr_x..z] for N candidates (see module doc).

    mounting: (3, 3) or (N, 3, 3) rotation matrices, or a scipy Rotation (identity when None);
    acc_bias, gyr_bias: (3,) or (N, 3); noise scales and gravity flag: scalar or (N,);
    noise: pre-drawn noise, or None for exact kinematics (scales are then ignored).
    """
    features = reading_features(kin, noise)
    weights = reading_weights(mounting, acc_bias, gyr_bias, acc_noise_scale, gyr_noise_scale,
                              gravity_included, with_noise=noise is not None)
    n = weights.shape[0]
    # One product for all candidates: (T, F) @ (F, N * 6).
    flat = weights.transpose(1, 0, 2).reshape(features.shape[1], n * 6)
    out = (features @ flat).reshape(kin.n_samples, n, 6)
    return np.ascontiguousarray(out.transpose(1, 0, 2))
