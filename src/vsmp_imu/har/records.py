"""Committed evaluation records: the compact form of an `evaluate` run kept in `results/`.

A record set is a folder `results/NAME/` holding `run.json` (the command that
produced the records, the code commit, the evaluation's configuration and the
class names) and `records.jsonl` (one line per (budget, backbone, method,
fold, seed)). `import_run` writes one from an `evaluate` output folder;
`load_run` reads it back for `vsmp-imu report`. Both check each record on the way in:
its fields' types and ranges (`EvaluationRecord`) and its classes (`check_classes`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import pydantic
from pydantic import BaseModel, ConfigDict, Field

from vsmp_imu.errors import ConfigError, InputFileError, ValidationError
from vsmp_imu.har.windows import natural_key
from vsmp_imu.io import dumps_json, read_text, write_text
from vsmp_imu.validation import validation_error

RUN_KEYS = ("dataset", "protocol", "budget", "backbone", "method", "fold", "seed")
SPLIT_KEYS = (
    "confusion",
    "head_classes",
    "tail_classes",
    "n_train_real",
    "n_synthetic",
    "n_synthetic_requested",
    "n_val",
    "n_test",
)
# What a committed record keeps of an evaluation record (precision, recall and support
# follow from the confusion matrix; wall times are not results).
RECORD_KEYS = (
    *RUN_KEYS,
    "macro_f1",
    "accuracy",
    "group_macro_f1",
    "head_macro_f1",
    "tail_macro_f1",
    "per_class_f1",
    *SPLIT_KEYS,
    "synthetic_shares",  # the do-no-harm choice per class (None where not chosen)
    "epochs",
    "best_epoch",
)
# What a record of the unseen protocol keeps besides (absent from the other protocols' records).
UNSEEN_KEYS = (
    "unseen_classes",
    "unseen_capable",
    "n_synthetic_unseen",
    "unseen_macro_f1",
    "seen_macro_f1",
    "seen_as_unseen",
    "unseen_as_seen",
)
RUN_FILE = "run.json"
RECORDS_FILE = "records.jsonl"
NAME_PATTERN = re.compile(r"^[a-z0-9][a-z0-9_-]*$")

Score = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
Count = Annotated[int, Field(ge=0)]
SCORE = "a number from 0 to 1"
SCORE_OR_NULL = f"{SCORE}, or null"
SCORES = "an object {name: a number from 0 to 1 or null}"
COUNT_OR_NULL = "an integer >= 0, or null"
NAMES = "a list of class names, or null"


def _field(allowed: str, default: Any = ...) -> Any:
    return Field(default, description=allowed)


class Share(BaseModel):
    """The do-no-harm choice of one class, as far as the tables read it."""

    model_config = ConfigDict(strict=True, extra="ignore")
    share: Score
    offered: Count
    kept: Count
    n_val: Count
    judged: bool | None = None


class EvaluationRecord(BaseModel):
    """The types and ranges of an evaluation record's committed fields (JSON types, no
    conversion); a field's description is what it allows. Other fields are not checked."""

    model_config = ConfigDict(strict=True, extra="ignore")
    dataset: str = _field("a string")
    protocol: str = _field("a string")
    backbone: str = _field("a string")
    method: str = _field("a string")
    fold: str = _field("a string (the held-out subject)")
    seed: Count = _field("an integer >= 0")
    budget: Annotated[float, Field(gt=0, le=100)] | None = _field("a percentage in (0, 100], or null", None)
    macro_f1: Score = _field(SCORE)
    accuracy: Score | None = _field(SCORE_OR_NULL, None)
    group_macro_f1: dict[str, Score | None] | None = _field(SCORES, None)
    head_macro_f1: Score | None = _field(SCORE_OR_NULL, None)
    tail_macro_f1: Score | None = _field(SCORE_OR_NULL, None)
    per_class_f1: dict[str, Score | None] | None = _field(SCORES, None)
    confusion: list[list[Count]] | None = _field("rows of integers >= 0, one row and column per class", None)
    head_classes: list[str] | None = _field(NAMES, None)
    tail_classes: list[str] | None = _field(NAMES, None)
    n_train_real: Count | None = _field(COUNT_OR_NULL, None)
    n_synthetic: Count | None = _field(COUNT_OR_NULL, None)
    n_synthetic_requested: Count | None = _field(COUNT_OR_NULL, None)
    n_val: Count | None = _field(COUNT_OR_NULL, None)
    n_test: Count | None = _field(COUNT_OR_NULL, None)
    synthetic_shares: dict[str, Share] | None = _field(
        "an object of class: {share (0 to 1), offered, kept, n_val (integers >= 0)}, or null", None)
    epochs: Count | None = _field(COUNT_OR_NULL, None)
    best_epoch: Count | None = _field(COUNT_OR_NULL, None)
    unseen_classes: list[str] | None = _field(NAMES, None)
    unseen_capable: bool | None = _field("true, false or null", None)
    n_synthetic_unseen: Count | None = _field(COUNT_OR_NULL, None)
    unseen_macro_f1: Score | None = _field(SCORE_OR_NULL, None)
    seen_macro_f1: Score | None = _field(SCORE_OR_NULL, None)
    seen_as_unseen: Score | None = _field(SCORE_OR_NULL, None)
    unseen_as_seen: Score | None = _field(SCORE_OR_NULL, None)


