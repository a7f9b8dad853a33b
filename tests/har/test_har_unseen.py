"""The unseen protocol: classes with no real training window (issue 22)."""

from __future__ import annotations

import json
from collections import defaultdict

import numpy as np
import pytest
from har_spies import Spy

from vsmp_imu.errors import ConfigError
from vsmp_imu.har import normalize
from vsmp_imu.har.backbones import BACKBONES, DeepConvLSTM, RandomForestECDF
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.metrics import unseen_metrics
from vsmp_imu.har.protocols import check_unseen_indices, resolve_unseen, split_fold
from vsmp_imu.har.records import compact
from vsmp_imu.har.synthetic import METHODS, UNSEEN_CAPABLE, FoldContext, unseen_budget
from vsmp_imu.har.windows import Windows

NAMES = ("a", "b", "c", "d")
GROUPS = {"pair": ("c", "d")}


def test_resolve_unseen_classes_groups_and_each():
    assert resolve_unseen("b", NAMES, GROUPS) == (("b",),)
    assert resolve_unseen("d,pair,a", NAMES, GROUPS) == (("a", "c", "d"),)  # dataset order, once each
    assert resolve_unseen(["each"], NAMES, GROUPS) == (("a",), ("b",), ("c",), ("d",))


@pytest.mark.parametrize("text,message", [
    ("z", "unknown class or group 'z'"),
    ("a,b,c,d", "between 1 and 3 unseen classes (got 4)"),
    ("pair,a,b", "between 1 and 3 unseen classes (got 4)"),
    ("each,a", "'each' cannot be combined"),
    ("", "between 1 and 3"),
])
def test_resolve_unseen_errors_name_the_option(text, message):
    with pytest.raises(ConfigError) as exc:
        resolve_unseen(text, NAMES, GROUPS)
    assert message in str(exc.value) and exc.value.field == "--unseen"


def test_resolve_unseen_errors_offer_each_group_and_class():
    allowed = "each, pair, a, b, c, d"
    for text, message in (("each,a", "'each' cannot be combined with class names"),
                          ("z", "unknown class or group 'z'")):
        with pytest.raises(ConfigError) as exc:
            resolve_unseen(text, NAMES, GROUPS)
        assert exc.value.message == message and exc.value.allowed == allowed


def test_check_unseen_indices_bounds():
    assert check_unseen_indices([3, 0, 3], NAMES) == (0, 3)  # sorted, once each
    for unseen in ([-1], [4], [0, 4], [0, 1, 2, 3], []):
        with pytest.raises(ConfigError) as exc:
            check_unseen_indices(unseen, NAMES)
        assert exc.value.field == "--unseen" and exc.value.allowed == "a, b, c, d"
        assert exc.value.message == f"the unseen protocol needs between 1 and 3 unseen classes (got {len(set(unseen))})"


def test_split_fold_removes_unseen_classes_from_the_training_side_only(tiny_dataset):
    windows = tiny_dataset.windows()
    split = split_fold(windows, "2", "unseen", seed=0, unseen=(1, 3))
    assert split.unseen == (1, 3)
    for part in (split.fit, split.val):
        assert len(part) and not np.isin(part.y, [1, 3]).any()
        assert "2" not in part.subjects
    assert set(split.test.subjects) == {"2"}
    held = windows.where_subjects(["2"])
    assert np.array_equal(split.test.class_counts(), held.class_counts())  # the test keeps them all
    # the seen classes keep every window of the training subjects
    pool = windows.where_subjects(["2"], keep=False)
    seen = ~np.isin(pool.y, [1, 3])
    assert len(split.fit) + len(split.val) == int(seen.sum())
    with pytest.raises(ConfigError):
        split_fold(windows, "2", "unseen", seed=0, unseen=())


def test_unseen_budget():
    counts = np.array([100, 300, 0, 200])  # class 2 unseen (no real window)
    uniform = unseen_budget(counts, 0.5, "uniform", (2,))
    assert uniform[[0, 1, 3]].tolist() == [50, 150, 100]
    assert uniform[2] == 100  # alpha x the median seen class (200)
    scarcity = unseen_budget(counts, 2.0, "scarcity", (2,))
    assert scarcity[2] == 400 and scarcity[[0, 1, 3]].sum() == 1200
    assert scarcity.tolist() == [655, 218, 400, 327]  # seen: 1/100 : 1/300 : 1/200 of 1200
    tail = unseen_budget(counts, 1.0, "tail", (2,))
    assert tail.tolist() == [0, 0, 200, 0]  # the unseen classes are the tail
    assert uniform.dtype == scarcity.dtype == tail.dtype == np.int64
    # a seen class of a single window counts in the median: median(1, 1, 9) = 1
    assert unseen_budget(np.array([1, 1, 9, 0]), 1.0, "uniform", (3,)).tolist() == [1, 1, 9, 1]


