"""The intensity spread of classes without real windows (grounding.intensity)."""

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.grounding.intensity import spread_channels, spread_intensity
from vsmp_imu.pipeline.spec import GenerationSpec, intensity_bounds

CHANNELS = ("acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z")


def windows(n=40, t=50, seed=0):
    rng = np.random.default_rng(seed)
    base = np.array([0.0, 0.0, 1.0, 0.2, -0.1, 0.0])  # gravity on z, a steady turn on the gyroscope
    return (base + 0.3 * rng.standard_normal((n, t, 6))).astype(np.float32)


def test_the_bounds_read_off_or_a_range_and_refuse_anything_else():
    assert intensity_bounds("off") is None and intensity_bounds(None) is None
    assert intensity_bounds("0.7,2") == (0.7, 2.0)
    assert intensity_bounds("1,1") == (1.0, 1.0)
    for bad in ("2,1", "0,2", "-1,2", "a,b", "1", "1,2,3", "nan,2", "1,inf"):
        with pytest.raises(ConfigError, match="intensity range"):
            intensity_bounds(bad)
    assert GenerationSpec(unseen_intensity=[0.5, 1.5]).unseen_intensity == (0.5, 1.5)  # as records store it
    with pytest.raises(ConfigError):
        GenerationSpec(unseen_intensity=(2.0, 1.0))


def test_the_factor_scales_the_gyroscope_around_each_windows_mean_and_keeps_the_rest():
    X = windows()
    mask = np.arange(len(X)) % 2 == 0
    out, f = spread_intensity(X, mask, (0.7, 2.0), spread_channels(CHANNELS), np.random.default_rng(1))
    assert np.isnan(f[~mask]).all() and ((f[mask] >= 0.7) & (f[mask] <= 2.0)).all()
    np.testing.assert_array_equal(out[~mask], X[~mask])  # unmasked windows untouched
    np.testing.assert_array_equal(out[:, :, :3], X[:, :, :3])  # accelerometer untouched
    np.testing.assert_allclose(out[:, :, 3:].mean(axis=1), X[:, :, 3:].mean(axis=1), atol=1e-5)  # means kept
    ratio = out[mask][:, :, 3:].std(axis=1) / X[mask][:, :, 3:].std(axis=1)
    np.testing.assert_allclose(ratio, np.repeat(f[mask][:, None], 3, axis=1), rtol=1e-4)
    assert f[mask].std() > 0.2  # a spread, not one gain


def test_without_a_gyroscope_every_channel_is_scaled():
    assert spread_channels(CHANNELS).tolist() == [3, 4, 5]
    assert spread_channels(("wrist_acc_x", "wrist_acc_y", "wrist_acc_z")).tolist() == [0, 1, 2]


def test_a_windows_factor_does_not_depend_on_which_others_are_spread():
    X = windows()
    a = np.zeros(len(X), bool)
    a[:10] = True
    b = a.copy()
    b[30:] = True
    _, fa = spread_intensity(X, a, (0.7, 2.0), np.array([3, 4, 5]), np.random.default_rng(5))
    _, fb = spread_intensity(X, b, (0.7, 2.0), np.array([3, 4, 5]), np.random.default_rng(5))
    np.testing.assert_array_equal(fa[:10], fb[:10])


def test_generate_prints_the_spread_of_each_class_without_real_windows():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "intensity_spread": {
        "STAND_TO_SIT": {"bounds": [0.7, 2.0], "windows": 12, "channels": ["gyr_x", "gyr_y", "gyr_z"],
                         "median": 1.31}}}
    with console.capture() as captured:
        _print_summary(summary)
    assert ("intensity spread STAND_TO_SIT (no real windows): 12 windows x U(0.7, 2) on gyr_x, gyr_y, gyr_z, "
            "median 1.31") in " ".join(captured.get().split())
