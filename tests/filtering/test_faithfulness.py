"""Validator, class-faithfulness and redundancy filters."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.filtering.faithfulness import (
    class_keep_mask,
    class_verdicts,
    macro_f1,
    nn_thresholds,
    redundancy_verdicts,
    select_tau,
)
from vsmp_imu.filtering.validator import HarValidator


def _data(rng, n_per_class=40):
    xs, ys = [], []
    for cls, freq in enumerate((0.5, 2.0, 4.0)):
        t = np.arange(100) / 50.0
        base = np.sin(2 * np.pi * freq * t)[None, :, None] * np.ones((n_per_class, 1, 6))
        xs.append(base * (1 + cls) + rng.normal(0, 0.3, base.shape))
        ys.append(np.full(n_per_class, cls))
    return np.concatenate(xs), np.concatenate(ys)


def test_validator_learns_and_embeds():
    rng = np.random.default_rng(0)
    X, y = _data(rng)
    v = HarValidator(seed=1).fit(X, y, n_classes=4)
    Xt, yt = _data(rng, 10)
    proba = v.predict_proba(Xt)
    assert proba.shape == (30, 4)
    assert np.allclose(proba.sum(1), 1.0)
    assert (proba[:, 3] == 0).all()  # class absent from training
    assert (proba.argmax(1) == yt).mean() > 0.9
    emb = v.embed(Xt)
    assert emb.shape == (30, 32)
    again = HarValidator(seed=1).fit(X, y, n_classes=4).predict_proba(Xt)
    assert np.array_equal(proba, again)


def test_a_validator_that_saw_one_class_is_certain_of_it():
    """sklearn's MLP gives two columns for one class; the validator gives that class probability 1."""
    X, y = _data(np.random.default_rng(0))
    proba = HarValidator(seed=1).fit(X[y == 1], y[y == 1], n_classes=3).predict_proba(X)
    assert proba.shape == (len(X), 3) and (proba[:, 1] == 1).all() and (proba.sum(axis=1) == 1).all()


def test_class_verdicts_apply_both_conditions():
    proba = np.array([[0.9, 0.1], [0.55, 0.45], [0.2, 0.8]])
    verdicts = class_verdicts(proba, np.array([0, 0, 0]), tau=0.6)
    assert [v.passed for v in verdicts] == [True, False, False]
    assert "below tau_cls" in verdicts[1].reason
    assert "predicts class 1" in verdicts[2].reason


def test_select_tau_uses_the_validation_score():
    proba = np.array([[0.52, 0.48], [0.58, 0.42], [0.66, 0.34], [0.9, 0.1]])
    y = np.zeros(4, int)
    seen = []

    def score(keep):
        seen.append(int(keep.sum()))
        return {4: 0.5, 3: 0.9, 2: 0.7, 1: 0.6, 0: 0.1}[int(keep.sum())]

    tau, scores = select_tau(proba, y, score)
    assert tau == 0.55 and scores[0.55] == 0.9
    # 0.60 and 0.65 keep the same two windows: one model scores both
    assert seen == [4, 3, 2, 1]
    assert scores[0.60] == scores[0.65] == 0.7


def test_select_tau_on_threads_scores_each_mask_once_with_the_same_choice():
    from sklearn.ensemble import RandomForestClassifier

    rng = np.random.default_rng(11)
    proba = rng.dirichlet(np.ones(3), size=120)
    y = rng.integers(0, 3, 120)
    f_real, y_real = rng.normal(size=(90, 5)), rng.integers(0, 3, 90)
    f_syn = rng.normal(size=(120, 5)) + y[:, None] * 0.3
    calls = []

    def score(keep):
        calls.append(np.packbits(keep).tobytes())
        model = RandomForestClassifier(n_estimators=5, n_jobs=2, random_state=0)
        model.fit(np.concatenate([f_real[:60], f_syn[keep]]), np.concatenate([y_real[:60], y[keep]]))
        return macro_f1(y_real[60:], model.predict(f_real[60:]))

    serial = select_tau(proba, y, score)
    n_serial = len(calls)
    assert n_serial >= 3  # several distinct masks to share out
    calls.clear()
    threaded = select_tau(proba, y, score, threads=3)
    assert threaded == serial
    assert len(calls) == len(set(calls)) == n_serial


def test_keep_mask_agrees_with_the_verdicts():
    rng = np.random.default_rng(5)
    proba = rng.dirichlet(np.ones(4), size=300)
    y = rng.integers(0, 4, 300)
    validated = np.array([True, False, True, True])
    for tau in (0.3, 0.5, 0.7):
        for val in (None, validated):
            expected = [v.passed for v in class_verdicts(proba, y, tau, val)]
            assert class_keep_mask(proba, y, tau, val).tolist() == expected
    assert class_keep_mask(np.zeros((0, 4)), np.zeros(0, int), 0.5).shape == (0,)


def test_select_tau_tie_prefers_paper_default():
    tau, _ = select_tau(np.array([[0.9, 0.1]]), np.array([0]), lambda keep: 0.5)
    assert tau == pytest.approx(0.60)


def test_redundancy_threshold_and_greedy_rejection():
    rng = np.random.default_rng(3)
    real = rng.normal(size=(50, 8))
    labels = np.repeat([0, 1], 25)
    th = nn_thresholds(real, labels)
    assert set(th) >= {0, 1, -1} and all(v > 0 for v in th.values())
    base = rng.normal(size=8)
    syn = np.stack([base, base * 1.0001, -base, base])
    verdicts = redundancy_verdicts(syn, np.array([0, 0, 0, 1]), th)
    assert [v.passed for v in verdicts] == [True, False, True, True]
    skipped = redundancy_verdicts(syn, np.array([0, 0, 0, 1]), th, eligible=np.array([False, True, True, True]))
    assert [v.passed for v in skipped] == [False, True, True, True]


def test_classes_the_validator_cannot_judge_pass_with_a_reason():
    proba = np.array([[0.9, 0.1], [0.8, 0.2]])
    verdicts = class_verdicts(proba, np.array([1, 1]), tau=0.6, validated=np.array([True, False]))
    assert all(v.passed for v in verdicts)
    assert "not validated" in verdicts[0].reason
    judged = class_verdicts(proba, np.array([1, 1]), tau=0.6, validated=np.array([True, True]))
    assert not any(v.passed for v in judged)


def test_small_classes_use_the_pooled_nn_threshold():
    rng = np.random.default_rng(5)
    real = np.concatenate([rng.normal(size=(40, 8)), rng.normal(size=(3, 8)) * 5])
    labels = np.repeat([0, 1], [40, 3])
    th = nn_thresholds(real, labels, min_class_windows=10)
    assert th[1] == th[-1] and th[0] != th[-1]
