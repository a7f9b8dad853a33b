"""SMP fields measured on a pose track, each with an uncertainty from its evidence.

Measurements reuse `vsmp_imu.motion.measure` (Butterworth 6 Hz, peaks with
prominence 0.40 sd and 0.35 s apart, C_sym = 0.82) on the retargeted motion:

- tempo: cycle frequency of the principal joints (periodic activities) or
  their mean angular speed (discrete ones), as a level on the 0..2 scale
  relative to the activity's reference (`calibrate`): one level per factor
  1.5 (the procedural backend's tempo step);
- amplitude: principal-joint range of motion relative to the reference
  (excursion factor 0.6 / 1.0 / 1.4 for small / medium / large);
- repetition count: peaks of the cycle signal (periodic activities);
- symmetry: mirrored left-right correlation C_sym, also at a half-cycle lag
  for periodic activities (alternating gait is symmetric half a cycle apart),
  and the left-right motion-energy balance;
- dominant side: which side's limbs move more (energy ratio);
- global displacement: the image-space hip trajectory in body heights (world
  landmarks are hip-centred), plus depth from the change of body scale
  under an assumed 60 degree horizontal field of view;
- body parts: motion energy per vocabulary segment -> dominant moving segments;
- periodicity: autocorrelation strength of the cycle signal.

Uncertainty: a track quality q in [0, 1] is the product of terms for the
fraction of frames with a pose, landmark visibility, person size in pixels
and identity switches (the tracker jumping to another person). Each field
multiplies q by its own evidence terms (the smoothness of the joints' landmark
trajectories, i.e. movement rather than jitter; periodicity strength, cycles in the
clip, agreement of the peak and autocorrelation periods, margin to a
decision threshold, a level far outside the 0..2 scale, ...) to a
confidence c, and u = 1 - (1 - U_FLOOR) c. Weak evidence therefore always means high
uncertainty; a field that cannot be measured has no value (u = 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from vsmp_imu.extract.calibrate import DEFAULT_PRINCIPAL, DEFAULT_SYMMETRY, Reference
from vsmp_imu.extract.landmarks import LM, PoseTrack
from vsmp_imu.motion import measure
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M
from vsmp_imu.smp.bodyparts import BODY_PARTS

U_FLOOR = 0.05
TEMPO_STEP = 1.5  # one tempo level = a factor 1.5 in speed (procedural backend's TEMPO_RATIO)
AMP_BASE, AMP_SLOPE = 0.6, 0.4  # excursion factor = 0.6 + 0.4 * level
STATIONARY_M = 0.30  # a travelled extent below this is "stationary"
TORSO_TO_HEIGHT = 0.29  # shoulder-to-hip length / standing height (SMPL neutral body)
ASSUMED_HFOV_DEG = 60.0
SWITCH_JUMP = 0.5  # a hip jump above this x body height between frames = another person
PERIODIC_MIN = 0.5  # autocorrelation strength above which a signal counts as periodic
SIDE_RATIO = 0.25  # |E_L - E_R| / (E_L + E_R) above which one side dominates
INVOLVED_FRACTION, DOMINANT_FRACTION = 0.2, 0.5
MIN_PART_SPEED = 0.05  # m/s: a segment slower than this does not move
VISIBLE = 0.5

# Body-part vocabulary -> the joint whose pelvis-relative trajectory stands for it,
# and the landmarks whose visibility supports it.
PART_JOINT = {
    "head": "head", "torso": "neck", "pelvis": "pelvis",
    "left_shoulder": "left_shoulder", "right_shoulder": "right_shoulder",
    "left_upper_arm": "left_elbow", "right_upper_arm": "right_elbow",
    "left_forearm": "left_wrist", "right_forearm": "right_wrist",
    "left_hand": "left_wrist", "right_hand": "right_wrist",
    "left_thigh": "left_knee", "right_thigh": "right_knee",
    "left_lower_leg": "left_ankle", "right_lower_leg": "right_ankle",
    "left_foot": "left_foot", "right_foot": "right_foot",
}
JOINT_LANDMARKS = {
    "pelvis": ("left_hip", "right_hip"), "spine1": ("left_hip", "right_hip", "left_shoulder", "right_shoulder"),
    "spine2": ("left_hip", "right_hip", "left_shoulder", "right_shoulder"),
    "spine3": ("left_shoulder", "right_shoulder"), "neck": ("left_shoulder", "right_shoulder"),
    "head": ("nose", "left_ear", "right_ear"),
    **{f"{s}_{j}": lms for s in ("left", "right") for j, lms in {
        "collar": (f"{s}_shoulder",), "shoulder": (f"{s}_shoulder", f"{s}_elbow"),
        "elbow": (f"{s}_elbow", f"{s}_wrist"), "wrist": (f"{s}_wrist", f"{s}_index", f"{s}_pinky"),
        "hip": (f"{s}_hip", f"{s}_knee"), "knee": (f"{s}_knee", f"{s}_ankle"),
        "ankle": (f"{s}_ankle", f"{s}_foot_index"), "foot": (f"{s}_foot_index", f"{s}_heel"),
    }.items()},
}
SIDE_JOINTS = ("elbow", "wrist", "knee", "ankle")


def _clip01(x: float) -> float:
    return float(min(1.0, max(0.0, x))) if math.isfinite(x) else 0.0


def _u(confidence: float) -> float:
    return round(1.0 - (1.0 - U_FLOOR) * _clip01(confidence), 4)


@dataclass
class Measurement:
    """One measured SMP field: the value to write (None: not measured) and its uncertainty."""

    field: str
    value: Any
    uncertainty: float
    raw: dict[str, Any] = field(default_factory=dict)
    evidence: dict[str, float] = field(default_factory=dict)
    note: str = ""

    @property
    def measured(self) -> bool:
        return self.value is not None

    def to_dict(self) -> dict[str, Any]:
        return {"field": self.field, "value": self.value, "uncertainty": self.uncertainty,
                "raw": _jsonable(self.raw), "evidence": _jsonable(self.evidence), "note": self.note}


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, float | np.floating):
        return None if not math.isfinite(float(obj)) else round(float(obj), 6)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


# -- track evidence ----------------------------------------------------------------
def _px(track: PoseTrack, name: str) -> np.ndarray:
    w, h = track.frame_size
    return track.image[:, LM[name], :2] * np.array([w, h], dtype=float)


def body_height_px(track: PoseTrack) -> np.ndarray:
    """(T,) standing-height estimate in pixels from the torso length (NaN where no pose)."""
    sh = 0.5 * (_px(track, "left_shoulder") + _px(track, "right_shoulder"))
    hip = 0.5 * (_px(track, "left_hip") + _px(track, "right_hip"))
    return np.linalg.norm(sh - hip, axis=1) / TORSO_TO_HEIGHT


def hip_px(track: PoseTrack) -> np.ndarray:
    return 0.5 * (_px(track, "left_hip") + _px(track, "right_hip"))


def segments(track: PoseTrack, max_gap: int) -> tuple[list[tuple[int, int]], int]:
    """Continuous runs of detected frames of one person, and the number of identity switches.

    A run ends at a gap longer than `max_gap` frames or where the hip jumps by
    more than SWITCH_JUMP body heights between consecutive detections.
    """
    det = np.flatnonzero(track.detected)
    if det.size == 0:
        return [], 0
    hip = hip_px(track)
    size = body_height_px(track)
    runs: list[tuple[int, int]] = []
    switches = 0
    start = prev = int(det[0])
    for i in det[1:]:
        i = int(i)
        scale = np.nanmedian([size[prev], size[i]])
        jump = float(np.linalg.norm(hip[i] - hip[prev]))
        if jump > SWITCH_JUMP * max(scale, 1.0):
            switches += 1
            runs.append((start, prev + 1))
            start = i
        elif i - prev - 1 > max_gap:
            runs.append((start, prev + 1))
            start = i
        prev = i
    runs.append((start, prev + 1))
    return runs, switches


def visibility(track: PoseTrack, landmarks: tuple[str, ...] | list[str]) -> float:
    """Mean visibility of `landmarks` over the frames with a pose (0 when none)."""
    if not track.detected.any():
        return 0.0
    cols = [LM[n] for n in landmarks]
    return float(track.visibility[track.detected][:, cols].mean())


def joints_visibility(track: PoseTrack, joints: tuple[str, ...] | list[str]) -> float:
    names = sorted({lm for j in joints for lm in JOINT_LANDMARKS.get(j, ())})
    return visibility(track, names) if names else 0.0


def facing_away_fraction(track: PoseTrack) -> float:
    """Share of pose frames whose face is hidden while the shoulders are seen (a back view)."""
    if not track.detected.any():
        return 0.0
    v = track.visibility[track.detected]
    face = v[:, [LM["nose"], LM["left_eye"], LM["right_eye"]]].mean(axis=1)
    shoulders = v[:, [LM["left_shoulder"], LM["right_shoulder"]]].mean(axis=1)
    return float(np.mean((face < VISIBLE) & (shoulders >= VISIBLE)))


@dataclass
class TrackEvidence:
    detected_fraction: float
    visibility: float
    body_height_px: float
    identity_switches: int
    switches_per_10s: float
    facing_away_fraction: float
    duration_s: float
    runs: list[tuple[int, int]]

    @property
    def quality(self) -> float:
        """q in [0, 1]: product of the detection, visibility, size and switch terms."""
        return (_clip01((self.detected_fraction - 0.2) / 0.6)
                * _clip01((self.visibility - 0.3) / 0.5)
                * _clip01((self.body_height_px - 60.0) / 180.0)
                / (1.0 + self.switches_per_10s))

    def to_dict(self) -> dict[str, Any]:
        return _jsonable({"detected_fraction": self.detected_fraction, "visibility": self.visibility,
                          "body_height_px": self.body_height_px,
                          "identity_switches": self.identity_switches,
                          "switches_per_10s": self.switches_per_10s,
                          "facing_away_fraction": self.facing_away_fraction,
                          "duration_s": self.duration_s, "quality": self.quality,
                          "runs": [list(r) for r in self.runs]})


def longest_run(track: PoseTrack, max_gap_s: float = 0.5) -> tuple[int, int] | None:
    """The run of one person with the most detected frames (see `segments`); None if no pose."""
    runs, _ = segments(track, int(round(max_gap_s * track.fps)))
    if not runs:
        return None
    return max(runs, key=lambda r: (int(track.detected[r[0]:r[1]].sum()), -r[0]))


def track_evidence(track: PoseTrack, max_gap_s: float = 0.5) -> TrackEvidence:
    runs, switches = segments(track, int(round(max_gap_s * track.fps)))
    duration = track.n_frames / track.fps
    size = body_height_px(track)[track.detected] if track.detected.any() else np.array([0.0])
    core = ("left_shoulder", "right_shoulder", "left_hip", "right_hip", "left_elbow",
            "right_elbow", "left_knee", "right_knee")
    return TrackEvidence(track.detected_fraction, visibility(track, core),
                         float(np.nanmedian(size)) if size.size else 0.0, switches,
                         10.0 * switches / max(duration, 1e-9), facing_away_fraction(track),
                         duration, runs)


# -- signals ------------------------------------------------------------------------
def periodicity_strength(signal: np.ndarray, fps: float) -> tuple[float, float]:
    """(strength, lag_s): highest normalized autocorrelation of the signal's velocity at
    lags from 0.35 s to half its length, and that lag."""
    v = np.gradient(np.asarray(signal, dtype=float))
    v = v - v.mean()
    n = len(v)
    lo, hi = max(1, int(round(measure.PEAK_DISTANCE_S * fps))), n // 2
    if hi <= lo or not np.any(v):
        return 0.0, float("nan")
    spec = np.fft.rfft(v, 2 * n)
    ac = np.fft.irfft(spec * np.conj(spec))[:n]
    k = lo + int(np.argmax(ac[lo:hi]))
    return float(ac[k] / ac[0]), k / fps


def lagged_symmetry(motion: Motion, joints: tuple[str, ...] | list[str], lag_frames: int) -> float:
    """C_sym with the right side shifted by `lag_frames` (same pair rules as measure.symmetry_score)."""
    pairs = measure.symmetry_pairs(joints)
    if not pairs or lag_frames >= motion.n_frames - 4:
        return float("nan")
    names = [n for pair in pairs for n in pair]
    traj = measure.lowpass(measure.joint_trajectories(motion, names), motion.fps)
    mirror = np.array([-1.0, 1.0, 1.0])
    n = motion.n_frames - lag_frames
    stats = []
    for k in range(len(pairs)):
        a = traj[:n, 2 * k] - traj[:n, 2 * k].mean(axis=0)
        b = traj[lag_frames:lag_frames + n, 2 * k + 1] * mirror
        b = b - b.mean(axis=0)
        rms = min(np.sqrt((a**2).sum(axis=1).mean()), np.sqrt((b**2).sum(axis=1).mean()))
        corr = float((a * b).sum() / max(np.sqrt((a**2).sum() * (b**2).sum()), 1e-12))
        stats.append((rms, corr))
    top = max(rms for rms, _ in stats)
    kept = [c for rms, c in stats if rms >= max(measure.STATIC_STD_M, measure.STATIC_FRACTION * top)]
    return float(np.mean(kept)) if kept else float("nan")


def smoothness(track: PoseTrack, joints: tuple[str, ...] | list[str], max_gap_s: float = 0.5) -> float:
    """How much of the landmark motion is movement rather than jitter, in [0, 1].

    r = RMS(second difference) / RMS(first difference) of the joints' landmark
    trajectories: a smooth movement at f Hz sampled at F fps gives
    r = 2 sin(pi f / F) (0.21 at 1 Hz and 30 fps), white jitter gives
    sqrt(3) = 1.73. The score is 1 for r <= 0.4 and 0 for r >= 1.2.
    """
    from vsmp_imu.extract.retarget import fill_gaps

    names = sorted({lm for j in joints for lm in JOINT_LANDMARKS.get(j, ())})
    if not names or track.detected.sum() < 3:
        return 0.0
    world, _, _ = fill_gaps(track.world[:, [LM[n] for n in names]], track.detected,
                            int(round(max_gap_s * track.fps)))
    d1 = np.diff(world, axis=0)
    d2 = np.diff(world, n=2, axis=0)
    rms1 = float(np.sqrt((d1**2).sum(axis=-1).mean()))
    if rms1 < 1e-12:
        return 0.0
    r = float(np.sqrt((d2**2).sum(axis=-1).mean())) / rms1
    return _clip01((1.2 - r) / 0.8)


def joint_speeds(motion: Motion, joints: list[str]) -> np.ndarray:
    """(k,) RMS speed (m/s) of each joint's pelvis-relative trajectory (heading frame, low-passed)."""
    traj = measure.lowpass(measure.joint_trajectories(motion, joints), motion.fps)
    vel = np.gradient(traj, axis=0) * motion.fps
    return np.sqrt((vel**2).sum(axis=2).mean(axis=0))


