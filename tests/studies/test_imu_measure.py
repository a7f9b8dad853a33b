"""IMU-side control measurements on signals with known cycles, energies and phases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from vsmp_imu.errors import ValidationError
from vsmp_imu.studies import imu_measure as im
from vsmp_imu.units import STANDARD_GRAVITY_M_S2 as G

FS = 50.0


def recording(duration_s: float, rest_s: float = 0.5) -> np.ndarray:
    """(T, 6) zeros with gravity on acc_y and a rest at both ends."""
    n = int(round((duration_s + 2 * rest_s) * FS))
    x = np.zeros((n, 6))
    x[:, 1] = G
    return x


def add_cycles(x: np.ndarray, channel: int, freq_hz: float, cycles: int, amp: float,
               rest_s: float = 0.5, double: bool = False) -> np.ndarray:
    """`cycles` excursions (1 - cos) on a channel after `rest_s`; `double` adds an extremum."""
    t = np.arange(len(x)) / FS - rest_s
    active = (t >= 0) & (t < cycles / freq_hz)
    phase = 2 * np.pi * freq_hz * t[active]
    wave = 1 - np.cos(phase)
    if double:  # out and back: a second, smaller bump inside every cycle
        wave = wave + 0.7 * (1 - np.cos(2 * phase))
    x[active, channel] += amp * wave
    return x


def moving_segment(freq: float, cycles: int, main: int, seed: int) -> np.ndarray:
    """Every channel sees the movement (as on a real segment): `main` strongly, the others
    weakly and phase-shifted; gyroscope cycles are zero-mean, accelerometer ones are excursions."""
    rng = np.random.default_rng(seed)
    x = recording(cycles / freq)
    t = np.arange(len(x)) / FS - 0.5
    active = (t >= 0) & (t < cycles / freq)
    for c in range(6):
        gain = 2.0 if c == main else rng.uniform(0.1, 0.4)
        phase = 2 * np.pi * freq * t[active] + (0.0 if c == main else rng.uniform(0, 2 * np.pi))
        x[active, c] += gain * (np.sin(phase) if c >= 3 else 1 - np.cos(phase))
    # sensor noise of the simulator's order (0.021 m/s^2, 0.0012 rad/s at 50 Hz), a bit more
    return x + rng.normal(0, 1, x.shape) * np.array([0.03, 0.03, 0.03, 0.003, 0.003, 0.003])


@settings(max_examples=25, deadline=None)
@given(freq=st.floats(0.5, 2.0), cycles=st.integers(3, 9), main=st.integers(0, 5),
       seed=st.integers(0, 1000))
@example(freq=1.0, cycles=3, main=0, seed=207)  # found by Hypothesis: 3.2 % off
def test_repetitions_and_tempo_of_clean_cycles(freq, cycles, main, seed):
    """Within one cycle: a phase-shifted channel may start or end with a partial cycle. The
    tempo within 3 % from four cycles on. Three cycles between rests leave the biased
    autocorrelation's period peak early (its triangular taper), by up to 3.9 % of the
    frequency over 2 500 random cases of this test's domain: the bound there is 5 %."""
    x = moving_segment(freq, cycles, main, seed)
    reps = im.count_repetitions(x, FS)
    assert abs(reps.count - cycles) <= 1
    tolerance = 0.05 if cycles == 3 else 0.03
    assert im.tempo_measure(x, FS, periodic=True) == pytest.approx(freq, rel=tolerance)


@pytest.mark.parametrize("cycles", [3, 6, 9])
def test_exact_count_on_one_moving_channel(cycles):
    x = add_cycles(recording(cycles / 1.2), 2, 1.2, cycles, amp=2.0)
    x += np.random.default_rng(cycles).normal(0, 0.01, x.shape) * np.array([1, 1, 0, 1, 1, 1])
    reps = im.count_repetitions(x, FS)
    assert (reps.count, reps.channel) == (cycles, 2)
    assert reps.peak_times_s[0] == pytest.approx(0.5 + 0.5 / 1.2, abs=0.05)


def test_two_extrema_per_cycle_count_once():
    """A punch's extension and retraction give two peaks per cycle; the period rule keeps one."""
    x = add_cycles(recording(6.0), 3, 1.0, 6, amp=1.5, double=True)
    s = x[:, 3]
    from scipy.signal import find_peaks

    naive, _ = find_peaks(s, prominence=0.4 * s.std(), distance=int(0.35 * FS))
    assert len(naive) == 12  # what the 0.35 s rule alone would count
    assert im.count_repetitions(x, FS).count == 6
    assert im.cycle_frequency_hz(x, FS) == pytest.approx(1.0, rel=0.02)


