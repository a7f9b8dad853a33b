"""Do no harm: the per-class share of synthetic windows chosen on the validation subjects."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.backbones import RandomForestECDF
from vsmp_imu.har.dataset import imu_channel_names
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.noharm import ShareSelector, dropped_summary, harm, shares_vector, take_shares
from vsmp_imu.har.windows import Windows, concat_windows
from vsmp_imu.methods import register_all

CHANNELS = imu_channel_names(None)


def _windows(means: list[float], labels: list[int], n_per: int, rng, subject: str, names=("a", "b", "c")):
    """n_per windows per (mean, label) pair: channel 1 is the class's level plus noise."""
    X, y = [], []
    for mean, label in zip(means, labels, strict=True):
        x = rng.normal(0, 0.3, (n_per, 20, len(CHANNELS)))
        x[:, :, 1] += mean
        X.append(x)
        y += [label] * n_per
    X = np.concatenate(X).astype(np.float32)
    return Windows(X, np.array(y), np.full(len(y), subject), names, CHANNELS, 10.0)


def _rf_fit(windows: Windows):
    return RandomForestECDF(n_estimators=30, n_jobs=1, random_state=0).fit(windows.X, windows.y)


def test_harm_needs_evidence():
    assert harm(np.array([])).p == 1 and not harm(np.array([])).hurts
    assert harm(np.zeros(50)).p == 1
    assert not harm(np.array([-0.2, -0.1, -0.3])).hurts  # three windows cannot show harm
    rng = np.random.default_rng(0)
    assert harm(rng.normal(-0.05, 0.05, 60)).hurts
    assert not harm(rng.normal(0.0, 0.05, 60)).hurts
    assert harm(np.full(40, -0.1)).p == harm(np.full(40, -0.1)).p  # seeded: same data, same p


def test_classes_weigh_the_same_in_the_balanced_mean():
    change = np.array([-0.1] * 90 + [0.5] * 10)
    labels = np.array([0] * 90 + [1] * 10)
    assert harm(change).mean_change == pytest.approx(-0.04)
    assert harm(change, labels).mean_change == pytest.approx(0.2)
    assert not harm(change, labels).hurts


def test_label_noise_of_one_class_gets_share_zero_per_class_and_clean_windows_are_kept():
    rng = np.random.default_rng(0)
    real = _windows([0.0, 1.0, 2.0], [0, 1, 2], 6, rng, "1")
    val = _windows([0.0, 1.0, 2.0], [0, 1, 2], 20, rng, "2")
    # class 1's synthetic windows look like class 0 (label noise); class 2's are right
    synthetic = _windows([0.0, 2.0], [1, 2], 30, rng, "synthetic")
    choice = ShareSelector("class").choose(_rf_fit, real, synthetic, val)
    assert choice[1].share == 0 and choice[1].kept == 0
    assert choice[1].reason.startswith("dropped: hurt one-vs-rest")
    assert choice[2].share == 1 and choice[2].kept == 30
    assert 0 not in choice  # no synthetic window offered, nothing chosen
    kept = take_shares(synthetic, shares_vector(choice, 3))
    assert set(kept.y.tolist()) == {2}


def test_a_method_whose_windows_are_label_noise_is_dropped_whole():
    rng = np.random.default_rng(2)
    real = _windows([0.0, 1.0, 2.0], [0, 1, 2], 6, rng, "1")
    val = _windows([0.0, 1.0, 2.0], [0, 1, 2], 20, rng, "2")
    noise = _windows([1.0, 2.0, 0.0], [0, 1, 2], 30, rng, "synthetic")  # every label wrong
    choice = ShareSelector("method").choose(_rf_fit, real, noise, val)
    assert [choice[c].share for c in range(3)] == [0, 0, 0]
    assert all("dropped with the method's other synthetic windows" in s.reason for s in choice.values())
    right = _windows([0.0, 1.0, 2.0], [0, 1, 2], 30, rng, "synthetic")
    assert all(s.share == 1 for s in ShareSelector("method").choose(_rf_fit, real, right, val).values())


