"""Grounding targets of the controllability study: real IMU statistics to ground to.

`UtdMhadTarget` (when the UTD-MHAD inertial files are given): per sensor
location (right wrist, right thigh), the device axes are inferred from the
data (UTD-MHAD does not document them: `grounding.align.infer_axes`), the
synthetic recordings are put in that convention, and one rank grounder per
location maps them to the real samples of that location (`RankGrounder`,
class-balanced with the UTD-MHAD class of every sample).

`HaptTarget` (fallback, ships offline): the HAPT waist phone. Synthetic
recordings are put in HAPT's declared convention (axes, gravity included, SI)
with `ConventionAlignment`, and one pooled rank grounder maps the synthetic
samples of every location to HAPT's windows. The sensor location differs
from UTD-MHAD's (waist instead of wrist or thigh) and the classes differ,
so the grounder is not class-balanced: this checks that the controls
survive a monotone per-channel map to real marginals, not a faithful
UTD-MHAD grounding.

Both follow the grounding room's interface: `fit(recordings)` with every
synthetic raw recording of the study, then `transform(recording)`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.align import AXIS_WORDS, Convention, ConventionAlignment, infer_axes
from vsmp_imu.grounding.rank import RankGrounder

HAPT_WINDOW_S = 2.56  # HAPT's standard 128-sample windows at 50 Hz
HAPT_OVERLAP = 0.5


@dataclass(frozen=True)
class SyntheticRecording:
    """One raw simulated recording: (T, 6) specific force and rate, gravity part (T, 3)."""

    key: str
    activity: str
    location: str
    data: np.ndarray
    gravity: np.ndarray


def axis_words(p: np.ndarray) -> tuple[str, str, str]:
    """The anatomical words of a signed permutation P (device = P @ simulated)."""
    inverse = {v: k for k, v in AXIS_WORDS.items()}
    words = []
    for row in np.asarray(p):
        dim = int(np.argmax(np.abs(row)))
        words.append(inverse[(dim, int(np.sign(row[dim])))])
    return tuple(words)  # type: ignore[return-value]


def _samples(recordings: Sequence[SyntheticRecording], align: ConventionAlignment) -> np.ndarray:
    return np.concatenate([align.transform(r.data, r.gravity) for r in recordings], axis=0)


class HaptTarget:
    """Ground to HAPT's waist-phone windows (pooled over locations; see the module notes)."""

    name = "hapt"

    def __init__(self, window_s: float = HAPT_WINDOW_S, overlap: float = HAPT_OVERLAP) -> None:
        self.window_s = window_s
        self.overlap = overlap

    def fit(self, recordings: Sequence[SyntheticRecording]) -> HaptTarget:
        from vsmp_imu.har.datasets import load_dataset

        if not recordings:
            raise ValidationError("no synthetic recordings to fit the grounding with", field="recordings")
        dataset = load_dataset("hapt")
        location = dataset.info.locations[0]
        windows = dataset.windows(self.window_s, self.overlap)
        self.convention_ = Convention(axes=location.axes, gravity_included=location.gravity_included)
        self.alignment_ = ConventionAlignment(self.convention_)
        synthetic = _samples(recordings, self.alignment_)
        self.grounder_ = RankGrounder(per_class=False, class_balanced=False).fit(synthetic, windows.X)
        self.description_ = {
            "target": "hapt",
            "statistics": f"HAPT (UCI smartphone dataset with postural transitions), "
                          f"{len(windows)} labelled windows of {self.window_s} s with "
                          f"{self.overlap:.0%} overlap from {len(windows.unique_subjects())} subjects, "
                          f"{len(windows.label_names)} activities ({', '.join(windows.label_names)}), "
                          f"{location.name} phone at {dataset.info.fs_hz:g} Hz",
            "real_samples": int(windows.X.shape[0] * windows.X.shape[1]),
            "synthetic_samples": int(len(synthetic)),
            "synthetic_locations": sorted({r.location for r in recordings}),
            "convention": self.convention_.as_dict(),
            "grounder": "RankGrounder, one pooled map per channel (no class balancing: the "
                        "synthetic classes are not HAPT classes)",
            "location_note": f"the target sensor is HAPT's {location.name} phone while the synthetic "
                             "sensors sit at the UTD-MHAD locations (right wrist or right thigh)",
        }
        return self

    def transform(self, recording: SyntheticRecording) -> np.ndarray:
        return self.grounder_.transform(self.alignment_.transform(recording.data, recording.gravity))


class UtdMhadTarget:
    """Ground to UTD-MHAD's own statistics, one map per sensor location (see the module notes)."""

    name = "utd-mhad"

    def __init__(self, data_dir: str | Path) -> None:
        self.data_dir = data_dir

    def fit(self, recordings: Sequence[SyntheticRecording]) -> UtdMhadTarget:
        from vsmp_imu.har.datasets import load_dataset

        if not recordings:
            raise ValidationError("no synthetic recordings to fit the grounding with", field="recordings")
        dataset = load_dataset("utd-mhad", self.data_dir)
        info = dataset.info
        by_location: dict[str, tuple[list[np.ndarray], list[np.ndarray]]] = {}
        for rec in dataset.recordings():
            classes = np.unique(rec.labels[rec.labels >= 0])
            if len(classes) != 1:
                continue
            location = info.location_by_label[info.label_names[int(classes[0])]]
            data, labels = by_location.setdefault(location, ([], []))
            data.append(rec.data.astype(float))
            labels.append(np.full(len(rec.data), int(classes[0])))
        self.alignment_: dict[str, ConventionAlignment] = {}
        self.grounder_: dict[str, RankGrounder] = {}
        per_location: dict[str, Any] = {}
        class_of = {name: i for i, name in enumerate(info.label_names)}
        for location in sorted({r.location for r in recordings}):
            if location not in by_location:
                raise ValidationError(f"the UTD-MHAD folder has no recordings at {location}",
                                      file=self.data_dir, allowed=", ".join(sorted(by_location)))
            real = np.concatenate(by_location[location][0])
            real_labels = np.concatenate(by_location[location][1])
            mine = [r for r in recordings if r.location == location]
            p, score = infer_axes(np.concatenate([r.data for r in mine]), real)
            convention = Convention(axes=axis_words(p), gravity_included=True)
            align = ConventionAlignment(convention)
            synthetic = _samples(mine, align)
            syn_labels = np.concatenate([np.full(len(r.data), class_of.get(r.activity, -1))
                                         for r in mine])
            self.alignment_[location] = align
            self.grounder_[location] = RankGrounder(per_class=False, class_balanced=True).fit(
                synthetic, real, syn_labels, real_labels)
            per_location[location] = {
                "real_samples": int(len(real)),
                "real_classes": sorted(info.label_names[c] for c in np.unique(real_labels)),
                "synthetic_samples": int(len(synthetic)),
                "inferred_axes": list(convention.axes),
                "axes_score": score,
            }
        self.description_ = {
            "target": "utd-mhad",
            "statistics": f"UTD-MHAD inertial recordings from {self.data_dir} "
                          f"({len(dataset.subjects)} subjects), one map per sensor location",
            "locations": per_location,
            "grounder": "RankGrounder per location, class-balanced by UTD-MHAD class; device axes "
                        "inferred from the data (UTD-MHAD does not document them), gravity included, SI",
        }
        return self

    def transform(self, recording: SyntheticRecording) -> np.ndarray:
        align = self.alignment_[recording.location]
        return self.grounder_[recording.location].transform(align.transform(recording.data,
                                                                            recording.gravity))
