"""Control measurements on a generated motion (paper appendix "Analysis Parameters").

Every measurement works on any `Motion` (procedural, HY-Motion, video pose)
and uses the paper's parameters: a 4th-order zero-phase Butterworth
low-pass at 6 Hz; peaks with prominence 0.40 x the signal's standard
deviation and at least 0.35 s apart; primitive boundaries where the relevant
joint speed crosses 20 % of its maximum, held for at least 0.10 s; symmetric
when the mirrored left-right trajectory correlation is at least 0.82.

Conventions of this implementation (documented in docs/motion.md):
- joint trajectories are positions relative to the pelvis in the body's mean
  heading frame (x = left, y = up, z = forward); the pelvis itself is its
  world position relative to its first frame;
- joint angles are local joint rotations (relative to the parent joint)
  relative to the first frame, projected on their main axis of variation;
  an elbow's leaves out the forearm's twist about its long axis (pronation);
- repetitions are peaks of the principal component of the principal
  joints' trajectories that carries the cycles: axes are fitted on the
  joints' velocities, and the first of the first three whose velocity is
  periodic is used (the first, unless a one-off posture change such as
  raising the arm before waving dominates it); the signal is oriented so
  that excursions away from the starting posture are peaks.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, find_peaks
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.motion import Motion
from vsmp_imu.zero_phase import filtfilt

# Paper appendix "Analysis Parameters", "Control-measurement parameters".
BUTTER_ORDER = 4
CUTOFF_HZ = 6.0
PEAK_PROMINENCE = 0.40  # x signal standard deviation
PEAK_DISTANCE_S = 0.35
VELOCITY_FRACTION = 0.20
MIN_HOLD_S = 0.10
SYMMETRY_THRESHOLD = 0.82  # C_sym
# Choices of this implementation (docs/motion.md, "Measuring controls").
STATIC_STD_M = 0.01  # a joint pair moving less than this is left out of C_sym
STATIC_FRACTION = 0.15  # ... or less than this fraction of the most moving pair
PERIODIC_AXIS_MIN = 0.55  # velocity autocorrelation peak that makes a principal axis "periodic"


@dataclass(frozen=True)
class Repetitions:
    """Cycle detection result."""

    count: int
    peak_times_s: tuple[float, ...]
    frequency_hz: float  # 1 / median peak interval; nan with fewer than 2 peaks


@dataclass(frozen=True)
class PhaseDuration:
    """The primitive around the principal motion peak (velocity landmarks)."""

    start_s: float
    end_s: float
    peak_s: float

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


@functools.lru_cache(maxsize=64)
def _lowpass_sos(order: int, wn: float) -> np.ndarray:
    """The Butterworth design, once per order and normalized cutoff (designing it cost about an eighth
    of a procedural motion's synthesis)."""
    return butter(order, wn, output="sos")  # callers only read it


def lowpass(x: np.ndarray, fps: float, cutoff_hz: float = CUTOFF_HZ, order: int = BUTTER_ORDER) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0."""
    x = np.asarray(x, dtype=float)
    nyquist = fps / 2.0
    if cutoff_hz >= nyquist or x.shape[0] < 4:
        return x.copy()
    sos = _lowpass_sos(order, cutoff_hz / nyquist)
    padlen = min(3 * (2 * len(sos) + 1), x.shape[0] - 1)
    return filtfilt(sos, x, axis=0, padlen=padlen)


def _indices(motion: Motion, joints: Sequence[str]) -> list[int]:
    if not joints:
        raise ValidationError("name at least one joint", field="joints", allowed=", ".join(motion.joint_names))
    return [motion.joint_index(j) for j in joints]


def heading_rotation(motion: Motion) -> Rotation:
    """The rotation about +Y that turns the body's mean heading to face +Z."""
    pelvis = Rotation.from_quat(motion.rotations[:, 0])
    left = pelvis.apply([1.0, 0.0, 0.0])  # stays horizontal when lying down, unlike the front
    yaw = np.arctan2(-left[:, 2], left[:, 0])
    mean_yaw = float(np.arctan2(np.sin(yaw).mean(), np.cos(yaw).mean()))
    return Rotation.from_rotvec([0.0, -mean_yaw, 0.0])


def joint_trajectories(motion: Motion, joints: Sequence[str]) -> np.ndarray:
    """(T, k, 3) trajectories in the heading frame: pelvis-relative; the pelvis from its start."""
    idx = _indices(motion, joints)
    heading = heading_rotation(motion)
    pos = motion.positions
    out = np.empty((motion.n_frames, len(idx), 3))
    for n, j in enumerate(idx):
        rel = pos[:, j] - (pos[:1, 0] if j == 0 else pos[:, 0])
        out[:, n] = heading.apply(rel)
    return out


def local_rotations(motion: Motion, joints: Sequence[str]) -> list[Rotation]:
    """Each joint's rotation relative to its parent (the root: its world rotation).

    An elbow's is its hinge alone: the forearm's twist about its own long axis
    (pronation / supination, which the forearm segment carries so that a watch
    turns with it) is left out, as it is a forearm movement, not the elbow's
    (`joint_plane_ranges` reports it as the forearm's).
    """
    out = []
    for j in _indices(motion, joints):
        glob = Rotation.from_quat(motion.rotations[:, j])
        p = motion.parents[j]
        local = glob if p < 0 else Rotation.from_quat(motion.rotations[:, p]).inv() * glob
        wrist = _forearm_end(motion, j)
        out.append(local if wrist is None else _without_twist(local, _bone_axis(motion, j, wrist)))
    return out


def _forearm_end(motion: Motion, j: int) -> int | None:
    """The wrist below joint `j` when `j` is an elbow, else None."""
    name = motion.joint_names[j]
    if not name.endswith("_elbow"):
        return None
    wrist = name.removesuffix("elbow") + "wrist"
    if wrist not in motion.joint_names:
        return None
    k = motion.joint_names.index(wrist)
    return k if motion.parents[k] == j else None


def _bone_axis(motion: Motion, j: int, child: int) -> np.ndarray:
    """(T, 3) unit direction from joint `j` to `child` in `j`'s own frame."""
    bone = motion.positions[:, child] - motion.positions[:, j]
    axis = Rotation.from_quat(motion.rotations[:, j]).inv().apply(bone)
    return axis / np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)


