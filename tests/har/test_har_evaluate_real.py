"""A small real evaluation on HAPT (2 folds), resume after an interruption, and the
result files."""

from __future__ import annotations

import json

import numpy as np
import pytest

from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.weights import DEFAULT_CLASS_WEIGHT, DEFAULT_SYNTHETIC_WEIGHT
from vsmp_imu.pipeline.spec import GenerationSpec

RF_FAST = ("--backbones", "rf", "--jobs", "2")


@pytest.fixture(scope="module")
def hapt_run(tmp_path_factory):
    """`vsmp-imu evaluate` on HAPT, held-out subjects 1 and 2, RF-ECDF, Real-only."""
    from typer.testing import CliRunner

    from vsmp_imu.cli import app

    out = tmp_path_factory.mktemp("hapt-2fold")
    result = CliRunner().invoke(
        app,
        [
            "evaluate",
            "--dataset",
            "hapt",
            "--protocol",
            "lopo",
            *RF_FAST,
            "--methods",
            "real",
            "--folds",
            "1,2",
            "--seeds",
            "1",
            "-o",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    return out


def test_two_fold_hapt_numbers_are_sane(hapt_run):
    results = json.loads((hapt_run / "results.json").read_text())
    records = results["records"]
    assert [(r["fold"], r["seed"], r["budget"]) for r in records] == [
        ("1", 0, None),
        ("2", 0, None),
    ]
    for r in records:
        assert 0.6 < r["macro_f1"] < 0.999  # chance is 1/6
        assert 0.6 < r["accuracy"] < 0.999
        assert set(r["per_class_f1"]) == {
            "WALKING",
            "WALKING_UPSTAIRS",
            "WALKING_DOWNSTAIRS",
            "SITTING",
            "STANDING",
            "LAYING",
        }
        assert r["head_macro_f1"] is None and r["tail_macro_f1"] is None
        assert np.asarray(r["confusion"]).sum() == r["n_test"]
        assert (
            r["n_val"] == 0 and r["n_train_real"] > 10000
        )  # a forest trains on every other subject
    (row,) = results["summary"]
    assert row["n"] == 2 and row["macro_f1_mean"] == pytest.approx(
        np.mean([r["macro_f1"] for r in records])
    )
    assert row["macro_f1_std"] == pytest.approx(np.std([r["macro_f1"] for r in records], ddof=1))
    (per_class,) = results["class_summary"]
    assert per_class["per_class"]["LAYING"]["f1_mean"] > 0.9


def test_result_files(hapt_run):
    md = (hapt_run / "results.md").read_text()
    assert "## hapt — lopo" in md and "| RF | Real-only |" in md and "±" in md
    png = hapt_run / "confusion_hapt_lopo_full_rf_real.png"
    import matplotlib.image

    image = matplotlib.image.imread(png)
    assert image.shape[0] > 400 and image.shape[1] > 400
    assert len(list((hapt_run / "records").glob("*.json"))) == 2


def test_resume_after_interruption_gives_the_same_results(hapt_run, tmp_path):
    out = tmp_path / "resumed"
    config = EvalConfig(
        dataset="hapt",
        backbones=("rf",),
        methods=("real",),
        folds=("1", "2"),
        # the command line's defaults (hapt_run is a command-line run)
        backbone_params={"rf": {"n_jobs": 2, "class_weight": DEFAULT_CLASS_WEIGHT}},
        synthetic_weight=DEFAULT_SYNTHETIC_WEIGHT,
        alpha=GenerationSpec().alpha,
        policy=GenerationSpec().policy,
        share_selection="class",
    )
    dataset = load_dataset("hapt")

    class Killed(Exception):
        pass

    def kill_after_first(description, done, total):
        if done == 1:
            raise Killed

    with pytest.raises(Killed):
        Evaluation(config, dataset, out).run(kill_after_first)
    assert len(list((out / "records").glob("*.json"))) == 1 and not (out / "results.json").exists()
    seen = []
    Evaluation(config, dataset, out).run(lambda d, done, total: seen.append(d))
    assert "(cached)" in seen[0] and "(cached)" not in seen[1]
    assert (out / "results.json").read_text() == (hapt_run / "results.json").read_text()


def test_tiny_deepconvlstm_learns_on_hapt():
    config = EvalConfig(
        dataset="hapt",
        backbones=("dclstm",),
        methods=("real",),
        folds=("3",),
        backbone_params={
            "dclstm": {
                "n_filters": 8,
                "n_conv": 2,
                "hidden": 16,
                "max_epochs": 3,
                "patience": 3,
                "batch_size": 256,
                "n_threads": 1,
            }
        },
    )
    (record,) = Evaluation(config, load_dataset("hapt")).run().records
    assert record["epochs"] == 3 and 1 <= record["best_epoch"] <= 3
    assert record["n_val"] > 0  # early stopping on validation subjects
    assert 0.3 < record["macro_f1"] < 1.0


def test_hapt12_reports_the_transition_group():
    config = EvalConfig(
        dataset="hapt12",
        backbones=("rf",),
        methods=("real",),
        folds=("4",),
        backbone_params={"rf": {"n_estimators": 40, "n_jobs": 2}},
        report_groups={"sitting_transitions": ("STAND_TO_SIT", "SIT_TO_STAND")},
    )
    results = Evaluation(config, load_dataset("hapt12")).run()
    (record,) = results.records
    groups = record["group_macro_f1"]
    assert set(groups) == {"activities", "transitions", "sitting_transitions"}
    assert 0.0 <= groups["transitions"] < groups["activities"] <= 1.0
    assert results.summary[0]["group_macro_f1"]["transitions"]["n"] == 1
    # the group score is the Macro-F1 of the member classes
    members = [v for k, v in record["per_class_f1"].items() if "_TO_" in k and v is not None]
    assert groups["transitions"] == pytest.approx(np.mean(members))


@pytest.mark.slow
@pytest.mark.parametrize("name,expected", [("hapt", 0.8843), ("hapt12", 0.7660)])
def test_full_lopo_rf_regression(name, expected):
    """All 30 folds, RF-ECDF, Real-only: pinned Macro-F1 (docs/har.md)."""
    config = EvalConfig(dataset=name, backbones=("rf",), methods=("real",))
    (row,) = Evaluation(config, load_dataset(name)).run().summary
    assert row["n"] == 30
    assert row["macro_f1_mean"] == pytest.approx(expected, abs=0.01)


def test_only_seeds_runs_part_of_an_evaluation_and_its_records_are_the_whole_ones(tmp_path):
    """`--only-seeds 1` writes the seed-1 records of `--seeds 2`; the full run then finds them
    (same settings digest) and computes seed 0 alone."""
    from typer.testing import CliRunner

    from vsmp_imu.cli import app

    def run(*extra):
        return CliRunner().invoke(app, ["evaluate", "--dataset", "hapt", *RF_FAST, "--methods", "real",
                                        "--folds", "1", "--seeds", "2", *extra, "-o", str(tmp_path)])

    part = run("--only-seeds", "1")
    assert part.exit_code == 0, part.output
    assert sorted(p.name for p in (tmp_path / "records").iterdir()) == ["lopo_full_real_rf_fold-1_seed-1.json"]
    one = json.loads((tmp_path / "records" / "lopo_full_real_rf_fold-1_seed-1.json").read_text())
    whole = run()
    assert whole.exit_code == 0, whole.output
    records = json.loads((tmp_path / "results.json").read_text())["records"]
    assert [(r["fold"], r["seed"]) for r in records] == [("1", 0), ("1", 1)]
    assert records[1]["confusion"] == one["confusion"] and records[1]["macro_f1"] == one["macro_f1"]


@pytest.mark.parametrize("extra, expected", [
    (("--only-seeds", "2"), "not one of --seeds 2"),
    (("--only-seeds", "1,x"), "x: not a seed"),
    (("--only-seeds", "-1"), "not a seed"),
])
def test_only_seeds_outside_the_seeds_is_a_config_error(cli, tmp_path, extra, expected):
    code, _, err = cli("evaluate", "--dataset", "hapt", "--seeds", "2", *extra, "-o", tmp_path / "out")
    assert code == 2 and expected in err and "--only-seeds" in err
    assert not (tmp_path / "out" / "records").exists()
