"""Source clip pools for IMU-only datasets (paper, "Source Video Collection for IMU-Only
Target Datasets"): candidate clips are filtered in two stages and the retained
pool is written to a manifest that every video-based method then shares.

Layout: `POOL/<activity>/<clip>.<video suffix>`; the folder name is the
activity (a library name or alias for the pose checker; any text for the VLM).

Stage 1, a checker decides whether the clip shows the named activity as its
dominant action and how confident it is:
- `VLMClipChecker`: a short yes/no + confidence JSON question with the
  clip's frames, through the same client (cached);
- `PoseClipChecker` (offline): a person is found in enough frames, and the
  measured motion matches the activity's library SMP: periodic or not (or
  still, for static activities), and the moving body parts (F1 of the
  expected moving parts that move and of the moving limb segments that
  belong to limbs the activity involves; head, torso and pelvis are free). Confidence = sqrt(track quality) x periodicity score x
  body-part score (both must hold).
Stage 2, a confidence threshold: retained when the checker says yes with
confidence >= threshold. Every decision is kept with its reason.

The same bytes twice (by sha256): a later copy under the same activity is rejected as a
`duplicate of` the first without being checked; a clip retained under two or more
activities is rejected under each, as its activity is ambiguous. No clip counts twice.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import json_repair

from vsmp_imu.errors import ConfigError, InputFileError, VsmpError
from vsmp_imu.extract.client import VLMClient
from vsmp_imu.extract.frames import VIDEO_SUFFIXES, FrameSampler, file_sha256
from vsmp_imu.extract.prompt import CHECK_TEMPLATE, prompt_sha256
from vsmp_imu.extract.vlm import JPEG_QUALITY, build_messages

MANIFEST_FORMAT = "vsmp-imu/source-pool/1"
DEFAULT_THRESHOLD = 0.6
MIN_DETECTED = 0.5  # pose checker: a person in at least half of the processed frames
Progress = Callable[[int, int, str], None]


@dataclass
class CheckResult:
    """A checker's answer for one clip."""

    shows_activity: bool | None  # None: the checker could not decide
    confidence: float  # in [0, 1], confidence in `shows_activity`
    reason: str
    details: dict[str, Any] = field(default_factory=dict)


def _activity_text(name: str) -> str:
    return name.replace("_", " ").strip()


def parse_check_answer(text: str) -> tuple[bool | None, float, str]:
    """(answer, confidence, reason) from a yes/no JSON answer; (None, 0, why) if unreadable."""
    try:
        obj = json_repair.loads(text or "")
    except Exception:  # json_repair raises plain exceptions on hopeless input
        obj = None
    if not isinstance(obj, dict):
        return None, 0.0, "the answer holds no JSON object"
    lower = {str(k).strip().lower(): v for k, v in obj.items()}
    raw = lower.get("answer", lower.get("shows_activity", lower.get("match")))
    if isinstance(raw, bool):
        answer: bool | None = raw
    else:
        word = str(raw).strip().lower() if raw is not None else ""
        answer = True if word in ("yes", "y", "true") else False if word in ("no", "n", "false") else None
    try:
        conf = float(lower.get("confidence", float("nan")))
    except (TypeError, ValueError):
        conf = float("nan")
    if not math.isfinite(conf):
        return answer, 0.0, "no numeric confidence in the answer"
    if not 0.0 <= conf <= 100.0:
        return answer, 0.0, f"confidence {conf:g} is neither a fraction 0..1 nor a percentage 0..100"
    if conf > 1.0:
        conf /= 100.0  # a percentage
    return answer, conf, str(lower.get("reason", "")).strip()


def unreadable_check(text: str) -> str | None:
    """None when the answer says yes or no (so it may be cached); else why not."""
    return None if parse_check_answer(text)[0] is not None else "no yes/no answer"


