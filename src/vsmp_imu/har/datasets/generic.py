"""The user's own data: a folder of CSV/Parquet files (or one table) described by a YAML file.

Each table has a subject column, a label column, optionally a session and a
time column (seconds), and the channel columns named in the YAML. Rows of one
(file, subject, session) form one recording, in file order (sorted by time
when there is a time column). With a time column the data are resampled
onto `fs_hz` (or onto the rate estimated from the median time step when
`fs_hz` is left out). A location may name a `side_column`: recordings whose side is not the
location's own (a watch on the left wrist in a `right_wrist` dataset) are
mirrored into the location's convention when loaded, so every window reads
as if worn on the declared side. See docs/har.md and docs/tutorial.md.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

import numpy as np
import pandas as pd
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.har.dataset import (
    AXES_SOURCES,
    PLACEMENTS,
    SIDES,
    DatasetInfo,
    HarDataset,
    Recording,
    SensorLocation,
    acc_to_si,
    gyr_to_si,
    mirror_matrix,
    placement_side,
    resolve_axes,
    uses_limb_words,
)
from vsmp_imu.har.datasets.resample import common_grid
from vsmp_imu.har.windows import natural_key
from vsmp_imu.io import read_structured
from vsmp_imu.units import STANDARD_GRAVITY_M_S2
from vsmp_imu.validation import validate_model

TABLE_SUFFIXES = (".csv", ".parquet")
# sampling rates a wearable dataset can have: below 1 Hz a 2 s window holds too few samples,
# above 10 kHz the value is a typo (an IMU samples at tens to a few thousand Hz)
MIN_RATE_HZ, MAX_RATE_HZ = 1.0, 10_000.0
# beyond these no wearable IMU reads (high-g accelerometers reach a few hundred g, gyroscopes a few
# thousand deg/s): a value past them is a fill value or a damaged row, warned with its row
ACC_MAX_G, GYR_MAX_DEG_S = 400.0, 5000.0
ACC_MAX_M_S2, GYR_MAX_RAD_S = ACC_MAX_G * STANDARD_GRAVITY_M_S2, float(np.deg2rad(GYR_MAX_DEG_S))
# a class's median rotation rate above this (rad/s, ~570 deg/s) reads deg/s declared as rad/s: a body
# segment turns at a few rad/s at most for a moment, its median over a class is far lower
GYR_MEDIAN_MAX_RAD_S = 10.0
# fs_hz this many times above or below the time column's median rate is warned
RATE_MISMATCH = 1.5
# shares of rows repeating their recording's previous time: noted above the first, refused above the second
REPEATS_NOTED, REPEATS_REFUSED = 0.01, 0.10


class LocationSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: Literal[PLACEMENTS]  # type: ignore[valid-type]
    acc: list[str] = Field(min_length=3, max_length=3)
    gyr: list[str] | None = Field(default=None, min_length=3, max_length=3)
    acc_unit: Literal["g", "m/s^2"]
    gyr_unit: Literal["rad/s", "deg/s"] | None = None
    # device x, y, z: body or limb words; with a side_column, one list per side
    axes: list[str] | dict[Literal["left", "right"], list[str]] | None = None
    axes_source: Literal[AXES_SOURCES] | None = None  # type: ignore[valid-type]
    gravity_included: bool = True
    acc_sign: Literal[1, -1] = 1  # -1: the device reads -1 g on the axis pointing up
    side_column: str | None = None  # per-row 'left' / 'right': the side each recording was worn on
    note: str = ""

    @model_validator(mode="after")
    def _gyro_unit(self) -> LocationSpec:
        if self.gyr is not None and self.gyr_unit is None:
            raise ValueError("gyr_unit is required when gyr columns are given")
        _once("column", self.acc + (self.gyr or []), "feeds two channels")
        lists = self.axes.values() if isinstance(self.axes, dict) else [self.axes] if self.axes else []
        if any(len(words) != 3 for words in lists):
            raise ValueError("axes are three words: the device x, y and z")
        return self

    def words(self, side: str | None) -> list[str] | None:
        """The axis words declared for `side` (the list itself when not given per side)."""
        if isinstance(self.axes, dict):
            return self.axes.get(side) if side else None
        return self.axes


class GenericSpec(BaseModel):
    """The YAML file of a dataset in the generic format."""

    model_config = ConfigDict(extra="forbid")

    name: str = Field(min_length=1)
    data: str = Field(min_length=1)
    fs_hz: float | None = Field(default=None, ge=MIN_RATE_HZ, le=MAX_RATE_HZ)
    time_column: str | None = None
    subject_column: str = "subject"
    label_column: str = "label"
    session_column: str | None = None
    labels: list[str] | None = None
    unlabelled: list[str] = Field(default_factory=list)
    locations: list[LocationSpec] = Field(min_length=1)
    min_share: float = Field(default=1.0, gt=0, le=1)
    class_min_share: dict[str, Annotated[float, Field(gt=0, le=1)]] = Field(default_factory=dict)
    pad_short: bool = False
    groups: dict[str, list[str]] = Field(default_factory=dict)
    description: str = ""

    @field_validator("fs_hz", mode="before")
    @classmethod
    def _not_a_flag(cls, value):
        if isinstance(value, bool):  # YAML's yes/true would read as 1 Hz
            raise ValueError("expected a rate in Hz, not true or false")
        return value

    @model_validator(mode="after")
    def _rate(self) -> GenericSpec:
        if self.fs_hz is None and self.time_column is None:
            raise ValueError("give fs_hz, a time_column, or both")
        names = [loc.name for loc in self.locations]
        if len(set(names)) != len(names):
            raise ValueError("each location may appear once")
        _once("column", [c for loc in self.locations for c in loc.acc + (loc.gyr or [])], "feeds two channels")
        self._distinct_roles()
        if self.labels is not None:
            _once("class", self.labels, "is declared twice in labels")
            if any(not name.strip() for name in self.labels):
                raise ValueError("a class name in labels is empty")
            both = sorted(set(self.labels) & set(self.unlabelled), key=natural_key)
            if both:
                raise ValueError(f"{', '.join(both)}: both a class (labels) and no class (unlabelled)")
        return self


    def _distinct_roles(self) -> None:
        """Each column has one role: subject_column: label made every class a 'subject' (leave one
        class out, scored as leave one subject out) and time_column: ax a channel the clock."""
        roles: list[tuple[str, str]] = [(self.subject_column, "subject_column"), (self.label_column, "label_column")]
        roles += [(col, key) for col, key in ((self.session_column, "session_column"),
                                               (self.time_column, "time_column")) if col]
        roles += [(col, f"locations[{i}].{kind}") for i, loc in enumerate(self.locations)
                  for kind in ("acc", "gyr") for col in getattr(loc, kind) or []]
        sides = [(loc.side_column, f"locations[{i}].side_column") for i, loc in enumerate(self.locations)
                 if loc.side_column]
        taken: dict[str, str] = {}
        for col, key in roles + sides:
            other = taken.get(col)
            # a side column may also be the session column (one session per side)
            if other and not (key.endswith("side_column") and other in ("session_column",)) \
                    and not (key.endswith("side_column") and other.endswith("side_column")):
                raise ValueError(f"column '{col}' is both {other} and {key}; each column has one role")
            taken.setdefault(col, key)


def _once(what: str, names: list[str], problem: str) -> None:
    """Refuse a list that holds one name twice."""
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise ValueError(f"{what} '{name}' {problem}")
        seen.add(name)


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


UNIT_OK_G = (0.4, 3.0)  # a class's median |acc| in g, gravity included, when the unit is right
# a class's median |acc| in g that says gravity is in the values although declared removed
GRAVITY_FREE_NEAR_1G = (0.9, 1.1)


def _unit_hint(g: float, unit: str) -> str:
    """What a class's median |acc| (in g, as declared) says about the declared unit ('' if fine)."""
    if UNIT_OK_G[0] <= g <= UNIT_OK_G[1]:
        return ""
    if unit == "g" and 0.4 * STANDARD_GRAVITY_M_S2 <= g <= 3.0 * STANDARD_GRAVITY_M_S2:
        return "the values look like m/s², not g; set acc_unit: m/s^2."
    if unit == "m/s^2" and 0.4 / STANDARD_GRAVITY_M_S2 <= g <= 3.0 / STANDARD_GRAVITY_M_S2:
        return "the values look like g, not m/s²; set acc_unit: g."
    return ("about 1 g was expected; check acc_unit, the acc columns, and gravity_included "
            "(false when the device removes gravity).")