def _without_twist(local: Rotation, axis: np.ndarray) -> Rotation:
    """The swing of `local` = swing * twist, the twist being about `axis` (child frame)."""
    q = local.as_quat()
    twist = np.concatenate([np.sum(q[:, :3] * axis, axis=1, keepdims=True) * axis, q[:, 3:]], axis=1)
    norm = np.linalg.norm(twist, axis=1, keepdims=True)
    twist = np.where(norm > 1e-9, twist / np.maximum(norm, 1e-12), [0.0, 0.0, 0.0, 1.0])
    return local * Rotation.from_quat(twist).inv()


def joint_angles(motion: Motion, joints: Sequence[str]) -> np.ndarray:
    """(T, k) signed joint angles (rad) about each joint's main axis, from the first frame."""
    out = np.empty((motion.n_frames, len(joints)))
    for n, rot in enumerate(local_rotations(motion, joints)):
        rv = (rot[0].inv() * rot).as_rotvec()
        centred = rv - rv.mean(axis=0)
        _, _, vt = np.linalg.svd(centred, full_matrices=False)
        out[:, n] = rv @ vt[0]
    return out


def range_of_motion(motion: Motion, joints: Sequence[str]) -> float:
    """Mean principal-joint range of motion (rad): paper's amplitude A^M."""
    ang = lowpass(joint_angles(motion, joints), motion.fps)
    return float(np.mean(ang.max(axis=0) - ang.min(axis=0)))


def angular_speeds(motion: Motion, joints: Sequence[str]) -> np.ndarray:
    """(T, k) local angular speed (rad/s) of each joint, from low-passed rotation vectors."""
    out = np.empty((motion.n_frames, len(joints)))
    for n, rot in enumerate(local_rotations(motion, joints)):
        rv = lowpass((rot[0].inv() * rot).as_rotvec(), motion.fps)
        out[:, n] = np.linalg.norm(np.gradient(rv, axis=0), axis=1) * motion.fps
    return out


def mean_joint_speed(motion: Motion, joints: Sequence[str]) -> float:
    """Mean principal-joint angular speed (rad/s): tempo of discrete actions."""
    return float(angular_speeds(motion, joints).mean())


def _periodicity(v: np.ndarray, fps: float) -> float:
    """Highest normalized autocorrelation of a velocity signal at lags of 0.35 s .. half its length."""
    v = v - v.mean()
    n = len(v)
    lo, hi = max(1, int(round(PEAK_DISTANCE_S * fps))), n // 2
    if hi <= lo or not np.any(v):
        return 0.0
    spec = np.fft.rfft(v, 2 * n)
    ac = np.fft.irfft(spec * np.conj(spec))[:n]
    return float(ac[lo:hi].max() / ac[0])


