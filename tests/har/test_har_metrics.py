"""Metrics: Macro-F1 over present classes, groups, head/tail, mean ± std."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.metrics import f1_score

from vsmp_imu.har.metrics import evaluate_predictions, macro_f1, macro_f1_from_confusion, mean_std

NAMES = ("a", "b", "c", "d")


def test_macro_f1_counts_classes_in_truth_or_predictions():
    y_true = np.array([0, 0, 1, 1])
    y_pred = np.array([0, 0, 1, 2])  # class 2 predicted but absent: F1 0 counts
    assert macro_f1(y_true, y_pred) == pytest.approx((1 + 2 / 3 + 0) / 3)
    assert macro_f1(y_true, y_pred, among=[0]) == 1.0
    assert macro_f1(y_true, y_pred, among=[3]) is None


def test_evaluate_predictions_fields():
    y_true = np.array([0, 0, 1, 1, 2, 2])
    y_pred = np.array([0, 1, 1, 1, 2, 0])
    m = evaluate_predictions(
        y_true, y_pred, NAMES, groups={"bc": ("b", "c")}, head=(0, 1), tail=(2, 3)
    )
    assert m["accuracy"] == pytest.approx(4 / 6)
    assert m["per_class_f1"]["d"] is None and m["per_class_support"]["a"] == 2
    assert np.asarray(m["confusion"]).sum() == 6
    assert m["group_macro_f1"]["bc"] == pytest.approx(
        np.mean([m["per_class_f1"]["b"], m["per_class_f1"]["c"]])
    )
    assert m["head_macro_f1"] == pytest.approx(
        np.mean([m["per_class_f1"]["a"], m["per_class_f1"]["b"]])
    )
    assert m["tail_macro_f1"] == pytest.approx(m["per_class_f1"]["c"])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 3)), min_size=1, max_size=40))
def test_confusion_macro_f1_matches_sklearn(pairs):
    y_true, y_pred = np.array(pairs).T
    from sklearn.metrics import confusion_matrix

    cm = confusion_matrix(y_true, y_pred, labels=[0, 1, 2, 3])
    present = sorted(set(y_true) | set(y_pred))
    expected = f1_score(y_true, y_pred, labels=present, average="macro", zero_division=0)
    assert macro_f1_from_confusion(cm, [0, 1, 2, 3]) == pytest.approx(expected)


def test_mean_std():
    assert mean_std([0.5, None, 0.7]) == (
        pytest.approx(0.6),
        pytest.approx(np.std([0.5, 0.7], ddof=1)),
        2,
    )
    assert mean_std([0.4]) == (0.4, 0.0, 1)
    assert mean_std([None]) == (None, None, 0)