def test_a_class_without_validation_windows_keeps_its_windows_and_says_why():
    rng = np.random.default_rng(1)
    real = _windows([0.0, 1.0, 2.0], [0, 1, 2], 6, rng, "1")
    val = _windows([0.0, 1.0], [0, 1], 20, rng, "2")
    synthetic = _windows([1.0, 2.0], [0, 2], 10, rng, "synthetic")
    choice = ShareSelector("class").choose(_rf_fit, real, synthetic, val)
    assert choice[2].share == 1 and choice[2].n_val == 0 and choice[2].mean_change is None
    assert not choice[2].judged and choice[2].reason.startswith("kept unjudged: 0 validation windows")
    assert choice[0].judged and choice[0].share == 0  # class 0's windows carry class 1's level
    nothing = ShareSelector("class").choose(_rf_fit, real, synthetic, val[:0])
    assert all(s.share == 1 and not s.judged for s in nothing.values())


def test_the_class_guard_judges_a_class_only_on_enough_windows_of_its_own():
    """Label noise in class 1's synthetic windows is dropped with 20 validation windows of class 1
    (test above) but kept unjudged with 5: the others' side alone would charge any class for being
    learnt at all. Where no class reaches the floor nothing is fitted."""
    from vsmp_imu.har.noharm import MIN_OWN_VALIDATION

    rng = np.random.default_rng(0)
    real = _windows([0.0, 1.0, 2.0], [0, 1, 2], 6, rng, "1")
    synthetic = _windows([0.0, 2.0], [1, 2], 30, rng, "synthetic")
    few = MIN_OWN_VALIDATION // 2
    val = _windows([0.0, 1.0, 2.0], [0, 1, 2], few, rng, "2")
    fits = []

    def counted(windows):
        fits.append(len(windows))
        return _rf_fit(windows)

    choice = ShareSelector("class").choose(counted, real, synthetic, val)
    assert fits == [] and all(s.share == 1 and not s.judged for s in choice.values())
    assert choice[1].reason.startswith(f"kept unjudged: {few} validation windows of the class, "
                                       f"fewer than {MIN_OWN_VALIDATION}")
    # one class at the floor: both fits run, and only that class is judged
    val = concat_windows([_windows([0.0], [0], 20, rng, "2"), _windows([1.0], [1], MIN_OWN_VALIDATION, rng, "2"),
                          _windows([2.0], [2], few, rng, "2")])
    choice = ShareSelector("class").choose(counted, real, synthetic, val)
    assert len(fits) == 2 and choice[1].judged and not choice[2].judged
    assert choice[1].share == 0 and choice[2].share == 1
    # the method-wide guard still judges every class on all validation windows
    method = ShareSelector("method").choose(_rf_fit, real, synthetic, val)
    assert all(s.judged for s in method.values())


def test_the_summary_counts_unjudged_classes_from_the_choice_and_older_records_by_their_windows():
    new = {"shares": {"A": {"share": 1.0, "n_val": 4, "judged": False}, "B": {"share": 0.0, "n_val": 30}}}
    old = {"shares": {"A": {"share": 1.0, "n_val": 0}, "B": {"share": 1.0, "n_val": 3}}}
    summary = dropped_summary([{"synthetic_shares": r["shares"]} for r in (new, old)])
    assert summary == {"A": {"runs": 2, "none": 0, "unjudged": 2}, "B": {"runs": 2, "none": 1, "unjudged": 0}}


def test_an_unknown_mode_is_a_config_error():
    with pytest.raises(ConfigError) as err:
        EvalConfig(dataset="tiny", share_selection="some").check()
    assert err.value.field == "--share-selection"
    assert "Allowed: off, method, class, amount." in str(err.value)


def test_tstr_refuses_a_guard_it_has_no_real_only_model_for():
    with pytest.raises(ConfigError, match="no real-only model") as err:
        EvalConfig(dataset="tiny", protocol="tstr", share_selection="class").check()
    assert err.value.field == "--share-selection"
    EvalConfig(dataset="tiny", protocol="tstr", share_selection="off").check()


