"""`vsmp-imu data check`: each class's activity file simulated against the user's real windows.

Before a whole evaluation, a user wants to know which activity file (or which
declared convention) is off. Per class and sensor location this simulates a
few executions of the class's base SMP (the default motion, no grounding, no
filter), cuts them into windows as the pipeline does (a class whose real
windows need only a share of the window, a transition, keeps the windows that
overlap the movement by that share), puts them in the dataset's declared
convention (axes, gravity), turns
them by the sensor's mounting and compares them with the real windows of the
class.

Declared axes say which way a device's axes point, not how it sits on the
body (a phone turned on the belt, a watch strapped tilted). The pipeline
estimates that nominal mounting per location from the class means before it
grounds anything (grounding/mounting.py); the check estimates it the same way
(the rotation that best maps every class's simulated mean acceleration onto
its real one, weighted by the real windows) and reports it, so what is common
to every class is told apart from what is off in one activity file. A
mounting of more than `MAX_MOUNTING_DEG` is flagged (declared axes that are
wrong, rather than a sensor that sits askew). `mounting=False` compares in the
declared axes alone. Per class:

- `l_sim`: the D_stat loss between the two (grounding/stats.py: window
  covariance, band energies, RMS norms and autocorrelation; 0 = identical);
- the mean acceleration vector (where gravity points, device frame) and the
  angle between the real and the simulated one (also before the mounting:
  `declared_gravity_angle_deg`);
- the dominant frequency of the acceleration magnitude; for a single
  execution (an activity file that makes one execution, not a rhythm: a
  transition) how long one execution moves instead (`movement_s`), the
  simulated executions' median against the real labelled runs' median;
- the RMS of the acceleration around its window mean (how much it moves);
- the median skewness of |acc| within a window: impacts (heel strikes, a seat
  stopping the body) make it positive, a sine-like or minimum-jerk movement
  does not, and the ECDF features of a HAR model see exactly these
  within-window distributions;
- the mean gyroscope vector (a net turn, one way on average, e.g. the quarter
  turn of lying down along a bed; for a single execution, how far each
  execution turns from start to end, since a window's mean rate of a movement
  that turns and turns back depends on where the window cuts it), and the RMS of the rotation rate around
  each window's mean (how much it turns: a too rigid simulated pelvis shows
  here).

A class is flagged when gravity points more than `MAX_GRAVITY_ANGLE_DEG`
apart, when one execution moves more than `MAX_DURATION_RATIO` times faster or
slower than the real ones, when the dominant frequencies of an activity with
a rhythm differ by more than a factor `MAX_FREQUENCY_RATIO` (unless either side's spectrum peaks nearly as high at
the other's: one rhythm with two harmonics of about equal power), when one
moves `MAX_MOTION_RATIO` times more than the other, or when the two turn
differently on average (mean gyroscope vectors further apart than
`MIN_TURN_RAD_S` and half the larger one; the flag says whether one side does
not turn, the two turn opposite ways, or one turns further per window; for
an SMP that lists `dominant_side` among its variant fields, an opposite turn
adds that the generator takes the side from the real windows, since the file
leaves it open: pipeline/side.py).
Nothing but the mounting is fitted: it is a look, not a grounding.

Pairs of classes (`check_pairs`): a model learns from synthetic windows the
cues that tell two classes apart. Where the simulated windows of two classes
differ sharply on a cue the real windows of the same two classes barely
differ on (or differ on the other way), the model learns a rule a real
subject does not follow: on HAPT12 the simulated sit-to-lie and stand-to-lie
differ in one quarter of the window, the real ones hardly at all. Per location
and pair whose real windows no single cue tells apart well (every AUC within
`MAX_REAL_SEPARATION` of 0.5), each cue (every channel's mean over each
quarter of the window, its window mean and standard deviation) is scored by
the AUC of the pair on the real and on the simulated windows; the pair is
flagged when a cue separates the simulated windows by `MIN_OVERSHARP_GAP`
more than the real ones (|AUC - 0.5|), or the two sides separate clearly
(beyond `MIN_REVERSED`) in opposite directions. Windows of fewer than `QUARTERS` samples
have no quarters: the pairs are then not compared, and `pairs_skipped_` says why.

Which real class the simulated windows look like (`taken_for`): per location, a
Random Forest on ECDF features (the HAR backbone, balanced class weights),
trained on the real windows of every class checked there (at most
`TAKEN_MAX_PER_CLASS` a class, drawn evenly), reads each class's
simulated windows (train on real, test on synthetic). Per class it gives the
share of them taken for each class (`taken_for`, largest first) and for the
class itself (`recognised_pct`); a class whose simulated windows are taken for
one other class more often than for itself is flagged, naming that class. The
simulated windows are neither calibrated nor rank-grounded here, so a class
recognised well is one whose raw motion already reads like its real windows;
one taken for another class says which real class its activity file imitates
(on HAPT12 the compiled sit-to-lie is taken for stand-to-lie). A forest answers
with one of the classes it knows: a file unlike every class is still taken for
one of them, so a high share says the file reads more like its own class than
like the others, not that it reads like it (the loss and the motion say that).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import skew

from vsmp_imu.grounding.align import SIM_AXES, Convention, ConventionAlignment
from vsmp_imu.grounding.levels import part_means
from vsmp_imu.grounding.mounting import mounting_classes
from vsmp_imu.grounding.stats import sim_loss, summarize_windows
from vsmp_imu.har.dataset import HarDataset, SensorLocation
from vsmp_imu.har.holdout import require_windows
from vsmp_imu.har.windows import window_geometry, window_starts
from vsmp_imu.imu import simulate_kinematics
from vsmp_imu.io import atomic_path
from vsmp_imu.motion import Motion
from vsmp_imu.pipeline.sample import ACTIVE_SPEED_FRACTION, active_span, backend_for
from vsmp_imu.pipeline.side import side_is_free
from vsmp_imu.smp import SMP

MAX_GRAVITY_ANGLE_DEG = 45.0
MAX_FREQUENCY_RATIO = 1.6
SECOND_PEAK_SHARE = 0.7  # a peak this high beside the highest also counts as dominant
MAX_MOTION_RATIO = 3.0
STATIC_RMS_M_S2 = 0.5  # below this RMS around the mean a window set has no dominant frequency
MIN_FREQUENCY_HZ = 0.2
GYRO = slice(3, 6)  # the gyroscope's channels of a 6-channel window
MIN_TURN_RAD_S = 0.1  # mean rotation rates closer than this never differ
MIN_EXECUTION_TURN_DEG = 20.0  # net turns of one execution closer than this never differ
MAX_MOUNTING_DEG = 60.0  # a sensor turned further than this from its declared axes: check them
MAX_REAL_SEPARATION = 0.35  # a pair some real cue separates beyond AUC 0.85 is told apart anyway
MIN_OVERSHARP_GAP = 0.25  # |AUC - 0.5| simulated minus real that flags a cue
MIN_REVERSED = 0.15  # |AUC - 0.5| on both sides, opposite ways: a reversed cue
MIN_PAIR_WINDOWS = 6  # per class and side; fewer windows say nothing about a cue
TAKEN_TREES = 100  # the forest trained on the real windows that reads the simulated ones (`taken_for`)
TAKEN_MAX_PER_CLASS = 2000  # real windows per class it trains on at most (drawn evenly): seconds, not minutes
QUARTERS = 4
MAX_DURATION_RATIO = 1.3  # one execution's movement, simulated vs real, beyond this either way: flagged
MIN_EVENTS = 3  # labelled real executions a class needs for its duration
# one execution's peak rotation rate, simulated beyond this times the real one: flagged (only this way:
# a real rate holds sway and sensor noise a simulation has not, so a slower simulated peak says little)
MAX_PEAK_TURN_RATIO = 1.3
RATE_SMOOTH_S = 0.3  # moving average of the rotation rate before the threshold
# an SMP that lets its variants change side: the generator already takes the side the real windows show
SIDE_FROM_EVIDENCE = (" (the SMP leaves the side to its variants: generate and evaluate take it from the "
                      "real windows, the side from evidence)")


@dataclass
class ClassCheck:
    """The comparison of one class at one location (None where a side has no windows)."""

    label: str
    location: str
    source: str
    n_real: int
    n_synthetic: int
    real_mean_acc: list[float] | None = None
    synthetic_mean_acc: list[float] | None = None
    gravity_angle_deg: float | None = None
    real_frequency_hz: float | None = None
    synthetic_frequency_hz: float | None = None
    real_motion_rms: float | None = None
    synthetic_motion_rms: float | None = None
    real_acc_skew: float | None = None
    synthetic_acc_skew: float | None = None
    real_mean_gyro: list[float] | None = None
    synthetic_mean_gyro: list[float] | None = None
    real_turn_rms: float | None = None
    synthetic_turn_rms: float | None = None
    l_sim: float | None = None
    real_duration_s: float | None = None  # one execution's movement (median), single executions only
    synthetic_duration_s: float | None = None
    n_real_executions: int | None = None
    real_peak_turn_rad_s: float | None = None  # one execution's fastest rotation (median), single executions
    synthetic_peak_turn_rad_s: float | None = None
    real_execution_turn_deg: list[float] | None = None  # mean net turn of one execution (x, y, z)
    synthetic_execution_turn_deg: list[float] | None = None
    declared_gravity_angle_deg: float | None = None  # before the mounting
    recognised_pct: float | None = None  # simulated windows a forest trained on the real ones takes for this class
    taken_for: dict[str, float] | None = None  # % of the simulated windows taken for each class, largest first
    flags: list[str] = field(default_factory=list)


@dataclass
class MountingCheck:
    """The mounting estimated at one location: device-frame rotation of the simulated windows."""

    location: str
    classes: int  # classes whose means it was fitted to
    angle_deg: float | None = None  # None: not estimated (no gravity, no axes, fewer than 2 classes)
    axis: list[float] | None = None  # device frame, unit
    residual_deg: float | None = None  # rms angle between the turned simulated and the real class means
    quat_xyzw: list[float] | None = None  # the rotation itself (angle and axis are rounded for reading)
    flags: list[str] = field(default_factory=list)

    def matrix(self) -> np.ndarray:
        from scipy.spatial.transform import Rotation

        return np.eye(3) if self.quat_xyzw is None else Rotation.from_quat(self.quat_xyzw).as_matrix()

    def describe(self) -> str:
        if self.angle_deg is None:
            return f"{self.location}: no mounting estimated ({self.classes} classes with gravity and axes)"
        axis = " ".join(f"{v:+.2f}{n}" for v, n in zip(self.axis, "xyz", strict=True) if abs(v) >= 0.05)
        return (f"{self.location}: the real sensor sits {self.angle_deg:.0f}° from its declared axes (about "
                f"{axis}; {self.classes} class means fit within {self.residual_deg:.0f}° rms); the simulated "
                "windows are turned by it, as grounding does")


def estimate_location_mounting(location: str, pairs: list[tuple[np.ndarray, np.ndarray]]) -> MountingCheck:
    """The mounting from (real, simulated) windows of each class at one location (device frame)."""
    from vsmp_imu.grounding.mounting import estimate_mounting

    pairs = [(r, s) for r, s in pairs if len(r) and len(s)]
    out = MountingCheck(location, len(pairs))
    if len(pairs) < 2:
        return out
    rot, rms = estimate_mounting(np.array([mean_acc(s) for _, s in pairs]), np.array([mean_acc(r) for r, _ in pairs]),
                                 np.array([len(r) for r, _ in pairs], dtype=float))
    if not np.isfinite(rms):  # too few classes carry a gravity direction
        return out
    vec = rot.as_rotvec()
    angle = float(np.degrees(np.linalg.norm(vec)))
    out.angle_deg, out.residual_deg = round(angle, 2), round(rms, 2)
    out.quat_xyzw = [float(v) for v in rot.as_quat()]
    out.axis = (vec / np.linalg.norm(vec)).round(3).tolist() if angle > 0 else [1.0, 0.0, 0.0]
    if angle > MAX_MOUNTING_DEG:
        out.flags.append(f"the real sensor sits {angle:.0f}° from its declared axes: check the axes (a sensor "
                         "askew on the body sits a few tens of degrees off, wrong axes 90° or 180°)")
    return out


def turned(windows: np.ndarray, mounting: MountingCheck) -> np.ndarray:
    """Windows (N, T, C) with each 3-axis group (acc, gyro) turned by the mounting."""
    if mounting.quat_xyzw is None:
        return windows
    matrix = mounting.matrix()
    out = windows.copy()
    for start in range(0, windows.shape[-1] - 2, 3):
        out[..., start : start + 3] = windows[..., start : start + 3] @ matrix.T
    return out


def mean_acc(windows: np.ndarray) -> np.ndarray:
    """Mean accelerometer vector (3,) of windows (N, T, >=3)."""
    return windows[..., :3].reshape(-1, 3).mean(axis=0)


def motion_rms(windows: np.ndarray, channels: slice = slice(0, 3)) -> float:
    """RMS norm of the acceleration (or of `channels`) around each window's mean (m/s², rad/s)."""
    x = windows[..., channels]
    centred = x - x.mean(axis=1, keepdims=True)
    return float(np.sqrt((centred**2).sum(-1).mean()))


