"""Gait cadence from real windows (grounding.cadence)."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.grounding import cadence

FS = 50.0


def _walk(rate_hz: np.ndarray, seed: int = 0, n: int = 100) -> np.ndarray:
    """Accelerometer windows of a gait: gravity on x, a bounce at the step rate with a weaker
    stride (half-rate) sway on y, and noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    out = np.zeros((len(rate_hz), n, 3))
    for i, f in enumerate(rate_hz):
        phase = rng.uniform(0, 2 * np.pi)
        out[i, :, 0] = 9.81 + 2.5 * np.sin(2 * np.pi * f * t + phase)
        out[i, :, 1] = 0.8 * np.sin(np.pi * f * t + phase)
        out[i] += rng.normal(0, 0.3, (n, 3))
    return out


def test_the_step_rate_is_the_acceleration_magnitudes_peak():
    rates = np.array([1.5, 1.7, 1.9, 2.2])
    found = cadence.step_rates(_walk(rates), FS)
    assert found == pytest.approx(rates, abs=0.06)


def test_step_rates_refuse_what_is_not_three_axis_windows():
    with pytest.raises(ValueError, match="N, T, 3"):
        cadence.step_rates(np.zeros((4, 100, 6)), FS)
    with pytest.raises(ValueError, match="cannot resolve"):
        cadence.step_rates(np.zeros((4, 100, 3)), 1.5)


def test_a_class_needs_enough_windows():
    values, reason = cadence.class_cadence(_walk(np.full(cadence.MIN_WINDOWS - 1, 1.8)), FS)
    assert len(values) == 0 and "fewer than" in reason
    assert cadence.summary(values, reason) == {"used": False, "reason": reason}
    values, reason = cadence.class_cadence(_walk(np.linspace(1.6, 2.0, 20)), FS)
    found = cadence.summary(values, reason)
    assert found["used"] and found["windows"] == 20 and 1.6 <= found["median_hz"] <= 2.0
    assert found["q10_hz"] <= found["median_hz"] <= found["q90_hz"]


def test_a_rate_too_low_for_the_step_band_keeps_the_smps_tempo():
    """Step rates reach 3 Hz: below 6 Hz the spectrum stops short of that (or of 1 Hz)."""
    acc = np.random.default_rng(0).normal(9.81, 1.0, (20, 12, 3))
    assert len(cadence.class_cadence(acc, cadence.MIN_RATE_HZ)[0]) == 20
    for fs_hz in (5.9, 1.0):
        values, reason = cadence.class_cadence(acc, fs_hz)
        assert len(values) == 0 and f"{fs_hz:g} Hz cannot resolve" in reason and "needs 6 Hz" in reason


def test_the_scale_times_a_cycle_to_the_target_and_is_clipped():
    # a 1.2 s two-step cycle steps at 1.67 /s; at 2 /s it must last 1.0 s
    assert cadence.scale_for(2.0, 2, 1.2) == pytest.approx(1.0 / 1.2)
    assert cadence.scale_for(1.0, 1, 1.0) == pytest.approx(1.0)
    assert cadence.scale_for(10.0, 2, 1.2) == cadence.SCALE_BOUNDS[0]
    assert cadence.scale_for(0.1, 2, 1.2) == cadence.SCALE_BOUNDS[1]


def test_a_draw_is_one_of_the_real_rates_and_seeded():
    rates = np.array([1.5, 1.8, 2.1])
    draws = [cadence.draw_rate(rates, np.random.default_rng(s)) for s in range(20)]
    assert set(draws) <= set(rates.tolist()) and len(set(draws)) > 1
    assert cadence.draw_rate(rates, np.random.default_rng(4)) == cadence.draw_rate(rates, np.random.default_rng(4))


def test_the_step_rate_is_read_at_the_trunk_where_there_is_one():
    assert cadence.reading_location(["left_lower_leg", "right_wrist", "chest"]) == "chest"
    assert cadence.reading_location(["right_wrist", "waist", "back"]) == "waist"
    assert cadence.reading_location(["right_wrist", "left_lower_leg"]) == "right_wrist"


def test_exactly_min_windows_are_enough():
    values, reason = cadence.class_cadence(_walk(np.full(cadence.MIN_WINDOWS, 1.8)), FS)
    assert reason == f"{cadence.MIN_WINDOWS} real windows"
    assert values == pytest.approx(np.full(cadence.MIN_WINDOWS, 1.8), abs=0.06)


def test_a_windows_rate_does_not_depend_on_the_windows_read_with_it():
    """Each window's own mean magnitude is removed: a slow, weak step read next to a window of a
    larger magnitude (another subject's sensor offset) gives the rate it gives alone."""
    t = np.arange(100) / FS
    acc = np.zeros((2, 100, 3))
    acc[0, :, 0] = 9.81 + 0.2 * np.sin(2 * np.pi * 1.2 * t)
    acc[1, :, 0] = 9.81 + 4.0 + 2.5 * np.sin(2 * np.pi * 2.0 * t)
    alone = np.r_[cadence.step_rates(acc[:1], FS), cadence.step_rates(acc[1:], FS)]
    assert alone == pytest.approx([1.2, 2.0], abs=0.03)
    assert (cadence.step_rates(acc, FS) == alone).all()


def test_float32_windows_are_read_in_float64():
    """Windows keep float32 (har.windows); the magnitude and its mean are taken in float64, so the
    rates are those of the same values held as float64, also for near-still windows whose noise
    (1e-5 m/s^2) is about ten float32 steps at gravity."""
    rng = np.random.default_rng(0)
    acc = (np.array([9.81, 0.3, -0.2]) + rng.normal(0, 1e-5, (60, 100, 3))).astype(np.float32)
    assert (cadence.step_rates(acc, FS) == cadence.step_rates(acc.astype(np.float64), FS)).all()


def test_a_window_longer_than_the_fft_is_read_whole():
    """A 40 s window (2000 samples, more than N_FFT) whose walk starts halfway: the rate is the walk's."""
    n = 2000
    assert n > cadence.N_FFT
    t = np.arange(n) / FS
    acc = np.zeros((1, n, 3))
    acc[0, :, 0] = 9.81
    acc[0, n // 2:, 0] += 2.5 * np.sin(2 * np.pi * 1.8 * t[n // 2:])
    assert cadence.step_rates(acc, FS) == pytest.approx([1.8], abs=0.01)


@pytest.mark.parametrize("rate_hz", list(cadence.BAND_HZ))
def test_the_step_band_includes_its_ends(rate_hz):
    """At 64 Hz the spectrum has a bin at exactly 1 and 3 Hz (1/16 Hz apart): a step at either end is read there."""
    fs_hz = 64.0
    t = np.arange(128) / fs_hz
    acc = np.zeros((1, 128, 3))
    acc[0, :, 0] = 9.81 + np.sin(2 * np.pi * rate_hz * t)
    assert cadence.step_rates(acc, fs_hz)[0] == rate_hz
