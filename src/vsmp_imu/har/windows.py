"""Fixed-length labelled IMU windows, the unit every backbone and protocol works on."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from vsmp_imu.errors import ValidationError


@dataclass
class Windows:
    """A batch of IMU windows with their labels and subjects.

    `X` is `(N, T, C)` float32 in SI units (m/s², rad/s), `y` holds class
    indices into `label_names`, `subjects` the subject id (a string) of each
    window. `meta` holds optional per-window arrays of length N, e.g.
    `recording`, `session`, `start` (first sample in its recording) or, for
    synthetic windows, `source`.
    """

    X: np.ndarray
    y: np.ndarray
    subjects: np.ndarray
    label_names: tuple[str, ...]
    channel_names: tuple[str, ...]
    fs_hz: float
    meta: dict[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.X = np.asarray(self.X, dtype=np.float32)
        self.y = np.asarray(self.y, dtype=np.int64)
        self.subjects = np.asarray(self.subjects).astype(str)
        self.label_names = tuple(self.label_names)
        self.channel_names = tuple(self.channel_names)
        self.fs_hz = float(self.fs_hz)
        if self.X.ndim != 3:
            raise ValidationError(f"windows must be (N, T, C), got shape {self.X.shape}", field="X")
        n = len(self.X)
        if self.y.shape != (n,) or self.subjects.shape != (n,):
            raise ValidationError(
                f"y and subjects must have length {n}, got {self.y.shape} and {self.subjects.shape}",
                field="y",
            )
        if self.X.shape[2] != len(self.channel_names):
            raise ValidationError(
                f"{self.X.shape[2]} channels but {len(self.channel_names)} channel names",
                field="channel_names",
            )
        if n and (self.y.min() < 0 or self.y.max() >= len(self.label_names)):
            raise ValidationError(
                "labels must index label_names",
                field="y",
                allowed=f"0..{len(self.label_names) - 1}",
            )
        for key, values in list(self.meta.items()):
            values = np.asarray(values)
            if values.shape[:1] != (n,):
                raise ValidationError(f"meta '{key}' must have length {n}", field=f"meta.{key}")
            self.meta[key] = values

    def __len__(self) -> int:
        return len(self.X)

    @property
    def n_timesteps(self) -> int:
        return self.X.shape[1]

    @property
    def n_channels(self) -> int:
        return self.X.shape[2]

    @property
    def n_classes(self) -> int:
        return len(self.label_names)

    @property
    def window_s(self) -> float:
        return self.n_timesteps / self.fs_hz

    def __getitem__(self, index: slice | np.ndarray | Sequence[int]) -> Windows:
        """A subset by slice, integer indices or boolean mask."""
        if isinstance(index, int | np.integer):
            index = [int(index)]
        return Windows(
            X=self.X[index],
            y=self.y[index],
            subjects=self.subjects[index],
            label_names=self.label_names,
            channel_names=self.channel_names,
            fs_hz=self.fs_hz,
            meta={k: v[index] for k, v in self.meta.items()},
        )

    def where_subjects(self, subjects: Sequence[str], keep: bool = True) -> Windows:
        """The windows whose subject is (keep=True) or is not (keep=False) in `subjects`."""
        mask = np.isin(self.subjects, np.asarray(list(subjects)).astype(str))
        return self[mask if keep else ~mask]

    def class_counts(self) -> np.ndarray:
        """Number of windows per class, length `n_classes`."""
        return np.bincount(self.y, minlength=self.n_classes)

    def unique_subjects(self) -> list[str]:
        return sorted(set(self.subjects.tolist()), key=natural_key)

    def with_meta(self, **meta: np.ndarray) -> Windows:
        merged = dict(self.meta)
        merged.update({k: np.asarray(v) for k, v in meta.items()})
        return Windows(
            self.X, self.y, self.subjects, self.label_names, self.channel_names, self.fs_hz, merged
        )

    def summary(self) -> str:
        counts = ", ".join(
            f"{n}={c}" for n, c in zip(self.label_names, self.class_counts(), strict=True)
        )
        return (
            f"{len(self)} windows x {self.n_timesteps} samples x {self.n_channels} channels "
            f"at {self.fs_hz:g} Hz, {len(self.unique_subjects())} subjects ({counts})"
        )


def natural_key(text: str) -> tuple:
    """Sort key that orders '2' before '10' and 'subject2' before 'subject10'."""
    import re

    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", str(text)))


def check_compatible(a: Windows, b: Windows, what: str = "windows") -> None:
    """Raise unless `b` can be stacked under `a` (same labels, channels, rate and length)."""
    if a.label_names != b.label_names:
        raise ValidationError(
            f"{what}: label names differ", field="label_names", allowed=", ".join(a.label_names)
        )
    if a.channel_names != b.channel_names:
        raise ValidationError(
            f"{what}: channel names differ ({', '.join(b.channel_names)})",
            field="channel_names",
            allowed=", ".join(a.channel_names),
        )
    if not math.isclose(a.fs_hz, b.fs_hz):
        raise ValidationError(
            f"{what}: sampling rate {b.fs_hz:g} Hz", field="fs_hz", allowed=f"{a.fs_hz:g}"
        )
    if a.n_timesteps != b.n_timesteps:
        raise ValidationError(
            f"{what}: window length {b.n_timesteps} samples", field="X", allowed=f"{a.n_timesteps}"
        )


def concat_windows(parts: Sequence[Windows]) -> Windows:
    """Stack windows with the same labels, channels, rate and length.

    Meta keys missing from some parts are filled with empty strings (text) or -1.
    """
    parts = [p for p in parts]
    if not parts:
        raise ValidationError("nothing to concatenate")
    first = parts[0]
    for p in parts[1:]:
        check_compatible(first, p)
    keys: list[str] = []
    for p in parts:
        keys += [k for k in p.meta if k not in keys]
    meta: dict[str, np.ndarray] = {}
    for k in keys:
        columns = []
        for p in parts:
            if k in p.meta:
                columns.append(p.meta[k])
            else:
                kind = next(q.meta[k] for q in parts if k in q.meta).dtype.kind
                filler = "" if kind in "US" else -1
                columns.append(np.full(len(p), filler, dtype=object if kind == "O" else None))
        meta[k] = np.concatenate([np.asarray(c) for c in columns])
    return Windows(
        X=np.concatenate([p.X for p in parts]) if parts else first.X,
        y=np.concatenate([p.y for p in parts]),
        subjects=np.concatenate([p.subjects for p in parts]),
        label_names=first.label_names,
        channel_names=first.channel_names,
        fs_hz=first.fs_hz,
        meta=meta,
    )


def empty_like(template: Windows) -> Windows:
    """No windows, with the template's labels, channels, rate and length."""
    return Windows(
        X=np.zeros((0, template.n_timesteps, template.n_channels), np.float32),
        y=np.zeros(0, np.int64),
        subjects=np.zeros(0, str),
        label_names=template.label_names,
        channel_names=template.channel_names,
        fs_hz=template.fs_hz,
    )


