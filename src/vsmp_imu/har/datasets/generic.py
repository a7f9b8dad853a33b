"""The user's own data: a folder of CSV/Parquet files (or one table) described by a YAML file.

Each table has a subject column, a label column, optionally a session and a
time column (seconds), and the channel columns named in the YAML. Rows of one
(file, subject, session) form one recording, in file order (sorted by time
when there is a time column). With a time column the data are resampled
onto `fs_hz` (or onto the rate estimated from the median time step when
`fs_hz` is left out). See docs/har.md for a complete example.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, model_validator

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.har.dataset import (
    AXES_SOURCES,
    PLACEMENTS,
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    acc_to_si,
    gyr_to_si,
)
from vsmp_imu.har.datasets.resample import common_grid
from vsmp_imu.har.windows import natural_key
from vsmp_imu.io import read_structured
from vsmp_imu.validation import validate_model

TABLE_SUFFIXES = (".csv", ".parquet")


class LocationSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: Literal[PLACEMENTS]  # type: ignore[valid-type]
    acc: list[str] = Field(min_length=3, max_length=3)
    gyr: list[str] | None = Field(default=None, min_length=3, max_length=3)
    acc_unit: Literal["g", "m/s^2"]
    gyr_unit: Literal["rad/s", "deg/s"] | None = None
    axes: list[str] | None = Field(default=None, min_length=3, max_length=3)
    axes_source: Literal[AXES_SOURCES] | None = None  # type: ignore[valid-type]
    gravity_included: bool = True
    note: str = ""

    @model_validator(mode="after")
    def _gyro_unit(self) -> LocationSpec:
        if self.gyr is not None and self.gyr_unit is None:
            raise ValueError("gyr_unit is required when gyr columns are given")
        return self


class GenericSpec(BaseModel):
    """The YAML file of a dataset in the generic format."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1)
    data: str = Field(min_length=1)
    fs_hz: float | None = Field(default=None, gt=0, allow_inf_nan=False)
    time_column: str | None = None
    subject_column: str = "subject"
    label_column: str = "label"
    session_column: str | None = None
    labels: list[str] | None = None
    unlabelled: list[str] = Field(default_factory=list)
    locations: list[LocationSpec] = Field(min_length=1)
    min_share: float = Field(default=1.0, gt=0, le=1)
    class_min_share: dict[str, float] = Field(default_factory=dict)
    pad_short: bool = False
    groups: dict[str, list[str]] = Field(default_factory=dict)
    description: str = ""

    @model_validator(mode="after")
    def _rate(self) -> GenericSpec:
        if self.fs_hz is None and self.time_column is None:
            raise ValueError("give fs_hz, a time_column, or both")
        names = [loc.name for loc in self.locations]
        if len(set(names)) != len(names):
            raise ValueError("each location may appear once")
        return self


def _channel_names(spec: GenericSpec) -> list[tuple[str, str, str]]:
    """(in-memory channel name, source column, kind) for every channel."""
    out = []
    prefix_needed = len(spec.locations) > 1
    for loc in spec.locations:
        prefix = f"{loc.name}_" if prefix_needed else ""
        out += [(f"{prefix}acc_{a}", col, "acc") for a, col in zip("xyz", loc.acc, strict=True)]
        if loc.gyr:
            out += [(f"{prefix}gyr_{a}", col, "gyr") for a, col in zip("xyz", loc.gyr, strict=True)]
    return out


def _read_table(path: Path) -> pd.DataFrame:
    try:
        if path.suffix.lower() == ".parquet":
            return pd.read_parquet(path)
        return pd.read_csv(path)
    except Exception as exc:  # pandas/pyarrow raise many types for a broken table
        raise InputFileError(f"cannot read table ({type(exc).__name__}: {exc})", file=path) from exc