def test_amount_keeps_all_of_helpful_windows_and_little_of_half_wrong_ones():
    """With two real windows per class the right synthetic windows help most when all are mixed;
    where the later half of each class's windows carry the wrong class's level, the first
    windows alone (a smaller share) score best; with no validation window everything is kept."""
    from vsmp_imu.har.noharm import AMOUNTS

    rng = np.random.default_rng(3)
    real = _windows([0.0, 1.0, 2.0], [0, 1, 2], 2, rng, "1")
    val = _windows([0.0, 1.0, 2.0], [0, 1, 2], 20, rng, "2")
    right = _windows([0.0, 1.0, 2.0], [0, 1, 2], 40, rng, "synthetic")
    choice = ShareSelector("amount").choose(_rf_fit, real, right, val)
    assert sorted(choice) == [0, 1, 2] and {s.share for s in choice.values()} == {1.0}
    assert choice[0].kept == 40 and choice[0].n_val == 20 and choice[0].reason.startswith("share 1 chosen")
    assert all(f"{a:g}: " in choice[0].reason for a in AMOUNTS)
    # each class: 5 right windows first, then 35 of the next class's level
    parts = [_windows([m], [c], 5, rng, "synthetic") for m, c in ((0.0, 0), (1.0, 1), (2.0, 2))]
    parts += [_windows([m], [c], 35, rng, "synthetic") for m, c in ((1.0, 0), (2.0, 1), (0.0, 2))]
    from vsmp_imu.har.windows import concat_windows

    mixed = concat_windows(parts)
    order = np.argsort(mixed.y, kind="stable")  # per class: the right windows first
    choice = ShareSelector("amount").choose(_rf_fit, real, mixed[order], val)
    assert 0 < choice[0].share <= 0.25 and len({s.share for s in choice.values()}) == 1
    nothing = ShareSelector("amount").choose(_rf_fit, real, right, val[:0])
    assert all(s.share == 1 and "no validation windows" in s.reason for s in nothing.values())


def _config(**kw) -> EvalConfig:
    register_all()
    base = dict(dataset="tiny", protocol="low-resource", budgets=(50.0,), backbones=("rf",),
                methods=("real", "classical"), folds=("3",), seeds=(0, 1), alpha=1.0,
                policy="scarcity", backbone_params={"rf": {"n_estimators": 10, "n_jobs": 1}},
                share_selection="method")
    return EvalConfig(**{**base, **kw})


def _changed_subject(dataset, subject: str, seed: int = 7):
    """The same dataset with the windows of `subject` replaced by noise with other labels."""
    original = dataset._load
    rng = np.random.default_rng(seed)

    def _load():
        out = []
        for rec in original():
            if rec.subject == subject:
                rec = replace(rec, data=rng.normal(0, 3, rec.data.shape), labels=(rec.labels + 1) % 4)
            out.append(rec)
        return out

    dataset._load = _load
    return dataset


def _choices(results) -> list:
    return [(r["method"], r["seed"], r["synthetic_shares"]) for r in results.records]


def test_the_held_out_subject_never_influences_the_choice(tiny_dataset, tiny_factory):
    config = _config()
    base = Evaluation(config, tiny_dataset).run()
    changed = Evaluation(config, _changed_subject(tiny_factory(), "3")).run()
    assert _choices(base) == _choices(changed)
    assert [r["macro_f1"] for r in base.records] != [r["macro_f1"] for r in changed.records]
    # the instrument can fail: changing a validation subject changes the recorded scores
    val_subject = base.records[1]["val_subjects"][0]
    moved = Evaluation(config, _changed_subject(tiny_factory(), val_subject)).run()
    assert _choices(moved) != _choices(base)


