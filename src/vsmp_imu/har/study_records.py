"""Committed study records: the compact results of a `vsmp-imu study` run kept in `results/`.

A study record set is a folder `results/NAME/` holding `run.json` (`kind:
study`, which study, the command that produced it, the code commit and the
study's settings) and `study.json` (the study's `results.json` less the
per-sample rows no table reads: the controllability cases, the matched 2x2's
prompts). `import_study` writes one from a study output folder; `load_study`
reads it back; `StudyTable` renders one of its tables with the study's own
report builder (`studies/*_report.py`), so a table in the docs and the
study's report.md print the same figures the same way.
"""

from __future__ import annotations

import dataclasses
import json
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.records import RUN_FILE, check_name, require_files
from vsmp_imu.io import dumps_json, read_text, write_text

STUDY_FILE = "study.json"
COMMAND = re.compile(r"^vsmp-imu\s+study\s+(?P<study>[a-z]+)(\s|$)")
# keys a study's results.json must have to be read as that study's output
REQUIRED = {
    "control": ("settings", "summary", "retention"),
    "ablation": ("settings", "parts"),
    "granularity": ("settings", "taxonomy", "groups", "overall"),
    "realism": ("settings", "label_names", "channel_names", "encoder", "methods"),
}
STUDIES = tuple(REQUIRED)


def _drop_cases(results: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in results.items() if k != "cases"}  # one row per motion (cases.csv)


def _drop_prompts(results: dict[str, Any]) -> dict[str, Any]:
    parts = dict(results["parts"])
    if "caption" in parts:  # every prompt of the first fold (runs/caption/matched/ keeps them all)
        parts["caption"] = {k: v for k, v in parts["caption"].items() if k != "prompts"}
    return {**results, "parts": parts}


COMPACT: dict[str, Callable[[dict[str, Any]], dict[str, Any]]] = {
    "control": _drop_cases,
    "ablation": _drop_prompts,
}


@dataclass(frozen=True)
class StudyRecord:
    """One committed study run: where it came from and its results."""

    name: str
    study: str
    command: str
    code_commit: str | None
    note: str | None
    results: dict[str, Any]


def study_of(command: str) -> str | None:
    """The study a command runs (`vsmp-imu study NAME ...`), or None for another command."""
    match = COMMAND.match(command.strip())
    return match["study"] if match else None


def _read_json(path: Path) -> Any:
    try:
        return json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise InputFileError(f"not valid JSON: {exc}", file=path) from exc


def read_study(run_dir: str | Path, study: str) -> dict[str, Any]:
    """The `results.json` of a study output folder, checked to be that study's."""
    if study not in REQUIRED:
        raise ConfigError(f"'vsmp-imu study {study}' writes no tabled results", field="--command",
                          allowed=", ".join(f"vsmp-imu study {s} ..." for s in STUDIES))
    path = Path(run_dir) / "results.json"
    if not path.is_file():
        raise InputFileError(f"no results.json: not a `vsmp-imu study {study}` output folder", file=run_dir)
    data = _read_json(path)
    missing = [k for k in REQUIRED[study] if not isinstance(data, dict) or k not in data]
    if missing:
        raise InputFileError(f"not a `vsmp-imu study {study}` result (no {', '.join(missing)})", file=path)
    return data


def import_study(
    run_dir: str | Path,
    name: str,
    command: str,
    results_dir: str | Path,
    code_commit: str | None = None,
    note: str | None = None,
) -> Path:
    """Write `results_dir/NAME/` (run.json + study.json) from a study output folder."""
    check_name(name)
    study = study_of(command)
    if study is None:
        raise ConfigError(f"'{command}' is not a study command", field="--command",
                          allowed="the `vsmp-imu study NAME ...` command that wrote the folder")
    results = read_study(run_dir, study)
    results = COMPACT.get(study, dict)(results)
    folder = Path(results_dir) / name
    meta = {"name": name, "kind": "study", "study": study, "command": command.strip(),
            "code_commit": code_commit, "config": results["settings"], "note": note}
    write_text(folder / STUDY_FILE, dumps_json(results))
    write_text(folder / RUN_FILE, dumps_json(meta))
    return folder


def is_study_set(results_dir: str | Path, name: str) -> bool:
    return (Path(results_dir) / name / STUDY_FILE).is_file()


def load_study(results_dir: str | Path, name: str) -> StudyRecord:
    """Read `results_dir/NAME/` of a study; a missing or malformed file is an `InputFileError`."""
    meta_path, study_path = require_files(results_dir, name, (RUN_FILE, STUDY_FILE),
                                          f"OUT_DIR --name {name} --command 'vsmp-imu study ...'")
    meta = _read_json(meta_path)
    if not isinstance(meta, dict) or meta.get("study") not in REQUIRED or not isinstance(meta.get("command"), str):
        raise InputFileError(f"needs an object with 'command' and 'study' (one of {', '.join(STUDIES)})",
                             file=meta_path)
    results = _read_json(study_path)
    missing = [k for k in REQUIRED[meta["study"]] if not isinstance(results, dict) or k not in results]
    if missing:
        raise InputFileError(f"not a {meta['study']} study record (no {', '.join(missing)})", file=study_path)
    return StudyRecord(name=name, study=meta["study"], command=meta["command"],
                       code_commit=meta.get("code_commit"), note=meta.get("note"), results=results)


