"""Exact values of the ECDF features, the synthetic budget and its plumbing, and the
protocol helpers: every expected value is written out or computed from its definition."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har import synthetic
from vsmp_imu.har.features import N_LEVELS, ecdf_features, ecdf_levels, segment_means
from vsmp_imu.har.protocols import (
    check_protocol,
    choose_val_subjects,
    long_tail_counts,
    low_resource_counts,
    parse_budgets,
    rank_classes,
    subsample_per_class,
)
from vsmp_imu.har.synthetic import (
    FoldContext,
    apportion,
    check_synthetic,
    make_method,
    mix,
    register_method,
    synthetic_budget,
    take_budget,
)
from vsmp_imu.har.windows import Windows

CHANNELS = ("acc_x", "acc_y")


def _windows(y, x=None, subjects=None, labels=("a", "b", "c")) -> Windows:
    y = np.asarray(y)
    x = np.arange(len(y) * 4 * 2, dtype=float).reshape(len(y), 4, 2) if x is None else x
    subjects = np.array(["1"] * len(y)) if subjects is None else subjects
    return Windows(x, y, subjects, labels, CHANNELS, 20.0)


# -- ECDF features -------------------------------------------------------------------------
def test_ecdf_levels_are_k_over_k_plus_one():
    assert N_LEVELS == 15
    assert np.allclose(ecdf_levels(), np.arange(1, 16) / 16)
    assert ecdf_levels(1).tolist() == [0.5]
    assert ecdf_levels(3).tolist() == [0.25, 0.5, 0.75]
    with pytest.raises(ValidationError) as err:
        ecdf_levels(0)
    assert err.value.field == "n_levels"


def test_ecdf_features_are_channel_major_window_quantiles():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(5, 40, 3))
    f = ecdf_features(x, n_levels=4)
    assert f.shape == (5, 12) and f.dtype == np.float32
    levels = np.arange(1, 5) / 5
    for n in range(5):
        want = np.concatenate([np.quantile(x[n, :, c].astype(np.float32), levels) for c in range(3)])
        assert np.allclose(f[n], want, atol=1e-6)
    assert ecdf_features(x).shape == (5, 3 * 15)
    with pytest.raises(ValidationError) as err:
        ecdf_features(x[0])
    assert err.value.field == "X"


# -- segment means -------------------------------------------------------------------------
def test_segment_means_are_means_of_consecutive_parts_segment_major():
    x = np.arange(2 * 7 * 2, dtype=float).reshape(2, 7, 2)  # 7 samples, 2 channels
    out = segment_means(x, 3)  # edges round(0, 7/3, 14/3, 7) = 0, 2, 5, 7: parts of 2, 3, 2 samples
    assert out.shape == (2, 6) and out.dtype == np.float32 and out.flags.c_contiguous
    # window 0: channel 0 is 0, 2, ..., 12 and channel 1 is 1, 3, ..., 13; window 1 adds 14
    assert out.tolist() == [[1, 2, 6, 7, 11, 12], [15, 16, 20, 21, 25, 26]]


def test_segment_means_at_one_segment_and_one_per_sample():
    x = np.random.default_rng(0).normal(size=(3, 5, 2))
    assert np.allclose(segment_means(x, 1), x.mean(axis=1), atol=1e-6)
    assert np.allclose(segment_means(x, 5), x.reshape(3, 10), atol=1e-6)  # each sample, time-major


@pytest.mark.parametrize("n_segments", [0, 8])
def test_segment_means_refuse_a_count_outside_1_to_the_window_length(n_segments):
    with pytest.raises(ValidationError) as err:
        segment_means(np.zeros((2, 7, 3)), n_segments)
    assert err.value.field == "n_segments"
    assert err.value.message == f"need 1..7 segments for windows of 7 samples, got {n_segments}"


def test_features_are_those_of_the_float32_windows():
    x = np.random.default_rng(1).normal(size=(20, 50, 3))
    x32 = x.astype(np.float32)
    assert np.array_equal(ecdf_features(x), ecdf_features(x32))
    assert np.array_equal(segment_means(x, 4), segment_means(x32, 4))


# -- budget plumbing ---------------------------------------------------------------------------
def test_fold_context_budget_follows_the_label_order():
    ctx = FoldContext(dataset=None, fold="1", held_out_subject="1", train=_windows([0, 1]),
                      train_subjects=("2",), seed=0, budget={"c": 4, "a": 2}, alpha=0.5, protocol="lopo")
    assert ctx.total_budget == 6
    v = ctx.budget_vector()
    assert v.tolist() == [2, 0, 4] and v.dtype == np.int64
    numpy_counts = FoldContext(dataset=None, fold="1", held_out_subject="1", train=_windows([0, 1]),
                               train_subjects=("2",), seed=0, alpha=0.5, protocol="lopo",
                               budget=dict(zip("abc", np.array([3, 0, 1], dtype=np.int32), strict=True)))
    v = numpy_counts.budget_vector()
    assert v.tolist() == [3, 0, 1] and v.dtype == np.int64  # whatever integer type the counts have


def test_registry_makes_registered_sources(monkeypatch):
    monkeypatch.setattr(synthetic, "METHODS", {"real": None})
    monkeypatch.setattr(synthetic, "METHOD_DISPLAY", {"real": "Real-only"})
    register_method("echo", lambda **p: ("echo", p))
    register_method("shown", lambda **p: None, display="Shown Name")
    assert synthetic.METHOD_DISPLAY == {"real": "Real-only", "echo": "echo", "shown": "Shown Name"}
    assert make_method("echo", k=3) == ("echo", {"k": 3})
    assert make_method("real") is None
    with pytest.raises(ConfigError) as err:
        make_method("nope")
    assert err.value.field == "methods" and err.value.allowed == "real, echo, shown"
    assert err.value.message == "unknown method 'nope'"


def test_registry_marks_the_sources_that_make_unseen_classes(monkeypatch):
    monkeypatch.setattr(synthetic, "METHODS", {"real": None})
    monkeypatch.setattr(synthetic, "METHOD_DISPLAY", {"real": "Real-only"})
    capable: set[str] = set()
    monkeypatch.setattr(synthetic, "UNSEEN_CAPABLE", capable)
    register_method("plain", lambda **p: None)
    assert capable == set()  # not capable unless said
    register_method("open", lambda **p: None, unseen_classes=True)
    assert capable == {"open"}
    register_method("open", lambda **p: None)  # registered again without it: no longer capable
    assert capable == set()


@pytest.mark.parametrize(("total", "weights", "want"), [
    (10, [1, 1, 1], [4, 3, 3]),  # ties of the remainder go to the lower index
    (7, [0.5, 0.25, 0.25], [3, 2, 2]),
    (5, [0, 3, 0], [0, 5, 0]),
    (1, [1, 2], [0, 1]),
    (0, [1, 2], [0, 0]),
    (-3, [1, 2], [0, 0]),
    (4, [0, 0], [0, 0]),
])
def test_apportion_largest_remainder(total, weights, want):
    out = apportion(total, np.array(weights))
    assert out.tolist() == want and out.dtype == np.int64


def test_apportion_breaks_remainder_ties_by_index_for_many_classes():
    weights = np.array([2, 1] * 8 + [2])  # 17 classes: above the size numpy sorts by insertion
    assert np.flatnonzero(apportion(3, weights)).tolist() == [0, 2, 4]


def test_apportion_of_nothing_is_zeros_whatever_the_weights():
    for weights in ([np.nan, 1.0], [np.inf, 1.0]):
        out = apportion(0, np.array(weights))
        assert out.tolist() == [0, 0] and out.dtype == np.int64


def test_apportion_takes_integer_weights_as_numbers():
    # 10 x 50000 does not fit uint16: the weights are used as floats, not wrapped
    assert apportion(10, np.array([50000, 10000], dtype=np.uint16)).tolist() == [8, 2]


def test_synthetic_budget_exact_per_policy():
    counts = np.array([600, 300, 100, 0])
    assert synthetic_budget(counts, 0.5).tolist() == [300, 150, 50, 0]
    assert synthetic_budget(counts, 0.5, "tail").tolist() == [0, 250, 250, 0]
    assert synthetic_budget(counts, 0.5, "tail", tail=(0,)).tolist() == [500, 0, 0, 0]
    assert synthetic_budget(counts, 0.5, "tail", tail=(0, 3)).tolist() == [500, 0, 0, 0]
    # scarcity: 1/600 : 1/300 : 1/100 = 1 : 2 : 6 of 500
    assert synthetic_budget(counts, 0.5, "scarcity").tolist() == [56, 111, 333, 0]
    assert synthetic_budget(np.array([3, 2]), 0.5).sum() == 2  # round(2.5) = 2
    # a class of a single real window is present: it gets its share
    assert synthetic_budget(np.array([4, 1]), 2.0, "scarcity").tolist() == [2, 8]  # 1/4 : 1 of 10
    assert synthetic_budget(np.array([9, 1]), 0.5, "tail").tolist() == [0, 5]
    with pytest.raises(ConfigError) as err:
        synthetic_budget(counts, 0.5, "greedy")
    assert err.value.field == "policy" and err.value.allowed == "uniform, tail, scarcity"


def test_take_budget_trims_each_class_with_a_seeded_subset():
    syn = _windows([0, 1, 0, 2, 0, 1, 0])
    out = take_budget(syn, np.array([2, 5, 0]), np.random.default_rng(3))
    assert (out.y == 0).sum() == 2 and (out.y == 1).sum() == 2 and (out.y == 2).sum() == 0
    rows = [int(np.flatnonzero((w == syn.X).all(axis=(1, 2)))[0]) for w in out.X]
    assert rows == sorted(rows)  # order kept
    expect = np.sort(np.random.default_rng(3).choice(np.array([0, 2, 4, 6]), size=2, replace=False))
    assert [r for r in rows if syn.y[r] == 0] == expect.tolist()
    assert len(take_budget(syn, np.array([], dtype=int), np.random.default_rng(0))) == 0


def test_check_synthetic_rejects_what_does_not_fit():
    real = _windows([0, 1])
    check_synthetic(real, _windows([2]), "m")
    check_synthetic(real, real[:0], "m")  # an empty set passes
    with pytest.raises(ValidationError) as err:
        check_synthetic(real, np.zeros((1, 4, 2)), "m")
    assert err.value.field == "methods" and "returned ndarray, expected Windows" in err.value.message
    bad = _windows([0], x=np.full((1, 4, 2), np.nan))
    with pytest.raises(ValidationError) as err:
        check_synthetic(real, bad, "m")
    assert err.value.field == "methods" and err.value.message == "synthetic windows of method 'm' contain NaN or inf"


def test_mix_puts_real_first_and_tags_the_synthetic_windows():
    real, syn = _windows([0, 1], subjects=np.array(["4", "5"])), _windows([2])
    out = mix(real, syn, "vsmp")
    assert len(out) == 3 and out.y.tolist() == [0, 1, 2]
    assert out.subjects.tolist() == ["4", "5", "synthetic:vsmp"]
    assert out.meta["source"].tolist() == ["real", "real", "vsmp"]


# -- protocol helpers --------------------------------------------------------------------------
def test_check_protocol():
    assert check_protocol("long-tail") == "long-tail"
    with pytest.raises(ConfigError) as err:
        check_protocol("kfold")
    assert err.value.field == "protocol" and err.value.allowed == "lopo, low-resource, long-tail, unseen, tstr"
    assert err.value.message == "unknown protocol 'kfold'"
    with pytest.raises(ConfigError) as err:
        check_protocol("kfold", field="--protocol")
    assert err.value.field == "--protocol"


def test_subsample_per_class_draws_without_replacement_in_order():
    w = _windows([0, 1, 0, 0, 1, 2, 0])
    out = subsample_per_class(w, np.array([2, 9, 0]), np.random.default_rng(1))
    assert out.y.tolist().count(0) == 2 and out.y.tolist().count(1) == 2 and 2 not in out.y
    starts = out.X[:, 0, 0].tolist()
    assert starts == sorted(starts) and len(set(starts)) == len(starts)
    assert len(subsample_per_class(w, np.array([0, 0, 0]), np.random.default_rng(1))) == 0
    one = subsample_per_class(w, np.array([1, 1, 1]), np.random.default_rng(1))
    assert one.y.tolist() == [0, 1, 2]  # a budget of one window keeps one


def test_rank_and_resource_counts():
    assert rank_classes(np.array([5, 9, 5, 0, 9])).tolist() == [1, 4, 0, 2]
    assert rank_classes(np.array([1, 3, 0])).tolist() == [1, 0]  # one window is present
    none = rank_classes(np.array([0, 0]))
    assert none.dtype == np.int64 and np.array([5, 6])[none].tolist() == []  # indexes when empty
    assert low_resource_counts(np.array([250, 150, 4, 0]), 1.0).tolist() == [2, 2, 1, 0]  # round half even
    assert low_resource_counts(np.array([250, 0]), 10.0).dtype == np.int64
    assert long_tail_counts(np.array([0, 0])).tolist() == [0, 0]
    assert long_tail_counts(np.array([0, 7])).tolist() == [0, 7]
    assert long_tail_counts(np.array([100, 100]), rho=4).tolist() == [100, 25]
    assert long_tail_counts(np.array([100, 3, 50]), rho=100).tolist() == [100, 1, 10]


def test_validation_subject_count_bounds():
    subjects = [str(s) for s in range(1, 11)]
    assert len(choose_val_subjects(subjects, 0, "f")) == 2
    assert len(choose_val_subjects(subjects, 0, "f", val_fraction=0.01)) == 1
    assert len(choose_val_subjects(subjects, 0, "f", val_fraction=1.0)) == 9
    assert choose_val_subjects(subjects, 0, "f", val_fraction=0.0) == ()
    assert choose_val_subjects(["2", "1"], 0, "f") in (("1",), ("2",))
    val = choose_val_subjects(subjects, 0, "f", val_fraction=0.5)
    assert list(val) == sorted(val, key=int)


def test_parse_budgets_details():
    assert parse_budgets("10, 5%,,10", "low-resource") == (10.0, 5.0)
    assert parse_budgets("100", "low-resource") == (100.0,)
    assert parse_budgets("", "low-resource") == (1.0, 5.0, 10.0, 25.0, 50.0)
    for bad, message in (("nan", "label budget nan out of range"), (",", "no label budget given"),
                         ("abc", "'abc' is not a number")):
        with pytest.raises(ConfigError) as err:
            parse_budgets(bad, "low-resource")
        assert err.value.message == message and err.value.field == "--budgets"
        assert err.value.allowed == "percentages in [0.01, 100], e.g. 1,5,10,25,50"


def test_take_budget_draws_only_for_classes_over_budget():
    syn = _windows([0, 0, 0, 0, 1, 1, 1])
    out = take_budget(syn, np.array([4, 1]), np.random.default_rng(5))  # class 0 fits: no draw for it
    assert (out.y == 0).sum() == 4
    want = np.random.default_rng(5).choice(np.array([4, 5, 6]), size=1, replace=False)
    assert np.flatnonzero((out.X[-1] == syn.X).all(axis=(1, 2))).tolist() == want.tolist()


def test_check_synthetic_names_the_method_in_a_mismatch():
    real = _windows([0, 1])
    other = Windows(np.zeros((1, 4, 2)), [0], ["1"], ("a", "b", "c"), CHANNELS, 25.0)
    with pytest.raises(ValidationError) as err:
        check_synthetic(real, other, "vsmp")
    assert err.value.message.startswith("synthetic windows of method 'vsmp': sampling rate 25 Hz")


def test_validation_subjects_come_from_their_named_stream_in_natural_order():
    subjects = ["s10", "s2", "s1", "s3", "s20", "s2"]
    val = choose_val_subjects(subjects, 4, "7", val_fraction=0.5)
    from vsmp_imu.har.windows import natural_key
    from vsmp_imu.seeding import rng_for

    ordered = sorted(set(subjects), key=natural_key)
    assert ordered == ["s1", "s2", "s3", "s10", "s20"]
    draw = rng_for(4, "validation-subjects", "7").choice(ordered, size=2, replace=False).tolist()
    assert list(val) == sorted(draw, key=natural_key)


@pytest.mark.parametrize(("protocol", "budget"), [("low-resource", 10.0), ("long-tail", None), ("lopo", None)])
def test_split_fold_draws_from_its_named_streams(tiny_dataset, protocol, budget):
    from vsmp_imu.har.protocols import split_fold
    from vsmp_imu.seeding import rng_for

    windows = tiny_dataset.windows(window_s=2.0, overlap=0.5)
    split = split_fold(windows, 3, protocol, seed=2, budget_percent=budget)
    assert split.fold == "3"
    pool = windows.where_subjects(["3"], keep=False)
    if protocol == "low-resource":
        pool = subsample_per_class(pool, low_resource_counts(pool.class_counts(), 10.0),
                                   rng_for(2, "low-resource", "3", "10"))
    elif protocol == "long-tail":
        pool = subsample_per_class(pool, long_tail_counts(pool.class_counts(), 10.0), rng_for(2, "long-tail", "3"))
        assert split.head is not None and split.tail is not None
    else:
        assert split.head is None and split.tail is None
    val = choose_val_subjects(pool.unique_subjects(), 2, "3")
    assert split.val_subjects == val
    assert np.array_equal(split.fit.X, pool.where_subjects(val, keep=False).X)
    assert np.array_equal(split.val.X, pool.where_subjects(val).X)


@pytest.mark.parametrize("budget", [None, 0.0, -1.0, 100.5, 1e-9])
def test_split_fold_rejects_a_budget_out_of_range(tiny_dataset, budget):
    from vsmp_imu.har.protocols import split_fold

    windows = tiny_dataset.windows(window_s=2.0, overlap=0.5)
    with pytest.raises(ConfigError) as err:
        split_fold(windows, "3", "low-resource", seed=0, budget_percent=budget)
    assert err.value.field == "budgets" and err.value.allowed == "0.01 <= budget <= 100 (percent)"
    assert err.value.message == f"label budget {budget} out of range"
    assert len(split_fold(windows, "3", "low-resource", seed=0, budget_percent=100.0).fit) > 0
