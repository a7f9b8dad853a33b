"""Study records: a `vsmp-imu study` output folder imported into results/NAME/ and its tables rebuilt
by `vsmp-imu report` with the study's own report builders."""

from __future__ import annotations

import json

import pytest
from study_support import SMOKE_ACTIVITIES, invoke, rebuild_study_tables

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.published import Publication
from vsmp_imu.har.study_records import StudyTable, import_study, load_study, study_of

COMMAND = f"vsmp-imu study control -o out --seeds 1 --activities {','.join(SMOKE_ACTIVITIES)}"
VIEWS = {"control:main": "control:summary", "control:checkpoints": "control:checkpoints",
         "control:duration": "control:duration", "control:repetitions": "control:repetitions"}


@pytest.fixture(scope="module")
def control_out(tmp_path_factory):
    out = tmp_path_factory.mktemp("control")
    code, _, err = invoke(*COMMAND.replace("-o out", f"-o {out}").split()[1:])
    assert code == 0, err
    return out


def _table_after(report: str, heading: str) -> str:
    """The first markdown table under a heading of report.md."""
    lines = report[report.index(heading):].splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    return "\n".join(lines[start:end])


def test_control_tables_rebuild_as_the_study_report_prints_them(control_out, tmp_path):
    blocks = rebuild_study_tables(control_out, COMMAND, VIEWS, tmp_path)
    report = (control_out / "report.md").read_text()
    assert blocks["control:main"].startswith(_table_after(report, "## Summary") + "\n\n")
    assert blocks["control:checkpoints"].startswith(_table_after(report, "## Every checkpoint") + "\n\n")
    assert blocks["control:duration"].startswith(_table_after(report, "### Primitive duration") + "\n\n")
    assert blocks["control:repetitions"].startswith(_table_after(report, "### Repetition count") + "\n\n")
    assert f"from `{COMMAND}` at commit 0000000" in blocks["control:main"]


def test_the_record_is_compact_and_keeps_its_provenance(control_out, tmp_path):
    folder = import_study(control_out, "ctl", COMMAND, tmp_path, "abc", "note")
    meta = json.loads((folder / "run.json").read_text())
    assert (meta["kind"], meta["study"], meta["command"], meta["code_commit"], meta["note"]) == \
        ("study", "control", COMMAND, "abc", "note")
    assert meta["config"]["activities"] == list(SMOKE_ACTIVITIES)
    full = json.loads((control_out / "results.json").read_text())
    kept = json.loads((folder / "study.json").read_text())
    assert "cases" in full and "cases" not in kept
    assert kept["summary"] == full["summary"] and kept["retention"] == full["retention"]
    assert load_study(tmp_path, "ctl").results == kept


def test_a_changed_figure_fails_the_check(control_out, tmp_path):
    rebuild_study_tables(control_out, COMMAND, {"control:main": "control:summary"}, tmp_path)
    readme = tmp_path / "README.md"
    readme.write_text(readme.read_text().replace("| Tempo |", "| Tempo (typed) |"))
    code, stdout, _ = invoke("report", "--root", tmp_path, "--check")
    assert code == 1 and "Tempo (typed)" in stdout


def test_the_command_tells_the_study():
    assert study_of("vsmp-imu study control -o x") == "control"
    assert study_of("  vsmp-imu  study realism") == "realism"
    assert study_of("vsmp-imu evaluate --dataset hapt12") is None


def test_wrong_folders_commands_and_views_are_refused(control_out, tmp_path):
    with pytest.raises(InputFileError, match="not a `vsmp-imu study ablation` result"):
        import_study(control_out, "x", "vsmp-imu study ablation -o out", tmp_path)
    with pytest.raises(InputFileError, match="no results.json"):
        import_study(tmp_path, "x", "vsmp-imu study control -o out", tmp_path)
    with pytest.raises(ConfigError, match="writes no tabled results"):
        import_study(control_out, "x", "vsmp-imu study case -o out", tmp_path)
    with pytest.raises(ConfigError, match="not a study command"):
        import_study(control_out, "x", "vsmp-imu evaluate -o out", tmp_path)
    import_study(control_out, "ctl", COMMAND, tmp_path)
    with pytest.raises(ConfigError, match="needs a record of the ablation study"):
        StudyTable("t:x", "ablation:caption", load_study(tmp_path, "ctl")).render()
    with pytest.raises(InputFileError, match="has no run.json"):
        load_study(tmp_path, "missing")


def test_a_study_table_needs_a_known_view(tmp_path):
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "tables.yaml").write_text(
        "tables:\n  - id: t:x\n    records: s\n    kind: study\n    view: control:nothing\n")
    with pytest.raises(ConfigError, match="a study table needs a view"):
        Publication(tmp_path)


def test_an_evaluate_folder_still_imports_as_evaluation_records(control_out, tmp_path):
    code, _, err = invoke("report", "import", control_out, "--name", "x", "--command",
                          "vsmp-imu evaluate -o out", "--root", tmp_path)
    assert code == 2 and "not an evaluation result" in err
