"""Protocols (low-resource, long-tail, validation subjects) and synthetic budgets."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.protocols import (
    MAX_RHO,
    MIN_BUDGET,
    choose_val_subjects,
    head_tail,
    long_tail_counts,
    low_resource_counts,
    parse_budgets,
    require_two_classes,
    require_two_subjects,
    split_fold,
)
from vsmp_imu.har.synthetic import apportion, synthetic_budget
from vsmp_imu.har.windows import Windows


def test_low_resource_keeps_at_least_one_per_class():
    counts = np.array([1000, 200, 30, 0])
    assert low_resource_counts(counts, 1).tolist() == [10, 2, 1, 0]
    assert low_resource_counts(counts, 50).tolist() == [500, 100, 15, 0]


def test_long_tail_follows_the_power_law():
    counts = np.array([500, 800, 600, 700, 900, 1000])
    keep = long_tail_counts(counts, rho=10)
    # rank 1 (class 5) keeps everything, rank C keeps n_max / rho
    assert keep[5] == 1000 and keep[0] == 100
    ranked = [5, 4, 1, 3, 2, 0]
    expected = [min(counts[c], round(1000 * 10 ** (-(r / 5)))) for r, c in enumerate(ranked)]
    assert [keep[c] for c in ranked] == expected
    head, tail = head_tail(keep)
    assert head == (5, 4, 1) and tail == (3, 2, 0)


def test_head_tail_with_odd_class_count():
    head, tail = head_tail(np.array([9, 8, 7, 6, 5]))
    assert head == (0, 1) and tail == (2, 3, 4)


def test_validation_subjects_are_training_subjects():
    subjects = [str(s) for s in range(2, 31)]
    val = choose_val_subjects(subjects, seed=0, fold="1")
    assert len(val) == 6 and set(val) <= set(subjects)
    assert val == choose_val_subjects(subjects, seed=0, fold="1")
    assert val != choose_val_subjects(subjects, seed=1, fold="1")
    assert choose_val_subjects(["2"], seed=0, fold="1") == ()
    assert choose_val_subjects([], seed=0, fold="1") == ()
    most = choose_val_subjects(subjects, seed=0, fold="1", val_fraction=0.9)
    assert len(most) == len(set(most)) == 26  # drawn without replacement


@pytest.mark.parametrize("seed", range(4))
def test_validation_subjects_in_natural_order(seed):
    val = choose_val_subjects(["8", "9", "10"], seed=seed, fold="1", val_fraction=1.0)
    assert len(val) == 2 and list(val) == sorted(val, key=int)


@pytest.mark.parametrize(
    "protocol,budget", [("lopo", None), ("low-resource", 10.0), ("long-tail", None)]
)
def test_split_fold_partitions_subjects(tiny_dataset, protocol, budget):
    windows = tiny_dataset.windows(window_s=2.0, overlap=0.5)
    split = split_fold(windows, "3", protocol, seed=0, budget_percent=budget)
    assert split.test.unique_subjects() == ["3"]
    assert len(split.test) == int((windows.subjects == "3").sum())
    fit_subjects, val_subjects = set(split.fit.unique_subjects()), set(split.val.unique_subjects())
    assert "3" not in fit_subjects | val_subjects
    assert not fit_subjects & val_subjects and val_subjects == set(split.val_subjects)
    if protocol == "low-resource":
        pool = windows.where_subjects(["3"], keep=False).class_counts()
        kept = split.fit.class_counts() + split.val.class_counts()
        assert kept.tolist() == low_resource_counts(pool, 10).tolist()
    if protocol == "long-tail":
        assert split.head is not None and len(split.head) + len(split.tail) == 4
    again = split_fold(windows, "3", protocol, seed=0, budget_percent=budget)
    assert np.array_equal(again.fit.X, split.fit.X)


def _kept(split) -> list[int]:
    return (split.fit.class_counts() + split.val.class_counts()).tolist()


def test_split_fold_at_the_smallest_budget_keeps_one_window_per_class(tiny_dataset):
    windows = tiny_dataset.windows(window_s=2.0, overlap=0.5)
    split = split_fold(windows, "3", "low-resource", seed=0, budget_percent=MIN_BUDGET)
    assert _kept(split) == [1, 1, 1, 1]


def test_split_fold_long_tail_follows_rho(tiny_dataset):
    windows = tiny_dataset.windows(window_s=2.0, overlap=0.5)
    pool = windows.where_subjects(["3"], keep=False).class_counts()
    kept = _kept(split_fold(windows, "3", "long-tail", seed=0, rho=2.0))
    assert kept == long_tail_counts(pool, 2.0).tolist() != long_tail_counts(pool, 10.0).tolist()


def test_split_fold_draws_validation_subjects_of_its_fold_and_fraction(tiny_factory):
    windows = tiny_factory(n_subjects=12).windows(window_s=2.0, overlap=0.5)
    split = split_fold(windows, "5", "lopo", seed=3, val_fraction=0.5)
    others = [str(s) for s in range(1, 13) if s != 5]
    assert split.val_subjects == choose_val_subjects(others, 3, "5", val_fraction=0.5)
    assert len(split.val_subjects) == 6 and set(split.val.unique_subjects()) == set(split.val_subjects)
    assert set(split.fit.unique_subjects()) == set(others) - set(split.val_subjects)


class _Dataset:
    """What the checks read of a dataset: its name and, when it has one, its yaml file."""

    def __init__(self, yaml_path=None):
        self.info = type("Info", (), {"name": "tiny"})()
        if yaml_path is not None:
            self.yaml_path = yaml_path


def test_require_two_subjects():
    require_two_subjects(["1", "2"], _Dataset())
    with pytest.raises(ValidationError) as err:
        require_two_subjects(["7"], _Dataset("/data/tiny.yaml"))
    assert err.value.message == ("dataset 'tiny' has 1 subject(s) with labelled windows (7); "
                                 "leave-one-subject-out evaluation holds one out and trains on the others")
    assert err.value.file == "/data/tiny.yaml" and err.value.field == "subject"
    assert err.value.allowed == "a dataset with at least 2 subjects"
    with pytest.raises(ValidationError) as err:
        require_two_subjects([], _Dataset())
    assert "has 0 subject(s) with labelled windows (none);" in err.value.message and err.value.file is None


def _labelled(y) -> Windows:
    return Windows(np.zeros((len(y), 4, 2)), np.asarray(y, dtype=int), ["1"] * len(y), ("a", "b", "c"),
                   ("acc_x", "acc_y"), 20.0)


def test_require_two_classes():
    require_two_classes(_labelled([0, 2]), _Dataset())  # one window each of two classes is enough
    with pytest.raises(ValidationError) as err:
        require_two_classes(_labelled([1, 1]), _Dataset("/data/tiny.yaml"))
    assert err.value.message == ("dataset 'tiny' has labelled windows of 1 class(es) (b); "
                                 "a classifier needs at least 2 classes to tell apart")
    assert err.value.file == "/data/tiny.yaml" and err.value.field == "labels"
    assert err.value.allowed == "a dataset with windows of at least 2 classes"
    with pytest.raises(ValidationError) as err:
        require_two_classes(_labelled([]), _Dataset())
    assert "of 0 class(es) (none);" in err.value.message and err.value.file is None


@settings(max_examples=50, deadline=None)
@given(total=st.integers(0, 5000), weights=st.lists(st.floats(0, 100), min_size=1, max_size=12))
def test_apportion_sums_exactly(total, weights):
    out = apportion(total, np.array(weights))
    if sum(weights) > 0:
        assert out.sum() == total
        assert (np.abs(out - total * np.array(weights) / sum(weights)) < 1 + 1e-9).all()
    else:
        assert out.sum() == 0


def test_synthetic_budget_policies():
    counts = np.array([600, 300, 100, 0])
    uniform = synthetic_budget(counts, 0.5, "uniform")
    assert uniform.tolist() == [300, 150, 50, 0]
    tail = synthetic_budget(counts, 0.5, "tail")
    assert tail.sum() == 500 and tail[0] == 0 and tail[2] > 0 and tail[3] == 0
    scarcity = synthetic_budget(counts, 0.5, "scarcity")
    assert scarcity.sum() == 500 and scarcity[2] > scarcity[1] > scarcity[0] and scarcity[3] == 0
    with pytest.raises(ConfigError, match="budget policy"):
        synthetic_budget(counts, 0.5, "greedy")


def test_parse_budgets():
    assert parse_budgets(None, "low-resource") == (1.0, 5.0, 10.0, 25.0, 50.0)
    assert parse_budgets("1,5%", "low-resource") == (1.0, 5.0)
    assert parse_budgets("5", "lopo") == (None,)
    for bad in ("0", "150", "x", "-1", "1e-9", "0.009"):
        with pytest.raises(ConfigError, match="--budgets"):
            parse_budgets(bad, "low-resource")
    assert parse_budgets("0.01", "low-resource") == (0.01,)


def test_parse_budgets_edges():
    """An empty item is skipped, not the end of the list; 100 % is a budget and 100.5 is not; only a
    trailing '%' is taken off (a trailing letter is a typo, refused); tstr without budgets trains
    on the whole pool, with them on each."""
    assert parse_budgets("1,,5", "low-resource") == (1.0, 5.0)
    assert parse_budgets(" 2 %, 100", "low-resource") == (2.0, 100.0)
    for bad in ("100.5", "5X", "5%X"):
        with pytest.raises(ConfigError, match="--budgets"):
            parse_budgets(bad, "low-resource")
    assert parse_budgets(None, "tstr") == (None,) and parse_budgets("", "tstr") == (None,)
    assert parse_budgets("5,25", "tstr") == (5.0, 25.0)


def test_budgets_below_the_smallest_only_repeat_it():
    """MIN_BUDGET's reason: a class keeps 1 window at least, so below 0.01 % a class of up to 5000
    windows keeps its 1 window whatever the budget; a smaller budget is the same protocol."""
    counts = np.array([5000, 2449, 164, 1])
    floor = low_resource_counts(counts, MIN_BUDGET)
    assert floor.tolist() == [1, 1, 1, 1]
    assert all((low_resource_counts(counts, b) == floor).all() for b in (1e-3, 1e-9))


def test_rho_above_the_largest_class_is_not_delivered():
    """MAX_RHO's reason: the tail keeps 1 window at least, so a ratio above the largest class's
    windows is not the ratio trained on (HAPT12's pool: ~2450 windows in its largest class)."""
    counts = np.array([2449, 2300, 2200, 1800, 250, 164])
    assert long_tail_counts(counts, MAX_RHO).tolist() == [2449, 615, 155, 39, 10, 2]  # 1224:1, near 1000
    assert long_tail_counts(counts, 1e12).tolist() == [2449, 10, 1, 1, 1, 1]  # 2449:1, four classes at 1


@pytest.mark.parametrize("rho", [1.0, 1000.001, 1e12, float("inf"), float("nan")])
def test_eval_config_refuses_a_rho_outside_1_to_1000(rho):
    from vsmp_imu.har.evaluate import EvalConfig

    with pytest.raises(ConfigError) as err:
        EvalConfig("x", protocol="long-tail", rho=rho).check()
    assert err.value.field == "--rho" and err.value.allowed == "1 < rho <= 1000"
    assert EvalConfig("x", protocol="long-tail", rho=1000.0).check().rho == 1000.0


def test_eval_config_budgets_follow_the_protocol():
    from vsmp_imu.har.evaluate import EvalConfig

    assert EvalConfig("x", protocol="low-resource").check().budgets == (1.0, 5.0, 10.0, 25.0, 50.0)
    assert EvalConfig("x", protocol="low-resource", budgets=(5,)).check().budgets == (5.0,)
    assert EvalConfig("x", protocol="long-tail").check().budgets == (None,)
    assert EvalConfig("x", protocol="tstr").check().budgets == (None,)  # every window grounds
    assert EvalConfig("x", protocol="tstr", budgets=(5, 1)).check().budgets == (5.0, 1.0)
    with pytest.raises(ConfigError, match="low-resource and tstr protocols only"):
        EvalConfig("x", protocol="lopo", budgets=(5.0,)).check()
    with pytest.raises(ConfigError, match="out of range"):
        EvalConfig("x", protocol="tstr", budgets=(150.0,)).check()
    with pytest.raises(ConfigError, match="out of range"):
        EvalConfig("x", protocol="low-resource", budgets=(0.0,)).check()
    with pytest.raises(ConfigError, match="out of range"):
        EvalConfig("x", protocol="low-resource", budgets=(1e-9,)).check()
