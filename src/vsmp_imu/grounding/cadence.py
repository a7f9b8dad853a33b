"""Gait cadence from the real training windows, and a sample's gait timed to one of them.

How fast a person steps is set by the person and the place (a stairwell slows the climb), not by
the SMP: its tempo word ("medium") and its uncertainty only say roughly how fast. Left to them,
a class's few SMP variants each draw a tempo, and on HAPT12 a fold's stair classes came out with
their real cadences swapped (synthetic ascent 2.15 steps/s against 1.61 real, descent 1.42
against 1.76; docs/results.md). The real windows carry the cadence: a walking window's
accelerometer magnitude peaks once per step (at the trunk: `reading_location`), so the frequency of
its largest peak between `BAND_HZ` is the window's step rate.

A sample of a gait class (an SMP with periodicity "cyclic" whose procedural recipe walks: its
`locomotion` is not "none") with at least `MIN_WINDOWS` real training windows draws one real
window's step rate, and its motion is planned a second time with every duration scaled so that
its cycle (two steps when the recipe's cycle alternates the legs) lasts that long; the factor is
clipped to `SCALE_BOUNDS`. A class without evidence keeps the SMP's tempo, and so does every
class of a dataset sampled below `MIN_RATE_HZ` (its spectrum stops short of the band). On by default
(`GenerationSpec.cadence`; the baselines' chain keeps the SMPs' tempo).
"""

from __future__ import annotations

import numpy as np

from vsmp_imu.grounding import floors
from vsmp_imu.grounding.durations import spread_summary

# where the body bounces once per step: the step rate is read at the first of these a class is worn at
# (a foot's or shank's sensor peaks once per stride, a wrist's with the arm swing too)
TRUNK_LOCATIONS = ("waist", "back", "chest", "head")
BAND_HZ = (1.0, 3.0)  # step rates of walking and stairs (running steps faster; no running class here)
N_FFT = 1024  # zero-padded length of the spectrum (0.05 Hz bins at 50 Hz)
MIN_WINDOWS = floors.CADENCE.floor  # real windows a class needs before its cadence is used
SCALE_BOUNDS = (0.6, 1.6)  # the factor a sample's durations may be scaled by
MIN_RATE_HZ = 2 * BAND_HZ[1]  # the lowest sampling rate whose spectrum reaches the band's top (Nyquist)


def step_rates(acc: np.ndarray, fs_hz: float) -> np.ndarray:
    """`(N, T, 3)` accelerometer windows -> `(N,)` step rates in Hz: the frequency of the largest
    peak of each window's magnitude spectrum (mean removed) inside `BAND_HZ`."""
    acc = np.asarray(acc, dtype=np.float64)
    if acc.ndim != 3 or acc.shape[-1] != 3:
        raise ValueError(f"accelerometer windows must be (N, T, 3), got {acc.shape}")
    norm = np.linalg.norm(acc, axis=2)
    norm -= norm.mean(axis=1, keepdims=True)
    n_fft = max(N_FFT, acc.shape[1])
    power = np.abs(np.fft.rfft(norm * np.hanning(acc.shape[1]), n=n_fft, axis=1)) ** 2
    freq = np.fft.rfftfreq(n_fft, 1.0 / fs_hz)
    band = (freq >= BAND_HZ[0]) & (freq <= BAND_HZ[1])
    if not band.any():
        raise ValueError(f"a sampling rate of {fs_hz:g} Hz cannot resolve {BAND_HZ} Hz")
    return freq[band][np.argmax(power[:, band], axis=1)]


def reading_location(names: list[str] | tuple[str, ...]) -> str:
    """Where a class's step rate is read: its first trunk location, else its first location."""
    trunk = [n for n in TRUNK_LOCATIONS if n in names]
    return trunk[0] if trunk else names[0]


def class_cadence(acc: np.ndarray, fs_hz: float) -> tuple[np.ndarray, str]:
    """A class's real step rates (empty when it has too few windows or the rate is too low), and why."""
    if len(acc) < MIN_WINDOWS:
        return np.zeros(0), f"{len(acc)} real window(s), fewer than {MIN_WINDOWS}"
    if fs_hz < MIN_RATE_HZ:
        return np.zeros(0), (f"a sampling rate of {fs_hz:g} Hz cannot resolve step rates up to {BAND_HZ[1]:g} Hz: "
                             f"that needs {MIN_RATE_HZ:g} Hz")
    return step_rates(acc, fs_hz), f"{len(acc)} real windows"


def draw_rate(rates: np.ndarray, rng: np.random.Generator) -> float:
    """One real window's step rate."""
    return float(rates[rng.integers(len(rates))])


def scale_for(target_hz: float, steps_per_cycle: int, cycle_s: float) -> float:
    """The duration factor that makes a cycle of `cycle_s` seconds (`steps_per_cycle` steps) step
    at `target_hz`, clipped to `SCALE_BOUNDS`."""
    target_cycle = steps_per_cycle / max(target_hz, 1e-3)
    return float(np.clip(target_cycle / max(cycle_s, 1e-3), *SCALE_BOUNDS))


def summary(rates: np.ndarray, reason: str) -> dict:
    """What the generation summary (and `generate`'s report) keeps of a class's cadence."""
    return spread_summary(rates, reason, "windows", "hz")
