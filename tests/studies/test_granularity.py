"""The activity-granularity study: taxonomy files, per-class and group metrics on real HAPT
data (low-resource, one fold), a custom taxonomy on UTD-MHAD files, outputs, CLI errors."""

from __future__ import annotations

import json

import numpy as np
import pytest
from study_support import FIXTURES, assert_blocks_in_report, invoke, rebuild_study_tables

from vsmp_imu.errors import ValidationError
from vsmp_imu.studies.granularity import default_taxonomy, load_taxonomy, match_taxonomy

PNG = b"\x89PNG\r\n\x1a\n"
HAPT6 = ("WALKING", "WALKING_UPSTAIRS", "WALKING_DOWNSTAIRS", "SITTING", "STANDING", "LAYING")


@pytest.fixture(scope="module")
def hapt_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("granularity")
    code, stdout, err = invoke("study", "granularity", "-o", out, "--protocol", "low-resource", "--budget", "2",
                               "--folds", "1", "--methods", "real,classical,vsmp", "--alpha", "0.25")
    assert code == 0, err
    results = json.loads((out / "results.json").read_text())
    records = json.loads((out / "runs" / "results.json").read_text())["records"]
    return out, stdout, results, records


def test_shipped_taxonomies():
    utd = load_taxonomy(default_taxonomy("utd_mhad"))
    assert [len(v) for v in utd.values()] == [9, 9, 5, 4]  # paper, Table "UTD-MHAD activity taxonomy"
    assert sum(len(v) for v in utd.values()) == len({c for v in utd.values() for c in v}) == 27
    hapt = load_taxonomy(default_taxonomy("hapt12"))
    assert sum(len(v) for v in hapt.values()) == 12
    # 6-class HAPT has no transitions: that group is left out, the others match case-insensitively
    six = match_taxonomy(hapt, HAPT6, tuple(n.lower() for n in HAPT6))
    assert list(six) == ["Locomotion", "Static postures"] and six["Locomotion"][0] == "walking"


@pytest.mark.parametrize("text, match", [
    ("- a\n- b\n", "mapping of group names"),
    ("g1: []\n", "at least one class label"),
    ("g1: [WALKING]\ng2: [walking]\n", "is in groups 'g1' and 'g2'"),
])
def test_bad_taxonomy_files_are_refused(tmp_path, text, match):
    path = tmp_path / "tax.yaml"
    path.write_text(text)
    with pytest.raises(ValidationError, match=match):
        load_taxonomy(path)


def test_labels_outside_the_dataset_are_refused():
    groups = {"g1": ("WALKING", "JUMPING"), "g2": ("SITTING",)}
    with pytest.raises(ValidationError, match="not in the dataset: JUMPING"):
        match_taxonomy(groups, HAPT6, HAPT6)
    with pytest.raises(ValidationError, match="no taxonomy label"):
        match_taxonomy({"g": ("x", "y")}, HAPT6, HAPT6)


def test_outputs_are_written(hapt_run):
    out, stdout, results, _ = hapt_run
    assert (out / "granularity.png").read_bytes()[:8] == PNG
    report = (out / "report.md").read_text()
    for text in ("## Taxonomy", "## Group Macro-F1 (%)", "## Per-class precision, recall and F1 (%)",
                 "Postural transitions", "## Deviations from the paper"):
        assert text in report
    assert results["settings"]["methods"] == ["real", "classical", "vsmp"]
    assert results["taxonomy"]["Static postures"] == ["SITTING", "STANDING", "LAYING"]
    assert "vsmp / Locomotion:" in stdout