def cycle_signal(motion: Motion, joints: Sequence[str], candidates: int = 3) -> np.ndarray:
    """The principal component of the principal joints' trajectories that carries the cycles (T,).

    Principal axes are fitted on the joints' velocities; the first of the
    first `candidates` axes whose velocity is periodic (autocorrelation peak
    >= PERIODIC_AXIS_MIN beyond 0.35 s) is used, else the most periodic one:
    the first axis unless a one-off posture change, such as raising the arm
    before waving, dominates it. Its position signal is oriented so that
    excursions away from the starting posture are peaks.
    """
    traj = lowpass(joint_trajectories(motion, joints).reshape(motion.n_frames, -1), motion.fps)
    vel = np.gradient(traj, axis=0)
    vel = vel - vel.mean(axis=0)
    if not np.any(vel):
        return np.zeros(motion.n_frames)
    _, sv, vt = np.linalg.svd(vel, full_matrices=False)
    axes = [vt[i] for i in range(min(candidates, len(sv))) if sv[i] > 1e-9 * sv[0]]
    scores = [_periodicity(vel @ a, motion.fps) for a in axes]
    periodic = [i for i, score in enumerate(scores) if score >= PERIODIC_AXIS_MIN]
    axis = axes[periodic[0] if periodic else int(np.argmax(scores))]
    s = (traj - traj.mean(axis=0)) @ axis
    start = s[: max(1, int(round(0.2 * motion.fps)))].mean()
    if s.max() - start < start - s.min():
        s = -s
    return s


def count_repetitions(motion: Motion, joints: Sequence[str]) -> Repetitions:
    """Cycles as peaks of the first principal component (prominence 0.40 sd, 0.35 s apart)."""
    s = cycle_signal(motion, joints)
    sd = float(np.std(s))
    if sd < 1e-9:
        return Repetitions(0, (), float("nan"))
    peaks, _ = find_peaks(s, prominence=PEAK_PROMINENCE * sd,
                          distance=max(1, int(round(PEAK_DISTANCE_S * motion.fps))))
    times = tuple(float(p) / motion.fps for p in peaks)
    freq = float(1.0 / np.median(np.diff(times))) if len(times) >= 2 else float("nan")
    return Repetitions(len(peaks), times, freq)


def cycle_frequency_hz(motion: Motion, joints: Sequence[str]) -> float:
    """Cycles per second of a repetitive motion (tempo of periodic actions)."""
    return count_repetitions(motion, joints).frequency_hz


def _runs_below(mask: np.ndarray) -> np.ndarray:
    """Length of the run of True values each sample belongs to (0 where False)."""
    out = np.zeros(len(mask), dtype=int)
    i = 0
    while i < len(mask):
        if mask[i]:
            j = i
            while j < len(mask) and mask[j]:
                j += 1
            out[i:j] = j - i
            i = j
        else:
            i += 1
    return out


def _crossing(speed: np.ndarray, i: int, j: int, level: float) -> float:
    """Fractional sample index where `speed` crosses `level` between samples i and j."""
    a, b = speed[i], speed[j]
    if a == b:
        return float(i)
    return float(i + (j - i) * (level - a) / (b - a))


def phase_duration(motion: Motion, joints: Sequence[str]) -> PhaseDuration:
    """The primitive around the principal motion peak, from velocity landmarks.

    It starts where the summed angular speed of `joints` rises above 20 % of
    its maximum and ends where it falls below it after the peak; a crossing
    counts only when the speed then stays below for at least 0.10 s. Crossing
    times are interpolated between frames.
    """
    speed = angular_speeds(motion, joints).sum(axis=1)
    peak = int(np.argmax(speed))
    level = VELOCITY_FRACTION * speed[peak]
    below = speed < level
    hold = max(1, int(round(MIN_HOLD_S * motion.fps)))
    quiet = _runs_below(below) >= hold
    start = peak
    while start > 0 and not quiet[start - 1]:
        start -= 1
    end = peak
    while end < len(speed) - 1 and not quiet[end + 1]:
        end += 1
    t0 = _crossing(speed, start - 1, start, level) if start > 0 else 0.0
    t1 = _crossing(speed, end, end + 1, level) if end < len(speed) - 1 else float(end)
    return PhaseDuration(t0 / motion.fps, t1 / motion.fps, peak / motion.fps)


def symmetry_pairs(joints: Sequence[str]) -> list[tuple[str, str]]:
    """(left, right) joint pairs named (on either side) in `joints`."""
    pairs: list[tuple[str, str]] = []
    for name in joints:
        if name.startswith(("left_", "right_")):
            stem = name.split("_", 1)[1]
            pair = (f"left_{stem}", f"right_{stem}")
            if pair not in pairs:
                pairs.append(pair)
    return pairs