# -- tables -------------------------------------------------------------------------------
def _fields(cls: type, results: dict[str, Any]) -> Any:
    return cls(**{f.name: results[f.name] for f in dataclasses.fields(cls) if f.name in results})


def _control_summary(results: dict[str, Any]) -> str:
    from vsmp_imu.studies.control_report import summary_table

    return summary_table(results["summary"], results["retention"])


def _control_checkpoints(results: dict[str, Any]) -> str:
    from vsmp_imu.studies.control_report import checkpoint_table

    return checkpoint_table(results["summary"])


def _control_activities(attribute: str) -> Callable[[dict[str, Any]], str]:
    def render(results: dict[str, Any]) -> str:
        from vsmp_imu.studies.control_report import activity_table

        if attribute not in results["summary"]:
            raise ConfigError(f"the controllability run has no '{attribute}' control",
                              allowed=", ".join(results["summary"]))
        return activity_table(results["summary"], attribute)

    return render


def _ablation_part(part: str) -> Callable[[dict[str, Any]], str]:
    def render(results: dict[str, Any]) -> str:
        from vsmp_imu.studies.ablation import COMPONENT_TITLES, GROUNDING_TITLES
        from vsmp_imu.studies.ablation_report import (
            acceptance_table,
            alpha_table,
            caption_table,
            effects_text,
            paired_table,
            variant_table,
        )

        name = part.split(":")[0]
        data = results["parts"].get(name)
        if data is None:
            raise ConfigError(f"the ablation run has no '{name}' part",
                              allowed=", ".join(results["parts"]) or "none")
        if part == "caption":
            return caption_table(data)
        if part == "caption:paired":
            return "\n\n".join(x for x in (effects_text(data), paired_table(data)) if x)
        if part == "caption:acceptance":
            return acceptance_table(data["accounting_pooled"])
        if part == "alpha":
            return alpha_table(data)
        return variant_table(data, COMPONENT_TITLES if part == "components" else GROUNDING_TITLES)

    return render


def _granularity(table: str) -> Callable[[dict[str, Any]], str]:
    def render(results: dict[str, Any]) -> str:
        from vsmp_imu.studies import granularity_report
        from vsmp_imu.studies.granularity import GranularityResults

        return getattr(granularity_report, table)(_fields(GranularityResults, results))

    return render


def _realism(table: str) -> Callable[[dict[str, Any]], str]:
    def render(results: dict[str, Any]) -> str:
        from vsmp_imu.studies import realism_report
        from vsmp_imu.studies.realism import RealismResults

        return getattr(realism_report, table)(_fields(RealismResults, results))

    return render


# view name -> (study, the report builder's table)
VIEWS: dict[str, tuple[str, Callable[[dict[str, Any]], str]]] = {
    "control:summary": ("control", _control_summary),
    "control:checkpoints": ("control", _control_checkpoints),
    "control:repetitions": ("control", _control_activities("repetitions")),
    "control:duration": ("control", _control_activities("duration")),
    "control:symmetry": ("control", _control_activities("symmetry")),
    "ablation:caption": ("ablation", _ablation_part("caption")),
    "ablation:paired": ("ablation", _ablation_part("caption:paired")),
    "ablation:acceptance": ("ablation", _ablation_part("caption:acceptance")),
    "ablation:components": ("ablation", _ablation_part("components")),
    "ablation:grounding": ("ablation", _ablation_part("grounding")),
    "ablation:alpha": ("ablation", _ablation_part("alpha")),
    "granularity:groups": ("granularity", _granularity("group_table")),
    "granularity:classes": ("granularity", _granularity("class_table")),
    "realism:distances": ("realism", _realism("distance_table")),
    "realism:classes": ("realism", _realism("class_distance_table")),
    "realism:c2st": ("realism", _realism("c2st_table")),
    "realism:c2st_features": ("realism", _realism("c2st_features_table")),
}


class StudyTable:
    """Render one study view (`VIEWS`) of a committed study record, with its source line."""

    def __init__(self, table_id: str, view: str, record: StudyRecord) -> None:
        self.table_id = table_id
        self.view = view
        self.record = record

    def render(self) -> str:
        study, build = VIEWS[self.view]
        if study != self.record.study:
            raise ConfigError(
                f"table '{self.table_id}': view '{self.view}' needs a record of the {study} study, "
                f"'{self.record.name}' holds one of the {self.record.study} study",
                field="view", allowed=", ".join(v for v, (s, _) in VIEWS.items() if s == self.record.study))
        source = f"Records: `results/{self.record.name}/` (study {study}), from `{self.record.command}`"
        if self.record.code_commit:
            source += f" at commit {self.record.code_commit[:7]}"
        return f"{build(self.record.results)}\n\n{source}; rebuilt by `vsmp-imu report --write`.\n"
