"""A gait's samples stepping at its class's real step rates (`cadence`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vsmp_imu.executor import LocalExecutor
from vsmp_imu.grounding.align import Convention
from vsmp_imu.grounding.cadence import step_rates
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.methods import BASELINE_CHAIN
from vsmp_imu.pipeline.fold import FoldGenerator, is_gait
from vsmp_imu.pipeline.sample import LocationTask, SampleTask, synthesize
from vsmp_imu.pipeline.sources import LibrarySmpSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary

FS = 50.0


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


def _task(library, activity: str, rate: float | None) -> SampleTask:
    smp = library.get(activity).smp
    conv = Convention(axes=("up", "forward", "left"), gravity_included=True).as_dict()
    return SampleTask(key=f"t/{activity}/0000", label=activity, label_index=0, source=f"library:{activity}",
                      variant=0, smp_json=smp.canonical_json(), prompt="", backend="procedural", seed=5,
                      fs_hz=FS, locations=(LocationTask("waist", conv, True, None),), sim_in_the_loop=False,
                      cadence_hz=rate)


def _rate(result) -> float:
    acc = result.signals["waist"][:, :3]
    windows = np.stack([acc[s:s + 100] for s in range(0, len(acc) - 100, 50)])
    return float(np.median(step_rates(windows, FS)))


@pytest.mark.parametrize(("activity", "target"), [("walking", 1.55), ("walking_upstairs", 2.0)])
def test_a_gait_sample_steps_at_its_drawn_rate_and_says_so(library, activity, target):
    plain, timed = synthesize(_task(library, activity, None)), synthesize(_task(library, activity, target))
    assert _rate(timed) == pytest.approx(target, abs=0.1)
    assert abs(_rate(plain) - target) > 0.15  # the SMP's tempo steps otherwise
    record = timed.provenance.motion.controls["cadence"]
    assert record["target_hz"] == target and abs(record["nominal_hz"] - _rate(plain)) < 0.15
    assert "cadence" not in (plain.provenance.motion.controls or {})


def test_only_walking_cycles_are_gaits(library):
    spec = GenerationSpec()
    assert spec.cadence is True and BASELINE_CHAIN["cadence"] is False  # on by default, not for baselines
    assert is_gait(spec, library.get("walking").smp) and is_gait(spec, library.get("walking_downstairs").smp)
    for name in ("jumping_jacks", "sit_to_lie", "standing"):
        assert not is_gait(spec, library.get(name).smp)


def test_the_fold_times_gait_classes_to_the_training_subjects_steps(library, tmp_path):
    ds = load_dataset("hapt12")
    info, windows = ds.info, ds.windows()
    train = windows.where_subjects(["2", "3", "4", "5"])
    names = ("WALKING", "WALKING_UPSTAIRS", "SIT_TO_LIE")
    budget = np.zeros(info.n_classes, np.int64)
    budget[[info.label_names.index(n) for n in names]] = 4
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    spec = GenerationSpec(k=2, oversample=1.0, max_rounds=1, quality_filter=False, sim_in_the_loop=False,
                          cadence=True)
    gen = FoldGenerator(spec, LocalExecutor(1, show_progress=False), tmp_path / "cache", library=library)
    out = gen.generate(info, train, sources, budget, seed=0, fold="t")
    found = out.summary["cadence"]
    assert set(found) == {"WALKING", "WALKING_UPSTAIRS"}
    up = info.label_names.index("WALKING_UPSTAIRS")
    real = step_rates(train.X[train.y == up][..., :3], FS)
    assert found["WALKING_UPSTAIRS"]["median_hz"] == pytest.approx(float(np.median(real)), abs=1e-3)
    assert found["WALKING_UPSTAIRS"]["median_hz"] < found["WALKING"]["median_hz"]  # climbing is slower
    for task in out.tasks:
        if task.label == "SIT_TO_LIE":
            assert task.cadence_hz is None
        else:
            assert task.cadence_hz in set(step_rates(train.X[train.y == info.label_names.index(task.label)][..., :3],
                                                     FS).tolist())
    few = train[np.r_[np.flatnonzero(train.y != up), np.flatnonzero(train.y == up)[:3]]]
    again = FoldGenerator(spec, LocalExecutor(1, show_progress=False), tmp_path / "cache", library=library)
    out = again.generate(info, few, sources, budget, seed=0, fold="t")
    assert out.summary["cadence"]["WALKING_UPSTAIRS"]["used"] is False
    assert all(t.cadence_hz is None for t in out.tasks if t.label == "WALKING_UPSTAIRS")
    plain = FoldGenerator(replace(spec, cadence=False), LocalExecutor(1, show_progress=False), tmp_path / "cache",
                          library=library).generate(info, train, sources, budget, seed=0, fold="t")
    assert "cadence" not in plain.summary and all(t.cadence_hz is None for t in plain.tasks)


def test_generate_prints_each_gait_class_cadence():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "cadence": {
        "WALKING": {"used": True, "windows": 2069, "median_hz": 1.76, "q10_hz": 1.61, "q90_hz": 1.9},
        "WALKING_UPSTAIRS": {"used": False, "reason": "3 real window(s), fewer than 5"}}}
    with console.capture() as captured:
        _print_summary(summary)
    text = " ".join(captured.get().split())
    assert ("cadence WALKING: every sample steps at the rate of one of 2069 real windows (median 1.76 steps/s, "
            "10-90 % 1.61-1.90)") in text
    assert "cadence WALKING_UPSTAIRS: the SMP's tempo (3 real window(s), fewer than 5)" in text


def test_only_the_gait_bases_of_a_class_draw_a_rate(library):
    from vsmp_imu.pipeline.fold import class_cadences, location_plan, sample_tasks

    ds = load_dataset("hapt12")
    info, train = ds.info, ds.windows().where_subjects(["2", "3"])
    conv = Convention(axes=("up", "forward", "left"), gravity_included=True).as_dict()
    bases = [("walk", library.get("walking").smp), ("jacks", library.get("jumping_jacks").smp)]
    spec = GenerationSpec(k=2)
    budget = np.zeros(info.n_classes, np.int64)
    budget[info.label_names.index("WALKING")] = 4
    rates, _ = class_cadences(spec, info, train, {"WALKING": bases}, budget, location_plan(info))
    values, gaits = rates["WALKING"]
    assert gaits == {"walk"}
    tasks = sample_tasks(spec, "WALKING", 0, bases, range(8), 0, "t", FS, (LocationTask("waist", conv, True, None),),
                         library, rates=rates["WALKING"])
    assert {t.source for t in tasks} == {"walk", "jacks"}
    for task in tasks:
        assert (task.cadence_hz in set(values.tolist())) if task.source == "walk" else task.cadence_hz is None
    assert all(t.cadence_hz is None for t in sample_tasks(spec, "WALKING", 0, bases, range(8), 0, "t", FS,
                                                          (LocationTask("waist", conv, True, None),), library))
