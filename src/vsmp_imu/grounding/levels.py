"""Window levels: an event class's synthetic windows shifted so that their means follow the real ones.

The rank map (grounding.rank) matches a class's sample values, pooled over its windows. For an
event (a transition, whose windows need only a share of the window inside the label: the
dataset's `min_share`) that is not enough: what a window averages, the gravity direction between
the two postures and how far into either it reaches, depends on where the window falls in the
event, and the synthetic events fall differently from the real ones. On HAPT12 a synthetic lying
transition window's accelerometer mean sat about 1 m/s^2 per axis away from where the real
windows' means put it (docs/results.md, "Window levels").

`LevelMap` fits, per event class with at least `MIN_WINDOWS` real windows, one monotone map per
channel from the synthetic windows' means to the real windows' means (the rank map's
kernel-smoothed pair, each window one value), and shifts every window of that class by its
mapped mean minus its own: the window's course inside stays as it is. With `parts` > 1
(`--level-parts 4`: quarters) the window's equal parts are mapped each on its own: the mean of
a window's first quarter onto the real windows' first-quarter means, and so on, and the shifts
join into a course linear between the parts' centres (flat before the first and after the
last), so no step enters the signal. Where in the window a transition's posture changes is then
where the real windows have it (one level leaves the lying pairs told apart by one quarter's
mean the real windows do not differ on, `vsmp-imu data check`). Quarters made the windows of a
5 % run better alone, those of the full training set worse, and left the mixes level or lower
(docs/results.md, "Window levels per quarter"), so the default maps the whole window's mean
(`PARTS`). With `GenerationSpec.posture_levels` a held posture's windows are mapped too: a still
window's mean is where gravity points in the sensor, which sets sitting apart from standing
(docs/results.md, "Window levels for the postures": TSTR gains, the long tail does not, so it is
off). Cyclic activities (walking), and classes with fewer real windows (low-resource budgets,
unseen classes), keep their windows. On by default (`GenerationSpec.window_levels`; the
baselines' chain does without).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding import floors
from vsmp_imu.grounding.rank import DEFAULT_N_QUANTILES, ChannelMap

# real windows an event class needs before its windows' means are mapped (20 before the 5 %
# measurement in docs/results.md, "Window levels from five real windows")
MIN_WINDOWS = floors.WINDOW_LEVELS.floor
PARTS = 1  # the window's parts whose means are mapped (1: the whole window's)


@dataclass(eq=False, repr=False)
class LevelMap:
    """Per class, a map of the synthetic windows' per-channel means onto the real windows' means.

    fit(synthetic, synthetic_labels, real, real_labels, classes): windows (N, T, C); only the
    classes in `classes` (the event classes) are considered, each needing `min_windows` windows
    on both sides. transform(X, y) shifts those classes' windows; the rest come back unchanged.
    `classes_` holds, per mapped class, its real window count and mean absolute shift per channel
    (fit's synthetic windows, over the parts); `skipped_` the event classes left alone, with their
    real window count.
    """

    min_windows: int = MIN_WINDOWS
    n_quantiles: int = DEFAULT_N_QUANTILES
    parts: int = PARTS  # the window's equal parts whose means are mapped, each on its own
    maps_: dict[int, ChannelMap] = field(default_factory=dict, init=False)
    classes_: dict[int, dict] = field(default_factory=dict, init=False)
    skipped_: dict[int, int] = field(default_factory=dict, init=False)

    def fit(self, synthetic: np.ndarray, synthetic_labels: np.ndarray, real: np.ndarray,
            real_labels: np.ndarray, classes) -> LevelMap:
        synthetic, real = _windows(synthetic, "synthetic"), _windows(real, "real")
        if synthetic.shape[2] != real.shape[2]:
            raise ValidationError(f"synthetic has {synthetic.shape[2]} channels but real has {real.shape[2]}",
                                  field="channels")
        syn_y, real_y = np.asarray(synthetic_labels), np.asarray(real_labels)
        self.maps_, self.classes_, self.skipped_ = {}, {}, {}  # a second fit starts afresh
        for cls in sorted({int(c) for c in classes}):
            syn, rea = synthetic[syn_y == cls], real[real_y == cls]
            if len(syn) == 0:
                continue
            if len(rea) < self.min_windows or len(syn) < self.min_windows:
                self.skipped_[cls] = int(len(rea))
                continue
            means = part_means(syn, self.parts)
            self.maps_[cls] = ChannelMap(means, part_means(rea, self.parts), self.n_quantiles)
            shift = self.maps_[cls].apply(means) - means
            self.classes_[cls] = {"real_windows": int(len(rea)),
                                  "mean_abs_shift": np.abs(shift).reshape(len(shift), self.parts, -1)
                                  .mean(axis=(0, 1)).round(4).tolist()}
        return self

    def transform(self, X: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Windows (N, T, C) with the mapped classes' windows shifted (float64)."""
        X = np.array(_windows(X, "X"), dtype=np.float64)
        y = np.asarray(y)
        for cls, channel_map in self.maps_.items():
            mask = y == cls
            if mask.any():
                means = part_means(X[mask], self.parts)
                X[mask] += shift_course(channel_map.apply(means) - means, X.shape[1], self.parts)
        return X


def part_means(x: np.ndarray, parts: int) -> np.ndarray:
    """(N, parts * C): each channel's mean over each of `parts` equal parts of the windows (N, T, C),
    part after part."""
    edges = np.linspace(0, x.shape[1], parts + 1).round().astype(int)
    return np.concatenate([x[:, a:b].mean(axis=1) for a, b in zip(edges[:-1], edges[1:], strict=True)], axis=1)


def shift_course(shift: np.ndarray, length: int, parts: int) -> np.ndarray:
    """(N, T, C): shifts per part (N, parts * C, as `part_means`) as a course over the window,
    linear between the parts' centres and flat before the first and after the last."""
    shift = shift.reshape(len(shift), parts, -1)
    if parts == 1:
        return np.repeat(shift, length, axis=1)
    centres = (np.arange(parts) + 0.5) * length / parts
    basis = np.stack([np.interp(np.arange(length), centres, row) for row in np.eye(parts)], axis=1)  # (T, parts)
    return np.einsum("tk,nkc->ntc", basis, shift)


def _windows(x: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 3:
        raise ValidationError(f"{name} must be windows (N, T, C), got shape {x.shape}", field=name)
    return x