class VLMClipChecker:
    """Ask the VLM whether a clip shows the activity as its dominant action."""

    name = "vlm"

    def __init__(self, client: VLMClient, sampler: FrameSampler | None = None,
                 jpeg_quality: int = JPEG_QUALITY) -> None:
        self.client = client
        self.sampler = sampler
        self.jpeg_quality = jpeg_quality

    def describe(self) -> dict[str, Any]:
        return {"checker": self.name, "base_url": self.client.base_url, "model": self.client.model,
                "frames": (self.sampler or FrameSampler()).settings()}

    def check(self, video: str | Path, activity: str) -> CheckResult:
        sampled = (self.sampler or FrameSampler()).sample(video)
        text = CHECK_TEMPLATE.format(activity=_activity_text(activity))
        messages = build_messages(sampled, [text], self.jpeg_quality)
        key = {"task": "pool_check", "clip_sha256": sampled.clip_hash,
               "frames": {"indices": [int(i) for i in sampled.indices],
                          "size_px": sampled.size_px, "jpeg_quality": self.jpeg_quality},
               "prompt_sha256": prompt_sha256(text), "query_index": 0}
        done = self.client.complete(messages, key, accept=unreadable_check)
        details = {"cached": done.cached, "attempts": done.attempts, "content": done.content,
                   "errors": done.errors, "cache_note": done.cache_note}
        if not done.ok:
            return CheckResult(None, 0.0, f"request failed: {done.error}", details)
        answer, conf, reason = parse_check_answer(done.content or "")
        if answer is None:
            return CheckResult(None, 0.0, f"unreadable answer ({reason or 'no yes/no'})", details)
        return CheckResult(answer, conf, reason or ("yes" if answer else "no"), details)


class PoseClipChecker:
    """Offline check from body pose (see module docs).

    extractor: a `PoseExtractor` (default: MediaPipe at 15 fps at most).
    min_detected: required fraction of processed frames with a person.
    """

    name = "pose"

    def __init__(self, extractor: Any = None, min_detected: float = MIN_DETECTED) -> None:
        self.extractor = extractor
        self.min_detected = min_detected

    def _extractor(self) -> Any:
        if self.extractor is None:
            from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
            from vsmp_imu.extract.pose import PoseExtractor

            self.extractor = PoseExtractor(MediaPipePoseEstimator(max_fps=15.0))
        return self.extractor

    def describe(self) -> dict[str, Any]:
        return {"checker": self.name, "min_detected": self.min_detected}

    def check(self, video: str | Path, activity: str) -> CheckResult:
        extractor = self._extractor()
        track = extractor.track(video)
        return self.check_track(track, activity)

    def check_track(self, track: Any, activity: str) -> CheckResult:
        """The decision from landmarks already computed."""
        detected = track.detected_fraction
        details: dict[str, Any] = {"detected_fraction": round(detected, 4)}
        if detected < self.min_detected:
            return CheckResult(False, _clip01(1.0 - detected / max(self.min_detected, 1e-9)),
                               f"a person is found in only {detected:.0%} of the frames "
                               f"(< {self.min_detected:.0%})", details)
        result = self._extractor().extract_track(track, activity)
        m = result.measurements
        q = m.evidence.quality if m.evidence is not None else 0.0
        details["track_quality"] = round(q, 4)
        if result.entry is None:
            conf = math.sqrt(q) * 0.5
            details["library_entry"] = None
            return CheckResult(q > 0, round(conf, 4),
                               f"'{activity}' is not in the activity library: only the person "
                               "detection was checked", details)
        entry = self._extractor().entry_for(activity)
        periodicity = m.get("periodicity")
        strength = periodicity.raw.get("strength", 0.0) if periodicity is not None else 0.0
        parts = m.get("body_parts")
        speeds = parts.raw.get("speed_m_s", {}) if parts is not None else {}
        visible = [p for p, v in (parts.raw.get("visibility", {}) if parts else {}).items() if v >= 0.5]
        involved = set(parts.raw.get("involved", []) if parts is not None else [])
        recipe_kind = _kind(entry)
        if recipe_kind == "static":
            top = max((speeds.get(p, 0.0) for p in visible), default=0.0)
            s_p = 1.0 - _clip01((top - 0.2) / 0.4)
            why_p = f"top segment speed {top:.2f} m/s for a static activity"
        elif entry.smp.temporal_structure.is_repetitive:
            s_p = _clip01((strength - 0.2) / 0.4)
            why_p = f"periodicity {strength:.2f} for a repetitive activity"
        else:
            s_p = 1.0 - _clip01((strength - 0.5) / 0.3)
            why_p = f"periodicity {strength:.2f} for a non-repetitive activity"
        bp = entry.smp.body_parts
        expected = set(bp.dominant_moving_segments or bp.mandatory)
        allowed = _whole_limbs(expected | set(bp.mandatory) | set(bp.optional))
        seen_expected = expected & set(visible)
        if recipe_kind == "static" or not expected:
            s_b, why_b = 1.0, "no moving parts expected"
        elif not seen_expected:
            s_b, why_b = 0.0, "none of the expected moving parts is visible"
        else:
            recall = len(seen_expected & involved) / len(seen_expected)
            moving = involved - set(CENTRAL_PARTS)
            precision = len(moving & allowed) / len(moving) if moving else 1.0
            s_b = 2 * recall * precision / (recall + precision) if recall + precision > 0 else 0.0
            why_b = (f"{len(seen_expected & involved)} of {len(seen_expected)} visible expected "
                     f"parts move, {len(involved - allowed - set(CENTRAL_PARTS))} part(s) of "
                     "uninvolved limbs move")
        conf = math.sqrt(q) * s_p * s_b
        details.update(library_entry=entry.name, periodicity_score=round(s_p, 4),
                       body_part_score=round(s_b, 4), periodicity_strength=round(strength, 4))
        return CheckResult(True, round(conf, 4),
                           f"track quality {q:.2f}; {why_p}; {why_b}", details)