def test_group_macro_f1_is_the_mean_of_its_classes_f1(hapt_run):
    _, _, results, records = hapt_run
    assert {r["method"] for r in records} == {"real", "classical", "vsmp"} and len(records) == 3
    for rec in records:
        for group, classes in results["taxonomy"].items():
            f1 = [rec["per_class_f1"][c] for c in classes if rec["per_class_f1"][c] is not None]
            assert rec["group_macro_f1"][group] == pytest.approx(np.mean(f1))
    # one fold and one seed: the study's group value is the mean of its classes' mean F1
    per_class = {(r["method"], r["class"]): r for r in results["per_class"]}
    for row in results["groups"]:
        f1 = [per_class[(row["method"], c)]["f1_mean"] for c in results["taxonomy"][row["group"]]]
        assert row["macro_f1_mean"] == pytest.approx(np.mean([v for v in f1 if v is not None]))
    transitions = next(r for r in results["groups"] if r["method"] == "real" and r["group"] == "Postural transitions")
    assert 0.0 < transitions["macro_f1_mean"] < 1.0  # real data: not a trivial split


def test_per_class_rows_agree_with_the_records(hapt_run):
    _, _, results, records = hapt_run
    by_method = {r["method"]: r for r in records}
    for row in results["per_class"]:
        rec = by_method[row["method"]]
        p, r, f = row["precision_mean"], row["recall_mean"], row["f1_mean"]
        assert f == pytest.approx(rec["per_class_f1"][row["class"]])
        if p + r > 0:
            assert f == pytest.approx(2 * p * r / (p + r))
        assert row["support"] == rec["per_class_support"][row["class"]]
    supports = [row["support"] for row in results["per_class"] if row["method"] == "real"]
    assert sum(supports) == by_method["real"]["n_test"]
    for row in results["groups"]:
        if row["method"] == "real":
            continue
        real = next(x for x in results["groups"] if x["method"] == "real" and x["group"] == row["group"])
        assert row["delta_vs_real"]["mean"] == pytest.approx(row["macro_f1_mean"] - real["macro_f1_mean"])


def test_a_custom_taxonomy_groups_any_dataset(tmp_path, utd_dir, cli):
    tax = tmp_path / "groups.yaml"
    tax.write_text("Arms:\n  - right_hand_wave\n  - Two Arm Curl\nLegs:\n  - jogging_in_place\n  - sit_to_stand\n")
    code, _, err = cli("study", "granularity", "-o", tmp_path / "out", "-d", "utd_mhad", "--data-dir", utd_dir,
                       "--taxonomy", tax, "--methods", "real", "--folds", "1")
    assert code == 0, err
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["taxonomy"] == {"Arms": ["right_hand_wave", "two_arm_curl"],
                                   "Legs": ["jogging_in_place", "sit_to_stand"]}
    assert len(results["ungrouped"]) == 23
    assert {r["group"] for r in results["groups"]} == {"Arms", "Legs"}


@pytest.mark.parametrize("args, field", [
    (("--taxonomy", "missing.yaml"), "--taxonomy"),
    (("--methods", "real,gan"), "--methods"),
    (("--protocol", "low-resource"), "--budget"),
    (("--alpha", "5"), "--alpha"),
    (("--seeds", "0"), "--seeds"),
])
def test_bad_input_gives_a_clean_message(cli, tmp_path, args, field):
    code, _, err = cli("study", "granularity", "-o", tmp_path / "out", *args)
    assert code == 2
    assert field in err


def test_a_dataset_without_a_taxonomy_needs_one(cli, tmp_path):
    generic = FIXTURES / "datasets" / "generic" / "dataset.yaml"
    code, _, err = cli("study", "granularity", "-o", tmp_path / "out", "-d", generic, "--methods", "real")
    assert code == 2 and "--taxonomy" in err


def test_the_study_record_rebuilds_the_group_table(hapt_run, tmp_path):
    out = hapt_run[0]
    command = f"vsmp-imu study granularity -o {out} --protocol low-resource --budget 2 --folds 1"
    blocks = rebuild_study_tables(out, command, {"granularity:main": "granularity:groups",
                                                           "granularity:classes": "granularity:classes"}, tmp_path)
    assert_blocks_in_report(blocks, (out / "report.md").read_text())
    assert "| Locomotion" in blocks["granularity:main"]