def test_records_carry_the_choice_and_the_summary_counts_it(tiny_dataset):
    results = Evaluation(_config(), tiny_dataset).run()
    for r in results.records:
        if r["method"] == "real":
            assert r["synthetic_shares"] is None
            continue
        shares = r["synthetic_shares"]
        assert shares and set(shares) <= set(tiny_dataset.info.label_names)
        assert r["n_synthetic"] == sum(s["kept"] for s in shares.values())
        for s in shares.values():
            assert s["kept"] == round(s["share"] * s["offered"]) and s["reason"]
    row = next(r for r in results.summary if r["method"] == "classical")
    assert row["synthetic_shares"] == dropped_summary([r for r in results.records if r["method"] == "classical"])
    assert all(v["runs"] == 2 for v in row["synthetic_shares"].values())


def test_selection_off_mixes_everything_and_keeps_the_old_digest(tiny_dataset):
    on, off = Evaluation(_config(), tiny_dataset), Evaluation(_config(share_selection="off"), tiny_dataset)
    assert on._digest("rf", "classical") != off._digest("rf", "classical")
    assert on._digest("rf", "real") == off._digest("rf", "real")
    assert Evaluation(_config(share_selection="class"), tiny_dataset)._digest("rf", "classical") not in (
        on._digest("rf", "classical"), off._digest("rf", "classical"))
    for r in off.run().records:
        assert r["synthetic_shares"] is None
        assert r["n_synthetic"] == r["n_synthetic_requested"]


def test_same_seed_same_bytes(tiny_dataset, tiny_factory, tmp_path):
    Evaluation(_config(), tiny_dataset, tmp_path / "a").run()
    Evaluation(_config(), tiny_factory(), tmp_path / "b").run()
    a, b = ((tmp_path / d / "results.json").read_bytes() for d in "ab")
    assert a == b
    assert any(r["synthetic_shares"] for r in json.loads(a)["records"])


def test_the_command_line_notes_name_classes_without_synthetic_windows():
    from vsmp_imu.cli.har import _share_notes

    row = {"method": "vsmp", "protocol": "low-resource", "budget": 1.0, "backbone": "rf",
           "synthetic_shares": {"WALKING": {"runs": 30, "none": 12, "unjudged": 0},
                                "SIT_TO_LIE": {"runs": 30, "none": 0, "unjudged": 30}}}
    lines = _share_notes([row])
    assert "WALKING in 12/30 runs" in lines[0] and "SIT_TO_LIE" not in lines[0]
    assert "SIT_TO_LIE (30/30)" in lines[1]


def test_evaluate_and_generate_default_to_the_settings_that_measured_a_gain():
    """alpha 2 with the scarcity policy (docs/results.md); the harness's own config keeps the
    paper's values for the studies."""
    import inspect

    from vsmp_imu.app import EvalRequest
    from vsmp_imu.cli.generate import generate_cmd
    from vsmp_imu.cli.har import budget_defaults, evaluate_cmd
    from vsmp_imu.pipeline.spec import GenerationSpec

    spec = GenerationSpec()
    assert (spec.alpha, spec.policy) == (2.0, "scarcity")
    params = inspect.signature(generate_cmd).parameters
    assert (params["alpha"].default.default, params["policy"].default.default) == (spec.alpha, spec.policy)
    # evaluate resolves them per protocol: tstr reads against TRTR (alpha 1, uniform), unseen
    # budgets the unseen classes only (tail), the others take these
    params = inspect.signature(evaluate_cmd).parameters
    assert params["alpha"].default.default is None and params["policy"].default.default is None
    for protocol in ("lopo", "low-resource", "long-tail"):
        assert budget_defaults(protocol, None, None) == (spec.alpha, spec.policy)
    assert budget_defaults("unseen", None, None) == (spec.alpha, "tail")
    # the per-class guard with the forests where the training subjects keep their labels
    # (docs/results.md, "The guard judges a class on its own windows"); off under low-resource and
    # tstr and with a network; the Python API keeps the paper's mixing
    from vsmp_imu.cli.har import share_default

    assert inspect.signature(evaluate_cmd).parameters["share_selection"].default.default is None
    for protocol in ("lopo", "long-tail", "unseen"):
        assert share_default(protocol, ("rf", "rf-seg"), None) == "class"
        assert share_default(protocol, ("rf", "dclstm"), None) == "off"
    assert share_default("tstr", ("rf",), None) == "off"
    assert share_default("low-resource", ("rf",), None) == "off"
    assert share_default("tstr", ("dclstm",), "method") == "method"
    with pytest.raises(ConfigError):
        share_default("lopo", ("rf",), "most")
    assert EvalRequest(dataset="x", output=None).share_selection == "off"
    assert EvalConfig(dataset="x").share_selection == "off"
    assert (EvalConfig(dataset="x").alpha, EvalConfig(dataset="x").policy) == (0.5, "uniform")


