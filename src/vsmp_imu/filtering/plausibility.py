"""Rule-based motion plausibility (appendix "Quality Filtering", "Motion plausibility").

Per class y, from the real training windows of the fold:
  a_max = min(6 g, Q_0.999(|a|) + 3 MAD(|a|)),
  w_max = min(35 rad/s, Q_0.999(|w|) + 3 MAD(|w|)),
  E_min = max(1e-4, Q_0.01(E(X))), E(X) = mean_t(|a_t - mean a|^2 + 0.1 |w_t - mean w|^2);
a class with fewer than 100 windows uses the all-class thresholds. A motion is
rejected when any joint moves more than 0.20 x body height between frames, or
when any frame is missing (allowed missing fraction 0 %).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from vsmp_imu.filtering.verdict import Verdict
from vsmp_imu.grounding import floors
from vsmp_imu.motion import Motion
from vsmp_imu.units import STANDARD_GRAVITY_M_S2

A_CAP = 6 * STANDARD_GRAVITY_M_S2  # 6 g = 58.84 m/s^2
W_CAP = 35.0  # rad/s
E_FLOOR = 1e-4
MAX_STEP_FRACTION = 0.20
MIN_CLASS_WINDOWS = floors.PLAUSIBILITY.floor


def motion_energy(windows: np.ndarray) -> np.ndarray:
    """E(X) of each window: (..., T, 6) -> (...)."""
    acc = windows[..., 0:3] - windows[..., 0:3].mean(axis=-2, keepdims=True)
    gyr = windows[..., 3:6] - windows[..., 3:6].mean(axis=-2, keepdims=True)
    return ((acc**2).sum(-1) + 0.1 * (gyr**2).sum(-1)).mean(-1)


def _robust_max(values: np.ndarray, cap: float) -> float:
    mad = float(np.median(np.abs(values - np.median(values))))
    return float(min(cap, np.quantile(values, 0.999) + 3.0 * mad))


@dataclass(frozen=True)
class Thresholds:
    a_max: float
    w_max: float
    e_min: float
    n_windows: int

    def as_dict(self) -> dict:
        return {"a_max": self.a_max, "w_max": self.w_max, "e_min": self.e_min, "n_windows": self.n_windows}


def _thresholds(windows: np.ndarray) -> Thresholds:
    acc = np.linalg.norm(windows[..., 0:3], axis=-1).ravel()
    gyr = np.linalg.norm(windows[..., 3:6], axis=-1).ravel()
    e_min = max(E_FLOOR, float(np.quantile(motion_energy(windows), 0.01)))
    return Thresholds(_robust_max(acc, A_CAP), _robust_max(gyr, W_CAP), e_min, len(windows))


class MotionPlausibilityFilter:
    """fit(real windows (N, T, 6) of one location, labels) then filter each synthetic sample."""

    def __init__(self, min_class_windows: int = MIN_CLASS_WINDOWS, max_step_fraction: float = MAX_STEP_FRACTION):
        self.min_class_windows = min_class_windows
        self.max_step_fraction = max_step_fraction

    def fit(self, windows: np.ndarray, labels: np.ndarray) -> MotionPlausibilityFilter:
        windows = np.asarray(windows, dtype=np.float64)
        labels = np.asarray(labels)
        if windows.ndim != 3 or windows.shape[-1] != 6 or len(windows) != len(labels) or len(windows) == 0:
            raise ValueError("fit needs real windows (N, T, 6) and N labels, N > 0")
        self.overall_ = _thresholds(windows)
        self.per_class_ = {
            int(c): _thresholds(windows[labels == c])
            for c in np.unique(labels)
            if (labels == c).sum() >= self.min_class_windows
        }
        return self

    def thresholds_for(self, label: int) -> Thresholds:
        return self.per_class_.get(int(label), self.overall_)

    def check_motion(self, motion: Motion) -> Verdict:
        """Missing frames and frame-to-frame joint jumps of the generated skeleton."""
        if not motion.is_finite():
            return Verdict(False, "motion", "missing or non-finite frames")
        steps = np.linalg.norm(np.diff(motion.positions, axis=0), axis=-1)
        d_max = self.max_step_fraction * motion.body_height_m()
        worst = float(steps.max()) if steps.size else 0.0
        if worst > d_max:
            return Verdict(False, "motion", f"joint jumped {worst:.3f} m between frames (> {d_max:.3f} m)",
                           {"max_step_m": worst, "d_max_m": d_max})
        return Verdict(True, "motion", "", {"max_step_m": worst, "d_max_m": d_max})

    def check_window(self, window: np.ndarray, label: int) -> Verdict:
        """Inertial magnitudes and motion energy of one grounded window (T, 6)."""
        return self.check_windows(np.asarray(window)[None], np.array([label]))[0]

    def check_windows(self, windows: np.ndarray, labels: np.ndarray) -> list[Verdict]:
        """`check_window` for windows (N, T, 6), the magnitudes computed for all at once."""
        windows = np.asarray(windows, dtype=np.float64)
        finite = np.isfinite(windows).all(axis=(-2, -1))
        clean = np.where(finite[:, None, None], windows, 0.0)
        a_all = np.linalg.norm(clean[..., 0:3], axis=-1).max(axis=-1)
        w_all = np.linalg.norm(clean[..., 3:6], axis=-1).max(axis=-1)
        e_all = motion_energy(clean)
        return [self._verdict(bool(ok), float(a), float(w), float(e), int(label))
                for ok, a, w, e, label in zip(finite, a_all, w_all, e_all, np.asarray(labels), strict=True)]

    def _verdict(self, finite: bool, a: float, w: float, e: float, label: int) -> Verdict:
        if not finite:
            return Verdict(False, "imu", "non-finite samples")
        th = self.thresholds_for(label)
        values = {"max_acc": a, "max_gyr": w, "energy": e, **th.as_dict()}
        if a > th.a_max:
            return Verdict(False, "imu", f"|a| reaches {a:.2f} m/s^2 (> a_max {th.a_max:.2f})", values)
        if w > th.w_max:
            return Verdict(False, "imu", f"|w| reaches {w:.2f} rad/s (> w_max {th.w_max:.2f})", values)
        if e < th.e_min:
            return Verdict(False, "imu", f"motion energy {e:.2e} below E_min {th.e_min:.2e}", values)
        return Verdict(True, "imu", "", values)
