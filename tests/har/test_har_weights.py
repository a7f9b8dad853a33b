"""`--synthetic-weight`: classes balanced per source, a class's synthetic windows weighing a
fixed share of its real ones (`vsmp_imu.har.weights`), in the weights, the backbones and the
harness."""

from __future__ import annotations

import numpy as np
import pytest
from har_spies import MARK, MarkedSource

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.backbones import BACKBONES, RandomForestECDF, make_backbone
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.synthetic import METHODS
from vsmp_imu.har.weights import source_weights
from vsmp_imu.methods import register_all


def _mass(w, mask):
    return float(w[mask].sum())


def test_each_class_real_windows_weigh_alike_and_synthetic_ones_a_share_of_them():
    y = np.array([0] * 3 + [0] * 30 + [1] * 40 + [1] * 10 + [2] * 5)
    is_real = np.array([True] * 3 + [False] * 30 + [True] * 40 + [False] * 10 + [False] * 5)
    w = source_weights(y, is_real, 3, 0.5)
    assert w.mean() == pytest.approx(1.0)
    real0, syn0 = _mass(w, (y == 0) & is_real), _mass(w, (y == 0) & ~is_real)
    real1, syn1 = _mass(w, (y == 1) & is_real), _mass(w, (y == 1) & ~is_real)
    assert real0 == pytest.approx(real1)  # 3 real windows weigh as much as 40
    assert syn0 == pytest.approx(0.5 * real0) and syn1 == pytest.approx(0.5 * real1)  # 30 or 10 alike
    # class 2 has no real window: its synthetic windows weigh a whole class
    assert _mass(w, y == 2) == pytest.approx(real0)
    # within a class and source, every window weighs the same
    assert len(set(np.round(w[(y == 0) & ~is_real], 12))) == 1
    # with every window real, the weights are scikit-learn's balanced ones
    from sklearn.utils.class_weight import compute_class_weight

    y_real = np.array([0] * 5 + [1] * 20 + [2] * 3)
    balanced = compute_class_weight("balanced", classes=np.arange(3), y=y_real)
    assert source_weights(y_real, np.ones(len(y_real), bool), 3, 0.5) == pytest.approx(balanced[y_real])


@pytest.mark.parametrize("share", [0.0, -1.0, float("nan"), float("inf")])
def test_a_share_outside_range_is_refused(share):
    with pytest.raises(ConfigError, match="synthetic weight") as caught:
        source_weights(np.zeros(3, int), np.ones(3, bool), 1, share)
    assert caught.value.field == "--synthetic-weight"
    with pytest.raises(ValueError, match="2 labels and 3 source flags"):
        source_weights(np.zeros(2, int), np.ones(3, bool), 1, 0.5)


def _two_groups(seed=0):
    """Class 0 around 0, class 1 around 3 on channel 0, and a group of class-1 windows that
    sit where class 0 does (the windows a weight can silence)."""
    rng = np.random.default_rng(seed)
    X = rng.normal(0, 0.3, (120, 20, 6)).astype(np.float32)
    y = np.r_[np.zeros(40, int), np.ones(40, int), np.ones(40, int)]
    X[40:80, :, 0] += 3.0
    test = rng.normal(0, 0.3, (50, 20, 6)).astype(np.float32)
    return X, y, test


@pytest.mark.parametrize("name", ["rf", "dclstm"])
def test_per_window_weights_decide_what_a_backbone_learns(name):
    X, y, test = _two_groups()
    est = BACKBONES[name]._get_test_params()
    if name == "dclstm":
        est = {**est, "max_epochs": 30, "patience": 30}
    heavy = np.r_[np.ones(80), np.full(40, 50.0)]  # the misplaced class-1 windows dominate
    light = np.r_[np.ones(80), np.full(40, 1e-3)]  # they hardly count
    as_one = (make_backbone(name, **est).fit(X, y, sample_weight=heavy).predict(test) == 1).mean()
    as_zero = (make_backbone(name, **est).fit(X, y, sample_weight=light).predict(test) == 0).mean()
    assert as_one > 0.8 and as_zero > 0.8


def test_a_network_refuses_weights_of_the_wrong_length():
    X, y, _ = _two_groups()
    with pytest.raises(ValidationError, match="sample weights"):
        make_backbone("dclstm", **BACKBONES["dclstm"]._get_test_params()).fit(X, y, sample_weight=np.ones(3))


SEEN: list[dict] = []


class WeightRecordingRF(RandomForestECDF):
    def fit(self, X, y, X_val=None, y_val=None, sample_weight=None):
        SEEN.append({"class_weight": self.class_weight, "y": np.asarray(y), "w": sample_weight,
                     "synthetic": np.asarray(X)[:, 0, 0] == MARK})
        return super().fit(X, y, X_val, y_val, sample_weight=sample_weight)


class NoWeightsRF(RandomForestECDF):
    def fit(self, X, y, X_val=None, y_val=None):
        return super().fit(X, y, X_val, y_val)


