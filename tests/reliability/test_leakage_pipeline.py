"""Fold isolation of the VSMP-IMU pipeline under every protocol.

The held-out subject's windows carry a sentinel (channel 0 = 4242 m/s^2 over
the whole window; no real or synthetic window reads that). Every place where
the pipeline fits something on real data is instrumented: the fold's training
windows, the D_stat / D_rank split, TargetStatistics.fit (D_stat),
the nominal-mounting estimate, the windows that vote on a class's side
(every SMP's side is made free here, so the side from evidence runs for
every class), RankGrounder.fit (D_rank),
MotionPlausibilityFilter.fit, HarValidator.fit, the embeddings given to
nn_thresholds and the tau_cls selection model. A run of `evaluate` with the
`vsmp` method under lopo, low-resource and long-tail must never show the
sentinel to any of them; a positive control that passes the held-out windows
in on purpose shows that every instrument sees it.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import replace

import numpy as np
import pytest
from sklearn.ensemble import RandomForestClassifier

import vsmp_imu.pipeline.fold as fold_mod
from vsmp_imu.executor import LocalExecutor
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter
from vsmp_imu.filtering.validator import HarValidator
from vsmp_imu.grounding.rank import RankGrounder
from vsmp_imu.grounding.stats import TargetStatistics
from vsmp_imu.grounding.texture import TextureModel
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.synthetic import METHODS, synthetic_budget
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.fold import FoldGenerator
from vsmp_imu.pipeline.method import VsmpMethod
from vsmp_imu.pipeline.sources import SmpDirSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary

SENTINEL = 4242.0
HELD = "1"
SMALL = GenerationSpec(k=1, oversample=1.5, max_rounds=2)
INSTRUMENTS = ("fold_train", "split_labels", "d_stat", "mounting_d_stat", "side_votes", "texture", "d_rank",
               "plausibility", "validator", "nn_threshold_embeddings", "tau_model_fit", "tau_model_predict")
SEEN: dict[str, list[bool]] = defaultdict(list)


def has_sentinel(X) -> bool:
    return bool((np.asarray(X) == SENTINEL).any())


class SentinelDataset:
    """The small dataset with the held-out subject's windows marked."""

    def __init__(self, base) -> None:
        self.base = base
        self.info = base.info

    def windows(self, window_s: float = 2.0, overlap: float = 0.5) -> Windows:
        w = self.base.windows(window_s, overlap)
        X = w.X.copy()
        X[w.subjects == HELD, :, 0] = SENTINEL
        return Windows(X, w.y, w.subjects, w.label_names, w.channel_names, w.fs_hz, meta=dict(w.meta))


class SpyForest(RandomForestClassifier):
    """The quick model that scores tau_cls candidates on validation subjects (on ECDF
    features: the sentinel channel's quantiles are all the sentinel)."""

    def fit(self, X, y, sample_weight=None):
        SEEN["tau_model_fit"].append(has_sentinel(X))
        return super().fit(X, y, sample_weight)

    def predict(self, X):
        SEEN["tau_model_predict"].append(has_sentinel(X))
        return super().predict(X)


@pytest.fixture
def instruments(monkeypatch):
    SEEN.clear()
    embedded: dict[int, bool] = {}

    def wrap(owner, name, record):
        original = getattr(owner, name)

        def spy(*args, **kwargs):
            record(*args, **kwargs)
            return original(*args, **kwargs)

        monkeypatch.setattr(owner, name, spy)

    wrap(FoldGenerator, "generate",
         lambda self, info, train, *a, **k: SEEN["fold_train"].append(has_sentinel(train.X)))
    split = fold_mod.stat_rank_split
    monkeypatch.setattr(fold_mod, "stat_rank_split", lambda labels, seed, *a, **k: (
        SEEN["split_labels"].append(False), split(labels, seed, *a, **k))[1])
    wrap(fold_mod, "nominal_mountings",
         lambda spec, info, plan, sources, d_stat: SEEN["mounting_d_stat"].append(has_sentinel(d_stat.X)))
    monkeypatch.setattr(fold_mod, "side_is_free", lambda smp: True)
    wrap(fold_mod, "side_evidence",
         lambda info, train, label, plan, probes: SEEN["side_votes"].append(has_sentinel(train.X)))
    wrap(TargetStatistics, "fit", lambda self, windows, labels, *_: SEEN["d_stat"].append(has_sentinel(windows)))
    wrap(TextureModel, "fit", lambda self, windows, labels, threads=1: SEEN["texture"].append(has_sentinel(windows)))
    wrap(RankGrounder, "fit", lambda self, syn, real, *a, **k: SEEN["d_rank"].append(has_sentinel(real)))
    wrap(MotionPlausibilityFilter, "fit", lambda self, X, y: SEEN["plausibility"].append(has_sentinel(X)))
    wrap(HarValidator, "fit_features", lambda self, X, y, *a, **k: SEEN["validator"].append(has_sentinel(X)))
    embed = HarValidator.embed_features

    def spy_embed(self, X):
        out = embed(self, X)
        embedded[id(out)] = has_sentinel(X)
        return out

    monkeypatch.setattr(HarValidator, "embed_features", spy_embed)
    nn = fold_mod.nn_thresholds

    def spy_nn(embeddings, labels, *a, **k):
        SEEN["nn_threshold_embeddings"].append(embedded[id(embeddings)])
        return nn(embeddings, labels, *a, **k)

    monkeypatch.setattr(fold_mod, "nn_thresholds", spy_nn)
    monkeypatch.setattr(fold_mod, "RandomForestClassifier", SpyForest)
    return SEEN


