"""Exact contracts of the quality filters: the appendix constants, each threshold from its
definition, the pass/fail boundaries and the verdicts' reasons and values."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.filtering import plausibility as pl
from vsmp_imu.filtering.faithfulness import (
    NN_QUANTILE,
    TAU_CANDIDATES,
    TAU_DEFAULT,
    class_keep_mask,
    class_verdicts,
    macro_f1,
    nn_thresholds,
    redundancy_verdicts,
    select_tau,
)
from vsmp_imu.filtering.plausibility import MotionPlausibilityFilter, motion_energy
from vsmp_imu.filtering.validator import HarValidator
from vsmp_imu.filtering.verdict import Verdict, first_failure


def test_appendix_constants():
    assert abs(pl.A_CAP / 6 - 9.81) < 0.01 and pl.W_CAP == 35.0 and pl.E_FLOOR == 1e-4  # 6 g
    assert pl.MAX_STEP_FRACTION == 0.20 and pl.MIN_CLASS_WINDOWS == 100
    assert TAU_CANDIDATES == (0.50, 0.55, 0.60, 0.65, 0.70) and TAU_DEFAULT == 0.60 and NN_QUANTILE == 0.05
    f = MotionPlausibilityFilter()
    assert (f.min_class_windows, f.max_step_fraction) == (100, 0.20)


def _windows(rng, n=30, t=20):
    w = rng.normal(0, 1, (n, t, 6))
    w[..., 1] += 9.81
    return w


def _robust(values, cap):
    mad = np.median(np.abs(values - np.median(values)))
    return min(cap, np.quantile(values, 0.999) + 3 * mad)


def test_motion_energy_by_definition():
    rng = np.random.default_rng(0)
    w = _windows(rng, 4)
    acc = w[..., :3] - w[..., :3].mean(1, keepdims=True)
    gyr = w[..., 3:] - w[..., 3:].mean(1, keepdims=True)
    want = [np.mean(np.sum(acc[i] ** 2, 1) + 0.1 * np.sum(gyr[i] ** 2, 1)) for i in range(4)]
    assert np.allclose(motion_energy(w), want)


def test_thresholds_follow_their_definitions_per_class_and_pooled():
    rng = np.random.default_rng(1)
    w = _windows(rng, 40)
    w[20:] *= np.array([3, 3, 3, 20, 20, 20])  # class 1: large gyro: w_max hits the cap
    labels = np.repeat([0, 1], 20)
    f = MotionPlausibilityFilter(min_class_windows=20).fit(w, labels)
    for cls, th in ((0, f.per_class_[0]), (1, f.per_class_[1]), (None, f.overall_)):
        part = w if cls is None else w[labels == cls]
        acc = np.linalg.norm(part[..., :3], axis=-1).ravel()
        gyr = np.linalg.norm(part[..., 3:], axis=-1).ravel()
        assert th.a_max == pytest.approx(_robust(acc, pl.A_CAP))
        assert th.w_max == pytest.approx(_robust(gyr, pl.W_CAP))
        assert th.e_min == pytest.approx(max(1e-4, np.quantile(motion_energy(part), 0.01)))
        assert th.n_windows == len(part)
    assert f.per_class_[1].w_max == pl.W_CAP
    assert f.thresholds_for(1) is f.per_class_[1] and f.thresholds_for(7) is f.overall_
    still = MotionPlausibilityFilter().fit(np.zeros((3, 10, 6)), np.zeros(3))
    assert still.overall_.e_min == pl.E_FLOOR and list(still.per_class_) == []


def test_min_class_windows_is_inclusive_and_fit_checks_input():
    rng = np.random.default_rng(2)
    w = _windows(rng, 39)
    labels = np.array([0] * 20 + [1] * 19)
    f = MotionPlausibilityFilter(min_class_windows=20).fit(w, labels)
    assert list(f.per_class_) == [0]
    message = r"^fit needs real windows \(N, T, 6\) and N labels, N > 0$"
    for bad_w, bad_y in ((w[:0], labels[:0]), (w, labels[:-1]), (w[0], labels), (w[..., :5], labels)):
        with pytest.raises(ValueError, match=message):
            MotionPlausibilityFilter().fit(bad_w, bad_y)


def test_window_verdict_boundaries_reasons_and_values():
    rng = np.random.default_rng(3)
    f = MotionPlausibilityFilter(min_class_windows=1000).fit(_windows(rng, 50), np.zeros(50))
    th = f.overall_
    base = np.zeros((20, 6))
    base[::2, 0], base[1::2, 0] = 3.0, -3.0  # energy exactly 9, |a| = 3, |w| = 0
    assert th.e_min < 9.0 < th.a_max**2
    ok = f.check_window(base, 0)
    assert ok == Verdict(True, "imu", "", {"max_acc": 3.0, "max_gyr": 0.0, "energy": 9.0, **th.as_dict()})
    at_a = base.copy()
    at_a[0, 2] = np.sqrt(th.a_max**2 - 9.0)
    assert f.check_window(at_a, 0).passed  # |a| == a_max passes
    over = at_a.copy()
    over[0, 2] *= 1.001
    v = f.check_window(over, 0)
    a = float(np.linalg.norm(over[0, :3]))
    assert not v.passed and v.reason == f"|a| reaches {a:.2f} m/s^2 (> a_max {th.a_max:.2f})"
    spin = base.copy()
    spin[:, 3] = th.w_max + 0.01
    v = f.check_window(spin, 0)
    assert v.reason == f"|w| reaches {th.w_max + 0.01:.2f} rad/s (> w_max {th.w_max:.2f})"
    quiet = base / 3 * np.sqrt(th.e_min) * 0.5  # energy e_min / 4
    v = f.check_window(quiet, 0)
    assert v.reason == f"motion energy {th.e_min / 4:.2e} below E_min {th.e_min:.2e}"
    assert v.values["energy"] == pytest.approx(th.e_min / 4)
    bad = base.copy()
    bad[3, 4] = np.nan
    assert f.check_window(bad, 0) == Verdict(False, "imu", "non-finite samples")
    both = f.check_windows(np.stack([base, bad]), np.array([0, 0]))
    assert [x.passed for x in both] == [True, False]


def test_first_failure_and_as_dict():
    good, bad = Verdict(True, "a"), Verdict(False, "b", "why", {"x": 1.0})
    assert first_failure([good, bad, Verdict(False, "c")]) is bad
    assert first_failure([good]) is None and first_failure([]) is None
    d = bad.as_dict()
    assert d == {"passed": False, "filter": "b", "reason": "why", "values": {"x": 1.0}}
    d["values"]["x"] = 2.0
    assert bad.values == {"x": 1.0}


def test_class_verdicts_and_mask_agree_at_the_tau_boundary():
    proba = np.array([[0.6, 0.4], [0.59, 0.41], [0.3, 0.7], [0.5, 0.5]])
    labels = np.array([0, 0, 0, 1])
    v = class_verdicts(proba, labels, 0.6)
    assert [x.passed for x in v] == [True, False, False, False]
    assert v[1].reason == "confidence 0.59 below tau_cls 0.60"
    assert v[2].reason == "validator predicts class 1, not 0"
    assert v[3].reason == "validator predicts class 0, not 1"  # ties: the first class
    assert v[0].values == {"p_max": 0.6, "p_label": 0.6, "tau_cls": 0.6}
    assert v[2].values == {"p_max": 0.7, "p_label": 0.3, "tau_cls": 0.6}
    assert class_keep_mask(proba, labels, 0.6).tolist() == [True, False, False, False]
    validated = np.array([True, False])
    v = class_verdicts(proba, labels, 0.6, validated)
    assert v[3].passed and v[3].reason == "not validated: too few real training windows of the class"
    assert class_keep_mask(proba, labels, 0.6, validated).tolist() == [True, False, False, True]
    assert class_keep_mask(np.zeros((0, 2)), np.zeros(0), 0.6).shape == (0,)


def test_select_tau_scores_each_distinct_mask_once_and_breaks_ties_towards_the_default():
    proba = np.array([[0.52, 0.48], [0.62, 0.38], [0.68, 0.32], [0.1, 0.9]])
    labels = np.array([0, 0, 0, 1])
    calls = []

    def score(keep):
        calls.append(tuple(keep.tolist()))
        return 0.5

    best, scores = select_tau(proba, labels, score)
    assert best == 0.60 and set(scores) == set(TAU_CANDIDATES) and len(calls) == len(set(calls)) == 4
    best, scores = select_tau(proba, labels, lambda keep: float(keep.sum()))
    assert best == 0.50 and scores == {0.50: 4.0, 0.55: 3.0, 0.60: 3.0, 0.65: 2.0, 0.70: 1.0}
    best, _ = select_tau(proba, labels, lambda keep: -float(keep.sum()), threads=2)
    assert best == 0.70


def test_macro_f1_over_the_true_classes():
    assert macro_f1(np.array([0, 0, 1, 1]), np.array([0, 0, 1, 1])) == 1.0
    assert macro_f1(np.array([0, 0]), np.array([0, 1])) == pytest.approx(2 / 3)  # class 1 not scored


def test_nn_thresholds_by_definition():
    rng = np.random.default_rng(4)
    z = rng.normal(size=(30, 4))
    labels = np.array([0] * 20 + [1] * 9 + [2])
    out = nn_thresholds(z, labels, min_class_windows=10)
    unit = z / np.linalg.norm(z, axis=1, keepdims=True)
    nn = {}
    for c in (0, 1):
        zc = unit[labels == c]
        d = np.linalg.norm(zc[:, None] - zc[None], axis=-1) + np.eye(len(zc)) * 9
        nn[c] = d.min(1)
    assert out[0] == pytest.approx(np.quantile(nn[0], 0.05))
    pooled = np.quantile(np.concatenate([nn[0], nn[1]]), 0.05)
    assert out[1] == pytest.approx(pooled) and out[2] == pytest.approx(pooled) and out[-1] == pytest.approx(pooled)
    assert nn_thresholds(z[:1], labels[:1]) == {0: 0.0, -1: 0.0}


def test_redundancy_keeps_windows_farther_than_tau_from_kept_ones():
    z = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 0.05], [0.0, 1.0]])
    labels = np.array([0, 0, 0, 0, 1])
    tau = float(np.linalg.norm(z[3] / np.linalg.norm(z[3]) - z[0]))
    v = redundancy_verdicts(z, labels, {0: tau, -1: 0.5}, eligible=np.array([True, True, True, True, False]))
    assert [x.passed for x in v] == [True, False, True, False, False]
    assert v[0].values == {"nn_distance": -1.0, "tau_nn": tau}
    assert v[1].values["nn_distance"] == 0.0
    assert v[1].reason == f"near-duplicate (distance 0.000 <= tau_nn {tau:.3f})"
    assert v[3].values["nn_distance"] == pytest.approx(tau)  # exactly tau: a duplicate
    assert v[4].reason == "not considered (rejected earlier)" and v[4].values == {"tau_nn": 0.5}
    fallback = redundancy_verdicts(z[:2], np.array([5, 5]), {-1: 0.1})
    assert [x.passed for x in fallback] == [True, False] and fallback[1].values["tau_nn"] == 0.1
    assert [x.passed for x in redundancy_verdicts(z[:2], np.array([5, 5]), {})] == [True, False]


def test_validator_probabilities_cover_every_class_and_embeddings_are_relu_of_the_hidden_layers():
    rng = np.random.default_rng(5)
    x = rng.normal(size=(60, 20, 6)) + np.repeat([0.0, 3.0], 30)[:, None, None]
    y = np.repeat([0, 2], 30)
    v = HarValidator(hidden=(16, 8), max_iter=100, seed=1).fit(x, y)
    assert (v.hidden, v.max_iter, v.seed) == ((16, 8), 100, 1)
    p = v.predict_proba(x)
    assert p.shape == (60, 3) and np.allclose(p.sum(1), 1.0) and (p[:, 1] == 0).all()
    assert (p.argmax(1) == y).mean() > 0.9
    e = v.embed(x)
    assert e.shape == (60, 8) and (e >= 0).all() and (e > 0).any()
    from vsmp_imu.har.features import ecdf_features

    h = v.scaler_.transform(ecdf_features(x))
    for w, b in zip(v.model_.coefs_[:2], v.model_.intercepts_[:2], strict=True):
        h = np.maximum(h @ w + b, 0.0)
    assert np.allclose(e, h)
    assert HarValidator(hidden=(16, 8), max_iter=100, seed=1).fit(x, y, n_classes=5).predict_proba(x).shape == (60, 5)
    default = HarValidator()
    assert (default.hidden, default.max_iter, default.seed) == ((64, 32), 200, 0)


def _motion():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "imu"))
    from imu_motions import make_motion, walking

    root, local = walking()
    return make_motion(2.0, 30.0, root, local)


def test_motion_check_reports_the_largest_joint_step_against_a_fifth_of_the_height():
    from vsmp_imu.motion import Motion

    m = _motion()
    f = MotionPlausibilityFilter()
    d_max = 0.2 * m.body_height_m()
    worst = float(np.linalg.norm(np.diff(m.positions, axis=0), axis=-1).max())
    assert f.check_motion(m) == Verdict(True, "motion", "", {"max_step_m": worst, "d_max_m": d_max})
    pos = m.positions.copy()
    pos[10:, 5] += [0.0, 0.0, 1.5 * d_max]  # joint 5 jumps between frames 9 and 10
    jumped = Motion(pos, m.rotations, m.fps, meta=m.meta)
    w = float(np.linalg.norm(np.diff(pos, axis=0), axis=-1).max())
    assert f.check_motion(jumped) == Verdict(
        False, "motion", f"joint jumped {w:.3f} m between frames (> {d_max:.3f} m)", {"max_step_m": w, "d_max_m": d_max})
    at_limit = MotionPlausibilityFilter(max_step_fraction=worst / m.body_height_m())
    assert at_limit.check_motion(m).passed  # a step exactly at d_max passes
    pos = m.positions.copy()
    pos[3, 2, 1] = np.nan
    missing = Motion(pos, m.rotations, m.fps, meta=m.meta)
    assert f.check_motion(missing) == Verdict(False, "motion", "missing or non-finite frames")


def test_verdicts_name_their_filter_and_inputs_must_pair_up():
    proba = np.array([[0.9, 0.1], [0.2, 0.8], [0.55, 0.45]])
    for v in class_verdicts(proba, np.array([0, 0, 0]), 0.6, np.array([True, True])) + \
            class_verdicts(proba, np.array([1, 1, 1]), 0.6, np.array([True, False])):
        assert v.filter == "class"
    assert class_verdicts(proba[:1], np.array([0]), 0.6)[0] == Verdict(
        True, "class", "", {"p_max": 0.9, "p_label": 0.9, "tau_cls": 0.6})
    with pytest.raises(ValueError):
        class_verdicts(proba, np.array([0, 0]), 0.6)
    z = np.array([[1.0, 0.0], [0.8, 0.6]])  # distance 0.632 between the two unit vectors
    v = redundancy_verdicts(z, np.array([3, 3]), {})  # no threshold at all: only exact duplicates go
    assert [x.passed for x in v] == [True, True] and {x.filter for x in v} == {"redundancy"}
    assert v[1].values["tau_nn"] == 0.0
    skipped = redundancy_verdicts(z, np.array([3, 3]), {-1: 0.1}, eligible=np.array([False, True]))
    assert skipped[0] == Verdict(False, "redundancy", "not considered (rejected earlier)", {"tau_nn": 0.1})
