"""What each filter verdict records (its filter, its reason, its values), exact boundaries, and
results that must not depend on the input's dtype or on where a class's count sits."""

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
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter, Thresholds, motion_energy
from vsmp_imu.filtering.validator import HarValidator


def _filter(rng: np.random.Generator) -> MotionPlausibilityFilter:
    w = rng.normal(0, 1, (50, 20, 6))
    w[..., 1] += 9.81
    return MotionPlausibilityFilter(min_class_windows=1000).fit(w, np.zeros(50))


def _base() -> np.ndarray:
    base = np.zeros((20, 6))
    base[::2, 0], base[1::2, 0] = 3.0, -3.0  # energy 9, |a| = 3, |w| = 0
    return base


def test_thresholds_as_a_dict():
    assert Thresholds(1.0, 2.0, 3.0, 4).as_dict() == {"a_max": 1.0, "w_max": 2.0, "e_min": 3.0, "n_windows": 4}


def test_every_imu_rejection_names_the_imu_filter_and_keeps_its_values():
    f = _filter(np.random.default_rng(3))
    th = f.overall_
    loud, spin, quiet = _base(), _base(), _base() / 3 * np.sqrt(th.e_min) * 0.5
    loud[0, 2] = 2 * th.a_max
    spin[:, 3] = th.w_max + 0.01
    for window, key in ((loud, "max_acc"), (spin, "max_gyr"), (quiet, "energy")):
        v = f.check_window(window, 0)
        assert not v.passed and v.filter == "imu"
        assert set(v.values) == {"max_acc", "max_gyr", "energy", "a_max", "w_max", "e_min", "n_windows"}
        assert v.values[key] == pytest.approx({"max_acc": np.linalg.norm(window[:, :3], axis=1).max(),
                                               "max_gyr": th.w_max + 0.01,
                                               "energy": th.e_min / 4}[key])


def test_a_window_exactly_at_a_threshold_passes():
    f = _filter(np.random.default_rng(5))
    window = _base()
    window[::2, 3], window[1::2, 3] = 2.0, -2.0  # |w| = 2
    energy = float(motion_energy(window[None])[0])
    f.overall_ = Thresholds(a_max=3.0, w_max=2.0, e_min=energy, n_windows=50)  # hit exactly
    v = f.check_window(window, 0)
    assert (v.values["max_acc"], v.values["max_gyr"], v.values["energy"]) == (3.0, 2.0, energy)
    assert v.passed, v.reason


def test_float32_windows_give_the_float64_thresholds_and_verdicts():
    rng = np.random.default_rng(6)
    w = rng.normal(0, 1, (120, 20, 6)).astype(np.float32)
    w[..., 1] += 9.81
    labels = np.repeat([0, 1], 60)
    f32 = MotionPlausibilityFilter(min_class_windows=50).fit(w, labels)
    f64 = MotionPlausibilityFilter(min_class_windows=50).fit(w.astype(np.float64), labels)
    assert f32.overall_ == f64.overall_ and f32.per_class_ == f64.per_class_
    assert f32.check_windows(w, labels) == f64.check_windows(w.astype(np.float64), labels)


def test_an_empty_batch_gives_an_empty_boolean_mask():
    keep = class_keep_mask(np.zeros((0, 3)), np.zeros(0, int), 0.6)
    assert keep.dtype == bool and keep.shape == (0,)
    assert np.zeros(5)[keep].shape == (0,)  # usable as an index


def test_a_single_window_batch_is_judged():
    assert class_keep_mask(np.array([[0.9, 0.1]]), np.array([0]), 0.6).tolist() == [True]
    assert class_keep_mask(np.array([[0.9, 0.1]]), np.array([1]), 0.6).tolist() == [False]


def test_class_verdicts_keep_their_values_when_rejecting():
    proba = np.array([[0.55, 0.45], [0.2, 0.8]])
    verdicts = class_verdicts(proba, np.array([0, 0]), 0.6)
    assert [v.passed for v in verdicts] == [False, False]
    for v in verdicts:
        assert v.filter == "class" and v.values


