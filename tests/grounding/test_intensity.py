"""The intensity spread of classes without real windows, and the spread matched to the real
windows of classes with them (grounding.intensity)."""

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.grounding.intensity import (
    MATCH_MIN_WINDOWS,
    log_intensity,
    match_factors,
    missing_spread,
    scale_deviations,
    spread_channels,
    spread_intensity,
)
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
    assert intensity_bounds("0.1,10") == (0.1, 10.0)
    for bad in ("2,1", "0,2", "-1,2", "a,b", "1", "1,2,3", "nan,2", "1,inf", "1,1e9", "0.5,10.5"):
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


def with_intensities(log_sd, n=400, seed=0):
    """Windows whose gyroscope's RMS deviation has a log standard deviation of `log_sd` (log-normal)."""
    X = windows(n, seed=seed)
    rng = np.random.default_rng(seed + 100)
    gains = np.exp(log_sd * rng.standard_normal(n))
    return scale_deviations(X, gains, np.array([3, 4, 5]))


def test_the_missing_spread_is_what_the_real_windows_have_beyond_the_synthetic_ones():
    gyro = np.array([3, 4, 5])
    real, narrow = with_intensities(0.5, seed=1), with_intensities(0.2, seed=2)
    spread = missing_spread(real, narrow, gyro)
    expected = np.sqrt(log_intensity(real, gyro).var() - log_intensity(narrow, gyro).var())
    assert spread == pytest.approx(expected) and 0.35 < spread < 0.55
    assert missing_spread(narrow, real, gyro) == 0.0  # synthetic already wider: nothing added
    assert missing_spread(real[: MATCH_MIN_WINDOWS - 1], narrow, gyro) == 0.0  # too few real windows
    assert missing_spread(real, narrow[: MATCH_MIN_WINDOWS - 1], gyro) == 0.0


def test_matched_windows_take_the_real_spread_and_keep_their_median():
    gyro = np.array([3, 4, 5])
    real, synthetic = with_intensities(0.5, seed=3), with_intensities(0.2, seed=4)
    spread = missing_spread(real, synthetic, gyro)
    mask = np.ones(len(synthetic), bool)
    mask[:50] = False
    z = np.random.default_rng(7).standard_normal(len(synthetic))
    factors = match_factors(mask, spread, z)
    assert np.isnan(factors[:50]).all()
    out = scale_deviations(synthetic, factors, gyro)
    np.testing.assert_array_equal(out[:50], synthetic[:50])  # unmasked windows untouched
    np.testing.assert_array_equal(out[:, :, :3], synthetic[:, :, :3])  # accelerometer untouched
    before, after = log_intensity(synthetic[mask], gyro), log_intensity(out[mask], gyro)
    assert abs(after.std() - log_intensity(real, gyro).std()) < 0.05  # as wide as the real windows
    assert before.std() < 0.25
    assert abs(np.median(after) - np.median(before)) < 0.06  # centred where it was
    np.testing.assert_allclose(after - before, np.log(factors[mask]), atol=1e-4)


def test_match_factors_are_clipped_and_one_where_nothing_is_missing():
    mask = np.ones(3, bool)
    z = np.array([-10.0, 0.0, 10.0])
    np.testing.assert_allclose(match_factors(mask, 0.4, z), np.exp(0.4 * np.array([-2.5, 0.0, 2.5])))
    np.testing.assert_array_equal(match_factors(mask, 0.0, z), np.ones(3))


def test_generate_prints_the_spread_matched_to_each_classes_real_windows():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "intensity_match": {
        "SIT_TO_STAND": {"spread": 0.37, "real_windows": 157, "windows": 47},
        "SITTING": {"spread": 0.0, "real_windows": 2232, "windows": 669}}}
    with console.capture() as captured:
        _print_summary(summary)
    assert ("intensity matched to the real windows: log spread added SIT_TO_STAND 0.37; none for 1 (as wide "
            "already, or too few windows)") in " ".join(captured.get().split())


