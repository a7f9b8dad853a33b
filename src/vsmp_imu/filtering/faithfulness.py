"""Class faithfulness and redundancy filters (appendix "Quality Filtering").

Class faithfulness keeps a synthetic window when the validator's
max_c p(c|X) >= tau_cls and argmax_c p(c|X) = its label; tau_cls is chosen from
{0.50, 0.55, 0.60, 0.65, 0.70} by validation Macro-F1 on training-fold
validation subjects. Redundancy rejects a window whose l2-normalized validator
embedding lies within tau_nn(y) of an already retained synthetic window of the
same class, tau_nn(y) = 5th percentile of within-class nearest-neighbour
distances among the real training windows.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from sklearn.metrics import f1_score
from sklearn.neighbors import NearestNeighbors

from vsmp_imu.executor import thread_map
from vsmp_imu.filtering.verdict import Verdict
from vsmp_imu.grounding import floors

TAU_CANDIDATES = (0.50, 0.55, 0.60, 0.65, 0.70)
TAU_DEFAULT = 0.60
NN_QUANTILE = 0.05


def class_verdicts(proba: np.ndarray, labels: np.ndarray, tau: float,
                   validated: np.ndarray | None = None) -> list[Verdict]:
    """One verdict per window from validator probabilities (N, C).

    `validated[c]` False marks a class the validator saw too few real windows
    of to judge it: its windows pass, with that reason recorded.
    """
    out = []
    for p, y in zip(proba, np.asarray(labels), strict=True):
        top = int(np.argmax(p))
        values = {"p_max": float(p[top]), "p_label": float(p[int(y)]), "tau_cls": tau}
        if validated is not None and not validated[int(y)]:
            out.append(Verdict(True, "class", "not validated: too few real training windows of the class",
                               values))
        elif top != int(y):
            out.append(Verdict(False, "class", f"validator predicts class {top}, not {int(y)}", values))
        elif p[top] < tau:
            out.append(Verdict(False, "class", f"confidence {p[top]:.2f} below tau_cls {tau:.2f}", values))
        else:
            out.append(Verdict(True, "class", "", values))
    return out


def class_keep_mask(proba: np.ndarray, labels: np.ndarray, tau: float,
                    validated: np.ndarray | None = None) -> np.ndarray:
    """Which windows `class_verdicts` passes, without building the verdicts."""
    proba = np.asarray(proba)
    labels = np.asarray(labels, dtype=np.int64)
    if len(proba) == 0:
        return np.zeros(0, bool)
    top = np.argmax(proba, axis=1)
    keep = (top == labels) & (proba[np.arange(len(proba)), top] >= tau)
    if validated is not None:
        keep |= ~np.asarray(validated, bool)[labels]
    return keep


def select_tau(
    proba_synthetic: np.ndarray,
    y_synthetic: np.ndarray,
    score_with: Callable[[np.ndarray], float],
    candidates: tuple[float, ...] = TAU_CANDIDATES,
    validated: np.ndarray | None = None,
    threads: int = 1,
) -> tuple[float, dict[float, float]]:
    """Pick tau_cls by validation Macro-F1.

    `score_with(keep_mask)` trains a model on the real training windows plus the
    kept synthetic windows and returns its Macro-F1 on the validation subjects.
    Candidates that keep the same windows share one score; the distinct masks are
    scored on `threads` threads (`score_with` must not depend on the order).
    Ties go to the candidate closest to the paper's 0.60.
    """
    keys, masks = [], {}
    for tau in candidates:
        keep = class_keep_mask(proba_synthetic, y_synthetic, tau, validated)
        keys.append(np.packbits(keep).tobytes())
        masks.setdefault(keys[-1], keep)
    scored = dict(zip(masks, thread_map(score_with, list(masks.values()), threads), strict=True))
    scores = {tau: float(scored[key]) for tau, key in zip(candidates, keys, strict=True)}
    best = max(candidates, key=lambda t: (round(scores[t], 10), -abs(t - TAU_DEFAULT)))
    return best, scores


def macro_f1(y_true: np.ndarray, y_pred: np.ndarray) -> float:
    labels = np.unique(y_true)
    return float(f1_score(y_true, y_pred, labels=labels, average="macro", zero_division=0))


def _normalize(z: np.ndarray) -> np.ndarray:
    return z / (np.linalg.norm(z, axis=1, keepdims=True) + 1e-12)


def nn_thresholds(real_embeddings: np.ndarray, real_labels: np.ndarray,
                  min_class_windows: int = floors.NN_MIN_WINDOWS) -> dict[int, float]:
    """tau_nn(y) per class.

    A class with fewer than `min_class_windows` real windows (a 5th percentile
    of a handful of distances says nothing) uses the pooled within-class
    nearest-neighbour distances of all classes.
    """
    z = _normalize(np.asarray(real_embeddings, dtype=np.float64))
    labels = np.asarray(real_labels)
    per_class: dict[int, np.ndarray] = {}
    for cls in np.unique(labels):
        zc = z[labels == cls]
        if len(zc) < 2:
            continue
        dist, _ = NearestNeighbors(n_neighbors=2).fit(zc).kneighbors(zc)
        per_class[int(cls)] = dist[:, 1]  # column 0 is the point itself
    pooled = np.concatenate(list(per_class.values())) if per_class else np.zeros(1)
    fallback = float(np.quantile(pooled, NN_QUANTILE))
    out = {int(c): float(np.quantile(v, NN_QUANTILE)) for c, v in per_class.items()
           if len(v) >= max(2, min_class_windows)}
    for cls in np.unique(labels):
        out.setdefault(int(cls), fallback)
    out[-1] = fallback
    return out


def redundancy_verdicts(embeddings: np.ndarray, labels: np.ndarray, thresholds: dict[int, float],
                        eligible: np.ndarray | None = None) -> list[Verdict]:
    """Greedy in the given order: a window is kept when farther than tau_nn from every kept one.

    Windows not `eligible` (already rejected by another filter) are skipped and
    never count as retained.
    """
    z = _normalize(np.asarray(embeddings, dtype=np.float64))
    labels = np.asarray(labels)
    eligible = np.ones(len(z), bool) if eligible is None else np.asarray(eligible, bool)
    kept = {int(c): np.empty((int((labels == c).sum()), z.shape[1])) for c in np.unique(labels)}
    n_kept = dict.fromkeys(kept, 0)
    out = []
    for i in range(len(z)):
        cls = int(labels[i])
        tau = thresholds.get(cls, thresholds.get(-1, 0.0))
        if not eligible[i]:
            out.append(Verdict(False, "redundancy", "not considered (rejected earlier)", {"tau_nn": tau}))
            continue
        others = kept[cls][: n_kept[cls]]
        dist = float(np.sqrt(((others - z[i]) ** 2).sum(axis=1).min())) if len(others) else float("inf")
        values = {"nn_distance": dist if np.isfinite(dist) else -1.0, "tau_nn": tau}
        if dist <= tau:
            out.append(Verdict(False, "redundancy", f"near-duplicate (distance {dist:.3f} <= tau_nn {tau:.3f})",
                               values))
        else:
            kept[cls][n_kept[cls]] = z[i]
            n_kept[cls] += 1
            out.append(Verdict(True, "redundancy", "", values))
    return out