class GenericDataset(HarDataset):
    """A dataset described by a YAML file in the generic format."""

    def __init__(self, yaml_path: str | Path) -> None:
        super().__init__()
        self.yaml_path = Path(yaml_path)
        if not self.yaml_path.is_file():
            raise InputFileError("dataset YAML file not found", file=self.yaml_path)
        try:
            raw = read_structured(self.yaml_path)
        except InputFileError as exc:  # unparsable YAML is a validation problem of the spec
            raise ValidationError(exc.message, file=self.yaml_path) from exc
        if not isinstance(raw, dict):
            raise ValidationError("expected a mapping of dataset settings", file=self.yaml_path)
        self.spec = validate_model(GenericSpec, raw, self.yaml_path)
        self.tables = self._tables()
        self._frames = {p: self._checked(p) for p in self.tables}
        labels = self._labels()
        channels = _channel_names(self.spec)
        locations = []
        for loc in self.spec.locations:
            prefix = f"{loc.name}_" if len(self.spec.locations) > 1 else ""
            names = [f"{prefix}acc_{a}" for a in "xyz"] + (
                [f"{prefix}gyr_{a}" for a in "xyz"] if loc.gyr else []
            )
            try:
                locations.append(
                    SensorLocation(
                        name=loc.name,
                        channels=tuple(names),
                        axes=tuple(loc.axes) if loc.axes else None,
                        axes_source=loc.axes_source or ("documented" if loc.axes else "unknown"),
                        gravity_included=loc.gravity_included,
                        acc_unit=loc.acc_unit,
                        gyr_unit=loc.gyr_unit,
                        note=loc.note,
                    )
                )
            except ValidationError as exc:
                raise ValidationError(
                    exc.message,
                    file=self.yaml_path,
                    field=f"locations.{exc.field}",
                    allowed=exc.allowed,
                ) from exc
        self.info = DatasetInfo(
            name=self.spec.name,
            fs_hz=self._rate(),
            label_names=labels,
            channel_names=tuple(c for c, _, _ in channels),
            locations=tuple(locations),
            description=self.spec.description,
            source=str(self.yaml_path),
            default_min_share=self.spec.min_share,
            min_share=dict(self.spec.class_min_share),
            pad_short=self.spec.pad_short,
            groups={k: tuple(v) for k, v in self.spec.groups.items()},
        )

    # -- reading and checks ----------------------------------------------------------------
    def _tables(self) -> list[Path]:
        target = Path(self.spec.data)
        if not target.is_absolute():
            target = self.yaml_path.parent / target
        if target.is_dir():
            tables = sorted(p for p in target.iterdir() if p.suffix.lower() in TABLE_SUFFIXES)
            if not tables:
                raise InputFileError("no .csv or .parquet files in the data folder", file=target)
            return tables
        if not target.exists():
            raise InputFileError("data file or folder not found", file=target)
        if target.suffix.lower() not in TABLE_SUFFIXES:
            raise InputFileError(
                "data must be a .csv or .parquet file, or a folder of them", file=target
            )
        return [target]

    def _checked(self, path: Path) -> pd.DataFrame:
        spec = self.spec
        frame = _read_table(path)
        needed = [spec.subject_column, spec.label_column]
        needed += [c for c in (spec.session_column, spec.time_column) if c]
        needed += [col for _, col, _ in _channel_names(spec)]
        for col in needed:
            if col not in frame.columns:
                raise ValidationError(
                    "column missing",
                    file=path,
                    field=col,
                    allowed=", ".join(map(str, frame.columns)),
                )
        numeric = [col for _, col, _ in _channel_names(spec)] + (
            [spec.time_column] if spec.time_column else []
        )
        for col in numeric:
            values = pd.to_numeric(frame[col], errors="coerce").to_numpy(np.float64)
            bad = np.flatnonzero(~np.isfinite(values))
            if len(bad):
                raise ValidationError(
                    f"{len(bad)} NaN, inf or non-numeric value(s), first at data row {bad[0] + 1}",
                    file=path,
                    field=col,
                )
            frame[col] = values
        for col in [spec.subject_column, spec.label_column] + (
            [spec.session_column] if spec.session_column else []
        ):
            missing = np.flatnonzero(frame[col].isna().to_numpy())
            if len(missing):
                raise ValidationError(
                    f"{len(missing)} empty value(s), first at data row {missing[0] + 1}",
                    file=path,
                    field=col,
                )
        return frame

    def _labels(self) -> tuple[str, ...]:
        spec = self.spec
        seen = set()
        for frame in self._frames.values():
            seen |= set(frame[spec.label_column].astype(str).unique())
        seen -= set(spec.unlabelled)
        if spec.labels is not None:
            unknown = sorted(seen - set(spec.labels), key=natural_key)
            if unknown:
                raise ValidationError(
                    f"label value(s) {', '.join(unknown)} are not declared",
                    file=self.yaml_path,
                    field="labels",
                    allowed=", ".join(spec.labels),
                )
            return tuple(spec.labels)
        if not seen:
            raise ValidationError("no labelled rows", file=self.yaml_path, field="label_column")
        return tuple(sorted(seen, key=natural_key))

    def _rate(self) -> float:
        if self.spec.fs_hz is not None:
            return float(self.spec.fs_hz)
        steps = []
        for frame in self._frames.values():
            t = np.sort(frame[self.spec.time_column].to_numpy(np.float64))
            dt = np.diff(t)
            steps.append(dt[dt > 0])
        steps = np.concatenate(steps)
        if len(steps) == 0:
            raise ValidationError(
                "cannot estimate the rate: time column never increases",
                file=self.yaml_path,
                field="time_column",
            )
        rate = 1.0 / float(np.median(steps))
        return float(round(rate)) if abs(rate - round(rate)) < 0.01 * rate else round(rate, 3)

    # -- recordings ------------------------------------------------------------------------
    def _load(self) -> list[Recording]:
        spec = self.spec
        channels = _channel_names(spec)
        units = {loc_ch: None for loc_ch, _, _ in channels}
        for loc in spec.locations:
            for name, col, kind in channels:
                if col in (loc.acc + (loc.gyr or [])):
                    units[name] = loc.acc_unit if kind == "acc" else loc.gyr_unit
        label_index = {name: i for i, name in enumerate(self.info.label_names)}
        recs = []
        for path, frame in self._frames.items():
            keys = [spec.subject_column] + ([spec.session_column] if spec.session_column else [])
            for key, rows in frame.groupby(keys, sort=False):
                key = key if isinstance(key, tuple) else (key,)
                subject = str(key[0])
                session = str(key[1]) if len(key) > 1 else path.stem
                if spec.time_column:
                    rows = rows.sort_values(spec.time_column, kind="stable")
                data = np.column_stack(
                    [
                        acc_to_si(rows[col].to_numpy(np.float64), units[name])
                        if kind == "acc"
                        else gyr_to_si(rows[col].to_numpy(np.float64), units[name])
                        for name, col, kind in channels
                    ]
                )
                labels = np.array(
                    [label_index.get(v, -1) for v in rows[spec.label_column].astype(str)]
                )
                if spec.time_column:
                    t = rows[spec.time_column].to_numpy(np.float64)
                    source = f"{path} (subject {subject})"
                    grid, values = common_grid(
                        [(t, data), (t, labels[:, None].astype(float))], self.info.fs_hz, source
                    )
                    data = values[:, :-1]
                    # nearest-sample labels, not interpolated ones
                    order = np.searchsorted(t, grid, side="left").clip(0, len(t) - 1)
                    prev = (order - 1).clip(0)
                    nearest = np.where(
                        np.abs(t[prev] - grid) < np.abs(t[order] - grid), prev, order
                    )
                    labels = labels[nearest]
                recs.append(
                    Recording(f"{path.stem}/{subject}/{session}", subject, session, data, labels)
                )
        return recs
