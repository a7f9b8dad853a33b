"""Classical Aug baseline (paper, Baselines): signal-level augmentation of real training
windows by jittering, scaling, 3-D rotation and time warping.

It is a synthetic source like the generative methods: per fold it receives
the real training windows and a per-class budget and returns that many
augmented windows, so it uses the same synthetic budget. Each new window
starts from a real window of the same class, drawn with replacement, and
goes through each augmentation with probability `p` (at least one applied):

- jitter: additive Gaussian noise, sigma = `jitter_sigma` x the channel's
  standard deviation over the training windows;
- scaling: every channel multiplied by a factor ~ N(1, `scale_sigma`);
- rotation: one random rotation (uniform axis, angle uniform in
  ±`max_rotation_deg`) applied jointly to the accelerometer and gyroscope
  triplets of a sensor location (same rotation for both);
- time warping: the time axis is resampled along a smooth monotone warp whose
  local speed at `warp_knots` knots is ~ N(1, `warp_sigma`).
"""

from __future__ import annotations

import re
from collections import defaultdict
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.seeding import rng_for

CHANNEL_PATTERN = re.compile(r"^(?:(?P<loc>.+)_)?(?P<kind>acc|gyr)_(?P<axis>[xyz])$")


def sensor_triplets(channel_names: tuple[str, ...]) -> list[list[int]]:
    """Index triplets (x, y, z) of every accelerometer/gyroscope of each location, grouped
    per location: [[acc_x, acc_y, acc_z, gyr_x, gyr_y, gyr_z], ...] (gyro part optional)."""
    found: dict[str, dict[str, dict[str, int]]] = defaultdict(lambda: defaultdict(dict))
    for i, name in enumerate(channel_names):
        m = CHANNEL_PATTERN.match(name)
        if m:
            found[m.group("loc") or ""][m.group("kind")][m.group("axis")] = i
    groups = []
    for kinds in found.values():
        idx = []
        for kind in ("acc", "gyr"):
            axes = kinds.get(kind, {})
            if set(axes) == {"x", "y", "z"}:
                idx += [axes["x"], axes["y"], axes["z"]]
        if idx:
            groups.append(idx)
    return groups


def jitter(x: np.ndarray, sigma: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return x + rng.normal(size=x.shape) * sigma


def scale(x: np.ndarray, sigma: float, rng: np.random.Generator) -> np.ndarray:
    return x * rng.normal(1.0, sigma, size=(1, x.shape[1]))


def rotate(
    x: np.ndarray, groups: list[list[int]], max_deg: float, rng: np.random.Generator
) -> np.ndarray:
    """One random rotation per location, applied to each of its xyz triplets."""
    out = x.copy()
    for idx in groups:
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis) + 1e-12
        angle = np.deg2rad(rng.uniform(-max_deg, max_deg))
        matrix = Rotation.from_rotvec(axis * angle).as_matrix()
        for start in range(0, len(idx), 3):
            cols = idx[start : start + 3]
            out[:, cols] = x[:, cols] @ matrix.T
    return out


def time_warp(x: np.ndarray, sigma: float, knots: int, rng: np.random.Generator) -> np.ndarray:
    """Resample along a smooth monotone warp of the time axis (same length out)."""
    n = len(x)
    knot_t = np.linspace(0, n - 1, knots + 2)
    speed = np.clip(rng.normal(1.0, sigma, size=knots + 2), 0.2, None)
    t = np.arange(n)
    warped = np.cumsum(CubicSpline(knot_t, speed)(t).clip(0.05))
    warped = (warped - warped[0]) / (warped[-1] - warped[0]) * (n - 1)
    return np.column_stack([np.interp(warped, t, x[:, c]) for c in range(x.shape[1])])


@dataclass(eq=False, repr=False)
class ClassicalAugmentation:
    """The Classical Aug synthetic source (see the module docstring)."""

    name = "classical"

    jitter_sigma: float = 0.05
    scale_sigma: float = 0.1
    max_rotation_deg: float = 30.0
    warp_sigma: float = 0.2
    warp_knots: int = 4
    p: float = 0.5

    def augment(
        self,
        x: np.ndarray,
        channel_std: np.ndarray,
        groups: list[list[int]],
        rng: np.random.Generator,
    ) -> np.ndarray:
        """One augmented copy of a `(T, C)` window."""
        chosen = rng.random(4) < self.p
        if not chosen.any():
            chosen[rng.integers(4)] = True
        out = x.astype(np.float64)
        if chosen[0]:
            out = jitter(out, self.jitter_sigma * channel_std, rng)
        if chosen[1]:
            out = scale(out, self.scale_sigma, rng)
        if chosen[2]:
            out = rotate(out, groups, self.max_rotation_deg, rng)
        if chosen[3]:
            out = time_warp(out, self.warp_sigma, self.warp_knots, rng)
        return out

    def augment_pool(
        self,
        X: np.ndarray,
        y: np.ndarray,
        budget: np.ndarray,
        channel_std: np.ndarray,
        groups: list[list[int]],
        rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`budget[c]` augmented copies of windows of class c drawn from `X` with replacement:
        (windows, labels, index in `X` of the window each one came from)."""
        xs, ys, origin = [], [], []
        for c, n in enumerate(budget):
            pool = np.flatnonzero(y == c)
            if n <= 0 or len(pool) == 0:
                continue
            for i in rng.choice(pool, size=int(n), replace=True):
                xs.append(self.augment(X[i], channel_std, groups, rng))
                ys.append(c)
                origin.append(i)
        out = np.stack(xs).astype(np.float32) if xs else np.zeros((0, *X.shape[1:]), np.float32)
        return out, np.array(ys, dtype=np.int64), np.array(origin, dtype=np.int64)

    def generate(self, context: FoldContext) -> Windows:
        real = context.train
        rng = rng_for(
            context.seed, "classical", context.fold, context.protocol, context.label_budget
        )
        std = (
            real.X.reshape(-1, real.n_channels).std(axis=0)
            if len(real)
            else np.ones(real.n_channels)
        )
        X, ys, origin = self.augment_pool(real.X, real.y, context.budget_vector(), std,
                                          sensor_triplets(real.channel_names), rng)
        meta = {"source": np.full(len(ys), self.name), "origin_index": origin}
        for key in ("recording", "start"):  # provenance: the real window each one came from
            if key in real.meta:
                meta[f"origin_{key}"] = real.meta[key][origin]
        return Windows(
            X=X,
            y=ys,
            subjects=np.full(len(ys), "classical"),
            label_names=real.label_names,
            channel_names=real.channel_names,
            fs_hz=real.fs_hz,
            meta=meta,
        )