CENTRAL_PARTS = ("head", "torso", "pelvis")  # move with almost every activity
LIMBS = {side_limb: tuple(f"{side}_{seg}" for seg in segs)
         for side in ("left", "right")
         for side_limb, segs in ((f"{side}_arm", ("shoulder", "upper_arm", "forearm", "hand")),
                                 (f"{side}_leg", ("thigh", "lower_leg", "foot")))}


def _whole_limbs(parts: set[str]) -> set[str]:
    """Every segment of each limb that has a part in `parts` (a limb moves as a chain)."""
    out = set(parts)
    for segs in LIMBS.values():
        if out & set(segs):
            out |= set(segs)
    return out


def _kind(entry: Any) -> str | None:
    from vsmp_imu.errors import ValidationError
    from vsmp_imu.motion.recipe import recipe_for_entry

    try:
        return recipe_for_entry(entry).kind
    except ValidationError:
        return None


def _clip01(x: float) -> float:
    return float(min(1.0, max(0.0, x))) if math.isfinite(x) else 0.0


@dataclass
class ClipDecision:
    activity: str
    path: str  # relative to the pool folder, '/'-separated
    sha256: str | None
    decision: str  # retained | rejected
    shows_activity: bool | None
    confidence: float
    reason: str
    details: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def pool_clips(pool_dir: str | Path) -> list[tuple[str, Path]]:
    """(activity, clip path) for every video under POOL/<activity>/, sorted."""
    root = Path(pool_dir)
    if not root.is_dir():
        raise InputFileError("the source pool must be a folder of activity folders", file=root)
    out = []
    for folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        for clip in sorted(folder.iterdir()):
            if clip.is_file() and clip.suffix.lower() in VIDEO_SUFFIXES:
                out.append((folder.name, clip))
    if not out:
        raise InputFileError("no video clips found; expected POOL/<activity>/<clip>"
                             f"{VIDEO_SUFFIXES[0]} (suffixes: {', '.join(VIDEO_SUFFIXES)})",
                             file=root)
    return out


