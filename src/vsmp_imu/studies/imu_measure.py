"""Control measurements on an IMU recording (paper, "End-to-End SMP Controllability Protocol").

The IMU-side counterparts of `vsmp_imu.motion.measure`, with the same
parameters (appendix "Analysis Parameters"): 4th-order zero-phase
Butterworth low-pass at 6 Hz, peaks with prominence 0.40 x the signal's
standard deviation and at least 0.35 s apart, landmarks at 20 % of the
maximum held for at least 0.10 s. They work on any (T, 6) array whose
channels are `acc_x acc_y acc_z gyr_x gyr_y gyr_z` in any axis convention
(raw simulator output or grounded data): nothing depends on which axis is
which.

Definitions (docs/studies.md, "Controllability"):
- a signal's *period peak* is the earliest local maximum of its normalized
  (biased) autocorrelation, at lags between 0.35 s and half the recording
  (the plausible cycle range), that is at least 0.85 x as high as the
  highest one there; the recording's *cycle period* is the period peak of
  the six channels' autocorrelations averaged with weights equal to the
  square of each channel's own period-peak height; the *most periodic
  channel* is the channel whose autocorrelation is highest at that lag;
- repetitions: peaks of that channel, oriented so that excursions away from
  its first 0.2 s are peaks (the motion rule), at least 0.35 s and 0.6
  cycle periods apart;
- tempo: for periodic activities 1 / the cycle period (Hz); for discrete
  ones the mean gyroscope magnitude (rad/s), the counterpart of the mean
  principal-joint angular speed;
- amplitude terms: gyroscope RMS magnitude (rad/s), integrated angular
  velocity (rad) and the mean peak-to-peak acceleration of the three axes
  (m/s^2); a study normalizes each by its value at the medium level of the
  same matched set and averages the three (`energy_index`);
- primitive duration: the window around the largest peak of the gyroscope
  magnitude envelope where it stays above 20 % of that peak (a crossing
  counts when the envelope then stays below for at least 0.10 s): the
  sensor segment's angular speed stands for the joint speed of the motion
  landmarks.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.measure import (
    MIN_HOLD_S,
    PEAK_DISTANCE_S,
    PEAK_PROMINENCE,
    VELOCITY_FRACTION,
    PhaseDuration,
    lowpass,
)

ACC = slice(0, 3)
GYR = slice(3, 6)
BASELINE_S = 0.2  # the start of a signal that orientation is measured from (motion rule)
ENERGY_TERMS = ("gyr_rms", "gyr_integral", "acc_ptp")
# Choice of this implementation: peaks closer than this fraction of the channel's
# autocorrelation period belong to one cycle (a punch's extension and retraction).
PERIOD_FRACTION = 0.6
FIRST_PEAK_FRACTION = 0.85
VOTE_FRACTION = 0.75  # channels less periodic than this x the most periodic one do not vote
CONSTANT_RTOL = 1e-9  # a signal varying less than this (relative to its level) is constant  # an earlier autocorrelation peak this high is the period


@dataclass(frozen=True)
class ImuRepetitions:
    """Cycle detection on one channel."""

    count: int
    channel: int
    peak_times_s: tuple[float, ...]


@dataclass(frozen=True)
class ImuPhase(PhaseDuration):
    """The landmark window around the largest angular-speed peak."""


def _check(x: np.ndarray, fs_hz: float) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.ndim != 2 or x.shape[1] != 6:
        raise ValidationError(f"expected an IMU array (T, 6) (acc xyz, gyr xyz), got {x.shape}",
                              field="imu")
    if fs_hz <= 0:
        raise ValidationError(f"fs_hz must be positive, got {fs_hz}", field="fs_hz")
    return x


def autocorrelation(s: np.ndarray) -> np.ndarray:
    """Biased autocorrelation of a mean-removed signal, normalized to 1 at lag 0 (zeros for a
    constant signal, whose rounding residue would otherwise look perfectly periodic)."""
    s = np.asarray(s, dtype=float)
    mean = float(np.mean(s))
    s = s - mean
    n = len(s)
    if np.sqrt(np.mean(s**2)) <= CONSTANT_RTOL * (1.0 + abs(mean)):
        return np.zeros(n)
    spec = np.fft.rfft(s, 2 * n)
    ac = np.fft.irfft(spec * np.conj(spec))[:n]
    return ac / ac[0] if ac[0] > 0 else np.zeros(n)


def _peak_in_range(ac: np.ndarray, fs_hz: float) -> tuple[float, float]:
    """(height, lag_s) of the period peak of `ac` at lags 0.35 s .. half its length: the earliest
    local maximum at least 0.85 x as high as the highest one. The lag is refined by a parabola
    through the peak and its neighbours; (0, nan) when there is no peak."""
    lo, hi = max(1, int(round(PEAK_DISTANCE_S * fs_hz))), len(ac) // 2
    if hi - lo < 3:
        return 0.0, float("nan")
    peaks, _ = find_peaks(ac[lo - 1: hi + 1])
    peaks = peaks + lo - 1
    peaks = peaks[(peaks >= lo) & (peaks < hi)]
    if len(peaks) == 0:
        return 0.0, float("nan")
    # the earliest peak nearly as high as the highest: a multiple of the period is not taken
    # for the period (the octave error of pitch detection)
    top = float(ac[peaks].max())
    k = int(peaks[np.flatnonzero(ac[peaks] >= top - (1 - FIRST_PEAK_FRACTION) * abs(top))[0]])
    a, b, c = ac[k - 1], ac[k], ac[k + 1]
    denom = a - 2 * b + c
    shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
    return float(b), float((k + shift) / fs_hz)


def periodic_peak(s: np.ndarray, fs_hz: float) -> tuple[float, float]:
    """(strength, period_s) of one signal's highest autocorrelation peak in the cycle range."""
    return _peak_in_range(autocorrelation(s), fs_hz)