@dataclass(frozen=True)
class Origin:
    """Where a record was read: its file and, in a file of several records, which one."""

    file: Path
    where: str = ""  # "record 3" (results.json), "line 3" (records.jsonl); "" for a file of one

    def __str__(self) -> str:
        return f"{self.file} {self.where}".strip()

    def error(self, message: str, field: str | None, allowed: str | None = None) -> ValidationError:
        text = f"{self.where}: {message}" if self.where else message
        return ValidationError(text, file=self.file, field=field, allowed=allowed)


def check_record(record: Any, origin: Origin) -> dict[str, Any]:
    """`record` itself where its committed fields have their types and ranges
    (`EvaluationRecord`); else a ValidationError naming its origin and the field."""
    if not isinstance(record, dict):
        raise origin.error(f"an evaluation record is an object, not {_json_kind(record)}", None)
    try:
        EvaluationRecord.model_validate(record)
    except pydantic.ValidationError as exc:
        found = validation_error(exc)
        top = re.split(r"[.\[]", found.field or "", maxsplit=1)[0]
        spec = EvaluationRecord.model_fields.get(top)
        raise origin.error(found.message, found.field, spec.description if spec else None) from exc
    return record


def _json_kind(value: Any) -> str:
    kinds = {dict: "an object", list: "a list", str: "a string", bool: "true or false", type(None): "null"}
    return kinds.get(type(value), "a number")


def check_classes(record: dict[str, Any], names: tuple[str, ...], origin: Origin, given: bool = False) -> None:
    """`record`'s confusion matrix is square with a row per class of `names` and its per-class
    F1 names those classes (where it has them); else a ValidationError, or where `names`
    came from --labels (`given`) a ConfigError about that option."""
    problem = _class_problem(record, names)
    if problem is None:
        return
    field, found, why = problem
    if given:
        raise ConfigError(f"{len(names)} classes given; {origin} has {found}", field="--labels")
    raise origin.error(f"{found}{why}", field)


def _class_problem(record: dict[str, Any], names: tuple[str, ...]) -> tuple[str, str, str] | None:
    """The field that does not fit the classes `names` (none known: a confusion matrix that is
    not square), what it holds and why that does not fit."""
    confusion, named = record.get("confusion"), record.get("per_class_f1")
    n = len(names)
    classes = f"the run's {n} classes ({', '.join(names)})"
    if confusion is not None:
        size = n or len(confusion)
        if len(confusion) != size or any(len(row) != size for row in confusion):
            why = f"; {classes} need {n}x{n}" if names else "; it must be square"
            return "confusion", f"a {_shape(confusion)} confusion matrix", why
    if names and named is not None and set(named) != set(names):
        return "per_class_f1", f"per-class F1 of {', '.join(sorted(named)) or 'no class'}", f", not of {classes}"
    return None