def test_committed_records_keep_the_choice(tiny_dataset, tmp_path):
    from vsmp_imu.har.records import import_run, load_run

    Evaluation(_config(seeds=(0,)), tiny_dataset, tmp_path / "run").run()
    import_run(tmp_path / "run", "tiny", "vsmp-imu evaluate ...", tmp_path / "results")
    records = load_run(tmp_path / "results", "tiny").records
    assert {r["method"]: r["synthetic_shares"] is not None for r in records} == {"real": False, "classical": True}


def test_the_sign_flip_p_counts_the_flips_at_or_below_the_observed_mean():
    """p = (1 + #flips with mean <= observed) / (1 + N_FLIPS): all-negative changes of 20 windows are
    beaten by no flip (p at its floor), all-positive ones by every flip (p = 1); one window is a coin."""
    from vsmp_imu.har.noharm import HARM_P, N_FLIPS, Harm

    assert harm(np.full(20, -0.1)).p == 1 / (1 + N_FLIPS)
    assert harm(np.full(20, 0.1)).p == 1.0
    coin = harm(np.array([-0.3]))
    assert 0.45 < coin.p < 0.55 and coin.mean_change == pytest.approx(-0.3)
    three = harm(np.array([-0.2, -0.1, -0.3]))  # all signs negative: 1 flip in 8
    assert 0.1 < three.p < 0.15 and three.n == 3
    assert Harm(30, -0.01, HARM_P - 1e-9).hurts and not Harm(30, -0.01, HARM_P).hurts
    assert not Harm(30, 0.0, 0.0).hurts and not Harm(0, -1.0, 0.0).hurts


def test_the_evidence_text_names_the_mean_the_windows_and_p():
    from vsmp_imu.har.noharm import Harm

    assert Harm(12, -0.0314, 0.0123).text() == ("validation p(true class) -0.031 on average over 12 windows, "
                                                "classes weighted equally (one-sided sign-flip p = 0.012)")


def test_full_proba_puts_each_column_at_its_class_index():
    class TwoOfFour:
        classes_ = np.array([1, 3])

        def predict_proba(self, X):
            return np.tile([0.25, 0.75], (len(X), 1))

    from vsmp_imu.har.noharm import full_proba

    rng = np.random.default_rng(0)
    w = _windows([0.0], [0], 3, rng, "1")
    assert full_proba(TwoOfFour(), w, 4).tolist() == [[0.0, 0.25, 0.0, 0.75]] * 3


def test_take_shares_keeps_the_first_windows_of_each_class_in_order():
    rng = np.random.default_rng(0)
    synthetic = _windows([0.0, 1.0, 2.0], [0, 1, 2], 4, rng, "s")
    kept = take_shares(synthetic, np.array([0.5, 0.0, 1.0]))
    assert kept.y.tolist() == [0, 0, 2, 2, 2, 2]
    assert np.array_equal(kept.X, np.concatenate([synthetic.X[:2], synthetic.X[8:]]))
    assert shares_vector({1: _share(0.0), 2: _share(1.0)}, 3).tolist() == [1.0, 0.0, 1.0]


def _share(value: float):
    from vsmp_imu.har.noharm import ClassShare

    return ClassShare(value, 4, int(4 * value), 2, None, "why")