def test_the_period_is_not_a_multiple_of_the_cycle():
    """Alternate cycles of slightly different height: the first autocorrelation peak wins."""
    x = recording(8.0)
    for k in range(8):
        seg = add_cycles(np.zeros_like(x), 4, 1.0, 1, amp=1.0 if k % 2 else 0.8, rest_s=0.5 + k)
        x += seg
    assert im.cycle_frequency_hz(x, FS) == pytest.approx(1.0, rel=0.03)


def test_aperiodic_channels_do_not_move_the_period():
    rng = np.random.default_rng(3)
    x = add_cycles(recording(8.0), 0, 0.8, 6, amp=3.0)
    x = add_cycles(x, 3, 0.8, 6, amp=1.0)
    x[:, 5] += np.cumsum(rng.normal(0, 0.05, len(x)))  # a drifting, aperiodic channel
    period, strength = im.cycle_period_s(x, FS)
    assert period == pytest.approx(1.25, rel=0.03)
    assert im.most_periodic_channel(x, FS) in (0, 3)
    assert strength[5] < strength[0]


def test_no_cycle_gives_nan_tempo():
    x = recording(3.0)
    assert np.isnan(im.cycle_frequency_hz(x, FS))
    assert im.count_repetitions(x, FS).count == 0


def test_energy_terms_scale_with_amplitude():
    base = add_cycles(recording(4.0), 4, 1.0, 4, amp=1.0)
    base = add_cycles(base, 0, 1.0, 4, amp=2.0)
    double = add_cycles(recording(4.0), 4, 1.0, 4, amp=2.0)
    double = add_cycles(double, 0, 1.0, 4, amp=4.0)
    e1, e2 = im.energy_terms(base, FS), im.energy_terms(double, FS)
    for key in im.ENERGY_TERMS:
        assert e2[key] / e1[key] == pytest.approx(2.0 if key != "acc_ptp" else (2 * 8 + 0) / 8 * 1.0,
                                                  rel=0.02)
    assert im.energy_index(e1, e1) == pytest.approx(1.0)
    assert im.energy_index(e2, e1) == pytest.approx(2.0, rel=0.02)


def test_discrete_tempo_is_mean_angular_rate():
    x = recording(2.0)
    x[:, 3] = 1.0  # constant 1 rad/s about x, 0 elsewhere
    assert im.tempo_measure(x, FS, periodic=False) == pytest.approx(1.0, rel=1e-6)


def bump(t: np.ndarray, t0: float, width: float, height: float = 1.0) -> np.ndarray:
    """A raised-cosine bump of `width` seconds from t0."""
    u = (t - t0) / width
    return np.where((u >= 0) & (u <= 1), height * 0.5 * (1 - np.cos(2 * np.pi * u)), 0.0)


def test_landmark_window_of_a_bump():
    """A raised cosine of width W is above 20 % of its peak for (1 - 2 acos(0.6) / 2 pi) W."""
    t = np.arange(0, 3, 1 / FS)
    speed = bump(t, 1.0, 0.5)
    window = im.landmark_window(speed, FS)
    expected = 0.5 * (1 - 2 * np.arccos(0.6) / (2 * np.pi))
    assert window.duration_s == pytest.approx(expected, abs=0.004)
    assert window.peak_s == pytest.approx(1.25, abs=1 / FS)


def test_landmark_window_stops_at_a_valley_and_follows_the_search_window():
    """Two movements back to back, the dip between them too short to count as a pause."""
    t = np.arange(0, 4, 1 / FS)
    speed = bump(t, 1.0, 0.5, 1.0) + bump(t, 1.45, 0.6, 0.8) + 0.01
    whole = im.landmark_window(speed, FS)
    assert whole.peak_s == pytest.approx(1.25, abs=0.03)
    assert whole.end_s < 1.55  # the valley between the two bumps, not the end of the second
    second = im.landmark_window(speed, FS, search=(1.5, 2.1))
    assert 1.6 < second.peak_s < 1.9 and second.start_s > 1.4


def test_phase_duration_on_the_gyroscope_magnitude():
    x = recording(3.0)
    t = np.arange(len(x)) / FS
    x[:, 3] = bump(t, 1.0, 0.6, 3.0)
    x[:, 5] = -bump(t, 1.0, 0.6, 4.0)  # magnitude: a 5 rad/s bump
    phase = im.phase_duration(x, FS)
    assert phase.duration_s == pytest.approx(0.6 * (1 - 2 * np.arccos(0.6) / (2 * np.pi)), abs=0.03)


def test_bad_input_is_a_validation_error():
    with pytest.raises(ValidationError):
        im.count_repetitions(np.zeros((100, 3)), FS)
    with pytest.raises(ValidationError):
        im.energy_terms(np.zeros((100, 6)), 0.0)