def window_starts(n_samples: int, size: int, step: int) -> np.ndarray:
    """Start indices of full windows of `size` samples every `step` samples."""
    if n_samples < size:
        return np.zeros(0, np.int64)
    return np.arange(0, n_samples - size + 1, step, dtype=np.int64)


def window_geometry(fs_hz: float, window_s: float, overlap: float) -> tuple[int, int]:
    """(size, step) in samples for a window length in seconds and an overlap fraction."""
    if not window_s > 0:
        raise ValidationError(f"window length must be positive, got {window_s}", field="--window-s")
    if not 0 <= overlap < 1:
        raise ValidationError(
            f"overlap must be in [0, 1), got {overlap}", field="--overlap", allowed="0 <= overlap < 1"
        )
    size = int(round(window_s * fs_hz))
    if size < 2:
        raise ValidationError(
            f"window of {window_s} s at {fs_hz:g} Hz has fewer than 2 samples", field="--window-s"
        )
    step = max(1, int(round(size * (1.0 - overlap))))
    return size, step


def label_windows(
    labels: np.ndarray, starts: np.ndarray, size: int, min_share: np.ndarray
) -> np.ndarray:
    """The class of each window, or -1 when no class covers its minimum share.

    `labels` holds per-sample class indices (-1 = unlabelled). A class is a
    candidate for a window when it covers at least `min_share[class]` of the
    window's samples; among candidates the one with the most samples wins
    (ties: lowest index). With a share of 1.0 every sample must agree.
    """
    n_classes = len(min_share)
    if len(starts) == 0:
        return np.zeros(0, np.int64)
    out = np.full(len(starts), -1, np.int64)
    best = np.zeros(len(starts), np.int64)
    for c in range(n_classes):
        indicator = np.concatenate([[0], np.cumsum(labels == c, dtype=np.int64)])
        count = indicator[starts + size] - indicator[starts]
        need = max(1, int(math.ceil(min_share[c] * size - 1e-9)))
        better = (count >= need) & (count > best)
        out[better] = c
        best[better] = count[better]
    return out
