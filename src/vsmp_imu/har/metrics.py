"""Metrics (paper, Evaluation Metrics): Macro-F1 first, accuracy, per-class
precision/recall/F1, confusion matrices, and Macro-F1 over class groups."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from sklearn.metrics import confusion_matrix, f1_score, precision_recall_fscore_support


def _labels_seen(
    y_true: np.ndarray, y_pred: np.ndarray, among: Sequence[int] | None = None
) -> list[int]:
    """Classes present in the truth or the predictions (optionally limited to `among`)."""
    seen = set(np.unique(y_true).tolist()) | set(np.unique(y_pred).tolist())
    if among is not None:
        seen &= set(int(c) for c in among)
    return sorted(seen)


def macro_f1(
    y_true: np.ndarray, y_pred: np.ndarray, among: Sequence[int] | None = None
) -> float | None:
    """Unweighted mean F1 over the classes present in the truth or the predictions.

    With `among`, only those classes count (head, tail or a named group);
    None when none of them occurs.
    """
    labels = _labels_seen(y_true, y_pred, among)
    if not labels:
        return None
    return float(f1_score(y_true, y_pred, labels=labels, average="macro", zero_division=0))


def evaluate_predictions(
    y_true: np.ndarray,
    y_pred: np.ndarray,
    label_names: Sequence[str],
    groups: dict[str, Sequence[str]] | None = None,
    head: Sequence[int] | None = None,
    tail: Sequence[int] | None = None,
) -> dict[str, Any]:
    """Every metric of one fold. Per-class values are None for a class that is
    neither in the truth nor predicted."""
    y_true = np.asarray(y_true)
    y_pred = np.asarray(y_pred)
    n = len(label_names)
    precision, recall, f1, support = precision_recall_fscore_support(
        y_true, y_pred, labels=list(range(n)), zero_division=0
    )
    seen = set(_labels_seen(y_true, y_pred))

    def per_class(values: np.ndarray) -> dict[str, float | None]:
        return {
            name: (float(values[i]) if i in seen else None) for i, name in enumerate(label_names)
        }

    confusion = confusion_matrix(y_true, y_pred, labels=list(range(n)))
    return {
        "macro_f1": macro_f1(y_true, y_pred),
        "accuracy": float(np.mean(y_true == y_pred)) if len(y_true) else None,
        "per_class_f1": per_class(f1),
        "per_class_precision": per_class(precision),
        "per_class_recall": per_class(recall),
        "per_class_support": {name: int(support[i]) for i, name in enumerate(label_names)},
        "confusion": confusion.tolist(),
        "head_macro_f1": macro_f1(y_true, y_pred, head) if head is not None else None,
        "tail_macro_f1": macro_f1(y_true, y_pred, tail) if tail is not None else None,
        "group_macro_f1": group_macro_f1(confusion, label_names, groups or {}),
    }


def macro_f1_from_confusion(confusion: np.ndarray, among: Sequence[int]) -> float | None:
    """Macro-F1 over the classes `among` that occur in the truth or the predictions of a
    confusion matrix (rows: truth, columns: predictions); None when none occurs."""
    confusion = np.asarray(confusion, dtype=float)
    tp = np.diag(confusion)
    truth, predicted = confusion.sum(axis=1), confusion.sum(axis=0)
    scores = [2 * tp[c] / (truth[c] + predicted[c]) for c in among if truth[c] + predicted[c] > 0]
    return float(np.mean(scores)) if scores else None


def group_macro_f1(
    confusion: np.ndarray, label_names: Sequence[str], groups: dict[str, Sequence[str]]
) -> dict[str, float | None]:
    """Macro-F1 of each named group of classes (e.g. HAPT12's transitions)."""
    names = list(label_names)
    return {
        g: macro_f1_from_confusion(confusion, [names.index(m) for m in members if m in names])
        for g, members in groups.items()
    }


def unseen_metrics(confusion: np.ndarray, unseen: Sequence[int]) -> dict[str, float | None]:
    """The unseen protocol's figures from a confusion matrix (rows: truth): Macro-F1 over the
    unseen classes and over the seen ones, the share of seen-class test windows predicted as
    an unseen class (`seen_as_unseen`) and of unseen-class windows predicted as a seen one
    (`unseen_as_seen`); None where the test holds no window of that side."""
    confusion = np.asarray(confusion, dtype=float)
    is_unseen = np.zeros(len(confusion), bool)
    is_unseen[list(unseen)] = True

    def share(truth: np.ndarray, predicted: np.ndarray) -> float | None:
        total = confusion[truth].sum()
        return float(confusion[np.ix_(truth, predicted)].sum() / total) if total else None

    return {
        "unseen_macro_f1": macro_f1_from_confusion(confusion, np.flatnonzero(is_unseen).tolist()),
        "seen_macro_f1": macro_f1_from_confusion(confusion, np.flatnonzero(~is_unseen).tolist()),
        "seen_as_unseen": share(~is_unseen, is_unseen),
        "unseen_as_seen": share(is_unseen, ~is_unseen),
    }


def mean_std(values: Sequence[float | None]) -> tuple[float | None, float | None, int]:
    """Mean, sample standard deviation (0 for a single value) and count, skipping None."""
    vals = np.array([v for v in values if v is not None], dtype=float)
    if len(vals) == 0:
        return None, None, 0
    std = float(vals.std(ddof=1)) if len(vals) > 1 else 0.0
    return float(vals.mean()), std, int(len(vals))
