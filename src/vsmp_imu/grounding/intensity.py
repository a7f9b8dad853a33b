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


def spread_channels(channel_names: tuple[str, ...]) -> np.ndarray:
    """Indices of the channels a factor scales: the gyroscopes, or every channel where there is none."""
    gyro = [i for i, name in enumerate(channel_names) if "gyr" in name.lower()]
    return np.array(gyro or range(len(channel_names)), dtype=np.int64)


def spread_intensity(X: np.ndarray, mask: np.ndarray, bounds: tuple[float, float], channels: np.ndarray,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """`X` (N, T, C) with each masked window's deviations from its mean scaled on `channels` by
    a factor ~ U(bounds); the factors (NaN where unmasked). One draw per window, masked or
    not, so a window's factor does not depend on which others are masked."""
    draws = rng.uniform(bounds[0], bounds[1], size=len(X))
    factors = np.where(mask, draws, np.nan)
    out = np.array(X, copy=True)
    if not mask.any() or len(channels) == 0:
        return out, factors
    part = out[mask][:, :, channels].astype(np.float64)
    mean = part.mean(axis=1, keepdims=True)
    scaled = mean + factors[mask][:, None, None] * (part - mean)
    rows = np.flatnonzero(mask)
    out[np.ix_(rows, np.arange(X.shape[1]), channels)] = scaled.astype(out.dtype)
    return out, factors