def pelvis_speed(motion: Motion, lever_m: float = 0.25) -> float:
    """RMS angular speed of the pelvis x a lever arm (m/s), its motion-energy stand-in."""
    return float(measure.angular_speeds(motion, ["pelvis"]).mean() * lever_m)


# -- measurements -----------------------------------------------------------------------
@dataclass
class PoseMeasurements:
    """All measured fields of one clip and the track evidence behind them."""

    fields: dict[str, Measurement]
    evidence: TrackEvidence | None
    reference: Reference | None
    periodic: bool
    principal_joints: tuple[str, ...]
    symmetry_joints: tuple[str, ...]
    window: tuple[int, int] | None = None  # analysed frames [start, stop) of the clip's track
    clip_evidence: TrackEvidence | None = None  # the whole clip's track

    def get(self, name: str) -> Measurement | None:
        return self.fields.get(name)

    def to_dict(self) -> dict[str, Any]:
        return {"fields": {k: m.to_dict() for k, m in self.fields.items()},
                "track": None if self.evidence is None else self.evidence.to_dict(),
                "reference": None if self.reference is None else _jsonable(self.reference.to_dict()),
                "periodic": self.periodic, "principal_joints": list(self.principal_joints),
                "symmetry_joints": list(self.symmetry_joints),
                "window": None if self.window is None else list(self.window),
                "clip_track": None if self.clip_evidence is None else self.clip_evidence.to_dict()}


