"""One contract suite run over every backbone (aeon/scikit-learn style)."""

from __future__ import annotations

import os

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.metrics import f1_score

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.backbones import BACKBONES, make_backbone
from vsmp_imu.har.backbones.neural import validation_score
from vsmp_imu.har.features import ecdf_features, ecdf_levels, segment_means
from vsmp_imu.har.normalize import ChannelStandardizer


def _toy(n=90, t=40, c=6, n_classes=3, seed=0):
    rng = np.random.default_rng(seed)
    y = np.arange(n) % n_classes
    X = rng.normal(0, 1, (n, t, c)).astype(np.float32)
    X[:, :, 0] += 3 * y[:, None]  # class shifts channel 0
    X[:, :, 1] *= 1 + y[:, None]  # and the spread of channel 1
    return X, y


def _make(name, **extra):
    cls = BACKBONES[name]
    return cls(**{**cls._get_test_params(), **extra})


@pytest.fixture(params=sorted(BACKBONES))
def name(request):
    return request.param


def test_parameters_are_stored_untouched(name):
    est = _make(name, random_state=7)
    params = est.get_params()
    assert params["random_state"] == 7
    assert clone(est).get_params() == params
    assert not [k for k in vars(est) if k.endswith("_")]  # nothing learned before fit


def test_fit_predict_shapes_and_probabilities(name):
    X, y = _toy()
    est = _make(name)
    assert est.fit(X[:60], y[:60], X[60:], y[60:]) is est
    assert est.classes_.tolist() == [0, 1, 2]
    pred = est.predict(X)
    proba = est.predict_proba(X)
    assert pred.shape == (90,) and set(pred) <= {0, 1, 2}
    assert proba.shape == (90, 3) and np.allclose(proba.sum(axis=1), 1.0)
    assert (proba >= 0).all()
    emb = est.embed(X[:5])
    assert emb.ndim == 2 and emb.shape[0] == 5 and emb.shape[1] > 0 and np.isfinite(emb).all()


def test_same_seed_same_model(name):
    X, y = _toy()
    a = _make(name, random_state=3).fit(X[:60], y[:60], X[60:], y[60:])
    b = _make(name, random_state=3).fit(X[:60], y[:60], X[60:], y[60:])
    assert np.array_equal(a.predict_proba(X), b.predict_proba(X))
    assert np.array_equal(a.embed(X), b.embed(X))


def test_classes_missing_from_training(name):
    X, y = _toy()
    keep = y != 1
    est = _make(name).fit(X[keep], y[keep])
    assert est.classes_.tolist() == [0, 2]
    assert set(est.predict(X)) <= {0, 2} and est.predict_proba(X).shape == (90, 2)


def test_make_backbone_registry():
    assert set(BACKBONES) == {"rf", "rf-seg", "dclstm", "dclstm-attn", "bilstm-attn"}
    assert make_backbone("dclstm", max_epochs=3).max_epochs == 3
    with pytest.raises(ConfigError, match="takes no parameter.*n_jobs") as err:
        make_backbone("dclstm", max_epochs=3, n_jobs=4)  # n_jobs is not one of its params
    assert err.value.field == "backbone_params" and "max_epochs" in err.value.allowed
    with pytest.raises(ConfigError, match="unknown backbone"):
        make_backbone("svm")


def test_random_forest_learns_the_toy_problem():
    X, y = _toy(n=300)
    est = make_backbone("rf", n_estimators=30, n_jobs=1).fit(X[:200], y[:200])
    assert f1_score(y[200:], est.predict(X[200:]), average="macro") > 0.9


def test_neural_early_stopping_keeps_the_best_epoch():
    X, y = _toy(n=150)
    est = make_backbone(
        "dclstm",
        **{
            **BACKBONES["dclstm"]._get_test_params(),
            "max_epochs": 6,
            "patience": 2,
            "batch_size": 32,
        },
    )
    est.fit(X[:100], y[:100], X[100:], y[100:])
    assert 1 <= est.best_epoch_ <= est.n_epochs_ <= 6
    assert len(est.history_) == est.n_epochs_
    best = est.history_[est.best_epoch_ - 1]["val_macro_f1"]
    assert best == max(h["val_macro_f1"] for h in est.history_)
    assert f1_score(y[100:], est.predict(X[100:]), average="macro") == pytest.approx(best)