def test_the_dropped_summary_counts_runs_empty_classes_and_unjudged_ones():
    from dataclasses import asdict

    from vsmp_imu.har.noharm import choice_record

    first = choice_record({1: _share(0.0), 0: replace(_share(1.0), n_val=0, judged=False)}, ("a", "b"))
    assert list(first) == ["a", "b"] and first["b"] == asdict(_share(0.0))
    second = choice_record({0: _share(1.0), 1: _share(1.0)}, ("a", "b"))
    records = [{"synthetic_shares": first}, {"synthetic_shares": None}, {"synthetic_shares": second}]
    assert dropped_summary(records) == {"a": {"runs": 2, "none": 0, "unjudged": 1},
                                        "b": {"runs": 2, "none": 1, "unjudged": 0}}


def test_the_decision_and_its_reason_in_each_mode():
    from vsmp_imu.har.noharm import Harm

    hurt, fine, empty = Harm(40, -0.05, 0.01), Harm(40, 0.02, 0.9), Harm(0, float("nan"), 1.0)
    method, per_class = ShareSelector("method"), ShareSelector("class")
    assert method._decide(empty, hurt) == (False, "no validation windows: kept all (harm cannot be measured)")
    assert method._decide(hurt, fine) == (True, "dropped with the method's other synthetic windows: "
                                             + hurt.text())
    assert method._decide(fine, hurt) == (False, "kept: no measured harm, " + fine.text())
    one_vs_rest = "p(class) for the class, -p(class) for the others,"
    drop, reason = per_class._decide(fine, hurt)
    assert drop and reason == "dropped: hurt one-vs-rest, " + hurt.text().replace("p(true class)", one_vs_rest)
    keep, reason = per_class._decide(hurt, fine)
    assert not keep and reason == ("kept: no measured harm one-vs-rest, "
                                   + fine.text().replace("p(true class)", one_vs_rest))


def test_the_method_decision_weighs_the_classes_equally():
    """90 validation windows of class 0 lose 0.11 of p(true class), 10 of class 1 gain 0.5: over windows the
    mean falls (-0.05), over classes it rises (+0.19), and the method keeps its windows."""

    def windows(labels, subject):
        X = np.zeros((len(labels), 20, len(CHANNELS)), np.float32)
        X[:, :, 1] = np.asarray(labels)[:, None]
        return Windows(X, np.asarray(labels), np.full(len(labels), subject), ("a", "b"), CHANNELS, 10.0)

    real, synthetic, val = windows([0, 1] * 5, "1"), windows([0, 1] * 3, "s"), windows([0] * 90 + [1] * 10, "2")

    class Model:
        classes_ = np.array([0, 1])

        def __init__(self, mixed: bool):
            self.mixed = mixed

        def predict_proba(self, X):
            level = X[:, 0, 1]
            p1 = np.where(level > 0.5, 1.0 if self.mixed else 0.5, 0.3123456 if self.mixed else 0.2)
            return np.stack([1 - p1, p1], axis=1)

    choice = ShareSelector("method").choose(lambda w: Model(len(w) > len(real)), real, synthetic, val)
    assert [choice[c].share for c in (0, 1)] == [1.0, 1.0]
    assert "p(true class) +0.194 on average over 100 windows" in choice[0].reason
    assert harm(np.array([-0.1123456] * 90 + [0.5] * 10)).hurts  # the same evidence unweighted would drop them
    # one-vs-rest, the class's own windows and the others' weigh the same: +0.5 on 10 against -0.11 on 90
    per_class = ShareSelector("class").choose(lambda w: Model(len(w) > len(real)), real, synthetic, val)
    assert [per_class[c].share for c in (0, 1)] == [1.0, 1.0]
    assert "+0.194 on average over 100 windows" in per_class[1].reason
    assert "no validation window of the class" not in per_class[1].reason
    assert per_class[1].mean_change == 0.5 and per_class[0].mean_change == -0.112346  # to 6 decimals