FIELDS = ("periodicity", "tempo", "repetition_count", "amplitude", "symmetry", "dominant_side",
          "global_displacement", "body_parts")


def unmeasured(reason: str) -> dict[str, Measurement]:
    return {name: Measurement(name, None, 1.0, note=reason) for name in FIELDS}


class PoseMeasurer:
    """Measure SMP fields on a pose track and its retargeted motion.

    reference: the activity's typical execution (None: levels cannot be set).
    periodic: whether the activity is repetitive (None: decided by the clip).
    base_dominant_side: the SMP's side, used when the sides move alike.
    height_m: body height that converts pixels to metres.
    """

    def __init__(self, reference: Reference | None = None, periodic: bool | None = None,
                 base_dominant_side: str | None = None, height_m: float = DEFAULT_HEIGHT_M,
                 max_gap_s: float = 0.5) -> None:
        self.reference = reference
        self.periodic = periodic
        self.base_dominant_side = base_dominant_side
        self.height_m = height_m
        self.max_gap_s = max_gap_s

    def measure(self, track: PoseTrack, motion: Motion | None) -> PoseMeasurements:
        ref = self.reference
        principal = ref.principal_joints if ref else DEFAULT_PRINCIPAL
        symmetry = ref.symmetry_joints if ref else DEFAULT_SYMMETRY
        if motion is None or not track.detected.any():
            return PoseMeasurements(unmeasured("no pose to measure (nobody detected, or no run "
                                               "of one person longer than a frame)"),
                                    track_evidence(track, self.max_gap_s), ref,
                                    bool(self.periodic), principal, symmetry)
        ev = track_evidence(track, self.max_gap_s)
        q = ev.quality
        out: dict[str, Measurement] = {}
        vis_p = joints_visibility(track, principal)
        cyc = measure.cycle_signal(motion, list(principal))
        strength, lag_s = periodicity_strength(cyc, motion.fps)
        reps = measure.count_repetitions(motion, list(principal))
        n_cycles = reps.frequency_hz * motion.duration_s if math.isfinite(reps.frequency_hz) else 0.0
        measured_periodic = strength >= PERIODIC_MIN and reps.count >= 2
        periodic = measured_periodic if self.periodic is None else bool(self.periodic)
        base_ev = {"track_quality": q, "principal_visibility": vis_p}
        out["periodicity"] = Measurement(
            "periodicity", bool(measured_periodic),
            _u(q * _clip01(abs(strength - PERIODIC_MIN) / 0.3)),
            raw={"strength": strength, "lag_s": lag_s}, evidence=base_ev)
        vis_term = _clip01((vis_p - 0.3) / 0.5) * smoothness(track, principal, self.max_gap_s)
        limbs = [f"{side}_{j}" for side in ("left", "right") for j in SIDE_JOINTS]
        q_limbs = q * smoothness(track, limbs, self.max_gap_s)
        out["tempo"] = self._tempo(motion, principal, reps, strength, lag_s, n_cycles, periodic, q,
                                   vis_term)
        out["repetition_count"] = self._repetitions(reps, strength, n_cycles, periodic, q, vis_term)
        out["amplitude"] = self._amplitude(motion, principal, q, vis_term)
        sides = self._side_energy(motion, track)
        q_sym = q * smoothness(track, symmetry, self.max_gap_s)
        out["symmetry"] = self._symmetry(motion, track, symmetry, reps, periodic, sides, q_sym)
        out["dominant_side"] = self._dominant_side(sides, ev, q_limbs)
        out["global_displacement"] = self._displacement(track, ev, q)
        out["body_parts"] = self._body_parts(motion, track, q_limbs)
        return PoseMeasurements(out, ev, ref, periodic, principal, symmetry)

    # each field ---------------------------------------------------------------------
    def _tempo(self, motion: Motion, principal: tuple[str, ...], reps: measure.Repetitions,
               strength: float, lag_s: float, n_cycles: float, periodic: bool, q: float,
               vis: float) -> Measurement:
        ref = self.reference
        raw: dict[str, Any] = {}
        if periodic:
            f = reps.frequency_hz
            raw["cycle_frequency_hz"] = f
            raw["cycles_per_min"] = 60.0 * f if math.isfinite(f) else float("nan")
            if ref is not None and ref.alternate and math.isfinite(f):
                raw["cadence_steps_per_min"] = 120.0 * f
            if not math.isfinite(f):
                return Measurement("tempo", None, 1.0, raw, note="fewer than two cycle peaks")
            evidence = {"track_quality": q, "visibility": vis,
                        "periodicity": _clip01((strength - 0.3) / 0.4),
                        "cycles": _clip01((n_cycles - 1.5) / 3.0),
                        "peaks_vs_autocorrelation": _agreement(f, lag_s)}
            raw["autocorrelation_frequency_hz"] = 1.0 / lag_s if lag_s and math.isfinite(lag_s) else float("nan")
            if ref is None or not math.isfinite(ref.frequency_hz):
                return Measurement("tempo", None, 1.0, raw, evidence,
                                   note="no reference for this activity: level not set")
            raw["reference_frequency_hz"] = ref.frequency_hz
            ratio = f / ref.frequency_hz
        else:
            speed = measure.mean_joint_speed(motion, list(principal))
            raw["mean_angular_speed_rad_s"] = speed
            evidence = {"track_quality": q, "visibility": vis, "discrete": 0.6}
            if ref is None or ref.mean_speed_rad_s <= 0:
                return Measurement("tempo", None, 1.0, raw, evidence,
                                   note="no reference for this activity: level not set")
            raw["reference_speed_rad_s"] = ref.mean_speed_rad_s
            ratio = speed / ref.mean_speed_rad_s
        level = ref.tempo_level + math.log(max(ratio, 1e-6)) / math.log(TEMPO_STEP)
        raw["ratio_to_reference"] = ratio
        raw["level_unclipped"] = level
        evidence["plausible"] = _plausible(level)
        value = round(min(2.0, max(0.0, level)), 3)
        return Measurement("tempo", value, _u(float(np.prod(list(evidence.values())))), raw, evidence)

    def _repetitions(self, reps: measure.Repetitions, strength: float, n_cycles: float,
                     periodic: bool, q: float, vis: float) -> Measurement:
        raw = {"peaks": reps.count, "peak_times_s": list(reps.peak_times_s)}
        if not periodic:
            return Measurement("repetition_count", None, 1.0, raw,
                               note="not a repetitive activity: no count")
        evidence = {"track_quality": q, "visibility": vis,
                    "periodicity": _clip01((strength - 0.3) / 0.4),
                    "cycles": _clip01((n_cycles - 1.0) / 3.0), "edges": 0.8}
        return Measurement("repetition_count", int(reps.count),
                           _u(float(np.prod(list(evidence.values())))), raw, evidence)

    def _amplitude(self, motion: Motion, principal: tuple[str, ...], q: float, vis: float) -> Measurement:
        rom = measure.range_of_motion(motion, list(principal))
        raw: dict[str, Any] = {"range_of_motion_rad": rom}
        evidence = {"track_quality": q, "visibility": vis, "jitter": 0.8}
        ref = self.reference
        if ref is None or ref.rom_rad <= 0:
            return Measurement("amplitude", None, 1.0, raw, evidence,
                               note="no reference for this activity: level not set")
        factor = (AMP_BASE + AMP_SLOPE * ref.amplitude_level) * rom / ref.rom_rad
        level = (factor - AMP_BASE) / AMP_SLOPE
        raw.update(reference_rom_rad=ref.rom_rad, ratio_to_reference=rom / ref.rom_rad,
                   level_unclipped=level)
        evidence["plausible"] = _plausible(level)
        value = round(min(2.0, max(0.0, level)), 3)
        return Measurement("amplitude", value, _u(float(np.prod(list(evidence.values())))), raw, evidence)

    def _side_energy(self, motion: Motion, track: PoseTrack) -> dict[str, float]:
        out = {}
        for side in ("left", "right"):
            joints = [f"{side}_{j}" for j in SIDE_JOINTS]
            out[side] = float(joint_speeds(motion, joints).sum())
            out[f"{side}_visibility"] = joints_visibility(track, joints)
        total = out["left"] + out["right"]
        out["ratio"] = (out["left"] - out["right"]) / total if total > 1e-9 else 0.0
        out["total"] = total
        return out

    def _symmetry(self, motion: Motion, track: PoseTrack, joints: tuple[str, ...],
                  reps: measure.Repetitions, periodic: bool, sides: dict[str, float],
                  q: float) -> Measurement:
        c0 = measure.symmetry_score(motion, list(joints))
        raw: dict[str, Any] = {"c_sym_lag0": c0, "energy_ratio": sides["ratio"]}
        scores = [c0]
        if periodic and math.isfinite(reps.frequency_hz):
            lag = int(round(0.5 * motion.fps / reps.frequency_hz))
            c_half = lagged_symmetry(motion, joints, lag)
            raw["c_sym_half_cycle"] = c_half
            scores.append(c_half)
        finite = [s for s in scores if math.isfinite(s)]
        vis = joints_visibility(track, [j for pair in measure.symmetry_pairs(joints) for j in pair])
        if not finite:
            return Measurement("symmetry", None, 1.0, raw, note="no moving left-right joint pair")
        c = max(finite)
        raw["c_sym"] = c
        one_sided = abs(sides["ratio"]) >= 0.4
        value = "symmetric" if c >= measure.SYMMETRY_THRESHOLD and not one_sided else "asymmetric"
        margin = max(abs(c - measure.SYMMETRY_THRESHOLD) / 0.15,
                     (abs(sides["ratio"]) - 0.25) / 0.3 if one_sided else 0.0)
        evidence = {"track_quality": q, "visibility": _clip01((vis - 0.3) / 0.5),
                    "margin": max(0.1, _clip01(margin))}
        return Measurement("symmetry", value, _u(float(np.prod(list(evidence.values())))), raw, evidence)

    def _dominant_side(self, sides: dict[str, float], ev: TrackEvidence, q: float) -> Measurement:
        ratio = sides["ratio"]
        vis = min(sides["left_visibility"], sides["right_visibility"])
        raw = {"left_energy_m_s": sides["left"], "right_energy_m_s": sides["right"],
               "energy_ratio": ratio}
        if sides["total"] < 4 * MIN_PART_SPEED:
            value = "none"
            margin = 1.0 - sides["total"] / (4 * MIN_PART_SPEED)
        elif abs(ratio) >= SIDE_RATIO:
            value = "left" if ratio > 0 else "right"
            margin = (abs(ratio) - 0.15) / 0.3
        else:
            base = self.base_dominant_side
            value = base if base in ("bilateral", "none") else "bilateral"
            margin = (SIDE_RATIO - abs(ratio)) / 0.15
        evidence = {"track_quality": q, "visibility": _clip01((vis - 0.3) / 0.5),
                    "margin": _clip01(margin),
                    # back views: MediaPipe may swap the person's left and right
                    "front_view": 1.0 - 0.5 * _clip01(ev.facing_away_fraction / 0.5)}
        return Measurement("dominant_side", value, _u(float(np.prod(list(evidence.values())))), raw, evidence)

    def _displacement(self, track: PoseTrack, ev: TrackEvidence, q: float) -> Measurement:
        hip = hip_px(track)
        size = body_height_px(track)
        w = track.frame_size[0]
        f_px = (w / 2.0) / math.tan(math.radians(ASSUMED_HFOV_DEG / 2.0))
        best, best_run, lateral_m, depth_m = 0.0, (0, 0), 0.0, 0.0
        min_len = max(2, int(round(1.0 * track.fps)))
        for a, b in ev.runs:
            idx = np.arange(a, b)
            idx = idx[track.detected[idx]]
            if len(idx) < min_len:
                continue
            scale = float(np.nanmedian(size[idx]))
            if not scale > 1.0:
                continue
            offsets = np.linalg.norm(hip[idx] - hip[idx[0]], axis=1)
            lat = float(offsets.max()) / scale * self.height_m
            smooth = _running_median(size[idx], max(3, int(round(0.5 * track.fps))))
            dist = f_px * self.height_m / np.maximum(smooth, 1.0)
            dep = float(dist.max() - dist.min()) if smooth.max() / max(smooth.min(), 1e-9) > 1.25 else 0.0
            extent = math.hypot(lat, dep)
            if extent > best:
                best, best_run, lateral_m, depth_m = extent, (a, b), lat, dep
        covered = (best_run[1] - best_run[0]) / max(track.n_frames, 1)
        raw = {"extent_m": best, "lateral_m": lateral_m, "depth_m": depth_m,
               "run": list(best_run), "assumed_hfov_deg": ASSUMED_HFOV_DEG, "height_m": self.height_m}
        if not ev.runs or best_run == (0, 0):
            return Measurement("global_displacement", None, 1.0, raw,
                               note="no continuous run of one person lasting 1 s")
        evidence = {"track_quality": q, "coverage": _clip01(covered / 0.5),
                    "camera_unknown": 0.7, "depth_share": 1.0 - 0.5 * _clip01(depth_m / max(best, 1e-9))}
        value = 0.0 if best < STATIONARY_M else round(best, 2)
        return Measurement("global_displacement", value,
                           _u(float(np.prod(list(evidence.values())))), raw, evidence,
                           note="image-space hip path; a moving camera is not compensated")

    def _body_parts(self, motion: Motion, track: PoseTrack, q: float) -> Measurement:
        joints = [PART_JOINT[p] for p in BODY_PARTS]
        speeds = dict(zip(BODY_PARTS, joint_speeds(motion, joints).tolist(), strict=True))
        speeds["pelvis"] = pelvis_speed(motion)
        visible = {p: joints_visibility(track, [PART_JOINT[p]]) for p in BODY_PARTS}
        seen = {p: s for p, s in speeds.items() if visible[p] >= VISIBLE}
        raw = {"speed_m_s": speeds, "visibility": visible,
               "not_visible": [p for p in BODY_PARTS if visible[p] < VISIBLE]}
        if not seen:
            return Measurement("body_parts", None, 1.0, raw, note="no body part visible enough")
        top = max(seen.values())
        if top < MIN_PART_SPEED:
            return Measurement("body_parts", [], _u(q * 0.5), raw, {"track_quality": q},
                               note="no visible segment moves")
        involved = [p for p in BODY_PARTS if p in seen and seen[p] >= max(INVOLVED_FRACTION * top, MIN_PART_SPEED)]
        dominant = [p for p in involved if seen[p] >= DOMINANT_FRACTION * top]
        raw["involved"] = involved
        vis = float(np.mean([visible[p] for p in dominant])) if dominant else 0.0
        evidence = {"track_quality": q, "visibility": _clip01((vis - 0.3) / 0.5),
                    "coverage": len(seen) / len(BODY_PARTS)}
        return Measurement("body_parts", dominant, _u(float(np.prod(list(evidence.values())))), raw, evidence)


def _plausible(level: float) -> float:
    """1 inside the 0..2 scale, falling to 0 one level beyond it (a far-off value is noise)."""
    excess = max(0.0, -level, level - 2.0)
    return _clip01(1.0 - excess)


def _agreement(freq_hz: float, lag_s: float) -> float:
    """How well the peak frequency matches the autocorrelation period (1 = same, 0 = x1.5 off)."""
    if not (math.isfinite(freq_hz) and math.isfinite(lag_s)) or freq_hz <= 0 or lag_s <= 0:
        return 0.0
    return _clip01(1.0 - abs(math.log(freq_hz * lag_s)) / math.log(1.5))


def _running_median(x: np.ndarray, width: int) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    half = width // 2
    return np.array([np.nanmedian(x[max(0, i - half):i + half + 1]) for i in range(len(x))])
