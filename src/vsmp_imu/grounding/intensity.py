"""Intensity spread: a range of movement intensity for a class without real windows.

A class with real training windows takes its spread of intensity from them
(per-class rank grounding, D_stat). A class with none (the unseen protocol)
rests on its SMP alone, and the procedural motion executes each variant at
close to one intensity: a real stand-to-sit turns the sensor several times
as much within a window as a synthetic one. So each selected window of such
a class has its deviations from its own mean scaled by a factor drawn
uniformly from `bounds`, on its gyroscopes (docs/results.md, "Intensity
spread for unseen classes"). The mean (the turn rate) is kept, and the
accelerometer, and with it the posture, is untouched. The factor of every
window goes into its record (`WindowRecord.intensity`) and the generation
summary.
"""

from __future__ import annotations

import numpy as np

from vsmp_imu.grounding import floors


def spread_channels(channel_names: tuple[str, ...]) -> np.ndarray:
    """Indices of the channels a factor scales: the gyroscopes, or every channel where there is none."""
    gyro = [i for i, name in enumerate(channel_names) if "gyr" in name.lower()]
    return np.array(gyro or range(len(channel_names)), dtype=np.int64)


def scale_deviations(X: np.ndarray, factors: np.ndarray, channels: np.ndarray) -> np.ndarray:
    """`X` (N, T, C) with each window's deviations from its mean scaled on `channels` by its
    factor; windows whose factor is NaN are left as they are."""
    out = np.array(X, copy=True)
    rows = np.flatnonzero(~np.isnan(factors))
    if len(rows) == 0 or len(channels) == 0:
        return out
    part = out[rows][:, :, channels].astype(np.float64)
    mean = part.mean(axis=1, keepdims=True)
    scaled = mean + factors[rows][:, None, None] * (part - mean)
    out[np.ix_(rows, np.arange(X.shape[1]), channels)] = scaled.astype(out.dtype)
    return out


def spread_intensity(X: np.ndarray, mask: np.ndarray, bounds: tuple[float, float], channels: np.ndarray,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`X` (N, T, C) with each masked window's deviations from its mean scaled on `channels` by
    a factor ~ U(bounds); the factors (NaN where unmasked). One draw per window, masked or
    not, so a window's factor does not depend on which others are masked."""
    draws = rng.uniform(bounds[0], bounds[1], size=len(X))
    factors = np.where(mask, draws, np.nan)
    return scale_deviations(X, factors, channels), factors


# -- a class with real windows: the spread of intensity its real windows show ---------------------------
# real and synthetic windows a class needs for its spread to be measured
MATCH_MIN_WINDOWS = floors.SEEN_INTENSITY.floor
MATCH_Z_MAX = 2.5  # the normal draws are clipped here (no window scaled beyond 2.5 standard deviations)


def log_intensity(X: np.ndarray, channels: np.ndarray) -> np.ndarray:
    """Per window, the log of the RMS deviation from the window mean over `channels` (N,)."""
    part = np.asarray(X[:, :, channels], dtype=np.float64)
    dev = part - part.mean(axis=1, keepdims=True)
    return np.log(np.sqrt((dev ** 2).sum(axis=-1).mean(axis=1)) + 1e-9)


def missing_spread(real: np.ndarray, synthetic: np.ndarray, channels: np.ndarray) -> float:
    """The log-intensity standard deviation the synthetic windows lack against the real ones:
    sqrt(max(0, var_real - var_synthetic)); 0 where either has fewer than MATCH_MIN_WINDOWS."""
    if len(real) < MATCH_MIN_WINDOWS or len(synthetic) < MATCH_MIN_WINDOWS or len(channels) == 0:
        return 0.0
    gap = log_intensity(real, channels).var() - log_intensity(synthetic, channels).var()
    return float(np.sqrt(gap)) if gap > 0 else 0.0


def match_factors(mask: np.ndarray, spread: float, z: np.ndarray) -> np.ndarray:
    """Per window, exp(spread * z) with z clipped to +-MATCH_Z_MAX (NaN where unmasked): the
    median intensity stays where it was (the log factors centre on 0)."""
    return np.where(mask, np.exp(spread * np.clip(z, -MATCH_Z_MAX, MATCH_Z_MAX)), np.nan)
