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
