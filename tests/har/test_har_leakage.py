"""No window of the held-out subject reaches training, normalisation, validation or a
synthetic source, in any protocol.

Every window of the tiny dataset carries its subject in channel 0 (1000 x
subject, constant over the window). The backbones, the normaliser and the
synthetic sources below record the subjects whose fingerprints they see.
Augmented windows lose the exact fingerprint (they are then not counted);
copies keep it.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest
from har_spies import Spy

from vsmp_imu.baselines.classical import ClassicalAugmentation
from vsmp_imu.har import normalize
from vsmp_imu.har.backbones import BACKBONES, DeepConvLSTM, RandomForestECDF
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.synthetic import METHODS, FoldContext
from vsmp_imu.har.windows import Windows

SEEN: dict[str, set] = defaultdict(set)


def fingerprints(X: np.ndarray) -> set[int]:
    ch = np.asarray(X)[:, :, 0]
    exact = np.all(ch == ch[:, :1], axis=1) & (np.mod(ch[:, 0], 1000) == 0) & (ch[:, 0] > 0)
    return {int(v) for v in ch[exact, 0] // 1000}


class SpyRF(Spy, RandomForestECDF):
    seen, marks = SEEN, staticmethod(fingerprints)


class SpyDCLSTM(Spy, DeepConvLSTM):
    seen, marks = SEEN, staticmethod(fingerprints)


def _record_context(context: FoldContext) -> None:
    SEEN["source"] |= fingerprints(context.train.X)
    SEEN["source_subjects"] |= set(context.train.subjects.tolist()) | set(context.train_subjects)
    SEEN["held_out_told"].add(context.held_out_subject)


class CopySource:
    """Synthetic windows that are exact copies of training windows (fingerprints kept)."""

    name = "copy"

    def generate(self, context: FoldContext) -> Windows:
        _record_context(context)
        picks = [
            np.flatnonzero(context.train.y == c)[:n] for c, n in enumerate(context.budget_vector())
        ]
        return context.train[np.concatenate(picks)]


class HalfSource(CopySource):
    """Copies half of each class's budget (rounded down): a source that falls short."""

    name = "half"

    def generate(self, context: FoldContext) -> Windows:
        picks = [
            np.flatnonzero(context.train.y == c)[: n // 2] for c, n in enumerate(context.budget_vector())
        ]
        return context.train[np.concatenate(picks)]


class SpyClassical(ClassicalAugmentation):
    def generate(self, context: FoldContext) -> Windows:
        _record_context(context)
        return super().generate(context)


@pytest.fixture
def spies(monkeypatch):
    monkeypatch.setitem(BACKBONES, "spy-rf", SpyRF)
    monkeypatch.setitem(BACKBONES, "spy-dclstm", SpyDCLSTM)
    monkeypatch.setitem(METHODS, "copy", CopySource)
    monkeypatch.setitem(METHODS, "spy-classical", SpyClassical)
    original_fit = normalize.ChannelStandardizer.fit

    def spy_fit(self, X):
        SEEN["normalizer"] |= fingerprints(X)
        return original_fit(self, X)

    monkeypatch.setattr(normalize.ChannelStandardizer, "fit", spy_fit)


@pytest.mark.parametrize(
    "protocol,budgets,policy",
    [
        ("lopo", (None,), "uniform"),
        ("low-resource", (5.0, 50.0), "scarcity"),
        ("long-tail", (None,), "tail"),
    ],
)
def test_held_out_subject_never_reaches_training_side(
    spies, tiny_dataset, protocol, budgets, policy
):
    subjects = tiny_dataset.subjects
    for _ in (policy,):
        for held in subjects:
            SEEN.clear()
            config = EvalConfig(
                dataset="tiny",
                protocol=protocol,
                budgets=budgets,
                backbones=("spy-rf", "spy-dclstm"),
                methods=("real", "copy", "spy-classical"),
                folds=(held,),
                alpha=1.0,
                policy=policy,
                backbone_params={
                    "spy-rf": {"n_estimators": 5, "n_jobs": 1},
                    "spy-dclstm": SpyDCLSTM._get_test_params(),
                },
            )
            results = Evaluation(config, tiny_dataset).run()
            assert len(results.records) == len(budgets) * 3 * 2
            h = int(held)
            others = {int(s) for s in subjects} - {h}
            # the instruments work: prediction sees the held-out subject, training sees others
            assert SEEN["predict"] == {h}
            assert SEEN["fit"] and SEEN["fit"] <= others
            assert SEEN["val"] and SEEN["val"] <= others
            assert SEEN["val_predict"] <= SEEN["val"]
            assert SEEN["normalizer"] and SEEN["normalizer"] <= others
            assert SEEN["source"] and SEEN["source"] <= others
            assert held not in SEEN["source_subjects"]
            assert SEEN["held_out_told"] == {held}
            # validation subjects are never training subjects of the same model
            for r in results.records:
                assert held not in r["val_subjects"]


def test_synthetic_windows_respect_the_budget(spies, tiny_dataset):
    config = EvalConfig(
        dataset="tiny",
        backbones=("spy-dclstm",),
        methods=("copy", "spy-classical"),
        folds=("2",),
        alpha=0.5,
        backbone_params={"spy-dclstm": SpyDCLSTM._get_test_params()},
    )
    for r in Evaluation(config, tiny_dataset).run().records:
        assert r["n_synthetic"] == round(0.5 * r["n_train_real"])


def test_a_source_that_falls_short_is_reported(monkeypatch, spies, tiny_dataset):
    """Records, summary and report say how many synthetic windows each run got of those asked."""
    from vsmp_imu.har.report import results_markdown

    monkeypatch.setitem(METHODS, "half", HalfSource)
    config = EvalConfig(dataset="tiny", backbones=("spy-rf",), methods=("real", "copy", "half"),
                        folds=("2",), alpha=0.5)
    results = Evaluation(config, tiny_dataset).run()
    by_method = {r["method"]: r for r in results.records}
    asked = by_method["copy"]["n_synthetic_requested"]
    assert asked > 0 and by_method["copy"]["n_synthetic"] == asked
    assert by_method["half"]["n_synthetic_requested"] == asked
    assert 0 < by_method["half"]["n_synthetic"] < asked
    assert by_method["real"]["n_synthetic_requested"] == 0
    rows = {r["method"]: r for r in results.summary}
    assert rows["half"]["n_synthetic_mean"] == by_method["half"]["n_synthetic"]
    assert rows["half"]["n_synthetic_requested_mean"] == asked
    md = results_markdown(results.to_json())
    share = round(100 * by_method["half"]["n_synthetic"] / asked)
    assert f"| half | {by_method['half']['n_synthetic']} | {asked} | {share} % |" in md
    assert f"| copy | {asked} | {asked} | 100 % |" in md
    assert "| Real-only |" not in md.split("Synthetic windows mixed in")[1]