def test_the_sign_flip_draws_are_pinned():
    """The flips come from default_rng(0): the same changes give the same p in every run and version
    (committed records quote it in their reasons); 124 and 177 of the 2000 flips fall at or below."""
    from vsmp_imu.har.noharm import N_FLIPS

    x = np.array([-0.2, 0.1, -0.15, -0.05, 0.02, -0.3, 0.04, -0.12])
    assert harm(x).p == (1 + 124) / (1 + N_FLIPS)
    assert harm(x, np.array([0, 0, 1, 1, 1, 2, 2, 2])).p == (1 + 177) / (1 + N_FLIPS)


def test_harm_without_evidence_reports_its_count_and_mean():
    import math

    empty = harm(np.array([]))
    assert (empty.n, empty.p) == (0, 1.0) and math.isnan(empty.mean_change)
    flat = harm(np.zeros(50))
    assert (flat.n, flat.mean_change, flat.p) == (50, 0.0, 1.0)


# -- what the mutation run of noharm.py found untested (docs/mutation-report.md) --------------------
def _level_windows(labels, subject, names=("a", "b", "c")):
    """One window per label, channel 1 at the label's value."""
    X = np.zeros((len(labels), 20, len(CHANNELS)), np.float32)
    X[:, :, 1] = np.asarray(labels)[:, None]
    return Windows(X, np.asarray(labels), np.full(len(labels), subject), names, CHANNELS, 10.0)


class _FixedModel:
    """Gives every window probability `p_true` for its own class (its level), the rest spread evenly."""

    def __init__(self, p_true: float, n_classes: int = 3):
        self.p_true, self.classes_ = p_true, np.arange(n_classes)

    def predict_proba(self, X):
        level = np.rint(X[:, 0, 1]).astype(int)
        out = np.full((len(X), len(self.classes_)), (1 - self.p_true) / (len(self.classes_) - 1))
        out[np.arange(len(X)), level] = self.p_true
        return out


def test_true_class_score_weighs_each_class_alike():
    from vsmp_imu.har.noharm import true_class_score

    proba = np.array([[0.9, 0.05, 0.05], [0.7, 0.2, 0.1], [0.2, 0.6, 0.2], [0.4, 0.4, 0.2]])
    labels = np.array([0, 0, 1, 2])
    # class 0: (0.9 + 0.7) / 2 = 0.8; class 1: 0.6; class 2: 0.2; each class weighs a third
    assert true_class_score(proba, labels) == pytest.approx(1.6 / 3)


def test_amount_takes_the_best_share_even_where_every_score_rounds_alike():
    """Share 0.25 scores 0.9, every other 0.8 (both round to 1): 0.25 is chosen, and the reason
    lists every share's score."""
    real, val = _level_windows([0, 1, 2] * 4, "1"), _level_windows([0, 1, 2] * 5, "2")
    synthetic = _level_windows([0] * 8 + [1] * 8 + [2] * 8, "synthetic")
    quarter = len(real) + 6  # two windows of each class

    choice = ShareSelector("amount").choose(lambda w: _FixedModel(0.9 if len(w) == quarter else 0.8),
                                            real, synthetic, val)
    assert {s.share for s in choice.values()} == {0.25}
    assert choice[0].reason == ("share 0.25 chosen: validation p(true class), classes weighted equally, per share "
                                "0: 0.8000, 0.125: 0.8000, 0.25: 0.9000, 0.5: 0.8000, 1: 0.8000")
    assert (choice[1].offered, choice[1].kept, choice[1].n_val, choice[1].judged) == (8, 2, 5, True)


def test_amount_without_validation_windows_of_a_class_says_it_was_not_judged():
    real, synthetic = _level_windows([0, 1, 2] * 4, "1"), _level_windows([0, 1, 2] * 4, "synthetic")
    choice = ShareSelector("amount").choose(lambda w: _FixedModel(0.8), real, synthetic,
                                            _level_windows([0, 1] * 5, "2"))
    assert choice[2].judged is False and choice[2].n_val == 0 and choice[0].judged is True
    one = ShareSelector("amount").choose(lambda w: _FixedModel(0.8), real, synthetic, _level_windows([0, 1, 2], "2"))
    assert one[2].judged is True and one[2].n_val == 1
    nothing = ShareSelector("amount").choose(lambda w: _FixedModel(0.8), real, synthetic, real[:0])
    assert [(s.share, s.offered, s.kept) for s in nothing.values()] == [(1.0, 4, 4)] * 3
    assert nothing[0].reason == "no validation windows: kept all (the amount cannot be chosen)"