@pytest.fixture
def recording(monkeypatch):
    SEEN.clear()
    monkeypatch.setitem(BACKBONES, "wrec-rf", WeightRecordingRF)
    monkeypatch.setitem(BACKBONES, "now-rf", NoWeightsRF)
    monkeypatch.setitem(METHODS, "marked", MarkedSource)


def _config(backbone="wrec-rf", class_weight="balanced", **kw) -> EvalConfig:
    register_all()
    params = {"n_estimators": 5, "n_jobs": 1, **({"class_weight": class_weight} if class_weight else {})}
    base = dict(dataset="tiny", protocol="low-resource", budgets=(50.0,), backbones=(backbone,),
                methods=("real", "classical"), folds=("3",), seeds=(0,), alpha=1.0, policy="scarcity",
                backbone_params={backbone: params}, synthetic_weight=0.5)
    return EvalConfig(**{**base, **kw})


def test_the_harness_weighs_synthetic_windows_and_leaves_real_only_balanced(tiny_dataset, recording):
    Evaluation(_config(methods=("real", "marked")), tiny_dataset).run()
    real, marked = SEEN
    # Real-only: the balanced forest itself, no per-window weights
    assert real["w"] is None and real["class_weight"] == "balanced" and not real["synthetic"].any()
    # with synthetic windows the source weights replace the forest's class weights
    assert marked["class_weight"] is None and len(marked["w"]) == len(marked["y"])
    w, y, synthetic = marked["w"], marked["y"], marked["synthetic"]
    assert synthetic.any() and (~synthetic).any()
    real_mass = {c: w[(y == c) & ~synthetic].sum() for c in np.unique(y[~synthetic])}
    assert max(real_mass.values()) == pytest.approx(min(real_mass.values()))  # classes alike
    for c in np.unique(y[synthetic]):  # each class's synthetic windows: half its real ones
        assert w[(y == c) & synthetic].sum() == pytest.approx(0.5 * real_mass[c])


def test_the_digest_changes_for_synthetic_methods_only(tiny_dataset):
    on, off = Evaluation(_config("rf"), tiny_dataset), Evaluation(_config("rf", synthetic_weight=None), tiny_dataset)
    assert on._digest("rf", "real") == off._digest("rf", "real")
    assert on._digest("rf", "classical") != off._digest("rf", "classical")
    assert Evaluation(_config("rf", synthetic_weight=0.25), tiny_dataset)._digest("rf", "classical") != on._digest(
        "rf", "classical")


def test_a_synthetic_weight_needs_balanced_backbones_that_take_weights(recording):
    with pytest.raises(ConfigError, match="rf not balanced") as caught:
        _config("rf", class_weight=None).check()
    assert caught.value.field == "--synthetic-weight" and "--class-weight balanced" in caught.value.allowed
    with pytest.raises(ConfigError, match="now-rf take no per-window weights"):
        _config("now-rf").check()
    with pytest.raises(ConfigError, match="out of range"):
        _config("rf", synthetic_weight=0.0).check()
    assert _config("rf", class_weight=None, synthetic_weight=None).check().synthetic_weight is None


def test_the_command_line_refuses_a_synthetic_weight_without_balanced_classes(cli, fixtures_dir, tmp_path):
    args = ("evaluate", "--dataset", fixtures_dir / "generic" / "dataset.yaml", "--protocol", "long-tail",
            "--rho", "2", "--methods", "real,classical", "--backbones", "rf", "--jobs", "1",
            "--synthetic-weight", "0.5", "-o", tmp_path / "out")
    code, stdout, stderr = cli(*args[:-2], "--class-weight", "none", "-o", tmp_path / "none")
    assert code == 2 and "needs balanced classes" in stdout + stderr
    code, stdout, _ = cli(*args)  # balanced classes are the default
    assert code == 0, stdout


def test_the_do_no_harm_fits_are_weighted_alike(tiny_dataset, recording):
    Evaluation(_config(methods=("marked",), share_selection="class"), tiny_dataset).run()
    assert len(SEEN) > 2  # the choice's fits and the final one
    for fit in SEEN:
        assert (fit["w"] is None) == (not fit["synthetic"].any())
        assert (fit["class_weight"] is None) == fit["synthetic"].any()


def test_the_report_says_how_the_windows_were_weighed(tiny_dataset):
    from vsmp_imu.har.report import results_markdown, weights_text

    assert weights_text({"backbones": ["rf"], "backbone_params": {}}) == "class weights none"
    weighed = {"backbones": ["rf", "rf-seg"], "synthetic_weight": 0.5,
               "backbone_params": {"rf": {"class_weight": "balanced"}, "rf-seg": {"class_weight": "balanced"}}}
    assert weights_text(weighed) == ("class weights balanced (per source: a class's synthetic windows "
                                     "together 0.5 times its real ones)")
    results = Evaluation(_config("rf", methods=("real",)), tiny_dataset).run()
    assert "class weights balanced (per source" in results_markdown(results.to_json())
