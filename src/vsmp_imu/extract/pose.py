"""Video -> SMP measured from body pose (offline, no VLM), and the fused VLM/library + pose mode.

`PoseExtractor.extract(video, label)`:
1. MediaPipe Pose landmarks per frame (`landmarks.MediaPipePoseEstimator`);
2. the SMPL-22 motion (`retarget.track_to_motion`; root held fixed);
3. the label's library SMP as the base (a label the library does not know
   gets a minimal SMP: the label, one generic primitive, high uncertainty,
   flagged `generic`);
4. measured fields with uncertainties (`posemeasure.PoseMeasurer`) against
   the activity's reference execution (`calibrate.reference_for`), on the
   longest run of one tracked person (no gap over `max_gap_s`, no identity
   switch); `.motion` is the whole clip, `.analysis_motion` that run;
5. the measurements written into the base SMP (`fuse.apply_measurements`,
   mode "replace"), or, with `base=` an SMP from a VLM or the library and
   mode "fuse", used to check and override it.
A clip without any detected person gives the base SMP unchanged, every
measurement marked not measured, and a report that says so.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.extract.calibrate import reference_for
from vsmp_imu.extract.fuse import FUSE_THRESHOLD, FieldChange, apply_measurements
from vsmp_imu.extract.landmarks import MediaPipePoseEstimator, PoseTrack
from vsmp_imu.extract.posemeasure import (
    PoseMeasurements,
    PoseMeasurer,
    longest_run,
    track_evidence,
)
from vsmp_imu.extract.retarget import LOWPASS_HZ, MAX_GAP_S, track_to_motion
from vsmp_imu.motion.motion import Motion
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry
from vsmp_imu.smp.schema import SMP, UNCERTAINTY_FIELDS

GENERIC_UNCERTAINTY = 0.8
Progress = Callable[[int, int], None]


def generic_smp(label: str) -> SMP:
    """A minimal SMP for a label the library does not know: one generic primitive."""
    name = "perform_" + (norm_name(label).replace(" ", "_") or "activity")
    unc = dict.fromkeys(UNCERTAINTY_FIELDS, GENERIC_UNCERTAINTY)
    unc["activity_label"] = 0.2  # the label is the user's
    return SMP.model_validate({
        "activity_label": label,
        "motion_primitives": [{"name": name, "order_index": 0,
                               "description": f"perform {label}"}],
        "primitive_sequence": [name],
        "uncertainty": unc,
    })


def _with_periodicity(smp: SMP, measurements: PoseMeasurements) -> SMP:
    """For a generic SMP: repetitive / periodicity from the measured periodicity."""
    m = measurements.get("periodicity")
    if m is None or not m.measured:
        return smp
    data = smp.model_dump(mode="json")
    data["temporal_structure"]["is_repetitive"] = bool(m.value)
    data["temporal_structure"]["periodicity"] = "cyclic" if m.value else "unknown"
    data["uncertainty"]["temporal_structure"] = max(m.uncertainty, 0.5)
    return SMP.model_validate(data)


@dataclass
class PoseExtraction:
    """The measured SMP of one clip, its motion, measurements and report."""

    label: str
    smp: SMP
    motion: Motion | None
    analysis_motion: Motion | None
    measurements: PoseMeasurements
    changes: list[FieldChange]
    track: PoseTrack
    entry: str | None
    generic: bool
    mode: str
    warnings: list[str] = field(default_factory=list)

    def report(self) -> dict[str, Any]:
        return {
            "extractor": "pose" if self.mode == "replace" else "fused",
            "label": self.label, "library_entry": self.entry, "generic_smp": self.generic,
            "track": self.track.summary(),
            "motion": None if self.motion is None else {
                k: v for k, v in self.motion.meta.items() if k not in ("detected", "frame_indices")},
            "measurements": self.measurements.to_dict(),
            "changes": [c.to_dict() for c in self.changes],
            "warnings": list(self.warnings),
        }

    def to_dict(self) -> dict[str, Any]:
        return {"smp": self.smp.model_dump(mode="json"), **self.report()}


@dataclass(eq=False, repr=False)
class PoseExtractor:
    """Measure an SMP from a clip's body pose.

    estimator: the landmark source (default MediaPipe, 30 fps at most).
    library: the activity library (None: built-in).
    height_m: body height of the retargeting skeleton and of pixel -> metre.
    max_gap_s: gaps up to this long are interpolated.
    lowpass_hz: landmark low-pass before retargeting (None: off).
    """

    estimator: MediaPipePoseEstimator | None = None
    library: ActivityLibrary | None = None
    height_m: float = DEFAULT_HEIGHT_M
    max_gap_s: float = MAX_GAP_S
    lowpass_hz: float | None = LOWPASS_HZ

    def _library(self) -> ActivityLibrary:
        return self.library if self.library is not None else ActivityLibrary.load()

    def entry_for(self, label: str) -> LibraryEntry | None:
        """The library entry whose name, alias or SMP label is `label` (case, space and
        underscore insensitive); None otherwise. No fuzzy matching: a measured SMP must not
        silently take another activity's template."""
        try:
            return self._library().get(label)
        except ValidationError:
            return None

    def track(self, video: str | Path, progress: Progress | None = None) -> PoseTrack:
        return (self.estimator or MediaPipePoseEstimator()).estimate(video, progress)

    def extract(self, video: str | Path, label: str, base: SMP | None = None, mode: str = "replace",
                threshold: float = FUSE_THRESHOLD, progress: Progress | None = None) -> PoseExtraction:
        """Pose mode (`mode="replace"`) or fused mode (`mode="fuse"`, `base` from a VLM or library)."""
        return self.extract_track(self.track(video, progress), label, base, mode, threshold)

    def extract_track(self, track: PoseTrack, label: str, base: SMP | None = None,
                      mode: str = "replace", threshold: float = FUSE_THRESHOLD) -> PoseExtraction:
        """The same from landmarks already computed."""
        if not label or not label.strip():
            raise ConfigError("a label is required for pose extraction", field="label")
        if mode not in ("replace", "fuse"):
            raise ConfigError(f"unknown mode '{mode}'", field="mode", allowed="replace, fuse")
        library = self._library()
        entry = self.entry_for(label)
        warnings: list[str] = []
        generic = False
        if base is None:
            if entry is not None:
                base = entry.smp
            else:
                base, generic = generic_smp(label), True
                close = library.close_matches(label)
                hint = f" (close: {', '.join(close)})" if close else ""
                warnings.append(f"'{label}' is not in the activity library{hint}: minimal SMP with "
                                "one generic primitive; tempo and amplitude levels cannot be set")
        periodic = None if generic else bool(base.temporal_structure.is_repetitive)
        motion = track_to_motion(track, self.height_m, self.max_gap_s, self.lowpass_hz)
        window = longest_run(track, self.max_gap_s)
        sub = track.slice(*window) if window is not None else track
        sub_motion = (track_to_motion(sub, self.height_m, self.max_gap_s, self.lowpass_hz)
                      if window is not None else None)
        reference = reference_for(entry, library) if entry is not None else None
        if entry is not None and reference is None:
            warnings.append(f"activity '{entry.name}' has no procedural recipe: tempo and "
                            "amplitude levels cannot be set")
        measurer = PoseMeasurer(reference, periodic, base.execution_attributes.dominant_side,
                                self.height_m, self.max_gap_s)
        measurements = measurer.measure(sub, sub_motion)
        measurements.window = window
        measurements.clip_evidence = track_evidence(track, self.max_gap_s)
        if window is not None and window != (0, track.n_frames):
            warnings.append(f"measured on frames {window[0]}..{window[1] - 1} (the longest run of "
                            "one tracked person); the rest of the clip has gaps or another person")
        if motion is None:
            warnings.append("no person detected: nothing measured, the base SMP is returned unchanged")
        elif measurements.evidence is not None and measurements.evidence.quality < 0.2:
            warnings.append(f"weak pose evidence (track quality {measurements.evidence.quality:.2f}): "
                            "measured fields carry high uncertainty")
        if generic:
            base = _with_periodicity(base, measurements)
        smp, changes = apply_measurements(base, measurements, mode, threshold)
        return PoseExtraction(label, smp, motion, sub_motion, measurements, changes, track,
                              entry.name if entry is not None else None, generic, mode, warnings)