def _shape(confusion: list[list[int]]) -> str:
    widths = sorted({len(row) for row in confusion})
    if len(widths) > 1:
        return f"ragged ({len(confusion)} rows of {widths[0]} to {widths[-1]} counts)"
    return f"{len(confusion)}x{widths[0] if widths else 0}"


@dataclass(frozen=True)
class RecordSet:
    """One committed run: where it came from and its records."""

    name: str
    command: str
    code_commit: str | None
    note: str | None
    config: dict[str, Any]
    label_names: tuple[str, ...]
    records: tuple[dict[str, Any], ...]

    def select(self, **where: Any) -> list[dict[str, Any]]:
        """The records whose fields equal every given value."""
        return [r for r in self.records if all(r.get(k) == v for k, v in where.items())]


def check_name(name: str) -> str:
    if not NAME_PATTERN.match(name):
        raise ConfigError(
            f"record-set name '{name}' is not allowed",
            field="--name",
            allowed="lower-case letters, digits, '_' and '-', starting with a letter or digit",
        )
    return name


def _sort_key(r: dict[str, Any]) -> tuple:
    budget = -1.0 if r.get("budget") is None else r["budget"]
    return (r["dataset"], r["protocol"], budget, r["backbone"], r["method"],
            tuple(r.get("unseen_classes") or ()), natural_key(str(r["fold"])), r["seed"])


def compact(record: dict[str, Any]) -> dict[str, Any]:
    """The committed fields of one evaluation record (one `check_record` passed)."""
    keys = RECORD_KEYS + (UNSEEN_KEYS if record.get("unseen_classes") is not None else ())
    return {k: record.get(k) for k in keys}


def _read_json(path: Path) -> Any:
    try:
        return json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise InputFileError(f"not valid JSON: {exc}", file=path) from exc


def read_evaluation(run_dir: str | Path, every_record: bool = False
                    ) -> tuple[dict[str, Any], tuple[str, ...], list[tuple[dict, Origin]]]:
    """Configuration, class names and records of an `evaluate` output folder: its
    `results.json`, or (for a run still going) the class names of none and the files
    in `records/`. `results.json` holds the last invocation's records only; where
    `records/` holds more (several invocations into one folder, e.g. one per
    `--only-seeds`), `every_record` takes them all and otherwise it is a ConfigError.
    Each record comes with its origin, checked by `check_record`."""
    run_dir = Path(run_dir)
    results = run_dir / "results.json"
    folder = run_dir / "records"
    files = [(_read_json(f), Origin(f)) for f in sorted(folder.glob("*.json"))] if folder.is_dir() else []
    if results.exists():
        data = _read_json(results)
        if not isinstance(data, dict) or "records" not in data:
            raise InputFileError("not an evaluation result (no 'records')", file=results)
        records = _listed(data["records"], results)
        extra = _extra_records(records, files)
        if extra and not every_record:
            raise ConfigError(
                f"{results} holds {len(records)} records and {folder} {len(extra)} more (earlier "
                "runs into this folder, e.g. one per --only-seeds): --every-record imports them all",
                field="--every-record")
        config, names = data.get("config", {}), tuple(data.get("label_names", ()))
        return config, names, [(check_record(r, o), o) for r, o in records + extra]
    if not files:
        raise InputFileError(
            "no results.json and no records/*.json: not an `vsmp-imu evaluate` output folder",
            file=run_dir,
        )
    # one folder is one dataset: record files written before records said their order follow it too
    orders = {tuple(r["label_names"]) for r, _ in files if isinstance(r, dict) and r.get("label_names")}
    return {}, orders.pop() if len(orders) == 1 else (), [(check_record(r, o), o) for r, o in files]