def _location_note(loc: LocationSpec) -> str:
    parts = [loc.note] if loc.note else []
    if isinstance(loc.axes, dict):
        parts.append("axes declared per side: " + "; ".join(f"{k} {', '.join(v)}" for k, v in sorted(loc.axes.items())))
    elif loc.axes and uses_limb_words(loc.axes):
        parts.append(f"axes declared as {', '.join(loc.axes)}")
    if loc.acc_sign == -1:
        parts.append("accelerometer negated (the device reads -1 g on the axis pointing up)")
    if loc.side_column:
        parts.append(f"recordings worn on the other side (column '{loc.side_column}') are mirrored "
                     f"into the {loc.name} convention")
    return "; ".join(parts)


def _read_table(path: Path, text_columns: list[str], used_columns: frozenset[str] = frozenset()) -> pd.DataFrame:
    """The table, with `text_columns` (subject, label, session) read as written: '01' is not '1', and
    'NA', 'None' or 'null' are a subject's initials or a label, not an empty cell (pandas' default)."""
    header: list[str] = []
    try:
        if path.suffix.lower() == ".parquet":
            frame = pd.read_parquet(path)
        else:
            # only a truly empty cell is missing in a text column; numeric columns keep pandas' words
            # ('nan', 'NA', ...), which the numeric check then refuses with their row
            na_words = {col: [""] for col in text_columns}
            frame = pd.read_csv(path, dtype=dict.fromkeys(text_columns, str), keep_default_na=False,
                                na_values=na_words)
            header = [str(v) for v in pd.read_csv(path, header=None, nrows=1, dtype=str,
                                                  keep_default_na=False).iloc[0]] if len(frame.columns) else []
    except Exception as exc:  # pandas/pyarrow raise many types for a broken table
        raise InputFileError(f"cannot read table ({type(exc).__name__}: {exc})", file=path) from exc
    if header:
        twice = sorted({name for name in header if header.count(name) > 1 and name in used_columns})
        if twice:  # pandas renames the second 'ax' to 'ax.1' and the first would be taken silently
            raise ValidationError(f"column(s) {', '.join(twice)} appear twice in the header", file=path,
                                  field=twice[0], allowed="each column name once")
    if frame.empty:
        raise InputFileError("the table holds no data rows (a header at most)", file=path,
                             allowed="a table with at least one row; take an empty file out of the data folder")
    return frame


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
        self._data_notes: list[str] = []
        self.tables = self._tables()
        self._time_notes: list[str] = []
        self._label_notes: list[str] = []
        self._range_notes: list[str] = []
        self._frames = {p: self._checked(p) for p in self.tables}
        labels = self._labels()
        channels = _channel_names(self.spec)
        locations = []
        for i, loc in enumerate(self.spec.locations):
            prefix = f"{loc.name}_" if len(self.spec.locations) > 1 else ""
            names = [f"{prefix}acc_{a}" for a in "xyz"] + (
                [f"{prefix}gyr_{a}" for a in "xyz"] if loc.gyr else []
            )
            axes = self._body_axes(loc, loc.name, i)
            try:
                locations.append(
                    SensorLocation(
                        name=loc.name,
                        channels=tuple(names),
                        axes=axes,
                        axes_source=loc.axes_source or ("documented" if loc.axes else "unknown"),
                        gravity_included=loc.gravity_included,
                        acc_unit=loc.acc_unit,
                        gyr_unit=loc.gyr_unit,
                        note=_location_note(loc),
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
        self.warnings = self._axes_warnings() + self._unit_warnings() + self._time_notes + self._label_notes + self._range_notes + self._data_notes

    # -- conventions -----------------------------------------------------------------------
    def _body_axes(self, loc: LocationSpec, placement: str, index: int) -> tuple[str, str, str] | None:
        """The location's axes as body words on `placement` (limb words read on its side)."""
        side, _ = placement_side(placement)
        where = f"locations[{index}].axes" + (f".{side}" if isinstance(loc.axes, dict) else "")
        per_side = isinstance(loc.axes, dict)
        if loc.side_column is not None or per_side:
            field, problem = None, ""
            if loc.side_column is not None and placement_side(loc.name)[0] is None:
                field, problem = "side_column", f"side_column is set but '{loc.name}' has no side"
            elif not per_side or set(loc.axes) != set(SIDES):
                field, problem = "axes", (
                    "recordings worn on either side are mirrored into one convention, which needs the "
                    "device axes of each side: axes: {left: [...], right: [...]}")
            elif loc.side_column is None:
                field, problem = "side_column", "axes are given per side but no side_column says which"
            if problem:
                raise ValidationError(
                    problem, file=self.yaml_path, field=f"locations[{index}].{field}",
                    allowed="a left_/right_ placement with side_column and axes {left: [...], right: [...]} "
                            "(e.g. a watch crown toward the hand: left [distal, ulnar, dorsal], "
                            "right [distal, radial, dorsal])")
        words = loc.words(side)
        if not words:
            return None
        try:
            return resolve_axes(words, placement, where)
        except ValidationError as exc:
            raise ValidationError(exc.message, file=self.yaml_path, field=where, allowed=exc.allowed) from exc

    def _axes_warnings(self) -> list[str]:
        return [
            f"{self.yaml_path}: location '{loc.name}' declares no axes (locations[{i}].axes). Synthetic "
            "windows are then simulated in an assumed frame, and grounding and the quality filter can "
            "reject most windows of a class. Declare the device axes (body words such as "
            "[up, left, backward], or limb words such as [distal, radial, dorsal]); `vsmp-imu dataset "
            "info FILE --measure CLASS` shows where gravity points in a static class."
            for i, loc in enumerate(self.spec.locations) if not loc.axes
        ]

    def _unit_warnings(self) -> list[str]:
        """Classes whose median |acc| is far from 1 g although gravity is declared included (over all
        files, then file by file for a file that alone is off), or near 1 g although it is not."""
        out = []
        for i, loc in enumerate(self.spec.locations):
            medians = self._median_g(loc)
            pooled = {label: float(np.median(np.concatenate(list(parts.values()))))
                      for label, parts in medians.items()}
            fine = []  # the classes that read right over all files
            for label, g in sorted(pooled.items()):
                hint = self._gravity_hint(loc, g)
                if not hint:
                    fine.append(label)
                    continue
                out.append(f"{self.yaml_path}: class '{label}' at '{loc.name}' reads a median acceleration "
                           f"of {g * STANDARD_GRAVITY_M_S2:.3g} m/s² ({g:.3g} g) with acc_unit "
                           f"{loc.acc_unit} (locations[{i}]): {hint}")
            for path in self.tables:
                odd = [(label, g, hint) for label in fine if path in medians[label]
                       for g in [float(np.median(medians[label][path]))] if (hint := self._gravity_hint(loc, g))]
                if odd:
                    label, g, hint = odd[0]
                    out.append(f"{path}: at '{loc.name}' class(es) {', '.join(k for k, _, _ in odd)} read a median "
                               f"acceleration unlike the other files' (first: '{label}', {g:.3g} g with acc_unit "
                               f"{loc.acc_unit}, locations[{i}]): {hint}")
            if loc.gyr and loc.gyr_unit == "rad/s":
                out += self._gyro_unit_warnings(loc, i)
        return out

    def _gyro_unit_warnings(self, loc: LocationSpec, index: int) -> list[str]:
        """A class turning at a median of over GYR_MEDIAN_MAX_RAD_S with gyr_unit rad/s: deg/s values
        declared as rad/s read 57 times too fast (the other way round reads as nearly still, which a
        still class also does, so it is not told)."""
        rates: dict[str, list[np.ndarray]] = {}
        for frame in self._frames.values():
            norm = np.linalg.norm(frame[loc.gyr].to_numpy(np.float64), axis=1)
            for label, rows in pd.Series(norm).groupby(frame[self.spec.label_column].astype(str).values):
                if label not in self.spec.unlabelled:
                    rates.setdefault(label, []).append(rows.to_numpy())
        out = []
        for label, parts in sorted(rates.items()):
            rate = float(np.median(np.concatenate(parts)))
            if rate > GYR_MEDIAN_MAX_RAD_S:
                out.append(f"{self.yaml_path}: class '{label}' at '{loc.name}' turns at a median {rate:.3g} rad/s "
                           f"({np.rad2deg(rate):.3g} deg/s) with gyr_unit rad/s (locations[{index}]): the values "
                           "look like deg/s; set gyr_unit: deg/s.")
        return out

    def _median_g(self, loc: LocationSpec) -> dict[str, dict[Path, np.ndarray]]:
        """Per class and file, |acc| in g (as declared) of the labelled rows."""
        by_class: dict[str, dict[Path, np.ndarray]] = {}
        for path, frame in self._frames.items():
            acc = acc_to_si(frame[loc.acc].to_numpy(np.float64), loc.acc_unit)
            norm = np.linalg.norm(acc, axis=1) / STANDARD_GRAVITY_M_S2
            for label, rows in pd.Series(norm).groupby(frame[self.spec.label_column].astype(str).values):
                if label not in self.spec.unlabelled:
                    by_class.setdefault(label, {})[path] = rows.to_numpy()
        return by_class

    @staticmethod
    def _gravity_hint(loc: LocationSpec, g: float) -> str:
        """What a median |acc| of `g` (in g, as declared) says about the declaration ('' if fine)."""
        if loc.gravity_included:
            return _unit_hint(g, loc.acc_unit)
        if GRAVITY_FREE_NEAR_1G[0] <= g <= GRAVITY_FREE_NEAR_1G[1]:
            return ("about 1 g although gravity_included is false: the values look like they include gravity "
                    "(set gravity_included: true).")
        return ""

    # -- reading and checks ----------------------------------------------------------------
    def _tables(self) -> list[Path]:
        target = Path(self.spec.data)
        if not target.is_absolute():
            target = self.yaml_path.parent / target
        if target.is_dir():
            # hidden files are no tables: '._p1.csv' is the resource fork a Mac leaves on a USB stick
            tables = sorted(p for p in target.iterdir()
                            if p.suffix.lower() in TABLE_SUFFIXES and not p.name.startswith("."))
            nested = sorted(p.name for p in target.iterdir() if p.is_dir() and not p.name.startswith(".")
                            and any(q.suffix.lower() in TABLE_SUFFIXES for q in p.rglob("*")))
            if nested:
                self._data_notes.append(
                    f"{target}: the tables in subfolder(s) {', '.join(nested)} are not read (only the data "
                    "folder's own .csv/.parquet files are); point data at each folder, or move the files up.")
            if not tables:
                raise InputFileError("no .csv or .parquet files in the data folder", file=target)
            stems: dict[str, Path] = {}
            for path in tables:  # recordings are named (and sessions default) by the file's stem
                if (first := stems.setdefault(path.stem.casefold(), path)) is not path:
                    raise InputFileError(
                        f"{first.name} and {path.name} share a name: one table saved twice (as CSV and "
                        "Parquet) would be read twice, and recordings are named by the file name",
                        file=target, allowed="one table per name in the data folder")
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
        ids = [spec.subject_column, spec.label_column] + ([spec.session_column] if spec.session_column else [])
        needed = [spec.subject_column, spec.label_column]
        needed += [c for c in (spec.session_column, spec.time_column) if c]
        needed += [col for _, col, _ in _channel_names(spec)]
        needed += [loc.side_column for loc in spec.locations if loc.side_column]
        frame = _read_table(path, ids, frozenset(needed))
        for col in needed:
            if col not in frame.columns:
                names = [str(c) for c in frame.columns]
                hint = ""
                if len(names) == 1 and (sep := next((c for c in ";\t|" if c in names[0]), None)):
                    hint = f"; the header is one column holding {sep!r}: columns must be separated by commas"
                elif not set(needed) & set(names):
                    hint = ("; none of the declared columns is in the first row: a table without a header "
                            "row? (the first row must name the columns)")
                raise ValidationError(
                    "column missing" + hint,
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
        self._check_range(path, frame)
        if spec.time_column:
            self._check_repeats(path, frame)
        for col in [spec.subject_column, spec.label_column] + (
            [spec.session_column] if spec.session_column else []
        ):
            # a cell of spaces shows as empty in every table and would be a class or a person of its own
            blank = frame[col].isna() | (frame[col].astype(str).str.strip() == "")
            missing = np.flatnonzero(blank.to_numpy())
            if len(missing):
                raise ValidationError(
                    f"{len(missing)} empty or blank value(s), first at data row {missing[0] + 1}",
                    file=path,
                    field=col,
                )
        return frame

    def _check_range(self, path: Path, frame: pd.DataFrame) -> None:
        """Refuse channel values that no longer fit a float32 once in SI units (the loader's type)."""
        top = float(np.finfo(np.float32).max)
        for loc in self.spec.locations:
            columns = [(c, loc.acc_unit, acc_to_si) for c in loc.acc] + [(c, loc.gyr_unit, gyr_to_si) for c in loc.gyr or []]
            for col, unit, to_si in columns:
                with np.errstate(over="ignore"):
                    bad = np.flatnonzero(~(np.abs(to_si(frame[col].to_numpy(np.float64), unit)) < top))
                if len(bad):
                    raise ValidationError(
                        f"{len(bad)} value(s) too large to be a sensor reading in {unit}, first at data row "
                        f"{bad[0] + 1}", file=path, field=col)
                limit, shown = (ACC_MAX_M_S2, f"{ACC_MAX_G:g} g") if to_si is acc_to_si else \
                    (GYR_MAX_RAD_S, f"{GYR_MAX_DEG_S:g} deg/s")
                values = frame[col].to_numpy(np.float64)
                odd = np.flatnonzero(np.abs(to_si(values, unit)) > limit)
                if len(odd):  # finite, but beyond any wearable sensor: a fill value (-9999) or a damaged row
                    self._range_notes.append(
                        f"{path}: {len(odd)} value(s) of column '{col}' beyond what a wearable sensor reads "
                        f"({shown}), first at data row {odd[0] + 1}: {values[odd[0]]:.6g} {unit}. A marker for "
                        "a missing sample or a damaged row" + (" (or deg/s values declared as rad/s)"
                                                                  if unit == "rad/s" else "") + "? Such values dominate every statistic of their "
                        "windows; remove or fix those rows.")

    def _check_repeats(self, path: Path, frame: pd.DataFrame) -> None:
        """Rows whose time repeats an earlier row's in their recording are dropped when resampled:
        a few are noted, many (a rounded time column) refused."""
        keys = [self.spec.subject_column] + ([self.spec.session_column] if self.spec.session_column else [])
        repeats = frame.duplicated(keys + [self.spec.time_column]).to_numpy()
        share = float(repeats.mean()) if len(repeats) else 0.0
        if share <= REPEATS_NOTED:
            return
        where = f"{share:.1%} of the rows repeat an earlier row's time in their recording, first at data row " \
                f"{np.flatnonzero(repeats)[0] + 1}"
        if share > REPEATS_REFUSED:
            raise ValidationError(f"{where}: the times look rounded; only the first of each is kept, so the "
                                  "rest would be lost (give fs_hz without time_column if the rows are evenly "
                                  "spaced)", file=path, field=self.spec.time_column)
        self._time_notes.append(f"{path}: {where} (column '{self.spec.time_column}'); only the first of each is kept.")

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
                    f"label value(s) {', '.join(v if v == v.strip() else repr(v) for v in unknown)} are not declared",
                    file=self.yaml_path,
                    field="labels",
                    allowed=", ".join(spec.labels),
                )
            absent = [name for name in spec.labels if name not in seen]
            if absent:
                self._label_notes.append(
                    f"{self.yaml_path}: class(es) {', '.join(map(repr, absent))} declared in labels are in no "
                    "row of the recordings: they get no window and no score (a misspelling in labels or in "
                    "the data?).")
            return self._share_classes(self._distinct(tuple(spec.labels)))
        if not seen:
            raise ValidationError("no labelled rows", file=self.yaml_path, field="label_column")
        return self._share_classes(self._distinct(tuple(sorted(seen, key=natural_key))))

    def _distinct(self, labels: tuple[str, ...]) -> tuple[str, ...]:
        """`labels`, once no two differ only in case or surrounding spaces: such classes look alike in
        every table and link to one activity (class names match activities case-insensitively)."""
        by_key: dict[str, list[str]] = {}
        for name in labels:
            by_key.setdefault(name.strip().casefold(), []).append(name)
        alike = [names for names in by_key.values() if len(names) > 1]
        field = "labels" if self.spec.labels is not None else self.spec.label_column
        for none in self.spec.unlabelled:  # 'None' as a class beside unlabelled 'none'
            names = by_key.get(none.strip().casefold(), [])
            if names:
                raise ValidationError(
                    f"label value(s) {', '.join(map(repr, names))} are a class, while unlabelled lists {none!r}: "
                    "they differ only in case or surrounding spaces", file=self.yaml_path, field=field,
                    allowed=f"one spelling (fix the label values in the recordings), or {names[0]!r} added to "
                            "unlabelled")
        if alike:
            raise ValidationError(
                "class names that differ only in case or surrounding spaces: "
                + "; ".join(" and ".join(map(repr, names)) for names in alike)
                + " (they would be separate classes given the same activity's synthetic windows)",
                file=self.yaml_path, field=field,
                allowed="one spelling per class (fix the label values in the recordings)")
        return labels

    def _share_classes(self, labels: tuple[str, ...]) -> tuple[str, ...]:
        """`labels`, once class_min_share names only classes among them."""
        unknown = sorted(set(self.spec.class_min_share) - set(labels), key=natural_key)
        if unknown:
            raise ValidationError(f"unknown class(es) {', '.join(unknown)}", file=self.yaml_path,
                                  field="class_min_share", allowed=", ".join(labels))
        return labels

    def _rate(self) -> float:
        if self.spec.fs_hz is not None:
            if self.spec.time_column:
                self._rate_note(float(self.spec.fs_hz))
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
        step = float(np.median(steps))
        rate = 1.0 / step
        if not MIN_RATE_HZ <= rate <= MAX_RATE_HZ:
            raise ValidationError(
                f"the median time step is {step:.6g} s, a rate of {rate:.6g} Hz: are the times in seconds? "
                "(or give fs_hz)", file=self.yaml_path, field="time_column",
                allowed=f"times in seconds, a rate of {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz")
        return float(round(rate)) if abs(rate - round(rate)) < 0.01 * rate else round(rate, 3)

    def _rate_note(self, fs_hz: float) -> None:
        """Warn where fs_hz is far from the rate the time column steps at: fs_hz: 500 on 50 Hz
        readings made ten interpolated samples of each reading, silently."""
        steps = []
        for frame in self._frames.values():
            dt = np.diff(np.sort(frame[self.spec.time_column].to_numpy(np.float64)))
            steps.append(dt[dt > 0])
        steps = np.concatenate(steps)
        if not len(steps):
            return
        measured = 1.0 / float(np.median(steps))
        if fs_hz > RATE_MISMATCH * measured:
            self._time_notes.append(
                f"{self.yaml_path}: fs_hz is {fs_hz:g} Hz but the time column '{self.spec.time_column}' steps "
                f"at {measured:.4g} Hz (median): the recordings are interpolated {fs_hz / measured:.3g}x up and "
                "the new samples hold no new motion. Give the device's rate as fs_hz, or leave fs_hz out to "
                "use the time column's.")
        elif fs_hz * RATE_MISMATCH < measured:
            self._time_notes.append(
                f"{self.yaml_path}: fs_hz is {fs_hz:g} Hz but the time column '{self.spec.time_column}' steps "
                f"at {measured:.4g} Hz (median): the recordings are resampled {measured / fs_hz:.3g}x down by "
                "linear interpolation, without a low-pass filter (motion faster than fs_hz/2 aliases). "
                "Leave fs_hz out to keep the time column's rate.")

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
                data = self._to_convention(data, rows, path)
                recs.append(
                    Recording(f"{path.stem}/{subject}/{session}", subject, session, data, labels)
                )
        return recs

    def _to_convention(self, data: np.ndarray, rows: pd.DataFrame, path: Path) -> np.ndarray:
        """Apply each location's accelerometer sign, and mirror a recording worn on the other side."""
        data = np.array(data, dtype=np.float64)
        start = 0
        for i, loc in enumerate(self.spec.locations):
            acc = slice(start, start + 3)
            gyr = slice(start + 3, start + 6) if loc.gyr else None
            start += 6 if loc.gyr else 3
            data[:, acc] *= loc.acc_sign
            side = self._side(loc, i, rows, path)
            own, limb = placement_side(loc.name)
            if side is None or side == own:
                continue
            q = mirror_matrix(self._body_axes(loc, f"{side}_{limb}", i), self._body_axes(loc, loc.name, i))
            data[:, acc] = data[:, acc] @ q.T
            if gyr is not None:
                data[:, gyr] = -data[:, gyr] @ q.T
        return data

    def _side(self, loc: LocationSpec, index: int, rows: pd.DataFrame, path: Path) -> str | None:
        """The side one recording was worn on (None without a side column)."""
        if loc.side_column is None:
            return None
        values = sorted({str(v).strip().lower() for v in rows[loc.side_column]})
        if len(values) != 1 or values[0] not in SIDES:
            subject = rows[self.spec.subject_column].iloc[0]
            raise ValidationError(
                f"subject {subject}: side value(s) {', '.join(values)} in one recording; a recording is "
                "worn on one side (a session_column, or one file per side, separates recordings)",
                file=path, field=loc.side_column, allowed="one of " + ", ".join(SIDES) + " per recording")
        return values[0]
