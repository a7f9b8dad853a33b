"""Committed evaluation records: the compact form of an `evaluate` run kept in `results/`.

A record set is a folder `results/NAME/` holding `run.json` (the command that
produced the records, the code commit, the evaluation's configuration and the
class names) and `records.jsonl` (one line per (budget, backbone, method,
fold, seed)). `import_run` writes one from an `evaluate` output folder;
`load_run` reads it back for `vsmp-imu report`.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.windows import natural_key
from vsmp_imu.io import dumps_json, read_text, write_text

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
    """The committed fields of one evaluation record."""
    missing = [k for k in ("dataset", "protocol", "backbone", "method", "fold", "seed", "macro_f1")
               if k not in record]
    if missing:
        raise InputFileError(f"an evaluation record lacks {', '.join(missing)}")
    keys = RECORD_KEYS + (UNSEEN_KEYS if record.get("unseen_classes") is not None else ())
    return {k: record.get(k) for k in keys}


def _read_json(path: Path) -> Any:
    try:
        return json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise InputFileError(f"not valid JSON: {exc}", file=path) from exc


def read_evaluation(run_dir: str | Path, every_record: bool = False
                    ) -> tuple[dict[str, Any], tuple[str, ...], list[dict]]:
    """Configuration, class names and records of an `evaluate` output folder: its
    `results.json`, or (for a run still going) the class names of none and the files
    in `records/`. `results.json` holds the last invocation's records only; where
    `records/` holds more (several invocations into one folder, e.g. one per
    `--only-seeds`), `every_record` takes them all and otherwise it is a ConfigError."""
    run_dir = Path(run_dir)
    results = run_dir / "results.json"
    files = sorted((run_dir / "records").glob("*.json")) if (run_dir / "records").is_dir() else []
    if results.exists():
        data = _read_json(results)
        if not isinstance(data, dict) or "records" not in data:
            raise InputFileError("not an evaluation result (no 'records')", file=results)
        records = data["records"]
        extra = _extra_records(records, [_read_json(f) for f in files])
        if extra and not every_record:
            raise ConfigError(
                f"{results} holds {len(records)} records and {run_dir / 'records'} {len(extra)} more (earlier "
                "runs into this folder, e.g. one per --only-seeds): --every-record imports them all",
                field="--every-record")
        return data.get("config", {}), tuple(data.get("label_names", ())), records + extra
    if not files:
        raise InputFileError(
            "no results.json and no records/*.json: not an `vsmp-imu evaluate` output folder",
            file=run_dir,
        )
    records = [_read_json(f) for f in files]
    # one folder is one dataset: record files written before records said their order follow it too
    orders = {tuple(r["label_names"]) for r in records if isinstance(r, dict) and r.get("label_names")}
    return {}, orders.pop() if len(orders) == 1 else (), records


def _extra_records(records: list[dict], files: list[Any]) -> list[dict]:
    """The record files whose run (RUN_KEYS and the unseen classes) `records` lacks."""
    def key(r: dict) -> tuple:
        return (*(str(r.get(k)) for k in RUN_KEYS), tuple(r.get("unseen_classes") or ()))

    known = {key(r) for r in records if isinstance(r, dict)}
    return [r for r in files if isinstance(r, dict) and key(r) not in known]


def import_run(
    run_dir: str | Path,
    name: str,
    command: str,
    results_dir: str | Path,
    code_commit: str | None = None,
    note: str | None = None,
    labels: tuple[str, ...] = (),
    every_record: bool = False,
) -> Path:
    """Write `results_dir/NAME/` from an `evaluate` output folder; returns the folder.
    `labels`: the class order of the confusion matrices, for a folder that does not say it
    (the record files of an unfinished run written before records carried it);
    `every_record`: also the records of earlier invocations into the folder (read_evaluation)."""
    check_name(name)
    if not command.strip():
        raise ConfigError("the command that produced the records is required", field="--command")
    config, label_names, records = read_evaluation(run_dir, every_record)
    rows = sorted((compact(r) for r in records), key=_sort_key)
    label_names = _class_order(label_names, tuple(labels), rows)
    folder = Path(results_dir) / name
    meta = {"name": name, "command": command.strip(), "code_commit": code_commit,
            "config": config, "label_names": list(label_names), "n_records": len(rows),
            "note": note}
    lines = "".join(json.dumps(r, sort_keys=True, ensure_ascii=False) + "\n" for r in rows)
    write_text(folder / RECORDS_FILE, lines)
    write_text(folder / RUN_FILE, dumps_json(meta))
    return folder


def _class_order(found: tuple[str, ...], given: tuple[str, ...], rows: list[dict]) -> tuple[str, ...]:
    """The confusion matrices' class order: the run's own, else `given` (which must name the
    records' classes, as many as the matrices have); a ConfigError when neither says it."""
    if found and given and found != given:
        raise ConfigError(f"the run says its classes are {', '.join(found)}", field="--labels")
    order = found or given
    if not rows:
        return order
    if not order:
        raise ConfigError("these record files do not say the order of their confusion matrices' classes; "
                          "give it (the dataset's class order, as `vsmp-imu dataset info` lists it)",
                          field="--labels")
    for row in rows:
        named = set(row.get("per_class_f1") or order)
        size = len(row.get("confusion") or order)
        if named != set(order) or size != len(order):
            raise ConfigError(f"{len(order)} classes given; the records have {size} "
                              f"({', '.join(sorted(named))})", field="--labels")
    return order


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
    """Read `results_dir/NAME/`; a missing or malformed file is an `InputFileError`."""
    meta_path, records_path = require_files(results_dir, name, (RUN_FILE, RECORDS_FILE),
                                            f"RUN_DIR --name {name} --command ...")
    meta = _read_json(meta_path)
    if not isinstance(meta, dict) or not isinstance(meta.get("command"), str):
        raise InputFileError("needs an object with a 'command' string", file=meta_path)
    records = []
    for i, line in enumerate(read_text(records_path).splitlines(), start=1):
        if not line.strip():
            continue
        try:
            record = json.loads(line)
        except json.JSONDecodeError as exc:
            raise InputFileError(f"line {i} is not valid JSON: {exc}", file=records_path) from exc
        if not isinstance(record, dict) or "macro_f1" not in record:
            raise InputFileError(f"line {i} is not an evaluation record", file=records_path)
        records.append(record)
    return RecordSet(
        name=name,
        command=meta["command"],
        code_commit=meta.get("code_commit"),
        note=meta.get("note"),
        config=meta.get("config") or {},
        label_names=tuple(meta.get("label_names") or ()),
        records=tuple(records),
    )