def test_balanced_class_weights_weigh_the_networks_loss_by_inverse_class_counts():
    from sklearn.utils.class_weight import compute_class_weight

    rng = np.random.default_rng(0)
    y = np.r_[np.zeros(110, int), np.ones(110, int), np.full(20, 2)]  # class 2 is rare
    X = rng.normal(0, 1, (len(y), 40, 6)).astype(np.float32)
    X[:, :, 0] += 0.8 * y[:, None]
    plain = _make("dclstm", max_epochs=5).fit(X, y)
    balanced = _make("dclstm", max_epochs=5, class_weight="balanced").fit(X, y)
    weights = balanced._loss_weights(np.searchsorted(balanced.classes_, y)).cpu().numpy()
    assert weights == pytest.approx(compute_class_weight("balanced", classes=np.arange(3), y=y))
    assert plain._loss_weights(y) is None
    # on windows of the three classes alike, the rare class is predicted where it was not
    X_test = rng.normal(0, 1, (300, 40, 6)).astype(np.float32)
    X_test[:, :, 0] += 0.8 * (np.arange(300) % 3)[:, None]
    assert (balanced.predict(X_test) == 2).sum() > (plain.predict(X_test) == 2).sum() + 50
    with pytest.raises(ValidationError, match="class_weight"):
        _make("dclstm", max_epochs=1, class_weight="equal").fit(X, y)


def test_validation_score_averages_over_the_validation_classes_only():
    y_true = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    y_pred = np.array([0, 0, 0, 2, 1, 1, 1, 1])  # one window of class 0 taken for class 2
    # class 0: precision 3/3, recall 3/4 -> F1 6/7; class 1: F1 1; class 2 is not in validation
    assert validation_score(y_true, y_pred) == pytest.approx((6 / 7 + 1) / 2)
    # the same error as a confusion between validation classes costs about as much
    assert validation_score(y_true, np.array([0, 0, 0, 1, 1, 1, 1, 1])) == pytest.approx(
        (6 / 7 + 8 / 9) / 2
    )
    # counting the absent class as a zero (the old score) would have cut a third off
    assert f1_score(y_true, y_pred, average="macro") == pytest.approx((6 / 7 + 1) / 3)


def test_early_stopping_with_a_class_missing_from_validation():
    X, y = _toy(n=150)
    val = np.flatnonzero(np.arange(150) >= 100)
    val = val[y[val] != 2]  # the unseen protocol: a class with training windows only
    est = make_backbone(
        "dclstm", **{**BACKBONES["dclstm"]._get_test_params(), "max_epochs": 4, "patience": 2}
    )
    est.fit(X[:100], y[:100], X[val], y[val])
    best = est.history_[est.best_epoch_ - 1]["val_macro_f1"]
    assert best == pytest.approx(validation_score(y[val], est.predict(X[val])))
    assert best == max(h["val_macro_f1"] for h in est.history_)


@pytest.mark.parametrize("name", ["dclstm", "bilstm-attn"])
def test_small_training_sets_get_several_steps_per_epoch(name, monkeypatch):
    est = make_backbone(name, **BACKBONES[name]._get_test_params())
    est.set_params(batch_size=1024, min_steps=8, max_epochs=2)
    assert est._batch_size(113) == 15  # a 1 % budget: 8 steps, not 1
    assert est._batch_size(20000) == 1024  # large sets keep the paper's batch
    sizes = []
    original = est._batches

    def spy(n, generator=None, size=None):
        sizes.append(size)
        return original(n, generator, size)

    monkeypatch.setattr(est, "_batches", spy)
    X, y = _toy(n=100)
    est.fit(X, y)
    assert sizes[:2] == [13, 13]  # ceil(100 / 8) in both epochs


def test_ecdf_features_are_window_quantiles():
    levels = ecdf_levels(15)
    assert levels[0] == pytest.approx(1 / 16) and levels[-1] == pytest.approx(15 / 16)
    X = np.stack([np.arange(101, dtype=np.float32)[:, None] * [1, -1]])  # one window, 2 channels
    feats = ecdf_features(X, 15)
    assert feats.shape == (1, 30)
    assert np.allclose(feats[0, :15], 100 * levels)  # channel-major, channel 0 first
    assert np.allclose(feats[0, 15:], -100 * levels[::-1])


def test_segment_means_follow_the_window_in_order():
    X = np.stack([np.arange(100, dtype=np.float32)[:, None] * [1, -1]])  # one rising, one falling channel
    means = segment_means(X, 4)
    assert means.shape == (1, 8)  # segment-major: (segment 0: ch 0, ch 1), (segment 1: ...), ...
    assert np.allclose(means[0, ::2], [12, 37, 62, 87]) and np.allclose(means[0, 1::2], [-12, -37, -62, -87])
    assert np.allclose(segment_means(X, 1), X.mean(axis=1))
    for bad in (0, 101):
        with pytest.raises(ValidationError, match="segments"):
            segment_means(X, bad)