def _listed(records: Any, results: Path) -> list[tuple[Any, Origin]]:
    """The records of results.json, numbered from 1; a ValidationError where `records` is
    not a non-empty list."""
    if not isinstance(records, list) or not records:
        got = "an empty list" if records == [] else _json_kind(records)
        raise ValidationError(f"is {got}", file=results, field="records", allowed="a list of evaluation records")
    return [(r, Origin(results, f"record {i}")) for i, r in enumerate(records, start=1)]


def _extra_records(records: list[tuple[Any, Origin]], files: list[tuple[Any, Origin]]
                   ) -> list[tuple[Any, Origin]]:
    """The record files whose run (`_run_key`) `records` lacks."""
    known = {_run_key(r) for r, _ in records if isinstance(r, dict)}
    return [(r, o) for r, o in files if isinstance(r, dict) and _run_key(r) not in known]


def _run_key(record: dict) -> tuple:
    """Which run a record is: RUN_KEYS and the unseen classes."""
    return (*(str(record.get(k)) for k in RUN_KEYS), tuple(record.get("unseen_classes") or ()))


def read_evaluations(run_dirs: Sequence[str | Path], every_record: bool = False
                     ) -> tuple[dict[str, Any], tuple[str, ...], list[tuple[dict, Origin]]]:
    """`read_evaluation` over several output folders of one experiment (e.g. one folder per
    `--only-seeds`): their records together, the class order they share, and their configuration
    with the seeds and folds of them all. A ConfigError where the folders differ in another setting
    or class order, or two of them hold the same run."""
    resolved = [Path(d).resolve() for d in run_dirs]
    twice = next((d for i, d in enumerate(resolved) if d in resolved[:i]), None)
    if twice is not None:
        raise ConfigError(f"{twice} is given twice", field="run_dir")
    reads = [(Path(d), *read_evaluation(d, every_record)) for d in run_dirs]
    orders = {found for _, _, found, _ in reads if found}
    if len(orders) > 1:
        raise ConfigError("the folders name different classes: " + "; ".join(
            f"{d}: {', '.join(found)}" for d, _, found, _ in reads if found), field="run_dir")
    seen: dict[tuple, Origin] = {}
    records = []
    for _, _, _, found in reads:
        for record, origin in found:
            key = _run_key(record)
            if key in seen:
                raise ConfigError(f"{origin} and {seen[key]} hold the same run", field="run_dir")
            seen[key] = origin
            records.append((record, origin))
    config = _merged_config([(d, c) for d, c, _, _ in reads if c])
    return config, orders.pop() if orders else (), records


def _merged_config(configs: list[tuple[Path, dict[str, Any]]]) -> dict[str, Any]:
    """One configuration for several folders: equal but for seeds and folds, which are joined."""
    if not configs:
        return {}
    first_dir, first = configs[0]
    joined = {k: v for k, v in first.items() if k not in ("seeds", "folds")}
    for run_dir, config in configs[1:]:
        other = {k: v for k, v in config.items() if k not in ("seeds", "folds")}
        for key in sorted(set(joined) | set(other)):
            if joined.get(key) != other.get(key):
                raise ConfigError(f"{first_dir} ran with {key} = {joined.get(key)!r}, {run_dir} with "
                                  f"{other.get(key)!r}: import them as separate record sets", field="run_dir")
    if any("seeds" in c for _, c in configs):
        joined["seeds"] = sorted({s for _, c in configs for s in c.get("seeds") or ()})
    if any("folds" in c for _, c in configs):
        folds = {str(f): f for _, c in configs for f in c.get("folds") or ()}
        joined["folds"] = [folds[k] for k in sorted(folds, key=natural_key)]
    return joined


