"""Smooth curves for the procedural backend: keyframe tracks and periodic waves.

Keyframes are joined by quintic Hermite segments with zero acceleration at
the keys. A "stop" key has zero velocity (each segment between two stop keys
is then the minimum-jerk profile 10u^3 - 15u^4 + 6u^5); a "smooth" key passes
through with the Catmull-Rom velocity of its neighbours. The result is C2
everywhere (velocity and acceleration continuous). Periodic waves are
periodic cubic splines over the cycle phase. Everything is vectorized over
frames and DOFs.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline


def minimum_jerk(u: np.ndarray) -> np.ndarray:
    """The minimum-jerk ease 0 -> 1 over u in [0, 1]."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10.0 - 15.0 * u + 6.0 * u**2)


def key_velocities(times: np.ndarray, values: np.ndarray, stop: np.ndarray,
                   through: np.ndarray | None = None) -> np.ndarray:
    """Velocity at each key: zero at stop keys and at the ends, Catmull-Rom otherwise. At a `through`
    key a DOF that turns back or holds on either side stops (the curve never swings past a key where
    it turns); the others keep their Catmull-Rom velocity, so the body moves on as one."""
    vel = np.zeros_like(values)
    if len(times) > 2:
        span = (times[2:] - times[:-2])[:, None]
        vel[1:-1] = (values[2:] - values[:-2]) / np.maximum(span, 1e-9)
    if through is not None and len(times) > 2:
        steps = np.diff(values, axis=0)
        turns = (steps[:-1] * steps[1:] <= 0.0) & through[1:-1, None]  # turns back or holds on a side
        vel[1:-1][turns] = 0.0
    vel[stop] = 0.0
    vel[0] = 0.0
    vel[-1] = 0.0
    return vel


def hermite_track(times: np.ndarray, values: np.ndarray, stop: np.ndarray, t: np.ndarray,
                  through: np.ndarray | None = None) -> np.ndarray:
    """Evaluate the keyframe track at times `t` -> (len(t), D).

    `times` (K,) strictly increasing, `values` (K, D), `stop` (K,) bool, `through` (K,) bool or None
    (keys passed where the DOF goes on the same way, `key_velocities`).
    Before the first key and after the last, the end values hold.
    """
    times = np.asarray(times, dtype=float)
    values = np.asarray(values, dtype=float)
    if len(times) == 1:
        return np.repeat(values[:1], len(t), axis=0)
    vel = key_velocities(times, values, np.asarray(stop, dtype=bool),
                         None if through is None else np.asarray(through, dtype=bool))
    i = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2)
    h = (times[i + 1] - times[i])[:, None]
    u = np.clip((t[:, None] - times[i][:, None]) / h, 0.0, 1.0)
    u2, u3 = u * u, u * u * u
    u4, u5 = u3 * u, u3 * u2
    h0 = 1.0 - 10.0 * u3 + 15.0 * u4 - 6.0 * u5
    h1 = u - 6.0 * u3 + 8.0 * u4 - 3.0 * u5
    h4 = -4.0 * u3 + 7.0 * u4 - 3.0 * u5
    h5 = 10.0 * u3 - 15.0 * u4 + 6.0 * u5
    return h0 * values[i] + h5 * values[i + 1] + h * (h1 * vel[i] + h4 * vel[i + 1])


class PeriodicWave:
    """A periodic C2 curve through [phase, value] keys (phase in cycles)."""

    def __init__(self, keys: list[tuple[float, float]]) -> None:
        phases = np.array([p for p, _ in keys], dtype=float)
        vals = np.array([v for _, v in keys], dtype=float)
        self._spline = CubicSpline(np.append(phases, phases[0] + 1.0), np.append(vals, vals[0]),
                                   bc_type="periodic")
        self._start = float(phases[0])

    def __call__(self, phase: np.ndarray) -> np.ndarray:
        p = self._start + np.mod(np.asarray(phase, dtype=float) - self._start, 1.0)
        return self._spline(p)


def smoothstep_ramp(t: np.ndarray, start: float, end: float, ramp_s: float, fade_in: bool,
                    fade_out: bool) -> np.ndarray:
    """An envelope: 0 outside [start, end], 1 inside, minimum-jerk ramps of `ramp_s`."""
    env = ((t >= start) & (t <= end)).astype(float)
    if ramp_s > 0:
        if fade_in:
            env = env * minimum_jerk((t - start) / ramp_s)
        if fade_out:
            env = env * minimum_jerk((end - t) / ramp_s)
    return env


def low_frequency_noise(rng: np.random.Generator, t: np.ndarray, n: int, sigma: float,
                        knot_s: float = 1.5) -> np.ndarray:
    """(len(t), n) smooth zero-mean noise of standard deviation ~sigma.

    Random values at knots every ~`knot_s` seconds (random offset), joined by
    C2 Catmull-Rom quintic segments: variability below ~1/knot_s Hz.
    """
    span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    k = int(np.ceil(span / knot_s)) + 3
    knots = t[0] - rng.uniform(0.0, knot_s) + knot_s * np.arange(k)
    values = rng.normal(0.0, sigma, size=(k, n))
    return hermite_track(knots, values, np.zeros(k, dtype=bool), t)