@pytest.fixture(scope="module")
def marked(small_dataset):
    return SentinelDataset(load_dataset(small_dataset))


def _register_vsmp(monkeypatch, small_dataset):
    source = f"smp:{small_dataset.parent / 'smps'}"
    monkeypatch.setitem(METHODS, "vsmp", lambda **_: VsmpMethod(spec=replace(SMALL, source=source)))


@pytest.mark.parametrize("protocol,budgets,policy", [
    ("lopo", (None,), "uniform"),
    ("low-resource", (50.0,), "scarcity"),
    ("long-tail", (None,), "tail"),
])
def test_held_out_subject_reaches_no_fitted_part_of_the_pipeline(
        instruments, marked, small_dataset, monkeypatch, protocol, budgets, policy):
    _register_vsmp(monkeypatch, small_dataset)
    config = EvalConfig(dataset=marked.info.name, protocol=protocol, budgets=budgets, backbones=("rf",),
                        methods=("vsmp",), folds=(HELD,), alpha=0.5, policy=policy,
                        backbone_params={"rf": {"n_estimators": 10, "n_jobs": 1}})
    (record,) = Evaluation(config, marked).run().records
    assert record["n_synthetic"] > 0 and record["n_test"] > 0
    for name in INSTRUMENTS:
        assert instruments[name], f"instrument {name} never ran"
        assert not any(instruments[name]), f"the held-out subject reached {name} ({protocol})"


def test_the_instruments_see_a_deliberate_leak(instruments, marked, small_dataset):
    """Positive control: marked windows passed in as training data are seen by every instrument.

    Every subject is marked here, so no instrument can miss the mark by the luck of
    which subjects the pipeline holds aside for validation.
    """
    windows = marked.windows()
    assert has_sentinel(windows.where_subjects([HELD]).X)
    windows.X[..., 0] = SENTINEL
    library = ActivityLibrary.load()
    sources = SmpDirSource(small_dataset.parent / "smps", library).smps(marked.info.name,
                                                                        marked.info.label_names)
    budget = synthetic_budget(windows.class_counts(), 0.3)
    FoldGenerator(SMALL, LocalExecutor(1, show_progress=False), library=library).generate(
        marked.info, windows, sources, budget, seed=0, fold="leak")
    for name in INSTRUMENTS:
        if name == "split_labels":  # labels carry no sentinel; the split is checked through its products
            continue
        assert instruments[name] and any(instruments[name]), f"instrument {name} missed the leak"


UNSEEN_SENTINEL = 4343.0


class UnseenMarkedDataset(SentinelDataset):
    """Also marks every window of the unseen class (channel 1 = 4343 m/s^2), whoever's it is."""

    def __init__(self, base, unseen: str) -> None:
        super().__init__(base)
        self.unseen = base.info.label_names.index(unseen)

    def windows(self, window_s: float = 2.0, overlap: float = 0.5) -> Windows:
        w = super().windows(window_s, overlap)
        w.X[w.y == self.unseen, :, 1] = UNSEEN_SENTINEL
        return w


def test_unseen_class_reaches_no_fitted_part_of_the_pipeline(instruments, small_dataset, monkeypatch):
    """Unseen protocol: neither the held-out subject nor any window of the unseen class reaches
    D_stat, D_rank, the mounting estimate or the filters; the unseen class's samples are made all
    the same, grounded on the seen classes, and their provenance says the class had no evidence."""
    marked = UnseenMarkedDataset(load_dataset(small_dataset), "sitting")
    made: list[VsmpMethod] = []
    source = f"smp:{small_dataset.parent / 'smps'}"

    def factory(**_):
        made.append(VsmpMethod(spec=replace(SMALL, source=source)))
        return made[-1]

    monkeypatch.setitem(METHODS, "vsmp", factory)
    # SENTINEL marks the held-out subject, UNSEEN_SENTINEL the unseen class: the instruments test both
    monkeypatch.setattr(f"{__name__}.has_sentinel",
                        lambda X: bool(np.isin(np.asarray(X), (SENTINEL, UNSEEN_SENTINEL)).any()))
    config = EvalConfig(dataset=marked.info.name, protocol="unseen", unseen=("sitting",), backbones=("rf",),
                        methods=("vsmp",), folds=(HELD,), alpha=0.5, policy="uniform",
                        backbone_params={"rf": {"n_estimators": 10, "n_jobs": 1}})
    (record,) = Evaluation(config, marked).run().records
    assert record["n_synthetic_unseen"] > 0 and record["per_class_support"]["sitting"] > 0
    for name in INSTRUMENTS:
        assert instruments[name], f"instrument {name} never ran"
        assert not any(instruments[name]), f"the unseen class or the held-out subject reached {name}"
    records = made[0].last_output_.records
    unseen = [r for r in records if r.label == "sitting"]
    assert unseen and all(r.provenance.class_windows == 0 and r.provenance.class_evidence is False
                          for r in unseen)
    assert all(r.provenance.class_windows > 0 for r in records if r.label != "sitting")