class SourcePoolFilter:
    """Check every clip of a pool and keep those that pass the threshold."""

    def __init__(self, checker: VLMClipChecker | PoseClipChecker, threshold: float = DEFAULT_THRESHOLD) -> None:
        self.checker = checker
        self.threshold = threshold

    def filter(self, pool_dir: str | Path, progress: Progress | None = None) -> dict[str, Any]:
        """The manifest (a JSON-serializable dict) of the pool."""
        if not 0.0 <= self.threshold <= 1.0:
            raise ConfigError(f"threshold must be within 0..1, got {self.threshold}", field="threshold")
        root = Path(pool_dir)
        clips = pool_clips(root)
        decisions: list[ClipDecision] = []
        first: dict[tuple[str, str], str] = {}  # (activity, sha256) -> the first such clip
        for n, (activity, path) in enumerate(clips):
            rel = path.relative_to(root).as_posix()
            decisions.append(self._decide(activity, path, rel, first))
            if progress is not None:
                progress(n + 1, len(clips), rel)
        _reject_ambiguous(decisions)
        return manifest(root, self.checker.describe(), self.threshold, decisions)

    def _decide(self, activity: str, path: Path, rel: str,
                first: dict[tuple[str, str], str]) -> ClipDecision:
        """One clip's decision; a copy of an earlier clip of the same activity is not checked again."""
        try:
            sha = file_sha256(path)
            earlier = first.setdefault((activity, sha), rel)
            if earlier != rel:
                return ClipDecision(activity, rel, sha, "rejected", None, 0.0,
                                    f"duplicate of {earlier} (the same bytes)", {"duplicate_of": earlier})
            result = self.checker.check(path, activity)
        except VsmpError as exc:
            if isinstance(exc, ConfigError):
                raise
            return ClipDecision(activity, rel, None, "rejected", None, 0.0,
                                f"unreadable clip: {exc.message}")
        keep = result.shows_activity is True and result.confidence >= self.threshold
        reason = result.reason
        if result.shows_activity is True and not keep:
            reason = f"confidence {result.confidence:.2f} below {self.threshold:g}: {reason}"
        return ClipDecision(activity, rel, sha, "retained" if keep else "rejected", result.shows_activity,
                            round(result.confidence, 4), reason, result.details)


def _reject_ambiguous(decisions: list[ClipDecision]) -> None:
    """A clip retained under several activities is the source of none: each copy is rejected,
    naming the others (copies within one activity are already `duplicate of`)."""
    retained: dict[str, list[ClipDecision]] = {}
    for d in decisions:
        if d.decision == "retained" and d.sha256 is not None:
            retained.setdefault(d.sha256, []).append(d)
    for same in (group for group in retained.values() if len(group) > 1):
        for d in same:
            others = [o for o in same if o is not d]
            names = ", ".join(f"{o.activity} ({o.path})" for o in others)
            d.decision = "rejected"
            d.reason = f"the same clip is also retained as {names}; a clip is the source of one activity only"
            d.details["also_retained_as"] = [o.path for o in others]


def manifest(root: Path, checker: dict[str, Any], threshold: float,
             decisions: list[ClipDecision]) -> dict[str, Any]:
    activities: dict[str, dict[str, list[str]]] = {}
    for d in decisions:
        slot = activities.setdefault(d.activity, {"retained": [], "rejected": []})
        slot[d.decision].append(d.path)
    return {
        "format": MANIFEST_FORMAT, "pool": str(root), "checker": checker, "threshold": threshold,
        "counts": {"clips": len(decisions),
                   "retained": sum(d.decision == "retained" for d in decisions),
                   "rejected": sum(d.decision == "rejected" for d in decisions)},
        "activities": activities, "clips": [d.to_dict() for d in decisions],
    }


def retained_clips(manifest_data: dict[str, Any], pool_dir: str | Path | None = None) -> list[tuple[str, Path]]:
    """(activity, path) of the retained clips of a manifest (paths resolved against the pool)."""
    if manifest_data.get("format") != MANIFEST_FORMAT:
        raise InputFileError(f"not a source-pool manifest (format {manifest_data.get('format')!r})",
                             allowed=MANIFEST_FORMAT)
    root = Path(pool_dir or manifest_data["pool"])
    return [(c["activity"], root / c["path"]) for c in manifest_data["clips"]
            if c["decision"] == "retained"]
