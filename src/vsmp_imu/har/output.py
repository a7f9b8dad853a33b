"""The output folder of `vsmp-imu evaluate`: taken before any work, bound to one run's settings.

`check_folder` (before the dataset loads) takes a new or empty folder, or one an earlier
`evaluate` wrote: it holds RUN_FILE, or (a folder written before RUN_FILE was) only the files
`evaluate` writes, records/ among them. Anything else is refused, so a run never overwrites
a user's files (`vsmp_imu.output_folder`, shared with the demo and the studies).

`claim` (after the dataset loads, before any record) writes RUN_FILE: what every record's
numbers depend on, the settings (`Evaluation.run_settings`, the protocol, the do-no-harm and
synthetic-weight choices, each chosen backbone's and method's parameters) and a fingerprint
of the dataset's declaration and recordings. A rerun into a folder with records resumes it
(or extends it with more methods, backbones, folds or seeds) only with the same settings and
data; other ones are refused, naming what differs, where they would replace its records.
"""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.io import write_json
from vsmp_imu.output_folder import OutputFolder, read_json_object

RUN_FILE = "evaluate.json"
OWN_NAMES = ("results.json", "results.md", "records", ".folds", RUN_FILE)
OWN_PATTERN = re.compile(r"confusion_.+\.png")  # har/report.py's confusion matrices
# RUN_FILE's settings as the command line names them (the others by their own name)
OPTIONS = {"protocol": "--protocol", "window_s": "--window-s", "overlap": "--overlap", "alpha": "--alpha",
           "policy": "--policy", "rho": "--rho", "share_selection": "--share-selection",
           "synthetic_weight": "--synthetic-weight", "dataset": "--dataset"}
# A folder an evaluate wrote before RUN_FILE was: its records/ (or its folds' .folds/) and its
# own files alone
FOLDER = OutputFolder("vsmp-imu evaluate", RUN_FILE, names=frozenset(OWN_NAMES),
                      markers=frozenset({"records", ".folds"}), patterns=(OWN_PATTERN,),
                      earlier=lambda folder: read_run_file(folder) is not None,
                      allowed="a new or empty folder, or the folder of an earlier `vsmp-imu evaluate` (to "
                              "resume or extend it); give another -o, or remove the folder")
REFUSED = ("a new --output folder, or remove this one first; the same settings and data resume or extend "
           "its run")


def check_folder(folder: Path) -> None:
    """`folder` is new, empty or an earlier evaluate's; else a ConfigError naming what it holds."""
    FOLDER.check(folder)


def read_run_file(folder: Path) -> dict[str, Any] | None:
    """The RUN_FILE of `folder`, or None when absent or not one `evaluate` wrote."""
    data = read_json_object(folder / RUN_FILE)
    if data is None or data.get("command") != "vsmp-imu evaluate":
        return None
    return data if all(isinstance(data.get(k), dict) for k in ("settings", "backbones", "methods", "data")) else None


def claim(evaluation) -> None:
    """Bind the evaluation's output folder to its settings and data (RUN_FILE), or refuse
    (ConfigError) where the folder's records were made with other ones."""
    folder = evaluation.output_dir
    now = run_file(evaluation)
    before = read_run_file(folder)
    if before is not None and _has_records(folder):
        differ = differences(before, now)
        if differ:
            raise ConfigError(f"holds records made with other settings or data: {'; '.join(differ)}",
                              file=folder, field="--output", allowed=REFUSED)
        now = {**now, "backbones": {**before["backbones"], **now["backbones"]},
               "methods": {**before["methods"], **now["methods"]}}
    write_json(folder / RUN_FILE, now)


def _has_records(folder: Path) -> bool:
    """Records in the folder, or in a fold's folder of `--processes` not yet merged into it."""
    return any(folder.glob("records/*.json")) or any(folder.glob(".folds/*/records/*.json"))


def run_file(evaluation) -> dict[str, Any]:
    """RUN_FILE's content for `evaluation` (JSON values, as read back)."""
    c = evaluation.config
    settings = {k: v for k, v in evaluation.run_settings().items() if k not in ("harness_version", "info")}
    settings |= {"protocol": c.protocol, "share_selection": c.share_selection,
                 "synthetic_weight": c.synthetic_weight}
    content = {
        "command": "vsmp-imu evaluate",
        "settings": settings,
        "backbones": {b: evaluation.backbone_settings(b) for b in c.backbones},
        "methods": {m: _without(evaluation.method_settings(m), REMADE) for m in c.methods},
        "data": {"declaration": _sha(json.dumps(evaluation.dataset.info.to_dict(), sort_keys=True, default=str)),
                 "recordings": data_fingerprint(evaluation.dataset)},
    }
    return json.loads(json.dumps(content, sort_keys=True, default=str))


# A method's settings whose change remakes the records it touches (a record's digest holds the
# activity library it read: editing or adding activity files, `--library DIR`, remakes the
# records of the classes they change), so a rerun with them changed resumes the folder.
REMADE = ("library_dirs",)


def _without(settings: dict[str, Any], keys: tuple[str, ...]) -> dict[str, Any]:
    return {k: v for k, v in settings.items() if k not in keys}


def data_fingerprint(dataset) -> str:
    """sha256 of the recordings an evaluation sees: ids, subjects, sessions, samples and labels."""
    digest = hashlib.sha256()
    for rec in dataset.recordings():
        digest.update(json.dumps([rec.recording_id, rec.subject, rec.session, list(rec.data.shape)]).encode())
        digest.update(rec.data.tobytes())
        digest.update(rec.labels.tobytes())
    return digest.hexdigest()


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def differences(before: dict[str, Any], now: dict[str, Any]) -> list[str]:
    """What differs between two RUN_FILEs, one phrase each: the settings, the parameters of a
    backbone or method both name, the data."""
    said = [f"{OPTIONS.get(k, k)} {_value(before['settings'].get(k))} (now {_value(v)})"
            for k, v in now["settings"].items() if before["settings"].get(k) != v]
    for kind in ("backbones", "methods"):
        for name in sorted(set(before[kind]) & set(now[kind])):
            old, new = before[kind][name], now[kind][name]
            said += [f"{name}'s {p} {_value(old.get(p))} (now {_value(new.get(p))})"
                     for p in sorted(set(old) | set(new)) if old.get(p) != new.get(p)]
    for part, what in (("declaration", "the dataset's declaration (its .yaml or loader)"),
                       ("recordings", "the dataset's recordings (its data files)")):
        if before["data"].get(part) != now["data"][part]:
            said.append(f"{what} changed")
    return said


def _value(value: Any) -> str:
    text = value if isinstance(value, str) else f"{value:g}" if isinstance(value, float) else json.dumps(value)
    return text if len(text) <= 60 else text[:57] + "..."