def test_the_log_intensity_is_the_log_rms_length_of_the_deviation_vector():
    X = np.zeros((2, 4, 6))
    X[0, :, 3:] = 0.5 + np.array([1.0, -1.0, 1.0, -1.0])[:, None] * [0.3, 0.3, 0.3]  # |dev| = 0.3 sqrt(3)
    X[1, :, 3] = [2.0, 4.0, 2.0, 4.0]  # |dev| = 1 on one channel only
    X[1, :, 4:] = -1.0
    X[:, :, :3] = np.arange(4.0)[:, None]  # the accelerometer is not counted
    np.testing.assert_allclose(log_intensity(X, np.array([3, 4, 5])), [np.log(0.3 * np.sqrt(3.0)), 0.0],
                               atol=1e-8)


def test_a_still_window_has_a_finite_log_intensity():
    X = windows(n=3)
    X[1, :, 3:] = 0.25  # the gyroscope at rest: no deviation at all
    got = log_intensity(X, np.array([3, 4, 5]))
    assert np.isfinite(got).all()
    assert got[1] == pytest.approx(np.log(1e-9))
    real = with_intensities(0.5, n=40, seed=5)
    real[0, :, 3:] = 0.1
    assert np.isfinite(missing_spread(real, with_intensities(0.2, n=40, seed=6), np.array([3, 4, 5])))


def test_float32_windows_give_the_float64_log_intensity():
    X = windows(n=20)  # float32, as generated windows are
    got = log_intensity(X, np.array([3, 4, 5]))
    assert got.dtype == np.float64
    np.testing.assert_array_equal(got, log_intensity(X.astype(np.float64), np.array([3, 4, 5])))


def test_the_spread_is_measured_from_exactly_the_floors_number_of_windows():
    gyro = np.array([3, 4, 5])
    real = with_intensities(0.6, n=MATCH_MIN_WINDOWS, seed=7)
    synthetic = with_intensities(0.1, n=MATCH_MIN_WINDOWS, seed=8)
    expected = np.sqrt(log_intensity(real, gyro).var() - log_intensity(synthetic, gyro).var())
    assert expected > 0.3
    assert missing_spread(real, synthetic, gyro) == pytest.approx(expected)


def test_the_spread_of_a_single_channel_and_of_none():
    real, synthetic = with_intensities(0.6, n=60, seed=9), with_intensities(0.1, n=60, seed=10)
    one = np.array([4])
    expected = np.sqrt(log_intensity(real, one).var() - log_intensity(synthetic, one).var())
    assert expected > 0.3
    assert missing_spread(real, synthetic, one) == pytest.approx(expected)
    assert missing_spread(real, synthetic, np.array([], dtype=np.int64)) == 0.0


def test_one_window_scaled_on_one_channel_moves_away_from_its_mean_by_its_factor():
    X = np.zeros((3, 4, 2))
    X[:, :, 0] = [1.0, 2.0, 3.0, 6.0]  # mean 3
    X[:, :, 1] = [5.0, 5.0, 7.0, 7.0]
    out = scale_deviations(X, np.array([np.nan, 2.0, np.nan]), np.array([0]))
    np.testing.assert_array_equal(out[1, :, 0], [-1.0, 1.0, 3.0, 9.0])  # 3 + 2 (x - 3), not mirrored
    np.testing.assert_array_equal(out[1, :, 1], X[1, :, 1])  # the other channel as it was
    np.testing.assert_array_equal(out[[0, 2]], X[[0, 2]])  # windows without a factor as they were
    shrunk = scale_deviations(X, np.array([0.5, np.nan, np.nan]), np.array([0, 1]))
    np.testing.assert_array_equal(shrunk[0], [[2.0, 5.5], [2.5, 5.5], [3.0, 6.5], [4.5, 6.5]])
