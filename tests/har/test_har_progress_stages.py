"""An evaluation tells where a long record is: its synthetic windows, a network's epochs."""

from __future__ import annotations

import re

from vsmp_imu.har import evaluate as evaluate_module
from vsmp_imu.har.backbones import BACKBONES
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.methods import register_all


def _lines(config, dataset) -> list[tuple[str, int]]:
    seen: list[tuple[str, int]] = []
    Evaluation(config, dataset).run(lambda description, done, total: seen.append((description, done)))
    return seen


def test_a_network_tells_its_stages_and_epochs(tiny_dataset, monkeypatch):
    monkeypatch.setattr(evaluate_module, "LOG_INTERVAL_S", 0.0)  # every epoch
    register_all()
    params = BACKBONES["dclstm"]._get_test_params()
    config = EvalConfig(dataset="tiny", backbones=("dclstm",), methods=("real", "classical"), folds=("3",),
                        backbone_params={"dclstm": params})
    seen = _lines(config, tiny_dataset)
    text = [d for d, _ in seen]
    run = "seed 0 fold 3 classical"
    assert text[0] == "seed 0 fold 3 real/dclstm: training"
    assert re.fullmatch(r"seed 0 fold 3 real/dclstm: training, epoch 1/2, validation Macro-F1 \d+\.\d\d", text[1])
    assert text.index(f"{run}: synthetic windows") < text.index(f"{run}/dclstm: training")
    epochs = [d for d in text if d.startswith(f"{run}/dclstm: training, epoch")]
    assert [int(re.search(r"epoch (\d+)/", d).group(1)) for d in epochs] == list(range(1, len(epochs) + 1))
    records = [d for d in text if ": Macro-F1 " in d]
    assert [d.split(":")[0] for d in records] == ["seed 0 fold 3 real/dclstm", f"{run}/dclstm"]
    # a stage line repeats the count of records done; only a record raises it
    counts = [done for _, done in seen]
    assert counts == sorted(counts) and counts[-1] == 2
    assert all(done == 1 for d, done in seen if d.startswith(run) and ": Macro-F1 " not in d)


def test_stage_lines_wait_for_the_interval(tiny_dataset, monkeypatch):
    monkeypatch.setattr(evaluate_module, "LOG_INTERVAL_S", 3600.0)
    params = BACKBONES["dclstm"]._get_test_params()
    config = EvalConfig(dataset="tiny", backbones=("dclstm",), methods=("real",), folds=("3",),
                        backbone_params={"dclstm": params})
    text = [d for d, _ in _lines(config, tiny_dataset)]
    assert text[0] == "seed 0 fold 3 real/dclstm: training" and len(text) == 2  # no epoch line


def test_a_forest_has_no_training_stage(tiny_dataset):
    config = EvalConfig(dataset="tiny", backbones=("rf",), methods=("real",), folds=("3",),
                        backbone_params={"rf": {"n_estimators": 10, "n_jobs": 1}})
    seen = _lines(config, tiny_dataset)
    assert len(seen) == 1 and ": Macro-F1 " in seen[0][0]


def test_an_unseen_group_is_named_by_its_group(tiny_dataset):
    config = EvalConfig(dataset="tiny", protocol="unseen", unseen=("pair",), methods=("real",), folds=("2",),
                        report_groups={"pair": ("class_1", "class_2")},
                        backbone_params={"rf": {"n_estimators": 5, "n_jobs": 1}})
    text = [d for d, _ in _lines(config, tiny_dataset)]
    assert text and all(d.startswith("seed 0 fold 2 unseen pair real/rf") for d in text)


def test_unseen_label_joins_classes_outside_a_group():
    groups = {"pair": ("class_1", "class_2")}
    assert evaluate_module._unseen_label(("class_2", "class_1"), groups) == "pair"
    assert evaluate_module._unseen_label(("class_1", "class_3"), groups) == "class_1+class_3"
    assert evaluate_module._unseen_label(None, groups) is None