def test_segment_forest_tells_a_window_from_its_time_reversal():
    """The paper's ECDF forest cannot: a window and its reversal have the same quantiles."""
    rng = np.random.default_rng(0)
    ramp = np.linspace(-1, 1, 50, dtype=np.float32)
    X = np.stack([ramp * (1 if i % 2 else -1) for i in range(200)])[:, :, None]
    X = X + rng.normal(0, 0.05, X.shape).astype(np.float32)
    y = np.arange(200) % 2  # class 1 rises, class 0 falls
    scores = {}
    for name in ("rf", "rf-seg"):
        est = make_backbone(name, n_estimators=30, n_jobs=1).fit(X[:100], y[:100])
        scores[name] = f1_score(y[100:], est.predict(X[100:]), average="macro")
    assert scores["rf-seg"] > 0.95 and scores["rf"] < 0.75
    assert make_backbone("rf-seg").embed(X[:3]).shape == (3, 15 + 8)
    assert make_backbone("rf").embed(X[:3]).shape == (3, 15)


def test_standardizer_uses_fit_statistics_only():
    rng = np.random.default_rng(0)
    train = rng.normal(5, 2, (50, 20, 3))
    other = rng.normal(-100, 50, (10, 20, 3))
    norm = ChannelStandardizer().fit(train)
    z = norm.transform(train)
    assert np.allclose(z.mean(axis=(0, 1)), 0, atol=1e-5) and np.allclose(
        z.std(axis=(0, 1)), 1, atol=1e-4
    )
    assert np.allclose(norm.transform(other), (other - norm.mean_) / norm.scale_, atol=1e-4)


def test_device_names_are_checked():
    from vsmp_imu.har.backbones.neural import resolve_device

    torch = pytest.importorskip("torch")
    assert resolve_device("cpu") == torch.device("cpu")
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    for bad in ("tpu9", "", "cuda:99"):
        with pytest.raises(ConfigError) as err:
            resolve_device(bad)
        assert err.value.field == "--device"
    if not torch.cuda.is_available():
        with pytest.raises(ConfigError, match="not available"):
            resolve_device("cuda")


def test_a_cuda_device_fixes_the_cublas_workspace(monkeypatch):
    """cuBLAS is deterministic only with a fixed workspace: set for CUDA, left alone for the CPU
    and when the user has chosen one."""
    from vsmp_imu.har.backbones.neural import resolve_device

    torch = pytest.importorskip("torch")
    monkeypatch.delenv("CUBLAS_WORKSPACE_CONFIG", raising=False)
    resolve_device("cpu")
    assert "CUBLAS_WORKSPACE_CONFIG" not in os.environ
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    monkeypatch.setattr(torch.cuda, "device_count", lambda: 1)
    assert resolve_device("auto").type == "cuda"
    assert os.environ["CUBLAS_WORKSPACE_CONFIG"] == ":4096:8"
    monkeypatch.setenv("CUBLAS_WORKSPACE_CONFIG", ":16:8")
    resolve_device("cuda:0")
    assert os.environ["CUBLAS_WORKSPACE_CONFIG"] == ":16:8"


def test_auto_device_trains_and_predicts_like_cpu():
    """On a machine without CUDA, `auto` is the CPU: the same model bit for bit."""
    torch = pytest.importorskip("torch")
    if torch.cuda.is_available():
        pytest.skip("a CUDA device is present: auto is not the CPU here")
    X, y = _toy(n=60)
    params = {**BACKBONES["dclstm"]._get_test_params(), "max_epochs": 2}
    cpu = make_backbone("dclstm", **params, device="cpu").fit(X, y)
    auto = make_backbone("dclstm", **params, device="auto").fit(X, y)
    assert np.array_equal(cpu.predict_proba(X), auto.predict_proba(X))


@pytest.mark.skipif(not __import__("torch").cuda.is_available(), reason="needs a CUDA device")
def test_cuda_training_runs_and_predicts():
    X, y = _toy(n=60)
    params = {**BACKBONES["dclstm"]._get_test_params(), "max_epochs": 2}
    gpu = make_backbone("dclstm", **params, device="cuda").fit(X, y)
    assert gpu.predict_proba(X).shape == (60, len(np.unique(y)))
