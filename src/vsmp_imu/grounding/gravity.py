"""Keep the accelerometer's gravity magnitude through rank grounding.

The rank map matches each channel's marginal on its own. Fitted on a few real
windows (a class's own map at 1 % of the labels), it can move the three
accelerometer channels of one window to quantiles that no posture gives
together: a synthetic sitting window mapped onto a reclined real one read
|g| = 7.7 m/s² where every real static window reads 9.9-10.1. This step keeps
the mapped direction of the slowly varying part (gravity plus the slow body
acceleration) and gives it back the magnitude the simulation had, scaled to
the real sensor's gravity reading; the faster part of the signal stays as the
map made it.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import uniform_filter1d

from vsmp_imu.errors import ValidationError

# the slow part: a centred moving average over this many seconds
SLOW_WINDOW_S = 1.0


def slow_part(acc: np.ndarray, fs_hz: float, window_s: float = SLOW_WINDOW_S) -> np.ndarray:
    """Moving average (T, 3) of the accelerometer over `window_s` (edges held)."""
    size = max(1, int(round(window_s * fs_hz)))
    return uniform_filter1d(np.asarray(acc, dtype=np.float64), size, axis=0, mode="nearest")


def gravity_scale(real_acc_means: np.ndarray, synthetic_slow_norms: np.ndarray) -> float:
    """How much larger the real sensor reads gravity than the simulation: the median norm of the
    real windows' mean accelerometer over the median slow norm of the synthetic samples."""
    real = np.linalg.norm(np.asarray(real_acc_means, dtype=np.float64), axis=-1)
    syn = np.asarray(synthetic_slow_norms, dtype=np.float64)
    if real.size == 0 or syn.size == 0 or np.median(syn) <= 0:
        raise ValidationError("gravity scale needs real window means and synthetic norms", field="gravity")
    return float(np.median(real) / np.median(syn))


def restore_gravity_norm(before: np.ndarray, after: np.ndarray, fs_hz: float, scale: float = 1.0,
                         window_s: float = SLOW_WINDOW_S) -> np.ndarray:
    """`after` (T, 6: acc, gyr) with its accelerometer's slow part rescaled, sample by sample, to
    `scale` x the slow norm of `before` (the same sample before the rank map); its direction, the
    fast part and the gyroscope stay as they are."""
    before, after = np.asarray(before, dtype=np.float64), np.asarray(after, dtype=np.float64)
    if before.shape != after.shape or before.ndim != 2 or before.shape[1] < 3:
        raise ValidationError(f"expected two (T, 6) signals of one shape, got {before.shape} and {after.shape}",
                              field="signals")
    return rescale_slow_part(after, scale * slow_norm(before[:, :3], fs_hz, window_s), fs_hz, window_s)


def slow_norm(acc: np.ndarray, fs_hz: float, window_s: float = SLOW_WINDOW_S) -> np.ndarray:
    """|slow_part(acc)| (T,), sample by sample."""
    return np.linalg.norm(slow_part(acc, fs_hz, window_s), axis=1)


def rescale_slow_part(after: np.ndarray, target: np.ndarray, fs_hz: float,
                      window_s: float = SLOW_WINDOW_S) -> np.ndarray:
    """`after` (T, 6) with its accelerometer's slow part rescaled to the norms `target` (T,)."""
    after = np.asarray(after, dtype=np.float64)
    slow = slow_part(after[:, :3], fs_hz, window_s)
    norm = np.linalg.norm(slow, axis=1)
    gain = np.divide(target, norm, out=np.ones_like(norm), where=norm > 1e-9)
    out = after.copy()
    out[:, :3] += slow * (gain - 1.0)[:, None]
    return out