def test_every_class_after_an_unjudged_one_gets_its_own_choice():
    """Class 0 has too few validation windows of its own (kept unjudged, with its counts); the classes
    after it are still judged."""
    from vsmp_imu.har.noharm import MIN_OWN_VALIDATION

    real = _level_windows([0, 1, 2] * 4, "1")
    val = _level_windows([0] + [1, 2] * MIN_OWN_VALIDATION, "2")
    synthetic = _level_windows([0] * 3 + [1] * 5 + [2] * 7, "synthetic")
    choice = ShareSelector("class").choose(lambda w: _FixedModel(0.8), real, synthetic, val)
    assert sorted(choice) == [0, 1, 2]
    assert (choice[0].share, choice[0].offered, choice[0].kept, choice[0].judged) == (1.0, 3, 3, False)
    assert choice[0].reason == (f"kept unjudged: 1 validation window of the class, fewer than {MIN_OWN_VALIDATION} "
                                "(the others' windows alone would charge the class for being learnt at all)")
    assert choice[1].judged is True and choice[2].judged is True
    assert (choice[2].offered, choice[2].kept) == (7, 7)  # no change in p: no harm, kept


def test_one_synthetic_window_is_enough_to_be_judged():
    from vsmp_imu.har.noharm import MIN_OWN_VALIDATION

    real = _level_windows([0, 1, 2] * 4, "1")
    val = _level_windows([0, 1, 2] * MIN_OWN_VALIDATION, "2")
    one = _level_windows([1], "synthetic")
    for mode in ("class", "method"):
        choice = ShareSelector(mode).choose(lambda w: _FixedModel(0.8), real, one, val)
        assert list(choice) == [1] and choice[1].judged is True and choice[1].offered == 1


def test_the_method_guard_on_a_class_without_validation_windows_reports_no_mean():
    """Only the first of three classes offers windows, and the last class has no validation window:
    the method's decision covers the offered class, and the class without windows of its own reports
    no mean change and no judgement of its own."""
    real = _level_windows([0, 1, 2] * 4, "1")
    val = _level_windows([0, 1] * 10, "2")
    synthetic = _level_windows([0] * 4, "synthetic")
    assert list(ShareSelector("method").choose(lambda w: _FixedModel(0.8), real, synthetic, val)) == [0]
    synthetic = _level_windows([0] * 4 + [2] * 4, "synthetic")
    choice = ShareSelector("method").choose(lambda w: _FixedModel(0.8), real, synthetic, val)
    assert choice[2].mean_change is None and choice[2].judged is False and choice[0].judged is True
    assert choice[0].mean_change == 0.0


def test_an_older_record_with_one_validation_window_was_judged():
    from vsmp_imu.har.noharm import unjudged

    assert unjudged({"share": 1.0, "n_val": 0}) and not unjudged({"share": 1.0, "n_val": 1})


def test_the_class_guard_fits_nothing_where_only_unjudged_classes_offer_windows():
    """Classes 0 and 1 have validation windows enough but offer no synthetic window; class 2 offers
    some but has too few validation windows: nothing to decide, so no backbone is fitted."""
    from vsmp_imu.har.noharm import MIN_OWN_VALIDATION

    fits = []

    def counted(windows):
        fits.append(len(windows))
        return _FixedModel(0.8)

    real = _level_windows([0, 1, 2] * 4, "1")
    val = _level_windows([0, 1] * MIN_OWN_VALIDATION + [2], "2")
    choice = ShareSelector("class").choose(counted, real, _level_windows([2] * 5, "synthetic"), val)
    assert fits == [] and list(choice) == [2] and choice[2].judged is False