def acc_skew(windows: np.ndarray) -> float | None:
    """Median over windows of the skewness of |acc| within each (None when it hardly moves)."""
    if motion_rms(windows) < STATIC_RMS_M_S2:
        return None
    mag = np.linalg.norm(windows[..., :3], axis=-1)
    return float(np.median(skew(mag, axis=1)))


def spectrum(windows: np.ndarray, fs_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies and mean periodogram of the acceleration magnitude, from MIN_FREQUENCY_HZ."""
    mag = np.linalg.norm(windows[..., :3], axis=-1)
    mag = mag - mag.mean(axis=1, keepdims=True)
    power = (np.abs(np.fft.rfft(mag, axis=1)) ** 2).mean(axis=0)
    freqs = np.fft.rfftfreq(mag.shape[1], 1.0 / fs_hz)
    usable = freqs >= MIN_FREQUENCY_HZ
    return freqs[usable], power[usable]


def dominant_frequency(windows: np.ndarray, fs_hz: float) -> float | None:
    """Peak of the mean periodogram of the acceleration magnitude (None when it hardly moves)."""
    if motion_rms(windows) < STATIC_RMS_M_S2:
        return None
    freqs, power = spectrum(windows, fs_hz)
    return float(freqs[np.argmax(power)])


def strong_at(windows: np.ndarray, fs_hz: float, freq: float) -> bool:
    """Whether the |acc| spectrum has a peak at `freq` nearly as high as its highest
    (SECOND_PEAK_SHARE): two such peaks are one rhythm, whichever wins the argmax."""
    freqs, power = spectrum(windows, fs_hz)
    return bool(power[np.argmin(np.abs(freqs - freq))] >= SECOND_PEAK_SHARE * power.max())


def mean_gyro(windows: np.ndarray) -> np.ndarray:
    """Mean gyroscope vector (3,) of windows (N, T, 6): the net turn rate, rad/s."""
    return windows[..., 3:6].reshape(-1, 3).mean(axis=0)


def mean_turn_size(windows: np.ndarray) -> np.ndarray:
    """Mean over windows (N, T, 6) of each window's net turn rate's size per axis, rad/s."""
    return np.abs(windows[..., 3:6].mean(axis=1)).mean(axis=0)


def turns_either_way(windows: np.ndarray, threshold: float = 3 * MIN_TURN_RAD_S) -> bool:
    """Whether the windows (N, T, 6) that turn (net rate above `threshold` about some axis)
    turn both ways about it, each way in at least a quarter of them."""
    rate = windows[..., 3:6].mean(axis=1)
    for k in range(3):
        turning = rate[np.abs(rate[:, k]) > threshold, k]
        if len(turning) and min((turning > 0).mean(), (turning < 0).mean()) >= 0.25:
            return True
    return False


def turn_flag(real: np.ndarray, syn: np.ndarray, axes, side_free: bool = False, per: str = "window") -> str | None:
    """What looks off when one side turns one way on average and the other does not (`side_free`:
    the SMP leaves its side to its variants, so the generator takes it from the real windows).
    `per` "window": mean rotation rates (rad/s); "execution": one execution's net turn (degrees)."""
    floor = MIN_TURN_RAD_S if per == "window" else MIN_EXECUTION_TURN_DEG
    gap = float(np.linalg.norm(real - syn))
    if gap <= max(floor, 0.5 * max(np.linalg.norm(real), np.linalg.norm(syn))):
        return None
    k = int(np.argmax(np.abs(real - syn)))
    axis = f"{'xyz'[k]} ({axes[k]})" if axes else "xyz"[k]
    r, s = real[k], syn[k]
    if min(abs(r), abs(s)) < 0.5 * floor:
        hint = "a turn the activity file lacks" if abs(r) > abs(s) else f"a turn the real {per}s lack"
    elif np.sign(r) != np.sign(s):
        hint = "check the side" + (SIDE_FROM_EVIDENCE if side_free else "")
    else:
        hint = f"the simulation turns {abs(s / r):.1f}x as far per {per}: check " + (
            "the tempo, or how far the activity file turns" if per == "window" else "how far the activity file turns")
    if per == "window":
        return f"mean rotation rate about {axis}: {r:+.2f} rad/s real vs {s:+.2f} simulated: {hint}"
    return f"one execution turns {r:+.0f}° about {axis} real vs {s:+.0f}° simulated: {hint}"


def _angle(a: np.ndarray, b: np.ndarray) -> float | None:
    na, nb = np.linalg.norm(a), np.linalg.norm(b)
    if na < 1.0 or nb < 1.0:  # no gravity direction to compare (gravity removed, or free fall)
        return None
    return float(np.degrees(np.arccos(np.clip(a @ b / (na * nb), -1.0, 1.0))))


def simulate_signal(motion: Motion, loc: SensorLocation, fs_hz: float) -> tuple[np.ndarray, float]:
    """The motion's readings (T, C) at one location, in its declared convention (SI units), and the
    motion time of the first one."""
    kin = simulate_kinematics(motion, loc.name, fs_hz)
    signal = np.hstack([kin.specific_force_seg(), kin.gyr_seg])
    conv = Convention(axes=loc.axes or SIM_AXES, gravity_included=loc.gravity_included)
    return ConventionAlignment(conv).transform(signal, kin.grav_seg)[:, : len(loc.channels)], float(kin.times[0])


def simulate_windows(signal: np.ndarray, size: int, step: int, span: tuple[float, float] | None = None,
                     share: float = 1.0) -> np.ndarray:
    """Windows (N, size, C) of a simulated signal (T, C). With `span` (first and last sample the
    body moves) and a `share` below 1, only the windows that overlap the span by that share of the
    window, as the pipeline keeps a transition's windows (the dataset's labelling rule)."""
    starts = window_starts(len(signal), size, step)
    if span is not None and share < 1.0 and len(starts):
        overlap = np.minimum(starts + size, span[1]) - np.maximum(starts, span[0])
        starts = starts[overlap >= share * size] if (overlap >= share * size).any() else starts[[overlap.argmax()]]
    if len(starts) == 0:  # a motion shorter than one window: one window, last sample repeated
        pad = np.repeat(signal[-1:], size - len(signal), axis=0)
        return np.concatenate([signal, pad])[None]
    return np.stack([signal[s : s + size] for s in starts])


def _smoothed(rate: np.ndarray, fs_hz: float) -> np.ndarray:
    """`rate` (T,) as a moving average over `RATE_SMOOTH_S`."""
    k = max(1, int(round(RATE_SMOOTH_S * fs_hz)))
    return np.convolve(rate, np.ones(k) / k, mode="same")


def _rotation_rate(signal: np.ndarray, fs_hz: float) -> np.ndarray:
    """The gyroscope's norm of `signal` (T, 6), smoothed."""
    return _smoothed(np.linalg.norm(signal[:, GYRO], axis=1), fs_hz)


def peak_turn_rad_s(signal: np.ndarray, fs_hz: float) -> float | None:
    """How fast the execution (T, 6) turns at its fastest, rad/s (smoothed as `movement_s`); None
    without a gyroscope."""
    return float(_rotation_rate(signal, fs_hz).max()) if signal.shape[1] >= 6 and len(signal) else None


def movement_s(signal: np.ndarray, fs_hz: float) -> float | None:
    """Seconds between the first and the last moment the signal (T, C) moves: its rotation rate
    (the gyroscope's norm; without one, how fast the acceleration changes), smoothed
    over `RATE_SMOOTH_S`, above `ACTIVE_SPEED_FRACTION` of its peak (the fraction of the pipeline's
    active span). None for a signal that never moves."""
    if len(signal) < 2:
        return None
    if signal.shape[1] >= 6:
        rate = _rotation_rate(signal, fs_hz)
    else:
        rate = _smoothed(np.linalg.norm(np.gradient(signal[:, :3], axis=0), axis=1), fs_hz)
    if not rate.max() > 0:
        return None
    moving = np.flatnonzero(rate > ACTIVE_SPEED_FRACTION * rate.max())
    return float((moving[-1] - moving[0]) / fs_hz)


def real_executions(dataset: HarDataset, label_index: int, cols: list[int]) -> list[np.ndarray]:
    """Every labelled run of the class in the dataset's recordings (each run one execution), the
    readings of the location's channels `cols`."""
    out = []
    for rec in dataset.recordings():
        edges = np.diff(np.r_[0, (rec.labels == label_index).astype(np.int8), 0])
        for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
            out.append(rec.data[a:b][:, cols].astype(np.float64))
    return out


def net_turn_deg(signal: np.ndarray, fs_hz: float) -> np.ndarray | None:
    """How far the execution (T, 6) turns about each gyroscope axis, start to end, in degrees."""
    return np.degrees(signal[:, GYRO].sum(axis=0) / fs_hz) if signal.shape[1] >= 6 else None


@dataclass(frozen=True)
class Timing:
    """One execution: how long it moves in seconds, real (median of `n_real` labelled runs; None
    with fewer than `MIN_EVENTS`) and simulated (median of the executions simulated); and with a
    gyroscope each execution's net turn (rows of degrees about x, y, z; None without)."""

    real_s: float | None
    synthetic_s: float | None
    n_real: int
    real_turns: np.ndarray | None = None
    synthetic_turns: np.ndarray | None = None
    real_peak: float | None = None  # rad/s, median over the executions (None without a gyroscope)
    synthetic_peak: float | None = None


def timing(real: list[np.ndarray], simulated: list[np.ndarray], fs_hz: float) -> Timing:
    """The Timing of real and simulated executions (T, C) in the same frame."""
    seconds = [[v for v in (movement_s(x, fs_hz) for x in side) if v is not None] for side in (real, simulated)]
    turns = [np.array([net_turn_deg(x, fs_hz) for x in side]) if side and side[0].shape[1] >= 6 else None
             for side in (real, simulated)]
    peaks = [[v for v in (peak_turn_rad_s(x, fs_hz) for x in side) if v is not None] for side in (real, simulated)]
    enough = len(seconds[0]) >= MIN_EVENTS
    return Timing(float(np.median(seconds[0])) if enough else None,
                  float(np.median(seconds[1])) if seconds[1] else None, len(seconds[0]),
                  turns[0] if enough else None, turns[1],
                  float(np.median(peaks[0])) if enough and peaks[0] else None,
                  float(np.median(peaks[1])) if peaks[1] else None)


def peak_turn_flag(t: Timing) -> str | None:
    """What looks off when one simulated execution turns much faster at its peak than a real one."""
    if not (t.real_peak and t.synthetic_peak) or t.synthetic_peak <= MAX_PEAK_TURN_RATIO * t.real_peak:
        return None
    return (f"one execution turns at up to {t.synthetic_peak:.1f} rad/s simulated vs {t.real_peak:.1f} rad/s real "
            f"(median of {t.n_real} labelled executions): the activity file turns the body "
            f"{t.synthetic_peak / t.real_peak:.1f}x as fast: give the primitive that turns more time")


def duration_flag(t: Timing) -> str | None:
    """What looks off when one simulated execution moves much faster or slower than a real one."""
    if not (t.real_s and t.synthetic_s):
        return None
    ratio = t.real_s / t.synthetic_s
    if 1 / MAX_DURATION_RATIO <= ratio <= MAX_DURATION_RATIO:
        return None
    if ratio > 1:
        hint = (f"the activity file is {ratio:.1f}x too fast: slow its tempo or lengthen its primitives' "
                "duration_s")
    else:
        hint = (f"the activity file is {1 / ratio:.1f}x too slow: raise its tempo or shorten its primitives' "
                "duration_s")
    return (f"one execution moves for {t.synthetic_s:.1f} s simulated vs {t.real_s:.1f} s real (median of "
            f"{t.n_real} labelled executions): {hint} (or time each sample to a real execution: "
            "--event-durations)")


@dataclass
class PairCheck:
    """Two classes at one location: the cue the simulated windows separate them by most beyond the
    real ones (AUC of the first class against the second; 0.5: no separation)."""

    location: str
    first: str
    second: str
    n_real: list[int]
    n_synthetic: list[int]
    real_best_separation: float  # max |AUC - 0.5| of any cue on the real windows
    cue: str | None = None
    real_auc: float | None = None
    synthetic_auc: float | None = None
    flags: list[str] = field(default_factory=list)


def pair_cues(windows: np.ndarray, channels: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Per window (N, T, C): each channel's mean over each quarter, its mean and its standard
    deviation, named like 'acc_z q1', 'acc_z mean', 'acc_z std'."""
    quarters = part_means(windows, QUARTERS).reshape(len(windows), QUARTERS, -1)
    out = {}
    for c, name in enumerate(channels):
        for k in range(QUARTERS):
            out[f"{name} q{k + 1}"] = quarters[:, k, c]
        out[f"{name} mean"] = windows[..., c].mean(axis=1)
        out[f"{name} std"] = windows[..., c].std(axis=1)
    return out


def _auc(first: np.ndarray, second: np.ndarray) -> float:
    from sklearn.metrics import roc_auc_score

    return float(roc_auc_score(np.r_[np.ones(len(first)), np.zeros(len(second))], np.r_[first, second]))


def compare_pair(location: str, first: str, second: str, real: tuple[np.ndarray, np.ndarray],
                 syn: tuple[np.ndarray, np.ndarray], channels: tuple[str, ...]) -> PairCheck | None:
    """The pair's sharpest simulated cue against the real windows (see module doc); None where a
    side has too few windows or a real cue already tells the two apart."""
    if min(len(w) for w in (*real, *syn)) < MIN_PAIR_WINDOWS:
        return None
    ra, rb = (pair_cues(w, channels) for w in real)
    sa, sb = (pair_cues(w, channels) for w in syn)
    real_auc = {k: _auc(ra[k], rb[k]) for k in ra}
    best_real = max(abs(v - 0.5) for v in real_auc.values())
    if best_real > MAX_REAL_SEPARATION:
        return None
    syn_auc = {k: _auc(sa[k], sb[k]) for k in sa}
    cue = max(syn_auc, key=lambda k: (abs(syn_auc[k] - 0.5) - abs(real_auc[k] - 0.5), k))
    out = PairCheck(location, first, second, [len(w) for w in real], [len(w) for w in syn], round(best_real, 3),
                    cue, round(real_auc[cue], 3), round(syn_auc[cue], 3))
    r, s = real_auc[cue] - 0.5, syn_auc[cue] - 0.5
    if abs(s) - abs(r) >= MIN_OVERSHARP_GAP:
        out.flags.append(f"the simulated windows tell {first} from {second} by {cue} (AUC {syn_auc[cue]:.2f}), "
                         f"the real ones {'hardly' if abs(r) < MIN_REVERSED else 'less'} (AUC {real_auc[cue]:.2f}): "
                         "a model learns a rule real subjects do not follow; check what the two activity files "
                         "do differently there")
    reversed_ = [k for k in real_auc if min(abs(real_auc[k] - 0.5), abs(syn_auc[k] - 0.5)) >= MIN_REVERSED
                 and (real_auc[k] - 0.5) * (syn_auc[k] - 0.5) < 0]
    if reversed_:
        k = max(reversed_, key=lambda k: (abs(syn_auc[k] - 0.5), k))
        out.flags.append(f"{k} separates {first} from {second} the other way in the simulated windows "
                         f"(AUC {syn_auc[k]:.2f}) than in the real ones ({real_auc[k]:.2f})")
    return out


def pairs_skipped(size: int) -> str | None:
    """Why the pair check cannot run on windows of `size` samples (None: it can)."""
    if size < QUARTERS:
        return f"a window of {size} samples has no {QUARTERS} quarters to compare: that needs {QUARTERS} samples"
    return None


def check_pairs(windows: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]],
                channels: dict[str, tuple[str, ...]]) -> list[PairCheck]:
    """`compare_pair` for every two classes at each location (`windows`: (label, location) ->
    (real, simulated) windows; `channels`: location -> channel names)."""
    out = []
    keys = list(windows)
    for i, (a, place) in enumerate(keys):
        for b, other in keys[i + 1:]:
            if other != place:
                continue
            (ra, sa), (rb, sb) = windows[(a, place)], windows[(b, other)]
            found = compare_pair(place, a, b, (ra, rb), (sa, sb), channels[place])
            if found is not None:
                out.append(found)
    return out


def taken_for(windows: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]], place: str) -> dict[str, dict[str, float]]:
    """At `place`, per class with real and simulated windows: the share (%) of its simulated windows a
    forest trained on every class's real windows takes for each class, largest first (see module doc);
    empty where fewer than two classes have real windows."""
    from vsmp_imu.har.backbones.rf import RandomForestECDF

    labels = [label for (label, at), (real, _) in windows.items() if at == place and len(real)]
    if len(labels) < 2:
        return {}
    real = [_evenly(windows[(label, place)][0], TAKEN_MAX_PER_CLASS) for label in labels]
    X = np.concatenate(real)
    y = np.concatenate([np.full(len(r), k) for k, r in enumerate(real)])
    forest = RandomForestECDF(n_estimators=TAKEN_TREES, class_weight="balanced", n_jobs=1).fit(X, y)
    out = {}
    for label in labels:
        syn = windows[(label, place)][1]
        if len(syn):
            counts = np.bincount(forest.predict(syn), minlength=len(labels))
            shares = {labels[k]: round(100.0 * n / len(syn), 1) for k, n in enumerate(counts) if n}
            out[label] = dict(sorted(shares.items(), key=lambda kv: (-kv[1], kv[0])))
    return out


def _evenly(windows: np.ndarray, most: int) -> np.ndarray:
    """At most `most` of `windows`, spread evenly over them (recordings stay represented in order)."""
    if len(windows) <= most:
        return windows
    return windows[np.linspace(0, len(windows) - 1, most).round().astype(int)]


def taken_flag(label: str, shares: dict[str, float]) -> str | None:
    """The flag of a class whose simulated windows are taken for one other class more often than for
    itself (`shares` as `taken_for` gives them); None otherwise."""
    own = shares.get(label, 0.0)
    other = next((k for k in shares if k != label), None)
    if other is None or shares[other] <= own:
        return None
    return (f"a forest trained on the real windows takes {shares[other]:.0f} % of the simulated windows for "
            f"{other} and {own:.0f} % for {label}: the activity file reads more like the real {other}; "
            "check what it does differently (the pair check names cues)")


def _turns(out: ClassCheck, real: np.ndarray, syn: np.ndarray,
           executions: Timing | None) -> tuple[np.ndarray, np.ndarray, str, float]:
    """What the turn flag compares: (real, simulated, per, either-way threshold). The windows, or for
    a single execution with both sides' net turns, one row per execution (as (N, 1, 6) windows
    whose gyroscope is the turn in degrees): a window's mean rate of a movement that turns and
    turns back depends on where the window cuts it and on the tempo, the whole execution's net
    turn does not."""
    if executions is None or executions.real_turns is None or executions.synthetic_turns is None:
        return real, syn, "window", 3 * MIN_TURN_RAD_S
    out.real_execution_turn_deg = executions.real_turns.mean(axis=0).round(1).tolist()
    out.synthetic_execution_turn_deg = executions.synthetic_turns.mean(axis=0).round(1).tolist()

    def rows(turns: np.ndarray) -> np.ndarray:
        return np.concatenate([np.zeros((len(turns), 1, 3)), turns[:, None, :]], axis=2)

    return rows(executions.real_turns), rows(executions.synthetic_turns), "execution", MIN_EXECUTION_TURN_DEG


def compare(label: str, loc: SensorLocation, source: str, real: np.ndarray, syn: np.ndarray,
            fs_hz: float, declared: np.ndarray | None = None, side_free: bool = False,
            executions: Timing | None = None) -> ClassCheck:
    """The statistics of one class at one location, and what looks off (`syn` turned by the
    mounting; `declared`: the same windows before it, for the angle in the declared axes;
    `side_free`: turn_flag; `executions`: a single execution's timing, which replaces the
    dominant frequency's flag)."""
    out = ClassCheck(label, loc.name, source, len(real), len(syn))
    if executions is not None:
        out.real_duration_s = None if executions.real_s is None else round(executions.real_s, 3)
        out.synthetic_duration_s = None if executions.synthetic_s is None else round(executions.synthetic_s, 3)
        out.n_real_executions = executions.n_real
        out.real_peak_turn_rad_s = None if executions.real_peak is None else round(executions.real_peak, 3)
        out.synthetic_peak_turn_rad_s = (None if executions.synthetic_peak is None
                                         else round(executions.synthetic_peak, 3))
    if len(real) == 0 or len(syn) == 0:
        out.flags.append("no real windows" if len(real) == 0 else "no simulated windows")
        return out
    r_mean, s_mean = mean_acc(real), mean_acc(syn)
    out.real_mean_acc, out.synthetic_mean_acc = r_mean.round(3).tolist(), s_mean.round(3).tolist()
    out.gravity_angle_deg = _angle(r_mean, s_mean)
    out.declared_gravity_angle_deg = _angle(r_mean, mean_acc(syn if declared is None else declared))
    out.real_frequency_hz = dominant_frequency(real, fs_hz)
    out.synthetic_frequency_hz = dominant_frequency(syn, fs_hz)
    out.real_motion_rms, out.synthetic_motion_rms = motion_rms(real), motion_rms(syn)
    out.real_acc_skew, out.synthetic_acc_skew = acc_skew(real), acc_skew(syn)
    if real.shape[-1] == 6:
        out.l_sim = float(sim_loss(summarize_windows(syn, fs_hz), summarize_windows(real, fs_hz)))
        r_gyro, s_gyro = mean_gyro(real), mean_gyro(syn)
        out.real_mean_gyro, out.synthetic_mean_gyro = r_gyro.round(3).tolist(), s_gyro.round(3).tolist()
        out.real_turn_rms, out.synthetic_turn_rms = motion_rms(real, GYRO), motion_rms(syn, GYRO)
        real_turns, syn_turns, per, either_way = _turns(out, real, syn, executions)
        turn = turn_flag(mean_gyro(real_turns), mean_gyro(syn_turns), loc.axes, side_free, per)
        # executions that turn to a drawn side (a stairwell's landings) cancel in the class mean:
        # turning either way as much per window as the real windows turn is no gap
        if turn and not (turns_either_way(syn_turns, either_way)
                         and turn_flag(mean_turn_size(real_turns), mean_turn_size(syn_turns), loc.axes,
                                       per=per) is None):
            out.flags.append(turn)
    if out.gravity_angle_deg is not None and out.gravity_angle_deg > MAX_GRAVITY_ANGLE_DEG:
        out.flags.append(f"gravity points {out.gravity_angle_deg:.0f}° apart: check the declared axes, "
                         "the side, or the posture in the activity file")
    fr, fs = out.real_frequency_hz, out.synthetic_frequency_hz
    for timed in ((duration_flag(executions), peak_turn_flag(executions)) if executions is not None else ()):
        if timed:
            out.flags.append(timed)
    if (executions is None and fr and fs and max(fr, fs) / min(fr, fs) > MAX_FREQUENCY_RATIO
            and not strong_at(syn, fs_hz, fr) and not strong_at(real, fs_hz, fs)):
        out.flags.append(f"dominant frequency {fs:.2f} Hz simulated vs {fr:.2f} Hz real: check the tempo "
                         "or the repetitions in the activity file")
    ratio = (out.synthetic_motion_rms + 0.1) / (out.real_motion_rms + 0.1)
    if not 1 / MAX_MOTION_RATIO <= ratio <= MAX_MOTION_RATIO:
        out.flags.append(f"the simulation moves {ratio:.1f}x as much as the real windows: check the "
                         "amplitude, or whether the file describes this activity")
    return out


def locations_of(info, label: str) -> list[SensorLocation]:
    """The locations a class is worn at (one per class where the placement depends on it)."""
    if info.location_by_label and label in info.location_by_label:
        return [info.location(info.location_by_label[label])]
    return list(info.locations)


def taken_matrix(results: list[ClassCheck], place: str) -> tuple[list[str], list[str], np.ndarray]:
    """The shares `taken_for` gives at `place` as a matrix: (simulated classes, the classes they are taken
    for: the rows' own first, then any other, e.g. one with real windows and none simulated, % per cell)."""
    rows = [r for r in results if r.location == place and r.taken_for]
    columns = list(dict.fromkeys([r.label for r in rows] + [k for r in rows for k in r.taken_for]))
    return [r.label for r in rows], columns, np.array([[r.taken_for.get(c, 0.0) for c in columns] for r in rows])


def _pyplot():
    """matplotlib.pyplot on the file backend (Agg, unless a backend is already chosen)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def _save_png(fig, path: Path) -> None:
    """Write `fig` to `path` as a PNG (90 dpi), atomically."""
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png", dpi=90)


@dataclass
class DataCheck:
    """Simulates each class's base SMP at the dataset's locations and compares (see module doc)."""

    backend: str = "procedural"
    samples: int = 3
    window_s: float = 2.0
    overlap: float = 0.5
    library_dirs: tuple[str, ...] = ()
    mounting: bool = True
    results_: list[ClassCheck] = field(default_factory=list)
    mountings_: list[MountingCheck] = field(default_factory=list)
    windows_: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    pairs_: list[PairCheck] = field(default_factory=list)
    pairs_skipped_: str | None = None  # why no pair was compared (windows too short)
    _channels: dict[str, tuple[str, ...]] = field(default_factory=dict, repr=False)

    def run(self, dataset: HarDataset, sources: dict[str, list]) -> list[ClassCheck]:
        info = dataset.info
        size, step = window_geometry(info.fs_hz, self.window_s, self.overlap)
        shares = info.share_vector()
        real = dataset.windows(self.window_s, self.overlap)
        require_windows(dataset, real, self.window_s)
        backend = backend_for(self.backend, tuple(self.library_dirs))
        declared: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]] = {}
        executions: dict[tuple[str, str], tuple[list, list]] = {}  # single executions: (real, simulated)
        sources_of: dict[str, str] = {}
        side_free: dict[str, bool] = {}  # the base SMP leaves its side to its variants (turn_flag)
        for i, label in enumerate(info.label_names):
            if label not in sources:
                continue
            source, base = sources[label][0]
            sources_of[label] = source
            side_free[label] = isinstance(base, SMP) and side_is_free(base)
            motions = [Motion.load(base) if isinstance(base, Path) else backend.generate(base, seed)
                       for seed in range(self.samples)]
            single = all(m.single_execution for m in motions)
            for loc in locations_of(info, label):
                cols = [info.channel_names.index(c) for c in loc.channels]
                r = real.X[real.y == i][..., cols].astype(np.float64)
                signals, windows = [], []
                for m in motions:
                    sig, start_s = simulate_signal(m, loc, info.fs_hz)
                    span = tuple((t - start_s) * info.fs_hz for t in active_span(m))
                    signals.append(sig)
                    windows.append(simulate_windows(sig, size, step, span, shares[i]))
                s = np.concatenate(windows)
                declared[(label, loc.name)] = (r, s)
                if single:
                    executions[(label, loc.name)] = (real_executions(dataset, i, cols), signals)
        singles = {label for label, _ in executions}
        self.mountings_ = [self._mounting(loc, declared, singles) for loc in info.locations
                           if any(name == loc.name for _, name in declared)]
        by_place = {m.location: m for m in self.mountings_}
        timings = {key: timing(r, [turned(x[None], by_place[key[1]])[0] for x in s], info.fs_hz)
                   for key, (r, s) in executions.items()}
        self.results_, self.windows_ = [], {}
        for (label, place), (r, s) in declared.items():
            loc = info.location(place)
            s_turned = turned(s, by_place[place])
            self.windows_[(label, place)] = (r, s_turned)
            self.results_.append(compare(label, loc, sources_of[label], r, s_turned, info.fs_hz, declared=s,
                                         side_free=side_free[label], executions=timings.get((label, place))))
        self._taken()
        self._channels = {loc.name: tuple(loc.channels) for loc in info.locations}
        self.pairs_skipped_ = pairs_skipped(size)
        self.pairs_ = [] if self.pairs_skipped_ else check_pairs(self.windows_, self._channels)
        return self.results_

    def _taken(self) -> None:
        """Each result's `taken_for`, `recognised_pct` and flag (module doc)."""
        for place in dict.fromkeys(at for _, at in self.windows_):
            taken = taken_for(self.windows_, place)
            for r in self.results_:
                if r.location == place and r.label in taken:
                    r.taken_for, r.recognised_pct = taken[r.label], taken[r.label].get(r.label, 0.0)
                    flag = taken_flag(r.label, r.taken_for)
                    if flag:
                        r.flags.append(flag)

    def _mounting(self, loc: SensorLocation, declared: dict, singles: set[str]) -> MountingCheck:
        """As grounding estimates it: from the classes that hold a posture or repeat a rhythm
        where two or more have windows, else from every class."""
        if not (self.mounting and loc.gravity_included and loc.axes):
            return MountingCheck(loc.name, 0)
        pairs = [(label, pair) for (label, place), pair in declared.items()
                 if place == loc.name and len(pair[0]) and len(pair[1])]
        used = mounting_classes(pairs, lambda item: item[0] in singles)
        return estimate_location_mounting(loc.name, [pair for _, pair in used])

    def plot_pairs(self, path: Path) -> Path | None:
        """Per flagged pair: its cue's distribution in the two classes, real beside simulated
        (written atomically); None when no pair is flagged."""
        flagged = [p for p in self.pairs_ if p.flags]
        if not flagged:
            return None
        plt = _pyplot()

        fig, axes = plt.subplots(len(flagged), 2, figsize=(8, 2.1 * len(flagged)), squeeze=False)
        try:
            for pair, row in zip(flagged, axes, strict=True):
                for ax, side, name in ((row[0], 0, "real"), (row[1], 1, "simulated")):
                    values = [pair_cues(self.windows_[(label, pair.location)][side],
                                        self._channels[pair.location])[pair.cue]
                              for label in (pair.first, pair.second)]
                    bins = np.histogram_bin_edges(np.concatenate(values), bins=20)
                    for v, label, color in zip(values, (pair.first, pair.second), ("#1f6fb4", "#d9822b"),
                                               strict=True):
                        ax.hist(v, bins=bins, density=True, alpha=0.55, color=color, label=label)
                    auc = pair.real_auc if side == 0 else pair.synthetic_auc
                    ax.set_title(f"{name}: {pair.cue} @ {pair.location} (AUC {auc:.2f})", fontsize=9, loc="left")
                row[0].legend(fontsize=7)
            fig.tight_layout()
            _save_png(fig, path)
        finally:
            plt.close(fig)
        return Path(path)

    def plot_taken(self, path: Path) -> Path | None:
        """Per location: which class a forest trained on the real windows takes each class's simulated
        windows for, as a matrix (rows: the simulated class; written atomically); None when no class
        was read."""
        places = list(dict.fromkeys(r.location for r in self.results_ if r.taken_for))
        if not places:
            return None
        plt = _pyplot()

        size = max(len(taken_matrix(self.results_, p)[1]) for p in places)
        fig, axes = plt.subplots(1, len(places), figsize=(1.8 + 0.42 * size * len(places), 1.8 + 0.42 * size),
                                 squeeze=False)
        try:
            for place, ax in zip(places, axes[0], strict=True):
                rows, labels, matrix = taken_matrix(self.results_, place)
                ax.imshow(matrix, cmap="Blues", vmin=0, vmax=100)
                for i, j in zip(*np.nonzero(matrix), strict=True):
                    ax.text(j, i, f"{matrix[i, j]:.0f}", ha="center", va="center", fontsize=7,
                            color="white" if matrix[i, j] > 60 else "black")
                ax.set_xticks(range(len(labels)), labels, rotation=60, ha="right", fontsize=7)
                ax.set_yticks(range(len(rows)), rows, fontsize=7)
                ax.set_xlabel("taken for (forest trained on the real windows)", fontsize=8)
                ax.set_ylabel("simulated class", fontsize=8)
                ax.set_title(f"{place}: % of each class's simulated windows", fontsize=9, loc="left")
            fig.tight_layout()
            _save_png(fig, path)
        finally:
            plt.close(fig)
        return Path(path)

    def to_json(self) -> list[dict]:
        return [asdict(r) for r in self.results_]

    def plot(self, path: Path, fs_hz: float) -> Path:
        """Per class and location: mean acceleration (x, y, z) and the spectrum of |acc|, real vs
        simulated (turned by the mounting; written atomically)."""
        plt = _pyplot()

        rows = list(self.windows_.items())
        fig, axes = plt.subplots(max(len(rows), 1), 2, figsize=(9, 2.2 * max(len(rows), 1)), squeeze=False)
        try:
            for (key, (real, syn)), (ax_g, ax_f), res in zip(rows, axes, self.results_, strict=True):
                label = f"{key[0]} @ {key[1]}" + ("  [!]" if res.flags else "")
                for offset, w, name, color in ((-0.2, real, "real", "#333333"), (0.2, syn, "simulated", "#c8342b")):
                    if len(w):
                        ax_g.bar(np.arange(3) + offset, mean_acc(w), width=0.4, label=name, color=color)
                        mag = np.linalg.norm(w[..., :3], axis=-1)
                        mag = mag - mag.mean(axis=1, keepdims=True)
                        power = (np.abs(np.fft.rfft(mag, axis=1)) ** 2).mean(axis=0)
                        ax_f.plot(np.fft.rfftfreq(mag.shape[1], 1 / fs_hz), power / (power.max() + 1e-12),
                                  color=color, label=name)
                ax_g.set_xticks(range(3), ["acc x", "acc y", "acc z"])
                ax_g.set_ylabel("mean m/s²")
                ax_g.set_title(label, fontsize=9, loc="left")
                ax_f.set_xlabel("Hz (|acc| spectrum, normalised)")
                ax_f.set_xlim(0, min(fs_hz / 2, 8))
            if rows:
                axes[0, 0].legend(fontsize=7)
            turns = [f"{m.location} {m.angle_deg:.0f}°" for m in self.mountings_ if m.angle_deg is not None]
            if turns:
                fig.suptitle(f"simulated windows turned by the estimated mounting ({', '.join(turns)})", fontsize=9)
            fig.tight_layout(rect=(0, 0, 1, 1 - 0.35 / fig.get_figheight()))
            _save_png(fig, path)
        finally:
            plt.close(fig)
        return Path(path)
