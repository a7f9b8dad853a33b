"""Exact contracts of the grounding helpers: the D_stat split, the mounting estimate,
convention alignment, the prior's perturbation bounds, axis inference, class balancing
and the calibrator's appendix defaults. Expected values come from the definitions."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding import align
from vsmp_imu.grounding.align import (
    Convention,
    ConventionAlignment,
    infer_axes,
    is_wrist,
    sample_mounting_perturbation,
    signed_permutations,
)
from vsmp_imu.grounding.calibrate import SimInTheLoopCalibrator
from vsmp_imu.grounding.mounting import MIN_MEAN_NORM, estimate_mounting, mounting_classes
from vsmp_imu.grounding.rank import _balance_weights
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.seeding import rng_for


# -- the D_stat / D_rank split -------------------------------------------------------------
def test_split_draws_each_class_from_its_own_named_stream():
    labels = np.array([2, 0, 1, 0, 2, 1, 0, 1, 2, 0, 1, 2, 0, 0])
    stat, rank = stat_rank_split(labels, seed=11)
    want_stat, want_rank = [], []
    for cls in (0, 1, 2):
        idx = np.flatnonzero(labels == cls)
        idx = idx[rng_for(11, "stat_rank_split", cls).permutation(idx.size)]
        n = int(np.ceil(idx.size / 2))
        want_stat += list(idx[:n])
        want_rank += list(idx[n:])
    assert list(stat) == sorted(want_stat) and list(rank) == sorted(want_rank)


def test_split_of_equal_classes_differs_per_class():
    labels = np.repeat([0, 1], 12)
    stat, _ = stat_rank_split(labels, seed=2)
    first = np.sort(stat[labels[stat] == 0])
    second = np.sort(stat[labels[stat] == 1]) - 12
    assert len(first) == len(second) == 6
    assert not np.array_equal(first, second)


def test_split_of_no_labels_is_two_empty_index_arrays():
    stat, rank = stat_rank_split(np.array([], dtype=int), seed=0)
    assert stat.size == 0 and rank.size == 0
    assert stat.dtype.kind == "i" and rank.dtype.kind == "i"


# -- nominal mounting frame ------------------------------------------------------------------
HIDDEN = Rotation.from_euler("zxy", [10.0, -20.0, 35.0], degrees=True)
SYN = np.array([[0.0, 9.81, 0.0], [0.0, 6.0, 7.0], [8.0, 5.0, 0.0]])


def _angle_deg(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    cos = np.sum(u * v, axis=1) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def test_mounting_is_exact_on_consistent_classes():
    rot, rms = estimate_mounting(SYN, HIDDEN.apply(SYN))
    assert np.degrees((rot * HIDDEN.inv()).magnitude()) < 1e-6
    assert rms == pytest.approx(0.0, abs=1e-5)
    two, _ = estimate_mounting(SYN[:2], HIDDEN.apply(SYN[:2]))  # two classes are enough
    assert np.degrees((two * HIDDEN.inv()).magnitude()) < 1e-6


def test_mounting_residual_is_the_weighted_rms_angle_and_follows_the_weights():
    real = HIDDEN.apply(SYN)
    real[2] = HIDDEN.apply([5.0, 8.0, 1.0])  # one class disagrees: the fit must compromise
    for weights in (np.array([1.0, 1.0, 1.0]), np.array([1.0, 1.0, 8.0])):
        rot, rms = estimate_mounting(SYN, real, weights)
        err = _angle_deg(rot.apply(SYN), real)
        assert rms == pytest.approx(np.sqrt(np.sum(weights * err**2) / weights.sum()), rel=1e-9)
        assert rms > 1.0
    plain_rot, _ = estimate_mounting(SYN, real)
    heavy_rot, _ = estimate_mounting(SYN, real, np.array([1.0, 1.0, 8.0]))
    plain_err = _angle_deg(plain_rot.apply(SYN), real)
    heavy_err = _angle_deg(heavy_rot.apply(SYN), real)
    assert heavy_err[2] < 0.5 * plain_err[2]  # the heavy class is fitted better
    assert np.allclose(_angle_deg(estimate_mounting(SYN, real, np.ones(3))[0].apply(SYN), real), plain_err)


def test_mounting_residual_stays_finite_when_rounding_passes_cos_one():
    rng = np.random.default_rng(0)  # a case where a fitted cosine rounds to 1 + 2e-16
    syn = rng.normal(size=(4, 3)) * 5
    syn[:, 1] += 9.81
    hidden = Rotation.random(random_state=0)
    rot, rms = estimate_mounting(syn, hidden.apply(syn))
    assert np.isfinite(rms) and rms < 1e-5
    assert np.degrees((rot * hidden.inv()).magnitude()) < 1e-6


@pytest.mark.parametrize("side", ["synthetic", "real"])
def test_mounting_leaves_out_classes_at_or_below_the_gravity_floor(side):
    syn, real = SYN.copy(), HIDDEN.apply(SYN)
    weak = np.array([MIN_MEAN_NORM, 0.0, 0.0])  # exactly at the floor, pointing elsewhere
    if side == "synthetic":
        syn = np.vstack([syn, weak])
        real = np.vstack([real, [0.0, 0.0, 9.81]])
    else:
        syn = np.vstack([syn, [0.0, 0.0, 9.81]])
        real = np.vstack([real, weak])
    rot, rms = estimate_mounting(syn, real)
    assert np.degrees((rot * HIDDEN.inv()).magnitude()) < 1e-6 and rms < 1e-5


def test_mounting_needs_two_usable_classes_with_positive_weight():
    real = HIDDEN.apply(SYN)
    rot, rms = estimate_mounting(SYN[:2], real[:2], np.array([1.0, 0.0]))
    assert np.allclose(rot.as_matrix(), np.eye(3)) and np.isnan(rms)
    rot, rms = estimate_mounting(SYN, real, np.array([1.0, 0.0, 1.0]))
    assert np.degrees((rot * HIDDEN.inv()).magnitude()) < 1e-6


# -- alignment and the prior ---------------------------------------------------------------
def test_alignment_error_names_the_gravity_field():
    conv = ConventionAlignment(Convention(gravity_included=False))
    with pytest.raises(ValidationError) as err:
        conv.transform(np.zeros((4, 6)))
    assert err.value.field == "gravity"
    assert err.value.message == "the target removes gravity, so the sensor-frame gravity is needed"


def test_alignment_of_integer_input_is_float():
    out = ConventionAlignment(Convention(acc_unit="g")).transform(np.full((2, 6), 3, dtype=int))
    assert out.dtype == np.float64
    assert out[0, 0] == pytest.approx(3 * align.UNIT_SCALE["g"])


@pytest.mark.parametrize(("location", "wrist"), [
    ("left_wrist", True), ("right_hand", True), ("smartwatch", True), ("wrist", True),
    ("waist", False), ("chest", False), ("right_ankle", False),
])
def test_is_wrist(location, wrist):
    assert is_wrist(location) is wrist


@pytest.mark.parametrize(("location", "bounds"), [("left_wrist", (30, 30, 30)), ("waist", (15, 15, 30))])
def test_mounting_perturbation_fills_the_prior_bounds_symmetrically(location, bounds):
    rng = np.random.default_rng(4)
    angles = np.array([sample_mounting_perturbation(location, rng).as_euler("zxy", degrees=True)
                       for _ in range(400)])
    for k, b in enumerate(bounds):
        assert angles[:, k].max() <= b + 1e-9 and angles[:, k].min() >= -b - 1e-9
        assert angles[:, k].max() > 0.9 * b and angles[:, k].min() < -0.9 * b


def _infer_score(syn: np.ndarray, real: np.ndarray, p: np.ndarray) -> float:
    syn, real = syn.reshape(-1, 6), real.reshape(-1, 6)
    a, g = syn[:, :3] @ p.T, syn[:, 3:] @ p.T
    ca, cg = np.cov(real[:, :3].T), np.cov(real[:, 3:].T)
    return float(np.linalg.norm(a.mean(0) - real[:, :3].mean(0)) * align.UNIT_SCALE["g"]
                 + np.linalg.norm(np.cov(a.T) - ca) / (np.linalg.norm(ca) + 1e-9)
                 + np.linalg.norm(np.cov(g.T) - cg) / (np.linalg.norm(cg) + 1e-9))


def test_infer_axes_returns_the_best_score_by_its_definition():
    rng = np.random.default_rng(2)
    syn = rng.normal(0, 1, (6, 50, 6)) * np.array([1, 2, 3, 0.5, 1, 2])
    syn[..., 1] += 9.81
    hidden = signed_permutations()[29]
    real = np.concatenate([syn[..., :3] @ hidden.T, syn[..., 3:] @ hidden.T], axis=-1)
    real = real + rng.normal(0, 0.3, real.shape) + np.array([0.4, 0, 0, 0, 0, 0])
    p, score = infer_axes(syn, real)
    assert np.array_equal(p, hidden)
    assert score == pytest.approx(_infer_score(syn, real, p), rel=1e-12)
    assert score == min(_infer_score(syn, real, q) for q in signed_permutations())


def test_infer_axes_keeps_the_identity_when_the_data_cannot_tell():
    p, score = infer_axes(np.zeros((2, 10, 6)), np.zeros((2, 10, 6)))
    assert np.array_equal(p, np.eye(3)) and score == 0.0


# -- class balancing of the synthetic pool ---------------------------------------------------
def test_balance_weights_give_the_synthetic_pool_the_real_class_shares():
    syn = np.array([0] * 10 + [1] * 30 + [2] * 10)
    real = np.array([0] * 60 + [1] * 40)
    w = _balance_weights(syn, real)
    assert w.shape == syn.shape and w.dtype == np.float64
    assert w[syn == 0] == pytest.approx(0.6 / 0.2)
    assert w[syn == 1] == pytest.approx(0.4 / 0.6)
    assert w[syn == 2] == pytest.approx(1.0)  # absent from the real data: keeps its share
    shares = [w[syn == c].sum() / w.sum() for c in (0, 1)]
    assert shares[0] / shares[1] == pytest.approx(60 / 40)


# -- the calibrator's appendix defaults ------------------------------------------------------
def test_calibrator_defaults_are_the_appendix_values():
    cem = SimInTheLoopCalibrator()
    assert (cem.n_iterations, cem.n_candidates, cem.elite_fraction, cem.search_gravity) == (30, 64, 0.20, False)


def test_convention_errors_name_the_field_and_the_allowed_values():
    from vsmp_imu.grounding.align import UNIT_SCALE, axes_matrix

    for field in ("acc_unit", "gyr_unit"):
        with pytest.raises(ValidationError) as err:
            Convention(**{field: "furlong"})
        assert (err.value.field, err.value.message) == (field, "unknown unit 'furlong'")
        assert err.value.allowed == ", ".join(UNIT_SCALE)
    with pytest.raises(ValidationError) as err:
        Convention(channel_names=("a", "b"))
    assert err.value.field == "channel_names"
    assert err.value.message == "a location has exactly 6 channels (acc xyz, gyr xyz)"
    with pytest.raises(ValidationError) as err:
        axes_matrix(("left", "up"))
    assert err.value.field == "axes" and err.value.allowed == "left, right, up, down, forward, backward"
    with pytest.raises(ValidationError) as err:
        axes_matrix(("left", "right", "up"))
    assert err.value.field == "axes" and "name the same body direction twice" in err.value.message


def test_the_mounting_is_fitted_on_postures_and_rhythms_where_two_have_evidence():
    def single(name):
        return name.startswith("to_")

    assert mounting_classes(["sit", "to_lie", "walk"], single) == ["sit", "walk"]
    assert mounting_classes(["sit", "to_lie", "to_sit"], single) == ["sit", "to_lie", "to_sit"]  # one held
    assert mounting_classes(["to_lie", "to_sit"], single) == ["to_lie", "to_sit"]
    assert mounting_classes([], single) == []
