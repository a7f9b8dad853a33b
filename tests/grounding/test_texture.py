"""Movement texture (grounding.texture): ratios from real windows, texture only where it lacks."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.texture import (
    HF_BAND_HZ,
    LF_BAND_HZ,
    MAX_YAW_SHARE,
    TextureModel,
    add_yaw,
    bands,
    yaw_energy,
)

FS = 50.0


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def _sines(n: int, t: int, lf_amp: float, hf_amp: float, rng) -> np.ndarray:
    """(n, t, 2) windows: a 1 Hz sine of lf_amp plus a 6 Hz sine of hf_amp, random phases."""
    time = np.arange(t) / FS
    phase = rng.uniform(0, 2 * np.pi, size=(n, 1, 2))
    return (lf_amp * np.sin(2 * np.pi * 1.0 * time[None, :, None] + phase)
            + hf_amp * np.sin(2 * np.pi * 6.0 * time[None, :, None] + 2 * phase))


def _band_std(x: np.ndarray, band) -> np.ndarray:
    sos = butter(4, band, btype="band", fs=FS, output="sos")
    return sosfiltfilt(sos, x, axis=0).std(axis=0)


def test_kappa_is_the_hf_to_lf_amplitude_ratio_per_class_and_pooled(rng):
    a = _sines(30, 200, 1.0, 0.5, rng)  # class 0: ratio 0.5
    b = _sines(30, 200, 2.0, 0.4, rng)  # class 1: ratio 0.2
    c = _sines(5, 200, 1.0, 1.0, rng)  # class 2: too few windows for its own
    model = TextureModel(FS, min_class_windows=20).fit(np.concatenate([a, b, c]), np.repeat([0, 1, 2], [30, 30, 5]))
    assert model.kappa(0) == pytest.approx([0.5, 0.5], rel=0.05)
    assert model.kappa(1) == pytest.approx([0.2, 0.2], rel=0.05)
    # pooled: energy-weighted, so the class with the larger motion (b) weighs more
    pooled = np.sqrt((30 * 0.25 + 30 * 0.16 + 5 * 1.0) / (30 * 1 + 30 * 4 + 5 * 1))
    assert model.kappa(2) == pytest.approx([pooled, pooled], rel=0.05)
    assert model.kappa(7) is model.pooled_  # a class never seen (the unseen protocol)
    assert [model.mapping(i) for i in (0, 1, 2, 7)] == ["class", "class", "pooled", "pooled"]


def test_a_smooth_motion_gets_the_hf_share_the_real_windows_have(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    smooth = _sines(1, 1000, 1.0, 0.0, rng)[0]
    out = model.apply(smooth, 0, np.random.default_rng(1))
    ratio = _band_std(out, HF_BAND_HZ) / _band_std(out, LF_BAND_HZ)
    np.testing.assert_allclose(ratio, 0.5, rtol=0.15)
    # the motion itself is kept: what was added lies above it
    assert (_band_std(out - smooth, (0.3, 1.5)) < 0.05 * _band_std(smooth, (0.3, 1.5))).all()


def test_nothing_is_added_to_a_still_signal_or_to_one_with_texture_enough(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.3, rng), np.zeros(40, int))
    still = np.full((500, 2), 9.81)
    assert np.abs(model.apply(still, 0, np.random.default_rng(0)) - still).max() < 1e-6
    rough = _sines(1, 500, 1.0, 0.6, rng)[0]  # HF above kappa x LF everywhere
    assert np.abs(model.apply(rough, 0, np.random.default_rng(0)) - rough).max() < 0.02


def test_the_texture_follows_the_motion_in_time(rng):
    """A posture, then a movement: texture only where the movement is."""
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    signal = np.zeros((1000, 2))
    signal[500:] = _sines(1, 500, 1.0, 0.0, rng)[0]
    added = model.apply(signal, 0, np.random.default_rng(0)) - signal
    assert np.abs(added[:400]).max() < 0.01 * np.abs(added[600:]).max()


def test_same_generator_same_bytes_and_unfitted_or_unfilterable_left_alone(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    x = _sines(1, 400, 1.0, 0.0, rng)[0]
    one = model.apply(x, 0, np.random.default_rng(5))
    assert one.tobytes() == model.apply(x, 0, np.random.default_rng(5)).tobytes()
    assert one.tobytes() != model.apply(x, 0, np.random.default_rng(6)).tobytes()
    assert np.array_equal(TextureModel(FS).apply(x, 0, rng), x)  # nothing fitted
    assert TextureModel(FS).mapping(0) == "none"
    assert np.array_equal(model.apply(x[:20], 0, rng), x[:20])  # too short to filter
    slow = TextureModel(6.0).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))  # no HF band at 6 Hz
    assert bands(6.0) is None and slow.pooled_ is None
    assert bands(20.0)[1][1] == pytest.approx(9.0)  # the HF band stops below the Nyquist rate


def test_channel_and_shape_errors_name_the_field(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    with pytest.raises(ValidationError, match="channels"):
        model.apply(np.zeros((400, 3)), 0, rng)
    with pytest.raises(ValidationError, match=r"\(N, T, C\)"):
        TextureModel(FS).fit(np.zeros((40, 200)), np.zeros(40, int))


# -- rotation about the vertical ------------------------------------------------------------------
AXES = ((0, 1, 2), (3, 4, 5))


def _turning(n: int, t: int, up: np.ndarray, pitch: float, yaw: float, rng) -> np.ndarray:
    """(n, t, 6) windows of a sensor whose up axis is `up` (gravity read there), rotating at 1 Hz
    with amplitude `pitch` about an axis square to `up` and `yaw` about `up`."""
    up = up / np.linalg.norm(up)
    side = np.cross(up, [0.0, 0.0, 1.0] if abs(up[2]) < 0.9 else [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    time = np.arange(t) / FS
    phase = rng.uniform(0, 2 * np.pi, size=(n, 1, 1))
    w = (pitch * np.sin(2 * np.pi * time[None, :, None] + phase) * side
         + yaw * np.sin(2 * np.pi * 1.3 * time[None, :, None] + 2 * phase) * up)
    acc = np.broadcast_to(9.81 * up, (n, t, 3))
    return np.concatenate([acc, w], axis=2)


def _share(x: np.ndarray) -> float:
    yaw, total = yaw_energy(x[None], AXES, FS)
    return float(np.sqrt(yaw.sum() / total.sum()))


def test_the_yaw_share_is_the_rotation_about_the_vertical_per_class_and_pooled(rng):
    up = np.array([1.0, 0.2, -0.1])  # a sensor mounted a little tilted
    a = _turning(30, 200, up, 0.4, 0.3, rng)  # share 0.6
    b = _turning(30, 200, up, 0.5, 0.0, rng)  # share 0
    model = TextureModel(FS, axes=AXES).fit(np.concatenate([a, b]), np.repeat([0, 1], 30))
    assert model.yaw_share(0) == pytest.approx(0.6, abs=0.03)
    assert model.yaw_share(1) == pytest.approx(0.0, abs=0.02)
    pooled = np.sqrt(30 * 0.09 / (30 * 0.25 + 30 * 0.25))  # energy-weighted
    assert model.yaw_share(5) == pytest.approx(pooled, abs=0.03)
    assert model.as_dict(["a", "b"])["yaw_share"]["classes"]["a"] == pytest.approx(0.6, abs=0.03)
    assert TextureModel(FS).fit(a, np.zeros(30, int)).yaw_share(0) is None  # no axes: none fitted


@pytest.mark.parametrize("up", [np.array([1.0, 0.0, 0.0]), np.array([0.1, 0.7, 0.7])])
def test_a_rotation_in_one_plane_gets_the_share_about_the_vertical_the_real_windows_have(up, rng):
    """Whatever axis is up (upright or lying), the added rotation is about it: the accelerometer and
    the rotation square to the vertical stay as they were, and the share reaches rho."""
    planar = _turning(1, 1000, up, 0.5, 0.0, rng)[0]
    assert _share(planar) < 0.01
    out = add_yaw(planar, AXES, 0.6, FS, np.random.default_rng(1))
    assert _share(out) == pytest.approx(0.6, abs=0.08)
    assert np.array_equal(out[:, :3], planar[:, :3])
    added = out[:, 3:] - planar[:, 3:]
    unit = up / np.linalg.norm(up)
    assert np.abs(added - np.outer(added @ unit, unit)).max() < 1e-9
    # below 2 Hz: what was added has little 3-12 Hz energy
    assert _band_std(added, HF_BAND_HZ).max() < 0.1 * _band_std(added, (0.3, 2.0)).max()


def test_nothing_is_turned_that_is_still_or_turns_enough_and_same_generator_same_bytes(rng):
    up = np.array([1.0, 0.0, 0.0])
    still = _turning(1, 500, up, 0.0, 0.0, rng)[0]
    assert np.abs(add_yaw(still, AXES, 0.6, FS, rng) - still).max() < 1e-9
    turning = _turning(1, 500, up, 0.3, 0.4, rng)[0]  # share 0.8 > 0.6
    assert np.abs(add_yaw(turning, AXES, 0.6, FS, rng) - turning).max() < 0.02
    planar = _turning(1, 500, up, 0.5, 0.0, rng)[0]
    one = add_yaw(planar, AXES, 0.6, FS, np.random.default_rng(3))
    assert one.tobytes() == add_yaw(planar, AXES, 0.6, FS, np.random.default_rng(3)).tobytes()
    assert np.array_equal(add_yaw(planar, None, 0.6, FS, rng), planar)  # no gyroscope
    assert np.array_equal(add_yaw(planar, AXES, None, FS, rng), planar)  # nothing fitted
    assert np.array_equal(add_yaw(planar[:20], AXES, 0.6, FS, rng), planar[:20])  # too short
    # a share near 1 is capped, so the noise stays bounded
    capped = add_yaw(planar, AXES, 0.999, FS, np.random.default_rng(3))
    assert _share(capped) == pytest.approx(MAX_YAW_SHARE, abs=0.08)


def test_imu_axes_finds_the_columns_of_a_location():
    from vsmp_imu.pipeline.fold import imu_axes

    assert imu_axes(("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")) == AXES
    assert imu_axes(("wrist_gyr_x", "wrist_gyr_y", "wrist_gyr_z", "wrist_acc_x", "wrist_acc_y",
                     "wrist_acc_z")) == ((3, 4, 5), (0, 1, 2))
    assert imu_axes(("acc_x", "acc_y", "acc_z")) is None
