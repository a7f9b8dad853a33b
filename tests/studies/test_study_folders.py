"""`vsmp-imu study NAME -o DIR` takes a new or empty folder, or one the same study wrote (with
study_run.json, or before it did: only the study's own names); a folder of a user's files or of
another study is refused with exit 2 before any work, its files untouched."""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import pytest
from study_support import AUDIT_DIR

from vsmp_imu.errors import ConfigError
from vsmp_imu.studies.folders import OWN, RUN_FILE, study_folder

AUDIT = ("study", "audit", "--pred", AUDIT_DIR / "pred", "--ref", AUDIT_DIR / "ref")
CASE = ("study", "case", "--activity", "jogging_in_place")
# the smallest arguments each study's tests use; every check before the work passes with them
ARGS = {"control": ("--seeds", "1", "--activities", "two_hand_push", "--controls", "duration"),
        "audit": AUDIT[2:], "case": CASE[2:],
        "ablation": ("--folds", "1", "--parts", "alpha", "--alphas", "0.5"),
        "granularity": ("--folds", "1", "--methods", "real"),
        "realism": ("--methods", "classical", "--epochs", "1")}
STUDIES = {"control": "ControlStudy", "ablation": "AblationStudy", "granularity": "GranularityStudy",
           "realism": "RealismStudy", "case": "CaseStudy", "audit": "ExtractionAudit"}


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("study", list(ARGS))
def test_a_folder_of_the_users_files_is_refused_before_any_work(monkeypatch, cli, tmp_path, study):
    def started(*_args, **_kwargs):
        raise AssertionError("the study started its work in a folder it does not own")

    for module, cls in STUDIES.items():
        monkeypatch.setattr(getattr(importlib.import_module(f"vsmp_imu.studies.{module}"), cls), "run", started)
    monkeypatch.setattr("vsmp_imu.studies.audit.load_audit_inputs", started)
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("my notes\n")
    (mine / "report.md").write_text("my report\n")  # a name every study writes
    code, _, err = cli("study", study, "-o", mine, *ARGS[study])
    assert code == 2 and "--output" in err and "notes.txt, report.md" in err, err
    assert f"earlier `vsmp-imu study {study}`" in err
    assert _files(mine) == {"notes.txt": b"my notes\n", "report.md": b"my report\n"}


def test_audit_takes_an_empty_folder_its_own_and_one_written_before_study_run_json(cli, tmp_path):
    out = tmp_path / "audit"
    out.mkdir()
    code, _, err = cli(*AUDIT, "-o", out)
    assert code == 0, err
    assert json.loads((out / RUN_FILE).read_text()) == {"command": "vsmp-imu study audit"}
    (out / "notes.txt").write_text("mine")  # beside study_run.json: the folder is still the study's
    (out / "results.json").write_text("{}")
    code, _, err = cli(*AUDIT, "-o", out)
    assert code == 0, err
    assert (out / "notes.txt").read_text() == "mine" and "failures" in json.loads((out / "results.json").read_text())
    (out / RUN_FILE).unlink()  # an audit folder of the code before study_run.json; the notes removed
    (out / "notes.txt").unlink()
    assert cli(*AUDIT, "-o", out)[0] == 0 and (out / RUN_FILE).exists()


def test_case_reruns_into_its_folder_and_refuses_another_studys(cli, tmp_path):
    out = tmp_path / "case"
    assert cli(*CASE, "-o", out)[0] == 0
    before = _files(out)
    code, _, err = cli(*CASE, "-o", out)
    assert code == 0, err
    assert set(_files(out)) == set(before)
    before = _files(out)
    code, _, err = cli(*AUDIT, "-o", out)
    assert code == 2 and "holds the output of `vsmp-imu study case`, not of `vsmp-imu study audit`" in err, err
    assert _files(out) == before


@pytest.mark.parametrize("study", list(OWN))
def test_a_folder_written_before_study_run_json_is_the_studys_alone(tmp_path, study):
    folder = study_folder(study)
    older = tmp_path / study
    older.mkdir()
    for name in OWN[study] + ("report.md", "results.json"):
        (older / name).write_text("")
    if study == "case":
        for name in ("variant_1.smp.json", "variant_1.npz", "variant_1_left_thigh.csv"):
            (older / name).write_text("")
    folder.check(older)
    for other in set(OWN) - {study}:
        with pytest.raises(ConfigError, match=f"earlier `vsmp-imu study {other}`"):
            study_folder(other).check(older)
    (older / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="notes.txt"):
        folder.check(older)
    (older / "notes.txt").unlink()
    for name in OWN[study]:  # report.md and results.json alone could be anyone's
        (older / name).unlink()
    with pytest.raises(ConfigError, match="report.md, results.json"):
        folder.check(older)


def test_the_names_are_those_the_report_modules_write():
    from vsmp_imu.studies import (
        ablation_report,
        case,
        control_report,
        granularity_report,
        realism_report,
    )

    assert control_report.FIGURE_NAME in OWN["control"] and ablation_report.FIGURE_NAME in OWN["ablation"]
    assert granularity_report.FIGURE_NAME in OWN["granularity"] and case.FIGURE_NAME in OWN["case"]
    assert {realism_report.PCA_FIGURE, realism_report.DISTANCE_FIGURE} <= set(OWN["realism"])