def symmetry_score(motion: Motion, joints: Sequence[str]) -> float:
    """C_sym: mean correlation of left and mirrored right joint trajectories (nan if none move).

    Pairs that barely move (RMS excursion below 1 cm or below 15 % of the
    most moving pair's) are left out: their correlation measures noise.
    """
    pairs = symmetry_pairs(joints)
    if not pairs:
        return float("nan")
    names = [n for pair in pairs for n in pair]
    traj = lowpass(joint_trajectories(motion, names), motion.fps)
    mirror = np.array([-1.0, 1.0, 1.0])
    stats = []
    for k in range(len(pairs)):
        a = traj[:, 2 * k] - traj[:, 2 * k].mean(axis=0)
        b = traj[:, 2 * k + 1] * mirror
        b = b - b.mean(axis=0)
        rms = min(np.sqrt((a**2).sum(axis=1).mean()), np.sqrt((b**2).sum(axis=1).mean()))
        corr = float((a * b).sum() / max(np.sqrt((a**2).sum() * (b**2).sum()), 1e-12))
        stats.append((rms, corr))
    top = max(rms for rms, _ in stats)
    kept = [c for rms, c in stats if rms >= max(STATIC_STD_M, STATIC_FRACTION * top)]
    return float(np.mean(kept)) if kept else float("nan")


def classify_symmetry(score: float, threshold: float = SYMMETRY_THRESHOLD) -> str:
    """'symmetric' when C_sym >= threshold, else 'asymmetric'."""
    return "symmetric" if score >= threshold else "asymmetric"


def tempo_measure(motion: Motion, joints: Sequence[str], periodic: bool) -> float:
    """Cycle frequency (Hz) for periodic actions, mean angular speed (rad/s) for discrete ones."""
    return cycle_frequency_hz(motion, joints) if periodic else mean_joint_speed(motion, joints)


# -- joint angular ranges per anatomical plane ---------------------------------------------
# measured joint -> (segment joint, parent joint, reference joint whose frame names the planes)
_PLANE_SEGMENTS: dict[str, tuple[str, str | None, str | None]] = {
    "shoulder": ("{s}_shoulder", "spine3", "spine3"), "elbow": ("{s}_elbow", "{s}_shoulder", "spine3"),
    "wrist": ("{s}_wrist", "{s}_elbow", "spine3"), "hip": ("{s}_hip", "pelvis", "pelvis"),
    "knee": ("{s}_knee", "{s}_hip", "pelvis"), "ankle": ("{s}_ankle", "{s}_knee", "pelvis"),
    "trunk": ("spine3", "pelvis", "pelvis"), "neck": ("head", "spine3", "spine3"), "body": ("pelvis", None, None),
}  # fmt: skip
# axis of the reference frame (x left, y up, z forward) -> anatomical plane of a rotation about it
_AXIS_PLANES = ("sagittal", "transverse", "frontal")


def joint_plane_ranges(motion: Motion) -> dict[tuple[str, str], float]:
    """Angular range (degrees) of every joint in every anatomical plane, the larger side for limbs.

    A joint's rotation relative to its parent segment, taken from the first
    frame, is expressed in a body frame (the chest for arms and head, the
    pelvis for legs and trunk, the world for the whole body) and split on its
    axes: about left-right = sagittal, about up = transverse, about forward =
    frontal. The forearm's axial twist at the elbow (about its long axis, which
    hangs vertical in the anatomical position) is reported as ("forearm",
    "transverse"): pronation / supination.
    """
    out: dict[tuple[str, str], float] = {}
    for joint, (seg, parent, ref) in _PLANE_SEGMENTS.items():
        sides = ("left", "right") if "{s}" in seg else ("",)
        for side in sides:
            spans = _plane_spans(motion, seg.format(s=side), parent and parent.format(s=side),
                                 ref and ref.format(s=side))
            for axis, span in enumerate(spans):
                plane = _AXIS_PLANES[axis]
                name = "forearm" if joint == "elbow" and plane == "transverse" else joint
                out[(name, plane)] = max(out.get((name, plane), 0.0), span)
    return out


def _plane_spans(motion: Motion, seg: str, parent: str | None, ref: str | None) -> np.ndarray:
    r_seg = Rotation.from_quat(motion.rotations[:, motion.joint_index(seg)])
    r_par = Rotation.from_quat(motion.rotations[:, motion.joint_index(parent)]) if parent else None
    r_ref = Rotation.from_quat(motion.rotations[:, motion.joint_index(ref)]) if ref else None
    local = r_seg if r_par is None else r_par.inv() * r_seg
    change = local * local[0].inv()  # rotation in the parent frame since the first frame
    vec = change.as_rotvec()
    if r_par is not None:
        vec = (r_ref.inv() * r_par).apply(vec)
    vec = np.degrees(vec)
    return vec.max(axis=0) - vec.min(axis=0)


def ranked_joint_planes(motion: Motion) -> list[tuple[tuple[str, str], float]]:
    """(joint, plane) pairs by angular range, largest first (ties by name)."""
    ranges = joint_plane_ranges(motion)
    return sorted(ranges.items(), key=lambda item: (-item[1], item[0]))