def import_run(
    run_dir: str | Path | Sequence[str | Path],
    name: str,
    command: str,
    results_dir: str | Path,
    code_commit: str | None = None,
    note: str | None = None,
    labels: tuple[str, ...] = (),
    every_record: bool = False,
) -> Path:
    """Write `results_dir/NAME/` from an `evaluate` output folder, or from several of one
    experiment (`read_evaluations`); returns the folder.
    `labels`: the class order of the confusion matrices, for a folder that does not say it
    (the record files of an unfinished run written before records carried it);
    `every_record`: also the records of earlier invocations into the folder (read_evaluation)."""
    check_name(name)
    if not command.strip():
        raise ConfigError("the command that produced the records is required", field="--command")
    dirs = [run_dir] if isinstance(run_dir, (str, Path)) else list(run_dir)
    config, found, records = read_evaluations(dirs, every_record)
    label_names = _class_order(found, tuple(labels))
    for record, origin in records:
        check_classes(record, label_names, origin, given=not found)
    rows = sorted((compact(r) for r, _ in records), key=_sort_key)
    folder = Path(results_dir) / name
    meta = {"name": name, "command": command.strip(), "code_commit": code_commit,
            "config": config, "label_names": list(label_names), "n_records": len(rows),
            "note": note}
    lines = "".join(json.dumps(r, sort_keys=True, ensure_ascii=False) + "\n" for r in rows)
    write_text(folder / RECORDS_FILE, lines)
    write_text(folder / RUN_FILE, dumps_json(meta))
    return folder


def _class_order(found: tuple[str, ...], given: tuple[str, ...]) -> tuple[str, ...]:
    """The confusion matrices' class order: the run's own, else `given`; a ConfigError when
    neither says it or they differ."""
    if found and given and found != given:
        raise ConfigError(f"the run says its classes are {', '.join(found)}", field="--labels")
    if not (found or given):
        raise ConfigError("these record files do not say the order of their confusion matrices' classes; "
                          "give it (the dataset's class order, as `vsmp-imu dataset info` lists it)",
                          field="--labels")
    return found or given


def require_files(results_dir: str | Path, name: str, files: tuple[str, ...], how: str) -> list[Path]:
    """The paths of `files` in `results_dir/NAME/`; an `InputFileError` saying how to import the
    set (`vsmp-imu report import HOW`) where one is missing."""
    paths = [Path(results_dir) / name / f for f in files]
    for path in paths:
        if not path.is_file():
            raise InputFileError(
                f"record set '{name}' has no {path.name}; import its run with `vsmp-imu report import {how}`",
                file=path,
            )
    return paths


def load_run(results_dir: str | Path, name: str) -> RecordSet:
    """Read `results_dir/NAME/`; a missing or malformed file is an `InputFileError`, a record
    with a field of the wrong type or range or not fitting the classes a `ValidationError`."""
    meta_path, records_path = require_files(results_dir, name, (RUN_FILE, RECORDS_FILE),
                                            f"RUN_DIR --name {name} --command ...")
    meta = _read_json(meta_path)
    if not isinstance(meta, dict) or not isinstance(meta.get("command"), str):
        raise InputFileError("needs an object with a 'command' string", file=meta_path)
    label_names = tuple(meta.get("label_names") or ())
    records = _read_lines(records_path, label_names)
    return RecordSet(
        name=name,
        command=meta["command"],
        code_commit=meta.get("code_commit"),
        note=meta.get("note"),
        config=meta.get("config") or {},
        label_names=label_names,
        records=tuple(records),
    )


def _read_lines(path: Path, label_names: tuple[str, ...]) -> list[dict[str, Any]]:
    """The records of a records.jsonl, each checked (`check_record`, `check_classes`); an
    error naming the line of the first bad one, or where the file holds none."""
    records = []
    for i, line in enumerate(read_text(path).splitlines(), start=1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputFileError(f"line {i} is not valid JSON: {exc}", file=path) from exc
        origin = Origin(path, f"line {i}")
        records.append(check_record(data, origin))
        check_classes(data, label_names, origin)
    if not records:
        raise InputFileError("holds no record", file=path)
    return records
