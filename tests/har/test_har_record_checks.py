"""Records are checked where they enter: `report import` (results.json, records/*.json) and the
committed `results/NAME/records.jsonl` that `vsmp-imu report` reads. The fixtures are a real
committed record (results/lr_rf, HAPT12's 12 classes) with one field changed."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.records import import_run, load_run

REPO_ROOT = Path(__file__).resolve().parents[2]
SOURCE = REPO_ROOT / "results" / "lr_rf"


def _real() -> tuple[list[str], list[dict]]:
    """The class names of results/lr_rf and its first two records (two seeds of one run)."""
    names = json.loads((SOURCE / "run.json").read_text())["label_names"]
    lines = (SOURCE / "records.jsonl").read_text().splitlines()[:2]
    return names, [json.loads(line) for line in lines]


def _results_json(tmp_path: Path, records, label_names=None) -> Path:
    """An `evaluate` output folder whose results.json holds `records`; returns the folder."""
    names, _ = _real()
    run = tmp_path / "run"
    run.mkdir(parents=True)
    data = {"config": {}, "label_names": names if label_names is None else label_names, "records": records}
    (run / "results.json").write_text(json.dumps(data))
    return run


class _Delete:
    """The marker for a field to delete (a stable repr: xdist's workers collect the same ids)."""

    def __repr__(self) -> str:
        return "deleted"


DELETE = _Delete()


def _changed(path: str, value) -> list[dict]:
    """The two real records, the second with the field at `path` ('a.b', 'a[0][1]') set to
    `value` (deleted where `value` is `DELETE`)."""
    records = _real()[1]
    *parents, last = path.replace("[", ".").replace("]", "").split(".")
    target = records[1]
    for key in parents:
        target = target[int(key)] if isinstance(target, list) else target[key]
    key = int(last) if isinstance(target, list) else last
    if value is DELETE:
        del target[key]
    else:
        target[key] = value
    return records


BAD = [
    ("macro_f1", "0.5", "valid number"),
    ("macro_f1", float("nan"), "finite number"),
    ("macro_f1", 1.5, "less than or equal to 1"),
    ("macro_f1", True, "valid number"),
    ("macro_f1", DELETE, "required"),
    ("accuracy", -0.1, "greater than or equal to 0"),
    ("per_class_f1.LAYING", float("inf"), "finite number"),
    ("per_class_f1.LAYING", "0.9", "valid number"),
    ("group_macro_f1.transitions", 2.0, "less than or equal to 1"),
    ("tail_macro_f1", "n/a", "valid number"),
    ("confusion[0][0]", -1, "greater than or equal to 0"),
    ("confusion[2][1]", 1.5, "valid integer"),
    ("seed", "0", "valid integer"),
    ("fold", 1, "valid string"),
    ("n_test", -5, "greater than or equal to 0"),
    ("budget", 0, "greater than 0"),
]


@pytest.mark.parametrize(("field", "value", "says"), BAD, ids=[f"{f}={v!r}" for f, v, _ in BAD])
def test_import_refuses_a_record_field_of_the_wrong_type_or_range(tmp_path, field, value, says):
    run = _results_json(tmp_path, _changed(field, value))
    with pytest.raises(ValidationError, match=says) as info:
        import_run(run, "x", "vsmp-imu evaluate x", tmp_path / "res")
    assert info.value.file == str(run / "results.json")
    assert info.value.field == field
    assert "record 2:" in info.value.message
    assert not (tmp_path / "res" / "x").exists()


def test_import_takes_a_null_score_for_a_class_absent_from_the_fold(tmp_path):
    """`evaluate_predictions` gives None to a class neither in the truth nor predicted."""
    records = _changed("per_class_f1.LIE_TO_STAND", None)
    records[1]["group_macro_f1"]["transitions"] = None
    folder = import_run(_results_json(tmp_path, records), "x", "vsmp-imu evaluate x", tmp_path / "res")
    loaded = load_run(folder.parent, "x").records
    assert [r["per_class_f1"]["LIE_TO_STAND"] for r in loaded] == [0.0, None]
    records[0]["per_class_f1"]["LIE_TO_STAND"] = float("nan")
    with pytest.raises(ValidationError, match="record 1: Input should be a finite number"):
        import_run(_results_json(tmp_path / "nan", records), "y", "vsmp-imu evaluate x", tmp_path / "res")


@pytest.mark.parametrize(("records", "says"), [
    ({"a": 1}, "is an object"),
    ([], "is an empty list"),
    ("records", "is a string"),
])
def test_import_needs_records_to_be_a_non_empty_list(tmp_path, records, says):
    run = _results_json(tmp_path, records)
    with pytest.raises(ValidationError, match=says) as info:
        import_run(run, "x", "vsmp-imu evaluate x", tmp_path / "res")
    assert (info.value.file, info.value.field) == (str(run / "results.json"), "records")


def test_import_refuses_a_record_that_is_not_an_object(tmp_path):
    run = _results_json(tmp_path, [_real()[1][0], [1, 2]])
    with pytest.raises(ValidationError, match="record 2: an evaluation record is an object, not a list"):
        import_run(run, "x", "vsmp-imu evaluate x", tmp_path / "res")


def test_a_confusion_matrix_that_does_not_fit_the_classes_names_the_record_not_labels(tmp_path, cli):
    run = _results_json(tmp_path, _changed("confusion", [[1]]))
    code, _, err = cli("report", "import", run, "--name", "x", "--command", "vsmp-imu evaluate x",
                       "--root", tmp_path)
    assert code == 2
    assert err.startswith(f"{run / 'results.json'}: field 'confusion': record 2: a 1x1 confusion matrix; "
                          "the run's 12 classes (")
    assert "--labels" not in err
    records = _changed("confusion[3]", [0, 1])
    with pytest.raises(ValidationError, match=r"ragged \(12 rows of 2 to 12 counts\)"):
        import_run(_results_json(tmp_path / "ragged", records), "x", "cmd", tmp_path / "res")
    records = _changed("per_class_f1", {"LAYING": 0.5})
    with pytest.raises(ValidationError, match="record 2: per-class F1 of LAYING, not of the run's 12") as info:
        import_run(_results_json(tmp_path / "named", records), "x", "cmd", tmp_path / "res")
    assert info.value.field == "per_class_f1"


def test_labels_that_do_not_fit_a_record_file_name_the_option_and_the_file(tmp_path):
    names, records = _real()
    run = tmp_path / "run"
    (run / "records").mkdir(parents=True)
    (run / "records" / "a.json").write_text(json.dumps(records[0]))
    with pytest.raises(ConfigError, match=r"11 classes given; .*a\.json has a 12x12 confusion matrix") as info:
        import_run(run, "x", "cmd", tmp_path / "res", labels=tuple(names[:11]))
    assert info.value.field == "--labels"
    (run / "records" / "a.json").write_text(json.dumps({**records[0], "seed": -1}))
    with pytest.raises(ValidationError, match="greater than or equal to 0") as info:
        import_run(run, "x", "cmd", tmp_path / "res", labels=tuple(names))
    assert info.value.file == str(run / "records" / "a.json") and info.value.field == "seed"


def _committed(root: Path, lines: list[str]) -> Path:
    """results/lr_rf/ under `root` with its run.json and `lines` as records.jsonl."""
    folder = root / "results" / "lr_rf"
    folder.mkdir(parents=True)
    shutil.copy(SOURCE / "run.json", folder / "run.json")
    (folder / "records.jsonl").write_text("".join(line + "\n" for line in lines))
    return folder / "records.jsonl"


@pytest.mark.parametrize(("field", "value", "says"), [
    ("macro_f1", "0.5", "valid number"),
    ("macro_f1", float("nan"), "finite number"),
    ("per_class_f1.WALKING", -1.0, "greater than or equal to 0"),
    ("confusion", [[1, 0], [0, 1]], "a 2x2 confusion matrix; the run's 12 classes"),
])
def test_a_hand_edited_committed_record_is_an_error_naming_its_line(tmp_path, field, value, says):
    path = _committed(tmp_path, [json.dumps(r) for r in _changed(field, value)])
    with pytest.raises(ValidationError, match=says) as info:
        load_run(tmp_path / "results", "lr_rf")
    assert info.value.file == str(path)
    assert info.value.field == field
    assert info.value.message.startswith("line 2: ")


def test_report_check_refuses_a_bad_committed_record_with_exit_2(report_repo, cli):
    catalogue = ("tables:\n  - id: lr_rf:main\n    records: lr_rf\n    kind: groups\n    budgets: [1]\n"
                 "    methods: [classical]\n    metrics:\n      - {label: all, metric: macro_f1}\n")
    root = report_repo(catalogue, {"README.md": "<!-- report:lr_rf:main -->\n<!-- /report -->\n"})
    path = _committed(root, [json.dumps(r) for r in _changed("macro_f1", "0.5")])
    code, _, err = cli("report", "--root", root, "--check")
    assert code == 2
    assert err == (f"{path}: field 'macro_f1': line 2: Input should be a valid number (got '0.5'). "
                   "Allowed: a number from 0 to 1.")
    path.write_text("\n")
    code, _, err = cli("report", "--root", root, "--check")
    assert code == 2 and err == f"{path}: holds no record."


def test_import_refuses_a_root_under_which_nothing_can_be_written_before_reading_the_run(tmp_path, cli):
    """--root a file: once a NotADirectoryError at the copy, naming no option."""
    (tmp_path / "README.md").write_text("mine")
    code, _, err = cli("report", "import", tmp_path / "no_run", "--name", "x", "--command", "vsmp-imu evaluate x",
                       "--root", tmp_path / "README.md")
    assert code == 2 and f"field '--root': '{tmp_path / 'README.md'}' is a file, so nothing can be written" in err
    assert (tmp_path / "README.md").read_text() == "mine"