def test_unseen_metrics_from_a_confusion_matrix():
    # rows: truth a, b, c; c unseen
    confusion = np.array([[8, 0, 2], [1, 9, 0], [3, 0, 1]])
    m = unseen_metrics(confusion, [2])
    assert m["unseen_macro_f1"] == pytest.approx(2 * 1 / (4 + 3))
    f1_a, f1_b = 2 * 8 / (10 + 12), 2 * 9 / (10 + 9)
    assert m["seen_macro_f1"] == pytest.approx((f1_a + f1_b) / 2)
    assert m["seen_as_unseen"] == pytest.approx(2 / 20)
    assert m["unseen_as_seen"] == pytest.approx(3 / 4)


# -- leakage ------------------------------------------------------------------------------
SEEN: dict[str, set] = defaultdict(set)


def fingerprints(X: np.ndarray) -> set[tuple[int, int]]:
    """(subject, class) of the windows whose channels 0 and 2 still hold the exact marks."""
    X = np.asarray(X)
    s, c = X[:, :, 0], X[:, :, 2]
    exact = (np.all(s == s[:, :1], axis=1) & np.all(c == c[:, :1], axis=1)
             & (np.mod(s[:, 0], 1000) == 0) & (s[:, 0] > 0) & (np.mod(c[:, 0], 1000) == 0) & (c[:, 0] > 0))
    return {(int(a) // 1000, int(b) // 1000 - 1) for a, b in zip(s[exact, 0], c[exact, 0], strict=True)}


class MarkedDataset:
    """The tiny dataset with the class marked as well: channel 2 = 1000 x (class + 1)."""

    def __init__(self, base) -> None:
        self.base, self.info = base, base.info

    def windows(self, window_s: float = 2.0, overlap: float = 0.5) -> Windows:
        w = self.base.windows(window_s, overlap)
        X = w.X.copy()
        X[:, :, 2] = 1000.0 * (w.y[:, None] + 1)
        return Windows(X, w.y, w.subjects, w.label_names, w.channel_names, w.fs_hz, meta=dict(w.meta))


class SpyRF(Spy, RandomForestECDF):
    seen, marks = SEEN, staticmethod(fingerprints)


class SpyDCLSTM(Spy, DeepConvLSTM):
    seen, marks = SEEN, staticmethod(fingerprints)


class MakerSource:
    """Copies the real training windows of seen classes and makes unseen-class windows from
    nothing (noise): what a generative method does for a class without evidence."""

    name = "maker"

    def generate(self, context: FoldContext) -> Windows:
        SEEN["source"] |= fingerprints(context.train.X)
        SEEN["context_unseen"].add(context.unseen)
        SEEN["budget"].add(tuple(sorted(context.budget.items())))
        train, xs, ys = context.train, [], []
        rng = np.random.default_rng(0)
        for c, n in enumerate(context.budget_vector()):
            pool = np.flatnonzero(train.y == c)
            if len(pool):
                xs.append(train.X[pool[:n]])
            else:
                xs.append(rng.normal(0, 1, (n, train.n_timesteps, train.n_channels)).astype(np.float32))
            ys.append(np.full(len(xs[-1]), c))
        y = np.concatenate(ys)
        return Windows(np.concatenate(xs), y, np.full(len(y), "maker"), train.label_names,
                       train.channel_names, train.fs_hz)


@pytest.fixture
def spies(monkeypatch):
    SEEN.clear()
    monkeypatch.setitem(BACKBONES, "spy-rf", SpyRF)
    monkeypatch.setitem(BACKBONES, "spy-dclstm", SpyDCLSTM)
    monkeypatch.setitem(METHODS, "maker", MakerSource)
    monkeypatch.setattr("vsmp_imu.har.synthetic.UNSEEN_CAPABLE", UNSEEN_CAPABLE | {"maker"})
    monkeypatch.setattr("vsmp_imu.har.evaluate.UNSEEN_CAPABLE", UNSEEN_CAPABLE | {"maker"})
    original_fit = normalize.ChannelStandardizer.fit

    def spy_fit(self, X):
        SEEN["normalizer"] |= fingerprints(X)
        return original_fit(self, X)

    monkeypatch.setattr(normalize.ChannelStandardizer, "fit", spy_fit)


@pytest.mark.parametrize("unseen", [("class_3",), ("class_0", "class_2")])
def test_unseen_windows_of_training_subjects_reach_test_only(spies, tiny_dataset, unseen):
    marked = MarkedDataset(tiny_dataset)
    names = marked.info.label_names
    hidden = {names.index(u) for u in unseen}
    subjects = {int(s) for s in tiny_dataset.windows().unique_subjects()}
    for held in ("2", "5"):
        for key in ("fit", "val", "val_predict", "predict", "normalizer", "source"):
            SEEN[key] = set()
        config = EvalConfig(dataset="tiny", protocol="unseen", unseen=unseen,
                            backbones=("spy-rf", "spy-dclstm"), methods=("real", "maker"), folds=(held,),
                            alpha=1.0, policy="uniform",
                            backbone_params={"spy-rf": {"n_estimators": 5, "n_jobs": 1},
                                             "spy-dclstm": SpyDCLSTM._get_test_params()})
        results = Evaluation(config, marked).run()
        h = int(held)
        # the instruments work: the training side sees the seen classes of the other subjects
        seen_pairs = {(s, c) for s in subjects - {h} for c in range(len(names)) if c not in hidden}
        assert SEEN["fit"] == seen_pairs  # the forest trains on the validation subjects too
        for key in ("normalizer", "source"):  # the fit subjects only
            assert SEEN[key] and SEEN[key] <= seen_pairs, key
        assert SEEN["val"] and SEEN["val"] <= seen_pairs
        assert SEEN["val_predict"] <= SEEN["val"]
        # the held-out subject keeps every class, unseen ones included, for the test only
        assert SEEN["predict"] == {(h, c) for c in range(len(names))}
        assert SEEN["context_unseen"] == {tuple(unseen)}
        by_method = {r["method"]: r for r in results.records}
        assert by_method["real"]["unseen_capable"] is False
        assert by_method["real"]["n_synthetic_unseen"] == 0
        maker = by_method["maker"]
        assert maker["unseen_capable"] is True and maker["unseen_classes"] == list(unseen)
        budget = dict(next(iter(SEEN["budget"])))
        assert maker["n_synthetic_unseen"] == sum(budget[u] for u in unseen) > 0
        for r in results.records:
            support = r["per_class_support"]
            assert all(support[u] > 0 for u in unseen)
            assert r["unseen_macro_f1"] is not None and r["seen_macro_f1"] is not None
            assert set(compact(r)) >= {"unseen_classes", "unseen_macro_f1", "seen_as_unseen"}


def test_each_class_unseen_in_turn_gives_separate_records(tmp_path, tiny_dataset):
    config = EvalConfig(dataset="tiny", protocol="unseen", unseen=("each",), methods=("real",),
                        folds=("2",), backbone_params={"rf": {"n_estimators": 5, "n_jobs": 1}})
    evaluation = Evaluation(config, tiny_dataset, tmp_path)
    results = evaluation.run()
    names = tiny_dataset.info.label_names
    assert sorted(tuple(r["unseen_classes"]) for r in results.records) == [(n,) for n in names]
    files = sorted(p.name for p in (tmp_path / "records").glob("*.json"))
    assert len(files) == len(names) and all(f"unseen-{n.replace('_', '-')}_" in " ".join(files) for n in names)
    assert len(results.summary) == len(names)
    digests = {json.loads(p.read_text())["settings_digest"] for p in (tmp_path / "records").glob("*.json")}
    assert len(digests) == len(names)  # the unseen set is part of the settings digest
    again = Evaluation(config, tiny_dataset, tmp_path).run()  # resumed from the records
    assert [r["macro_f1"] for r in again.records] == [r["macro_f1"] for r in results.records]


def test_unseen_option_needs_the_protocol_and_the_protocol_needs_the_option():
    with pytest.raises(ConfigError) as exc:
        EvalConfig(dataset="tiny", unseen=("class_1",)).check()
    assert exc.value.field == "--unseen" and "--protocol unseen" in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        EvalConfig(dataset="tiny", protocol="unseen").check()
    assert exc.value.field == "--unseen"


# -- command line and report ---------------------------------------------------------------
@pytest.mark.parametrize("args,message", [
    (("--protocol", "unseen", "--unseen", "FLYING"), "unknown class or group 'FLYING'"),
    (("--protocol", "unseen", "--unseen",
      "WALKING,WALKING_UPSTAIRS,WALKING_DOWNSTAIRS,SITTING,STANDING,LAYING"), "between 1 and 5"),
    (("--unseen", "WALKING"), "use --protocol unseen"),
    (("--protocol", "unseen"), "needs the classes to hold out"),
])
def test_unseen_option_errors_exit_2(cli, tmp_path, args, message):
    code, _, err = cli("evaluate", "--dataset", "hapt", *args, "-o", tmp_path / "out")
    assert code == 2
    assert "--unseen" in err and message in " ".join(err.split())
    assert not (tmp_path / "out" / "results.json").exists()


def test_unseen_on_the_command_line(cli, fixtures_dir, tmp_path):
    out = tmp_path / "unseen"
    code, stdout, _ = cli("evaluate", "--dataset", fixtures_dir / "generic" / "dataset.yaml",
                          "--protocol", "unseen", "--unseen", "sit", "--methods", "real,classical",
                          "--backbones", "rf", "--jobs", "1", "-o", out)
    assert code == 0, stdout
    results = json.loads((out / "results.json").read_text())
    assert {r["method"] for r in results["records"]} == {"real", "classical"}
    for r in results["records"]:
        assert r["unseen_classes"] == ["sit"] and r["unseen_capable"] is False
        assert r["n_synthetic_unseen"] == 0 and r["unseen_macro_f1"] is not None
    for row in results["summary"]:
        assert row["unseen_classes"] == ["sit"] and row["unseen_capable"] is False
    text = " ".join(stdout.split())
    assert "Unseen: sit" in text and "unseen F1" in text and "seen→uns." in text
    assert "real*/rf" in text and "classical*/rf" in text and "(the floor)" in text
    assert len(list((out / "records").glob("unseen_full_unseen-sit_*.json"))) == len(results["records"])
    md = (out / "results.md").read_text()
    assert "| Unseen | Backbone | Method | Unseen Macro-F1 |" in md and "| sit | RF | Real-only * |" in md
    assert (out / "confusion_my_waist_phone_unseen_full_unseen-sit_rf_real.png").exists()


def test_leave_one_class_out_prints_the_mean_unseen_f1(capsys):
    from vsmp_imu.cli.har import _print_summary

    def row(unseen, f1):
        return {"unseen_classes": [unseen], "method": "vsmp", "backbone": "rf", "unseen_capable": True,
                "unseen_macro_f1_mean": f1, "unseen_macro_f1_std": 0.0, "seen_macro_f1_mean": 0.9,
                "seen_macro_f1_std": 0.0, "seen_as_unseen_mean": 0.0, "unseen_as_seen_mean": 0.5, "n": 3,
                "n_synthetic_mean": 10, "n_synthetic_requested_mean": 10, "budget": None,
                "protocol": "unseen"}

    _print_summary([row("a", 0.2), row("b", 0.5)])
    out = " ".join(capsys.readouterr().out.split())
    assert "Unseen: a" in out and "Unseen: b" in out
    assert "vsmp/rf: mean unseen-class Macro-F1 over the 2 unseen sets 35.0 %" in out


def test_report_table_of_unseen_figures(tmp_path):
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    def record(method, fold, unseen_f1, capable):
        return {"method": method, "fold": fold, "seed": 0, "backbone": "rf", "budget": None,
                "macro_f1": 0.5, "unseen_macro_f1": unseen_f1, "seen_macro_f1": 0.9,
                "seen_as_unseen": 0.01, "unseen_as_seen": 1 - unseen_f1, "unseen_capable": capable}

    records = [record("real", "1", 0.0, False), record("real", "2", 0.0, False),
               record("vsmp", "1", 0.4, True), record("vsmp", "2", 0.6, True)]
    spec = TableSpec(id="unseen:main", records="unseen", kind="groups", methods=["real", "vsmp"],
                     metrics=[{"label": "unseen classes", "metric": "unseen"},
                              {"label": "seen taken for unseen", "metric": "seen_as_unseen"}])
    table = TableBuilder(spec, RecordSet("unseen", "vsmp-imu evaluate ...", None, None, {}, (), tuple(records))
                         ).render()
    assert "| unseen classes | 0.00 ± 0.00 | 50.00 ± 14.14 |" in table
    assert "| seen taken for unseen | 1.00 ± 0.00 | 1.00 ± 0.00 |" in table
    assert "Real-only cannot make windows of a class without real windows" in table
    assert "VSMP-IMU cannot" not in table
