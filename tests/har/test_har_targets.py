"""`targets` tables: the project's targets answered from committed records, verdicts computed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError
from scipy.stats import wilcoxon

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.published import Publication
from vsmp_imu.har.targets import TargetRow

LABELS = ("WALKING", "SIT_TO_LIE")
FOLDS, SEEDS = range(1, 5), range(2)


def _record(method: str, fold: int, seed: int, f1: float, left_out: str | None = None) -> dict:
    record = {
        "dataset": "hapt12", "protocol": "low-resource", "budget": 1.0, "backbone": "rf",
        "method": method, "fold": str(fold), "seed": seed, "macro_f1": f1, "accuracy": f1,
        "group_macro_f1": {}, "head_macro_f1": None, "tail_macro_f1": None,
        "per_class_f1": {"WALKING": f1 + 0.2, "SIT_TO_LIE": f1 - 0.2},
        "confusion": [[3, 1], [0, 2]], "n_synthetic": 0, "n_synthetic_requested": 0, "n_train_real": 140,
    }
    if left_out is not None:
        record.update(protocol="unseen", budget=None, unseen_classes=[left_out], unseen_capable=True,
                      unseen_macro_f1=f1, seen_macro_f1=f1)
    return record


def _base(fold: int, seed: int) -> float:
    return 0.5 + 0.02 * fold + 0.01 * seed


def _gain(fold: int) -> float:
    return 0.05 * (1 + 0.1 * fold)


def _low_resource() -> list[dict]:
    """Real-only and VSMP-IMU, 4 folds x 2 seeds; VSMP-IMU gains 5.5 to 7 points by fold."""
    return [_record(m, f, s, _base(f, s) + (_gain(f) if m == "vsmp" else 0.0))
            for f in FOLDS for s in SEEDS for m in ("real", "vsmp")]


def _leave_one_out() -> list[dict]:
    """WALKING left out on 4 folds (F1 0.2), SIT_TO_LIE on 1 fold (F1 0.8): the mean over the
    classes is 0.5, the mean over the runs 0.32."""
    return ([_record("vsmp", f, 0, 0.2, "WALKING") for f in FOLDS]
            + [_record("vsmp", 1, 0, 0.8, "SIT_TO_LIE")])


CATALOGUE = """
targets:
  - id: targets:demo
    rows:
      - {target: "+6 over Real-only", records: lr, method: vsmp, baseline: real, at_least: 6}
      - {target: "+7 over Real-only", records: lr, method: vsmp, baseline: real, at_least: 7}
      - {target: "VSMP-IMU 60", records: lr, method: vsmp, at_least: 60}
      - {target: "VSMP-IMU 62", records: lr, method: vsmp, at_least: 62}
      - {target: "VSMP-IMU not below", records: lr, method: vsmp, baseline: real, not_below: true}
      - {target: "Real-only not below", records: lr, method: real, baseline: vsmp, not_below: true}
      - {target: "every class 40", records: lr, method: vsmp, metric: lowest_class, at_least: 40}
      - {target: "one class out 50", records: loco, method: vsmp, metric: unseen, at_least: 50}
"""
DOC = "# Targets\n\n<!-- report:targets:demo -->\n<!-- /report -->\n"


@pytest.fixture()
def repo(report_repo, import_records) -> Path:
    root = report_repo(CATALOGUE, {"README.md": DOC})
    import_records(root, "lr", _low_resource(), LABELS)
    import_records(root, "loco", _leave_one_out(), LABELS)
    return root


def _rows(root: Path) -> dict[str, list[str]]:
    table = Publication(root).render("targets:demo")
    rows = [line.strip("|").split(" | ") for line in table.splitlines() if line.startswith("| ")][1:]
    return {cells[0].strip(): [c.strip() for c in cells[1:]] for cells in rows}


def test_targets_are_judged_from_the_records(repo):
    rows = _rows(repo)
    gains = np.array([_gain(f) for f in FOLDS for _ in SEEDS]) * 100
    p = wilcoxon(gains).pvalue
    assert p < 0.05
    assert rows["+6 over Real-only"][0].startswith(f"+{gains.mean():.2f} (8/8, p = ")
    assert rows["+6 over Real-only"][1] == "**met**"
    assert rows["+7 over Real-only"][1] == f"missed by {7 - gains.mean():.2f}"
    vsmp_mean = 100 * np.mean([_base(f, s) + _gain(f) for f in FOLDS for s in SEEDS])
    assert rows["VSMP-IMU 60"] == [f"{vsmp_mean:.2f} (8 runs)", "**met**", "`lr` at abc1234"]
    assert rows["VSMP-IMU 62"][1] == f"missed by {62 - vsmp_mean:.2f}"
    assert rows["VSMP-IMU not below"][1] == "**met**"
    assert rows["Real-only not below"][0].startswith(f"\u2212{gains.mean():.2f} (0/8")
    assert rows["Real-only not below"][1] == "missed"
    assert rows["every class 40"][0] == f"{vsmp_mean - 20:.2f} (SIT_TO_LIE, 8 runs)"
    assert rows["every class 40"][1] == "**met**"


def test_leave_one_class_out_counts_each_class_once(repo):
    assert _rows(repo)["one class out 50"] == ["50.00 (5 runs)", "**met**", "`loco` at abc1234"]


def test_the_check_finds_a_verdict_typed_by_hand(repo):
    publication = Publication(repo)
    publication.check(write=True)
    readme = repo / "README.md"
    assert Publication(repo).check().differing == []
    readme.write_text(readme.read_text().replace("missed by", "met, short by"))
    assert Publication(repo).check().differing == ["README.md: table 'targets:demo'"]


def test_a_baseline_from_another_record_set_pairs_the_runs_both_have(report_repo, import_records):
    catalogue = """