def test_select_tau_passes_the_unvalidated_classes_through():
    """A class the validator cannot judge keeps all its windows at every tau, so every tau scores
    the same and the default wins; without `validated` the low-confidence windows would go."""
    proba = np.array([[0.55, 0.45], [0.52, 0.48], [0.9, 0.1]])
    y = np.array([0, 0, 0])
    seen = []

    def score(keep):
        seen.append(keep.copy())
        return float(keep.sum())

    best, scores = select_tau(proba, y, score, validated=np.array([False, True]))
    assert all(k.all() for k in seen) and best == 0.60
    assert set(scores.values()) == {3.0}


def test_macro_f1_scores_an_unpredicted_true_class_zero():
    assert macro_f1(np.array([0, 1]), np.array([0, 0])) == pytest.approx((2 / 3 + 0) / 2)


def test_a_class_with_exactly_two_windows_gets_its_own_threshold():
    z = np.array([[1.0, 0.0], [0.9, 0.1], [0.0, 1.0], [0.3, 1.0], [1.0, 1.0]])
    labels = np.array([0, 0, 1, 1, 2])
    out = nn_thresholds(z, labels)
    unit = z / np.linalg.norm(z, axis=1, keepdims=True)
    d0 = float(np.linalg.norm(unit[0] - unit[1]))
    d1 = float(np.linalg.norm(unit[2] - unit[3]))
    assert out[0] == pytest.approx(d0) and out[1] == pytest.approx(d1)
    pooled = float(np.quantile([d0, d0, d1, d1], 0.05))
    assert out[2] == pytest.approx(pooled) and out[-1] == pytest.approx(pooled)
    # a later class with one window does not stop the ones after it
    z2 = np.concatenate([z[4:5], z[:4]])
    out2 = nn_thresholds(z2, np.array([0, 1, 1, 2, 2]))
    assert out2[1] == pytest.approx(d0) and out2[2] == pytest.approx(d1)


def test_redundancy_compares_with_every_window_kept_so_far():
    z = np.array([[1.0, 0.0], [0.0, 1.0], [0.05, 1.0], [1.0, 0.04]])
    v = redundancy_verdicts(z, np.zeros(4, int), {0: 0.2})
    assert [x.passed for x in v] == [True, True, False, False]
    assert all(x.filter == "redundancy" for x in v)
    assert v[0].reason == "" and v[1].reason == ""


def test_the_validator_trains_at_most_max_iter_epochs_with_its_l2_penalty():
    rng = np.random.default_rng(7)
    x = rng.normal(size=(60, 5))
    y = (x[:, 0] > 0).astype(int)
    v = HarValidator(hidden=(8,), max_iter=3, seed=1).fit_features(x, y)
    assert v.model_.n_iter_ <= 3
    assert v.model_.alpha == 1e-3


def test_unvalidated_windows_pass_with_their_values():
    (v,) = class_verdicts(np.array([[0.2, 0.8]]), np.array([0]), 0.6, validated=np.array([False, True]))
    assert v.passed and v.reason == "not validated: too few real training windows of the class"
    assert v.values == {"p_max": 0.8, "p_label": 0.2, "tau_cls": 0.6}


def test_the_keep_mask_takes_labels_as_floats_and_validated_as_zeros_and_ones():
    proba = np.array([[0.2, 0.8], [0.9, 0.1], [0.55, 0.45]])
    labels = np.array([0.0, 0.0, 1.0])
    keep = class_keep_mask(proba, labels, 0.6, validated=np.array([1, 0]))
    assert keep.tolist() == [False, True, True]  # class 1 is not validated: its window passes


def test_float32_embeddings_give_the_float64_thresholds():
    rng = np.random.default_rng(8)
    z = rng.normal(size=(40, 6)).astype(np.float32)
    labels = np.repeat([0, 1], 20)
    assert nn_thresholds(z, labels) == nn_thresholds(z.astype(np.float64), labels)


def test_float32_embeddings_give_the_float64_redundancy_verdicts():
    rng = np.random.default_rng(9)
    z = rng.normal(size=(30, 6)).astype(np.float32)
    labels = np.repeat([0, 1, 2], 10)
    thresholds = nn_thresholds(z.astype(np.float64), labels)
    assert redundancy_verdicts(z, labels, thresholds) == redundancy_verdicts(z.astype(np.float64), labels, thresholds)