def cycle_period_s(x: np.ndarray, fs_hz: float) -> tuple[float, np.ndarray]:
    """The recording's cycle period and every channel's autocorrelation at it.

    The period is the period peak (0.35 s .. half the recording) of the
    normalized autocorrelations of the channels whose own period peak is at
    least 0.75 x as high as the highest channel's, averaged with weights
    equal to the square of that height: a cycle shows in several periodic
    channels, while a spurious peak of one channel (a nearly constant channel
    whose small wiggles grounding stretches to a real range) is outvoted and
    aperiodic channels do not vote. Returns (nan, zeros) when there is no
    peak.
    """
    x = lowpass(_check(x, fs_hz), fs_hz)
    acs = np.stack([autocorrelation(x[:, c]) for c in range(x.shape[1])])
    strength = np.array([max(_peak_in_range(ac, fs_hz)[0], 0.0) for ac in acs])
    weights = np.where(strength >= VOTE_FRACTION * strength.max(), strength**2, 0.0)
    if weights.sum() <= 0:
        return float("nan"), np.zeros(x.shape[1])
    _, period = _peak_in_range(weights @ acs / weights.sum(), fs_hz)
    if not np.isfinite(period):
        return period, np.zeros(x.shape[1])
    k = int(round(period * fs_hz))
    return period, acs[:, k]


def most_periodic_channel(x: np.ndarray, fs_hz: float) -> int:
    """The channel with the highest autocorrelation at the recording's cycle period."""
    _, strength = cycle_period_s(x, fs_hz)
    return int(np.argmax(strength))


def _oriented(s: np.ndarray, fs_hz: float) -> np.ndarray:
    start = float(np.mean(s[: max(1, int(round(BASELINE_S * fs_hz)))]))
    return -s if s.max() - start < start - s.min() else s


def count_repetitions(x: np.ndarray, fs_hz: float) -> ImuRepetitions:
    """Peaks of the most periodic channel (prominence 0.40 sd, at least 0.35 s apart).

    Peaks must also be at least 0.6 x the cycle period apart: an inertial
    signal often has two extrema per cycle (acceleration out and back),
    which joint trajectories do not.
    """
    x = lowpass(_check(x, fs_hz), fs_hz)
    period, strength = cycle_period_s(x, fs_hz)
    channel = int(np.argmax(strength))
    s = _oriented(x[:, channel], fs_hz)
    sd = float(np.std(s))
    if sd < 1e-12:
        return ImuRepetitions(0, channel, ())
    distance_s = max(PEAK_DISTANCE_S, PERIOD_FRACTION * period if np.isfinite(period) else 0.0)
    peaks, _ = find_peaks(s, prominence=PEAK_PROMINENCE * sd,
                          distance=max(1, int(round(distance_s * fs_hz))))
    return ImuRepetitions(len(peaks), channel, tuple(float(p) / fs_hz for p in peaks))


def gyro_magnitude(x: np.ndarray, fs_hz: float) -> np.ndarray:
    """(T,) norm of the low-passed gyroscope (rad/s)."""
    x = lowpass(_check(x, fs_hz), fs_hz)
    return np.linalg.norm(x[:, GYR], axis=1)


def cycle_frequency_hz(x: np.ndarray, fs_hz: float) -> float:
    """1 / the recording's autocorrelation cycle period (nan when there is none)."""
    period, _ = cycle_period_s(x, fs_hz)
    return 1.0 / period if np.isfinite(period) and period > 0 else float("nan")


def tempo_measure(x: np.ndarray, fs_hz: float, periodic: bool) -> float:
    """Cycle frequency (Hz) for periodic activities, mean gyroscope magnitude (rad/s) otherwise."""
    if periodic:
        return cycle_frequency_hz(x, fs_hz)
    return float(gyro_magnitude(x, fs_hz).mean())