targets:
  - id: targets:other
    rows:
      - {target: "+5 over Real-only", records: mine, method: vsmp, baseline: real, baseline_records: theirs, at_least: 5}
"""
    root = report_repo(catalogue, {"README.md": DOC.replace("demo", "other")})
    records = _low_resource()
    import_records(root, "mine", [r for r in records if r["method"] == "vsmp"], LABELS)
    import_records(root, "theirs", [r for r in records if r["method"] == "real" and r["seed"] == 0], LABELS)
    table = Publication(root).render("targets:other")
    assert "(4/4, p = " in table and "`mine` at abc1234 against `theirs` at abc1234" in table


def test_a_target_without_runs_names_itself(repo):
    text = (repo / "results" / "tables.yaml").read_text().replace("method: vsmp, at_least: 60",
                                                                   "method: imugpt, at_least: 60")
    (repo / "results" / "tables.yaml").write_text(text)
    with pytest.raises(ConfigError, match="target 'VSMP-IMU 60'.*no run of IMUGPT-2.0-style"):
        Publication(repo).render("targets:demo")


def test_a_target_on_a_metric_its_runs_lack_says_so(repo):
    text = (repo / "results" / "tables.yaml").read_text().replace(
        '{target: "+6 over Real-only", records: lr, method: vsmp, baseline: real, at_least: 6}',
        '{target: "+6 over Real-only", records: lr, method: vsmp, baseline: real, at_least: 6, metric: tail}')
    (repo / "results" / "tables.yaml").write_text(text)
    with pytest.raises(ConfigError, match="target '\\+6 over Real-only'.*no run pair has the metric 'tail'"):
        Publication(repo).render("targets:demo")


def test_a_verdict_judges_the_figure_it_prints():
    from vsmp_imu.har.targets import _judge

    assert _judge(3, 0.030000000001) == (True, None)
    assert _judge(3, 0.0299999) == (True, None)  # printed 3.00
    assert _judge(3, 0.02994) == (False, 0.01)  # printed 2.99


@pytest.mark.parametrize("fields, message", [
    ({}, "one rule"),
    ({"at_least": 3, "not_below": True}, "one rule"),
    ({"not_below": True}, "needs|baseline"),
    ({"at_least": 3, "baseline_records": "x"}, "baseline method"),
    ({"at_least": 3, "metric": "lowest_class", "baseline": "real"}, "not a paired"),
    ({"at_least": 3, "metric": "f1_of_everything"}, "String should match"),
])
def test_a_target_row_states_one_rule_it_can_judge(fields, message):
    with pytest.raises(ValidationError, match=message):
        TargetRow(target="t", records="r", method="vsmp", **fields)


def test_a_target_over_runs_of_several_budgets_names_them(tmp_path, report_repo, import_records):
    catalogue = """
targets:
  - id: targets:mixed
    rows:
      - {target: "VSMP-IMU 60", records: both, method: vsmp, at_least: 60}
"""
    root = report_repo(catalogue, {"README.md": DOC.replace("demo", "mixed")})
    records = _low_resource()
    import_records(root, "both", records + [{**r, "budget": 5.0} for r in records], LABELS)
    with pytest.raises(ConfigError, match=r"several runs of VSMP-IMU per fold and seed \(budgets 1.0, 5.0\)"):
        Publication(root).render("targets:mixed")
