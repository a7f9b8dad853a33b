"""Datasets as objects: recordings indexed by subject, session and activity.

A loader declares everything the rest of the project needs to know about its
sensors (`DatasetInfo`, one `SensorLocation` per placement) and converts the
data to SI units. In memory every recording is `(T, C)` float32 in m/s² and
rad/s with per-sample class indices (-1 = unlabelled).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Any

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.har.windows import (
    Windows,
    empty_like,
    label_windows,
    natural_key,
    window_geometry,
    window_starts,
)
from vsmp_imu.units import RAD_PER_DEG, STANDARD_GRAVITY_M_S2

# The IMU room's placement names.
PLACEMENTS = (
    "waist",
    "chest",
    "back",
    "head",
    "left_wrist",
    "right_wrist",
    "left_upper_arm",
    "right_upper_arm",
    "left_thigh",
    "right_thigh",
    "left_lower_leg",
    "right_lower_leg",
    "left_ankle",
    "right_ankle",
)

# Anatomical axis words: directions of the body standing in the T-pose, as
# vectors of the body frame (x = left, y = up, z = forward).
AXIS_WORDS: dict[str, tuple[int, int, int]] = {
    "left": (1, 0, 0),
    "right": (-1, 0, 0),
    "up": (0, 1, 0),
    "down": (0, -1, 0),
    "forward": (0, 0, 1),
    "backward": (0, 0, -1),
}
# Limb-relative axis words, as body directions of the T-pose (arms out to the sides, palms
# down; legs straight) for a limb on the body's LEFT side; on the right side `left` and
# `right` swap. Words hold on both sides, so one declaration covers a watch on either wrist.
LIMB_WORDS: dict[str, dict[str, str]] = {
    "wrist": {"distal": "left", "proximal": "right", "dorsal": "up", "palmar": "down",
              "radial": "forward", "ulnar": "backward"},
    "upper_arm": {"distal": "left", "proximal": "right", "lateral": "up", "medial": "down",
                  "anterior": "forward", "posterior": "backward"},
    "leg": {"distal": "down", "proximal": "up", "anterior": "forward", "posterior": "backward",
            "lateral": "left", "medial": "right"},
}
LIMB_OF = {"wrist": "wrist", "upper_arm": "upper_arm", "thigh": "leg", "lower_leg": "leg", "ankle": "leg"}
SIDES = ("left", "right")
ACC_UNITS = ("g", "m/s^2")
GYR_UNITS = ("rad/s", "deg/s")
# How a declared axis convention was established.
AXES_SOURCES = ("measured", "documented", "assumed", "unknown")


def axes_matrix(axes: Sequence[str]) -> np.ndarray:
    """3x3 matrix whose columns are the device x, y, z axes in the body frame.

    `body_vector = axes_matrix(axes) @ device_vector`.
    """
    return np.array([AXIS_WORDS[a] for a in axes], dtype=float).T


def check_axes(axes: Sequence[str], where: str = "axes") -> tuple[str, str, str]:
    """Validate three anatomical words forming a right-handed orthogonal frame."""
    axes = tuple(str(a).strip().lower() for a in axes)
    if len(axes) != 3:
        raise ValidationError(f"need three axis words for x, y, z, got {len(axes)}", field=where)
    bad = [a for a in axes if a not in AXIS_WORDS]
    if bad:
        raise ValidationError(
            f"unknown axis word(s) {', '.join(bad)}", field=where, allowed=", ".join(AXIS_WORDS)
        )
    m = axes_matrix(axes)
    if not np.allclose(m.T @ m, np.eye(3)):
        raise ValidationError(
            f"axes {', '.join(axes)} are not three different directions", field=where
        )
    if np.linalg.det(m) < 0:
        raise ValidationError(
            f"axes {', '.join(axes)} form a left-handed frame; IMU frames are right-handed "
            "(x cross y must equal z)",
            field=where,
        )
    return axes  # type: ignore[return-value]


def placement_side(placement: str) -> tuple[str | None, str]:
    """('left' | 'right' | None, the placement without its side), e.g. ('left', 'wrist')."""
    side, _, rest = placement.partition("_")
    return (side, rest) if side in SIDES and rest else (None, placement)


def limb_words(placement: str) -> dict[str, str]:
    """The limb-relative axis words of a placement, as body words (empty for the trunk and head)."""
    side, limb = placement_side(placement)
    words = LIMB_WORDS.get(LIMB_OF.get(limb, ""), {})
    if side != "right":
        return dict(words)
    swap = {"left": "right", "right": "left"}
    return {k: swap.get(v, v) for k, v in words.items()}


def uses_limb_words(axes: Sequence[str]) -> bool:
    every = {w for words in LIMB_WORDS.values() for w in words}
    return any(str(a).strip().lower() in every for a in axes)


def resolve_axes(axes: Sequence[str], placement: str, where: str = "axes") -> tuple[str, str, str]:
    """Axis words (body words, or limb words of the placement) as checked body words.

    Limb words (`distal`, `dorsal`, `radial`...) are read on the placement's side: `distal`
    is `left` on the left wrist and `right` on the right wrist.
    """
    words = [str(a).strip().lower() for a in axes]
    if uses_limb_words(words):
        table = limb_words(placement)
        bad = [w for w in words if w not in table and w not in AXIS_WORDS]
        if not table or bad:
            raise ValidationError(
                f"axis word(s) {', '.join(bad or words)} do not apply to the {placement}",
                field=where, allowed=", ".join(list(AXIS_WORDS) + list(table)))
        body = [table.get(w, w) for w in words]
        try:
            return check_axes(body, where)
        except ValidationError as exc:
            raise ValidationError(
                f"axes {', '.join(words)} on the {placement} are {', '.join(body)}: {exc.message}",
                field=where, allowed=exc.allowed) from exc
    return check_axes(words, where)


MIRROR = np.diag([-1.0, 1.0, 1.0])  # the body's left-right mirror (x = left)


def mirror_matrix(source_axes: Sequence[str], target_axes: Sequence[str]) -> np.ndarray:
    """Q with acc_target = Q @ acc_source (and gyr_target = -Q @ gyr_source).

    A sensor on one side of the body recording a motion reads, in its device
    axes `source_axes` (body words), what a sensor with `target_axes` on the
    other side reads for the mirror image of that motion: the body frame is
    reflected left-right (acceleration is a vector; angular velocity an axial
    vector, which takes one more sign).
    """
    return axes_matrix(target_axes).T @ MIRROR @ axes_matrix(source_axes)


@dataclass(frozen=True)
class SensorLocation:
    """One sensor placement of a dataset and the conventions of its data.

    `axes` are the device x, y, z axes as anatomical words of the body in the
    T-pose (e.g. a waist phone whose x axis points up reads +9.81 m/s² on x
    when standing); None when not known. `axes_source` says how they were
    established (measured from the data, documented by the authors, assumed,
    unknown). `acc_unit`/`gyr_unit` are the units of the source files; in
    memory the data are SI.
    """

    name: str
    channels: tuple[str, ...]
    axes: tuple[str, str, str] | None
    gravity_included: bool
    acc_unit: str
    gyr_unit: str | None
    axes_source: str = "unknown"
    note: str = ""

    def __post_init__(self) -> None:
        if self.name not in PLACEMENTS:
            raise ValidationError(
                f"unknown sensor location '{self.name}'",
                field="name",
                allowed=", ".join(PLACEMENTS),
            )
        object.__setattr__(self, "channels", tuple(self.channels))
        if self.axes is not None:
            object.__setattr__(self, "axes", check_axes(self.axes, f"{self.name}.axes"))
        if self.acc_unit not in ACC_UNITS:
            raise ValidationError(
                f"unknown accelerometer unit '{self.acc_unit}'",
                field=f"{self.name}.acc_unit",
                allowed=", ".join(ACC_UNITS),
            )
        if self.gyr_unit is not None and self.gyr_unit not in GYR_UNITS:
            raise ValidationError(
                f"unknown gyroscope unit '{self.gyr_unit}'",
                field=f"{self.name}.gyr_unit",
                allowed=", ".join(GYR_UNITS),
            )
        if self.axes_source not in AXES_SOURCES:
            raise ValidationError(
                f"unknown axes source '{self.axes_source}'",
                field=f"{self.name}.axes_source",
                allowed=", ".join(AXES_SOURCES),
            )

    @property
    def acc_channels(self) -> tuple[str, ...]:
        return tuple(c for c in self.channels if "acc_" in c)

    @property
    def gyr_channels(self) -> tuple[str, ...]:
        return tuple(c for c in self.channels if "gyr_" in c)

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "channels": list(self.channels),
            "axes": list(self.axes) if self.axes else None,
            "axes_source": self.axes_source,
            "gravity_included": self.gravity_included,
            "acc_unit": self.acc_unit,
            "gyr_unit": self.gyr_unit,
            "note": self.note,
        }


def imu_channel_names(location: str | None, gyro: bool = True) -> tuple[str, ...]:
    """`acc_x acc_y acc_z gyr_x gyr_y gyr_z`, prefixed by the location when given."""
    kinds = ("acc", "gyr") if gyro else ("acc",)
    prefix = f"{location}_" if location else ""
    return tuple(f"{prefix}{k}_{a}" for k in kinds for a in "xyz")


@dataclass(frozen=True)
class DatasetInfo:
    """What a dataset is: rate, classes, channels, sensor placements and conventions.

    `min_share` gives, per class name, the share of a window the class must
    cover for the window to carry it (default `default_min_share`, 1.0 = every
    sample). `pad_short` makes a recording shorter than one window give one
    window, padded by repeating its last sample (for datasets of short clips).
    `groups` names subsets of classes reported separately (e.g. transitions).
    `location_by_label` is set when the sensor placement depends on the
    activity (UTD-MHAD).
    """

    name: str
    fs_hz: float
    label_names: tuple[str, ...]
    channel_names: tuple[str, ...]
    locations: tuple[SensorLocation, ...]
    description: str = ""
    source: str = ""
    default_min_share: float = 1.0
    min_share: dict[str, float] = field(default_factory=dict)
    pad_short: bool = False
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    location_by_label: dict[str, str] | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "label_names", tuple(self.label_names))
        object.__setattr__(self, "channel_names", tuple(self.channel_names))
        object.__setattr__(self, "locations", tuple(self.locations))
        declared = [c for loc in self.locations for c in loc.channels]
        missing = [c for c in declared if c not in self.channel_names]
        if missing and self.location_by_label is None:
            raise ValidationError(
                f"location channels not in channel_names: {', '.join(missing)}", field="locations"
            )
        for group, members in self.groups.items():
            unknown = [m for m in members if m not in self.label_names]
            if unknown:
                raise ValidationError(
                    f"group '{group}' names unknown classes {', '.join(unknown)}",
                    field="groups",
                    allowed=", ".join(self.label_names),
                )

    @property
    def n_classes(self) -> int:
        return len(self.label_names)

    def share_vector(self) -> np.ndarray:
        return np.array([self.min_share.get(n, self.default_min_share) for n in self.label_names])

    def location(self, name: str) -> SensorLocation:
        for loc in self.locations:
            if loc.name == name:
                return loc
        raise ValidationError(
            f"no sensor location '{name}'",
            field="location",
            allowed=", ".join(loc.name for loc in self.locations),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "fs_hz": self.fs_hz,
            "label_names": list(self.label_names),
            "channel_names": list(self.channel_names),
            "locations": [loc.to_dict() for loc in self.locations],
            "description": self.description,
            "source": self.source,
            "default_min_share": self.default_min_share,
            "min_share": dict(self.min_share),
            "pad_short": self.pad_short,
            "groups": {k: list(v) for k, v in self.groups.items()},
            "location_by_label": self.location_by_label,
            "notes": list(self.notes),
        }


@dataclass
class Recording:
    """One continuous recording of one subject: `(T, C)` SI data and per-sample labels."""

    recording_id: str
    subject: str
    session: str
    data: np.ndarray
    labels: np.ndarray

    def __post_init__(self) -> None:
        self.subject = str(self.subject)
        self.session = str(self.session)
        self.data = np.ascontiguousarray(self.data, dtype=np.float32)
        self.labels = np.asarray(self.labels, dtype=np.int64)
        if self.data.ndim != 2 or self.labels.shape != (len(self.data),):
            raise ValidationError(
                f"recording {self.recording_id}: data {self.data.shape} and labels "
                f"{self.labels.shape} do not match",
                field="data",
            )

    @property
    def n_samples(self) -> int:
        return len(self.data)


def acc_to_si(values: np.ndarray, unit: str) -> np.ndarray:
    """Accelerometer values from `unit` (g or m/s^2) to m/s²."""
    return _to_si(values, unit, {"g": STANDARD_GRAVITY_M_S2, "m/s^2": None}, "accelerometer", ACC_UNITS)


def gyr_to_si(values: np.ndarray, unit: str) -> np.ndarray:
    """Gyroscope values from `unit` (rad/s or deg/s) to rad/s."""
    return _to_si(values, unit, {"deg/s": RAD_PER_DEG, "rad/s": None}, "gyroscope", GYR_UNITS)


def _to_si(values: np.ndarray, unit: str, scales: dict, sensor: str, units: tuple) -> np.ndarray:
    """`values` times the scale of `unit` (None: already SI, returned as is)."""
    if unit not in scales:
        raise ValidationError(f"unknown {sensor} unit '{unit}'", allowed=", ".join(units))
    scale = scales[unit]
    return values if scale is None else values * scale


def found(items, message: str, root):
    """`items` a loader found under `root`, or an InputFileError with `message` when none."""
    if not items:
        raise InputFileError(message, file=root)
    return items


def inner_root(root, name: str):
    """`root/name` where the archive unpacked into that folder, else `root`."""
    return root / name if (root / name).is_dir() else root


class HarDataset:
    """Base class of every dataset: subclasses set `info` and implement `_load()`.

    Recordings are loaded once, on first use. `get_subset(subjects=...)`
    returns a dataset restricted to some subjects (the gaitmap/tpcp style of
    splitting by group); `windows()` cuts labelled windows.
    """

    info: DatasetInfo

    def __init__(self) -> None:
        self._subset: tuple[str, ...] | None = None
        self.skipped: list[str] = []
        # what looks wrong in the declared conventions (undeclared axes, a unit that does not fit)
        self.warnings: list[str] = []

    # -- loading ---------------------------------------------------------------------------
    def _load(self) -> list[Recording]:
        raise NotImplementedError

    @cached_property
    def _all_recordings(self) -> list[Recording]:
        recs = self._load()
        n_channels = len(self.info.channel_names)
        # the dataset's folder (or YAML file), so the message names where to look
        source = getattr(self, "data_dir", None) or getattr(self, "yaml_path", None)
        for rec in recs:
            if rec.data.shape[1] != n_channels:
                raise ValidationError(
                    f"recording {rec.recording_id} has {rec.data.shape[1]} channels",
                    file=source,
                    field="channel_names",
                    allowed=str(n_channels),
                )
            if not np.isfinite(rec.data).all():
                raise ValidationError(
                    f"recording {rec.recording_id} has NaN or inf values", file=source, field="data"
                )
        return sorted(recs, key=lambda r: (natural_key(r.subject), natural_key(r.recording_id)))

    def recordings(self) -> list[Recording]:
        recs = self._all_recordings
        if self._subset is None:
            return list(recs)
        return [r for r in recs if r.subject in self._subset]

    def __iter__(self) -> Iterator[Recording]:
        return iter(self.recordings())

    def __len__(self) -> int:
        return len(self.recordings())

    # -- index -----------------------------------------------------------------------------
    @property
    def index(self) -> pd.DataFrame:
        """One row per recording: recording, subject, session, activity, n_samples."""
        rows = []
        for rec in self.recordings():
            present = sorted(set(np.unique(rec.labels).tolist()) - {-1})
            activity = (
                self.info.label_names[present[0]]
                if len(present) == 1
                else ("mixed" if present else "unlabelled")
            )
            rows.append(
                {
                    "recording": rec.recording_id,
                    "subject": rec.subject,
                    "session": rec.session,
                    "activity": activity,
                    "n_samples": rec.n_samples,
                }
            )
        return pd.DataFrame(
            rows, columns=["recording", "subject", "session", "activity", "n_samples"]
        )

    @property
    def subjects(self) -> list[str]:
        return sorted({r.subject for r in self.recordings()}, key=natural_key)

    def get_subset(self, subjects: Sequence[str | int]) -> HarDataset:
        """The same dataset limited to `subjects`."""
        wanted = {str(s) for s in subjects}
        unknown = wanted - set(self.subjects)
        if unknown:
            raise ValidationError(
                f"unknown subject(s) {', '.join(sorted(unknown, key=natural_key))}",
                field="subjects",
                allowed=", ".join(self.subjects),
            )
        clone = object.__new__(type(self))
        clone.__dict__.update(self.__dict__)
        clone._subset = tuple(sorted(wanted, key=natural_key))
        return clone

    # -- windows ---------------------------------------------------------------------------
    def windows(self, window_s: float = 2.0, overlap: float = 0.5) -> Windows:
        """Labelled windows of `window_s` seconds with `overlap` (fraction) between neighbours.

        A window carries a class when that class covers at least its minimum
        share of samples (`DatasetInfo.min_share`); other windows are dropped.
        """
        info = self.info
        size, step = window_geometry(info.fs_hz, window_s, overlap)
        shares = info.share_vector()
        parts_x, parts_y, subj, rec_ids, sessions, starts_all = [], [], [], [], [], []
        for rec in self.recordings():
            data, labels = rec.data, rec.labels
            if info.pad_short and 0 < rec.n_samples < size:
                pad = size - rec.n_samples
                data = np.concatenate([data, np.repeat(data[-1:], pad, axis=0)])
                labels = np.concatenate([labels, np.repeat(labels[-1:], pad)])
            starts = window_starts(len(data), size, step)
            y = label_windows(labels, starts, size, shares)
            keep = y >= 0
            if not keep.any():
                continue
            starts, y = starts[keep], y[keep]
            view = np.lib.stride_tricks.sliding_window_view(data, size, axis=0)  # (n, C, size)
            parts_x.append(np.ascontiguousarray(view[starts].transpose(0, 2, 1)))
            parts_y.append(y)
            subj += [rec.subject] * len(y)
            rec_ids += [rec.recording_id] * len(y)
            sessions += [rec.session] * len(y)
            starts_all.append(starts)
        if not parts_x:
            template = Windows(
                np.zeros((0, size, len(info.channel_names))),
                np.zeros(0),
                np.zeros(0, str),
                info.label_names,
                info.channel_names,
                info.fs_hz,
            )
            return empty_like(template)
        return Windows(
            X=np.concatenate(parts_x),
            y=np.concatenate(parts_y),
            subjects=np.array(subj),
            label_names=info.label_names,
            channel_names=info.channel_names,
            fs_hz=info.fs_hz,
            meta={
                "recording": np.array(rec_ids),
                "session": np.array(sessions),
                "start": np.concatenate(starts_all),
            },
        )

    def describe(self, window_s: float = 2.0, overlap: float = 0.5) -> dict[str, Any]:
        """Everything `vsmp-imu dataset info` prints: subjects, classes with window counts,
        channels, rate and the declared conventions."""
        win = self.windows(window_s, overlap)
        counts = win.class_counts()
        return {
            **self.info.to_dict(),
            "subjects": self.subjects,
            "n_recordings": len(self),
            "window_s": window_s,
            "overlap": overlap,
            "n_windows": len(win),
            "windows_per_class": {
                n: int(c) for n, c in zip(self.info.label_names, counts, strict=True)
            },
            "skipped": list(self.skipped),
            "warnings": list(self.warnings),
        }


def measure_static_gravity(windows: Windows, label: str) -> dict[str, float]:
    """Mean of every accelerometer channel over the windows of one (static) class, in m/s².

    A declared convention can be checked with it: a waist phone whose x axis
    points up reads about +9.81 on x in the windows of 'standing'.
    """
    if label not in windows.label_names:
        raise ValidationError(
            f"unknown class '{label}'", field="label", allowed=", ".join(windows.label_names)
        )
    sel = windows.y == windows.label_names.index(label)
    if not sel.any():
        raise ValidationError(f"no windows of class '{label}'", field="label")
    means = windows.X[sel].mean(axis=(0, 1))
    return {c: float(m) for c, m in zip(windows.channel_names, means, strict=True) if "acc_" in c}


def with_info(dataset: HarDataset, **changes: Any) -> HarDataset:
    """A shallow copy of `dataset` whose `info` has some fields replaced."""
    clone = object.__new__(type(dataset))
    clone.__dict__.update(dataset.__dict__)
    clone.info = replace(dataset.info, **changes)
    return clone
