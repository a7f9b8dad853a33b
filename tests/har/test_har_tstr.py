"""Protocol tstr: train on a method's synthetic windows only, test on the held-out subject;
`real` under tstr is TRTR. Uses the tiny dataset whose channel 0 carries the subject."""

from __future__ import annotations

import json

import numpy as np
import pytest
from har_spies import MARK
from har_spies import MarkedSource as SharedMarkedSource

from vsmp_imu.errors import ValidationError
from vsmp_imu.har.backbones import BACKBONES, RandomForestECDF
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.protocols import split_fold
from vsmp_imu.har.report import results_markdown
from vsmp_imu.har.synthetic import METHODS, FoldContext
from vsmp_imu.har.windows import Windows

FITS: list[dict] = []
CONTEXTS: list[FoldContext] = []


def fingerprints(X: np.ndarray) -> set[int]:
    ch = np.asarray(X)[:, :, 0]
    exact = np.all(ch == ch[:, :1], axis=1) & (np.mod(ch[:, 0], 1000) == 0) & (ch[:, 0] > 0)
    return {int(v) for v in ch[exact, 0] // 1000}


class RecordingRF(RandomForestECDF):
    """Records what every fit is given and which subjects every prediction sees."""

    def fit(self, X, y, X_val=None, y_val=None):
        FITS.append({"n": len(X), "subjects": fingerprints(X), "marked": int(np.sum(X[:, 0, 0] == MARK)),
                     "val": X_val is not None, "classes": set(np.unique(y).tolist())})
        return super().fit(X, y, X_val, y_val)

    def predict(self, X):
        FITS[-1]["predicted_subjects"] = fingerprints(X)
        return super().predict(X)


class MarkedSource(SharedMarkedSource):
    """The shared marked source, recording each context it is given."""

    def generate(self, context: FoldContext) -> Windows:
        CONTEXTS.append(context)
        return super().generate(context)


class EmptySource(MarkedSource):
    name = "empty"

    def generate(self, context: FoldContext) -> Windows:
        return super().generate(context)[:0]


@pytest.fixture
def recording(monkeypatch):
    FITS.clear()
    CONTEXTS.clear()
    monkeypatch.setitem(BACKBONES, "rec-rf", RecordingRF)
    monkeypatch.setitem(METHODS, "marked", MarkedSource)
    monkeypatch.setitem(METHODS, "empty", EmptySource)


def _config(held: str, methods=("real", "marked"), alpha: float = 1.0) -> EvalConfig:
    return EvalConfig(dataset="tiny", protocol="tstr", backbones=("rec-rf",), methods=methods, folds=(held,),
                      alpha=alpha, backbone_params={"rec-rf": {"n_estimators": 5, "n_jobs": 1}})


def test_the_split_has_no_validation_subjects(tiny_dataset):
    windows = tiny_dataset.windows(2.0, 0.5)
    split = split_fold(windows, "3", "tstr", seed=0)
    assert split.val_subjects == () and len(split.val) == 0
    assert set(split.fit.unique_subjects()) == {"1", "2", "4", "5", "6"}
    assert set(split.test.unique_subjects()) == {"3"}


@pytest.mark.parametrize("held", ["1", "4"])
def test_the_model_trains_on_synthetic_windows_only(recording, tiny_dataset, held):
    results = Evaluation(_config(held), tiny_dataset).run()
    records = {r["method"]: r for r in results.records}
    others = {int(s) for s in tiny_dataset.subjects} - {int(held)}
    n_train = len(tiny_dataset.windows(2.0, 0.5).where_subjects([held], keep=False))
    real_fit, marked_fit = FITS  # methods in order: real (TRTR), then marked (TSTR)
    # TRTR: every training subject's real windows, no synthetic one
    assert real_fit["subjects"] == others and real_fit["marked"] == 0
    assert records["real"]["n_train_real"] == n_train == real_fit["n"]
    assert records["real"]["n_synthetic"] == 0
    # TSTR: only the method's windows (none carries a subject), as many as the records say
    assert marked_fit["subjects"] == set() and marked_fit["marked"] == marked_fit["n"]
    assert records["marked"]["n_train_real"] == 0
    assert records["marked"]["n_synthetic"] == marked_fit["n"] == records["marked"]["n_synthetic_requested"]
    for fit, record in zip(FITS, (records["real"], records["marked"]), strict=True):
        assert not fit["val"] and record["n_val"] == 0 and record["val_subjects"] == []
        assert fit["predicted_subjects"] == {int(held)}
        assert record["protocol"] == "tstr"
        assert set(record["per_class_f1"]) == set(tiny_dataset.info.label_names)
    # the source saw every training subject's full data, never the held-out subject
    (context,) = CONTEXTS
    assert fingerprints(context.train.X) == others
    assert held not in context.train_subjects and held not in set(context.train.subjects.tolist())
    assert len(context.train) == n_train and context.protocol == "tstr"


def _rows(windows: Windows) -> set[bytes]:
    return {x.tobytes() + bytes([int(y)]) for x, y in zip(windows.X, windows.y, strict=True)}


def test_a_label_budget_draws_the_windows_low_resource_draws(tiny_dataset):
    """tstr at 40 %: the pool low-resource draws at the same seed, fold and budget (its fit and
    validation subjects together), all of it for the synthetic source."""
    windows = tiny_dataset.windows(2.0, 0.5)
    tstr = split_fold(windows, "3", "tstr", seed=1, budget_percent=40)
    low = split_fold(windows, "3", "low-resource", seed=1, budget_percent=40)
    assert tstr.val_subjects == () and len(tstr.val) == 0
    assert _rows(tstr.fit) == _rows(low.fit) | _rows(low.val)
    assert len(tstr.fit) == len(low.fit) + len(low.val) < len(split_fold(windows, "3", "tstr", seed=1).fit)
    assert _rows(tstr.test) == _rows(low.test)


def test_tstr_with_a_label_budget(recording, tiny_dataset):
    config = EvalConfig(dataset="tiny", protocol="tstr", budgets=(40.0,), backbones=("rec-rf",),
                        methods=("real", "marked"), folds=("2",), alpha=2.0,
                        backbone_params={"rec-rf": {"n_estimators": 5, "n_jobs": 1}})
    results = Evaluation(config, tiny_dataset).run()
    records = {r["method"]: r for r in results.records}
    pool = split_fold(tiny_dataset.windows(2.0, 0.5), "2", "tstr", seed=0, budget_percent=40).fit
    (context,) = CONTEXTS
    assert _rows(context.train) == _rows(pool) and context.label_budget == 40.0
    assert records["real"]["n_train_real"] == len(pool) == FITS[0]["n"]  # TRTR on the budget's windows
    assert records["marked"]["n_synthetic_requested"] == 2 * len(pool) and records["marked"]["n_train_real"] == 0
    assert {r["budget"] for r in results.records} == {40.0}
    assert "### 40 % of the labels" in results_markdown(results.to_json())


def test_alpha_sets_the_synthetic_training_set(recording, tiny_dataset):
    results = Evaluation(_config("2", methods=("marked",), alpha=0.5), tiny_dataset).run()
    (record,) = results.records
    n_train = len(tiny_dataset.windows(2.0, 0.5).where_subjects(["2"], keep=False))
    assert record["n_synthetic"] == round(0.5 * n_train) == FITS[0]["n"]
    assert record["n_train_real"] == 0


def test_a_method_without_windows_stops_the_run(recording, tiny_dataset):
    with pytest.raises(ValidationError, match="made no synthetic window") as caught:
        Evaluation(_config("2", methods=("empty",)), tiny_dataset).run()
    assert caught.value.field == "--methods"
    assert FITS == []  # no model was trained on nothing


def test_tstr_on_the_command_line(cli, fixtures_dir, tmp_path):
    out = tmp_path / "tstr"
    code, stdout, _ = cli("evaluate", "--dataset", fixtures_dir / "generic" / "dataset.yaml", "--protocol", "tstr",
                          "--methods", "real,classical", "--backbones", "rf", "--jobs", "1", "-o", out)
    assert code == 0, stdout
    results = json.loads((out / "results.json").read_text())
    # by default as many synthetic windows per class as the real training set has (alpha 1, uniform)
    assert (results["config"]["alpha"], results["config"]["policy"]) == (1.0, "uniform")
    trtr = {r["fold"]: r["n_train_real"] for r in results["records"] if r["method"] == "real"}
    assert all(r["n_synthetic_requested"] == trtr[r["fold"]] for r in results["records"] if r["method"] != "real")
    assert {(r["protocol"], r["method"]) for r in results["records"]} == {("tstr", "real"), ("tstr", "classical")}
    for r in results["records"]:
        if r["method"] == "classical":
            assert r["n_train_real"] == 0 and r["n_synthetic"] > 0
        else:
            assert r["n_train_real"] > 0 and r["n_synthetic"] == 0
        assert r["per_class_f1"]


@pytest.mark.parametrize("protocol,given,expected", [
    ("tstr", (None, None), (1.0, "uniform")),
    ("low-resource", (None, None), (2.0, "scarcity")),
    ("unseen", (None, None), (2.0, "tail")),  # synthetic windows for the unseen classes only
    ("unseen", (None, "scarcity"), (2.0, "scarcity")),
    ("tstr", (0.5, "scarcity"), (0.5, "scarcity")),  # what is given is kept
])
def test_the_budget_defaults_follow_the_protocol(protocol, given, expected):
    from vsmp_imu.cli.har import budget_defaults

    assert budget_defaults(protocol, *given) == expected


@pytest.mark.parametrize("args,option,allowed", [
    (("--protocol", "long-tail", "--budgets", "5"), "--budgets", "low-resource or tstr"),
    (("--protocol", "tsrt"), "--protocol", "tstr"),
])
def test_tstr_option_errors_exit_2(cli, tmp_path, args, option, allowed):
    code, _, err = cli("evaluate", "--dataset", "hapt", *args, "-o", tmp_path / "out")
    assert code == 2 and option in err and allowed in err
    assert not (tmp_path / "out" / "results.json").exists()