def energy_terms(x: np.ndarray, fs_hz: float) -> dict[str, float]:
    """Gyroscope RMS magnitude, integrated angular velocity and mean acc peak-to-peak."""
    x = lowpass(_check(x, fs_hz), fs_hz)
    w = np.linalg.norm(x[:, GYR], axis=1)
    return {
        "gyr_rms": float(np.sqrt(np.mean(w**2))),
        "gyr_integral": float(np.sum(w) / fs_hz),
        "acc_ptp": float(np.mean(np.ptp(x[:, ACC], axis=0))),
    }


def energy_index(terms: Mapping[str, float], reference: Mapping[str, float]) -> float:
    """Mean of the energy terms, each divided by its value in `reference` (the medium level)."""
    ratios = [terms[k] / reference[k] for k in ENERGY_TERMS if reference[k] > 0]
    return float(np.mean(ratios)) if ratios else float("nan")


def _quiet_runs(below: np.ndarray, hold: int) -> np.ndarray:
    """True where a sample lies in a run of at least `hold` consecutive True values of `below`."""
    out = np.zeros(len(below), dtype=bool)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], below.astype(int), [0]])))
    for start, end in zip(edges[::2], edges[1::2], strict=True):
        if end - start >= hold:
            out[start:end] = True
    return out


def _valleys(speed: np.ndarray, depth: float) -> np.ndarray:
    """Local minima of `speed` at least `depth` below both neighbouring maxima."""
    valleys, _ = find_peaks(-speed, prominence=depth)
    return valleys


def landmark_window(speed: np.ndarray, fs_hz: float,
                    search: tuple[float, float] | None = None) -> ImuPhase:
    """The 20 %-of-peak window around a peak of `speed` (times in s from the first sample).

    The peak is the largest one, or the largest inside `search` (start_s,
    end_s). The window ends where the speed falls below 20 % of the peak and
    stays below for at least 0.10 s (`motion.measure.phase_duration`'s
    rule), or earlier at a valley that separates the peak from the next
    movement (a minimum at least 20 % of the peak below both neighbouring
    maxima): two primitives that follow each other without a pause are
    told apart there. Crossings are interpolated between samples.
    """
    speed = np.asarray(speed, dtype=float)
    lo, hi = 0, len(speed)
    if search is not None:
        lo = int(np.clip(np.floor(search[0] * fs_hz), 0, len(speed) - 1))
        hi = int(np.clip(np.ceil(search[1] * fs_hz) + 1, lo + 1, len(speed)))
    peak = lo + int(np.argmax(speed[lo:hi]))
    level = VELOCITY_FRACTION * speed[peak]
    quiet = _quiet_runs(speed < level, max(1, int(round(MIN_HOLD_S * fs_hz))))
    valleys = _valleys(speed, level)
    left = valleys[valleys < peak]
    right = valleys[valleys > peak]
    floor = int(left[-1]) if len(left) else 0
    ceil = int(right[0]) if len(right) else len(speed) - 1
    start = peak
    while start > floor and not quiet[start - 1]:
        start -= 1
    end = peak
    while end < ceil and not quiet[end + 1]:
        end += 1

    def crossing(i: int, j: int) -> float:
        a, b = speed[i], speed[j]
        return float(i) if a == b else float(i + (j - i) * (level - a) / (b - a))

    t0 = crossing(start - 1, start) if start > 0 and quiet[start - 1] else float(start)
    t1 = crossing(end, end + 1) if end < len(speed) - 1 and quiet[end + 1] else float(end)
    return ImuPhase(t0 / fs_hz, t1 / fs_hz, peak / fs_hz)


def phase_duration(x: np.ndarray, fs_hz: float,
                   search: tuple[float, float] | None = None) -> ImuPhase:
    """The primitive around a peak of the gyroscope magnitude envelope.

    `search` (start_s, end_s from the first sample) restricts where the peak
    is looked for: a study passes the motion-level primitive window of the
    same motion, so the IMU landmarks belong to the corresponding primitive
    and not to a faster preparation or return.
    """
    return landmark_window(gyro_magnitude(x, fs_hz), fs_hz, search)


def measure_all(x: np.ndarray, fs_hz: float, periodic: bool,
                search: tuple[float, float] | None = None) -> dict[str, float]:
    """Every IMU control measurement of one recording (energy terms unnormalized)."""
    reps = count_repetitions(x, fs_hz)
    return {
        "tempo": tempo_measure(x, fs_hz, periodic),
        "repetitions": float(reps.count),
        "repetition_channel": float(reps.channel),
        "duration": phase_duration(x, fs_hz, search).duration_s,
        **energy_terms(x, fs_hz),
    }

