"""A discrete event's samples timed to its class's real events (`event_durations`)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from vsmp_imu.errors import ValidationError
from vsmp_imu.executor import LocalExecutor
from vsmp_imu.grounding.align import Convention
from vsmp_imu.grounding.durations import SCALE_BOUNDS
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.pipeline.fold import FoldGenerator, is_discrete
from vsmp_imu.pipeline.sample import LocationTask, SampleTask, active_span, synthesize
from vsmp_imu.pipeline.sources import LibrarySmpSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


def _span(motion) -> float:
    start, end = active_span(motion)
    return end - start


def test_the_duration_scale_stretches_the_motion_and_is_recorded(library):
    backend = ProceduralBackend(library=library)
    smp = library.get("sit_to_lie").smp
    plain, slow = backend.generate(smp, 3), backend.generate(smp, 3, duration_scale=2.0)
    assert _span(slow) == pytest.approx(2.0 * _span(plain), rel=0.1)
    assert slow.meta["controls"]["duration_scale"] == 2.0 and "duration_scale" not in plain.meta["controls"]
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValidationError, match="duration_scale"):
            backend.generate(smp, 3, duration_scale=bad)


def _task(library, event_s: float | None) -> SampleTask:
    smp = library.get("sit_to_lie").smp
    conv = Convention(axes=("up", "forward", "left"), gravity_included=True).as_dict()
    return SampleTask(key="t/SIT_TO_LIE/0000", label="SIT_TO_LIE", label_index=8, source="library:sit_to_lie",
                      variant=0, smp_json=smp.canonical_json(), prompt="", backend="procedural", seed=11,
                      fs_hz=50.0, locations=(LocationTask("waist", conv, True, None),), sim_in_the_loop=False,
                      event_duration_s=event_s)


@pytest.mark.parametrize("target", [3.0, 4.5])
def test_a_sample_with_an_event_duration_moves_for_that_long(library, target):
    plain = synthesize(_task(library, None)).provenance.motion
    timed = synthesize(_task(library, target)).provenance.motion
    lo, hi = timed.active_span_s
    assert hi - lo == pytest.approx(target, abs=0.25)
    record = timed.controls["event_duration"]
    assert record["target_s"] == target and SCALE_BOUNDS[0] <= record["scale"] <= SCALE_BOUNDS[1]
    assert record["nominal_active_s"] == pytest.approx(plain.active_span_s[1] - plain.active_span_s[0], abs=1e-3)
    assert "event_duration" not in (plain.controls or {})


def test_only_single_events_are_discrete(library):
    assert is_discrete(library.get("sit_to_lie").smp)
    assert not is_discrete(library.get("walking").smp) and not is_discrete(library.get("sitting").smp)


def test_the_fold_times_transitions_to_the_training_subjects_events_and_leaves_the_rest(library, tmp_path):
    ds = load_dataset("hapt12")
    info, windows = ds.info, ds.windows()
    train = windows.where_subjects(["2", "3", "4", "5", "6", "7"])
    names = ("WALKING", "SIT_TO_LIE", "STAND_TO_LIE")
    budget = np.zeros(info.n_classes, np.int64)
    budget[[info.label_names.index(n) for n in names]] = 4
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    spec = GenerationSpec(k=2, oversample=1.0, max_rounds=1, quality_filter=False, sim_in_the_loop=False)
    assert spec.event_durations is False  # off by default

    def run(s):
        return FoldGenerator(s, LocalExecutor(1, show_progress=False), tmp_path / "cache", library=library).generate(
            info, train, sources, budget, seed=0, fold="t")

    plain, timed = run(spec), run(replace(spec, event_durations=True))
    found = timed.summary["event_durations"]
    assert set(found) == {"SIT_TO_LIE", "STAND_TO_LIE"} and "event_durations" not in plain.summary
    assert found["STAND_TO_LIE"]["median_s"] > found["SIT_TO_LIE"]["median_s"] > 2.0  # as recorded
    for name in names:
        made = [t.event_duration_s is not None for t in timed.tasks if t.label == name]
        if name == "WALKING":
            assert not any(made)
        else:  # rounds of the variants alternate: timed, then the SMP's timing
            assert len(made) >= 3 and made == [(i // 2) % 2 == 0 for i in range(len(made))]  # k = 2
        assert found.get(name, {}).get("chosen", "both") in ("both", "timed", "untimed")
    for name in ("SIT_TO_LIE", "STAND_TO_LIE"):
        assert set(found[name]["scores"]) == {"both", "timed", "untimed"}
        assert found[name]["scores"][found[name]["chosen"]] == max(found[name]["scores"].values())
    timed_samples = {r.key for r in timed.samples if "event_duration" in (r.provenance.motion.controls or {})}
    assert {t.key for t in timed.tasks if t.event_duration_s is not None} == timed_samples
    for rec in timed.records[: len(timed.generated)]:
        label = rec.label
        chosen = found.get(label, {}).get("chosen", "both")
        wrong = chosen != "both" and ((rec.sample in timed_samples) != (chosen == "timed"))
        assert rec.kept == (not wrong)
        assert any(v.filter == "timing" for v in rec.verdicts) == wrong
    sit_to_lie = info.label_names.index("SIT_TO_LIE")
    sparse = train[np.r_[np.flatnonzero(train.y != sit_to_lie), np.flatnonzero(train.y == sit_to_lie)[::3]]]
    gen = FoldGenerator(replace(spec, event_durations=True), LocalExecutor(1, show_progress=False),
                        tmp_path / "cache", library=library)
    out = gen.generate(info, sparse, sources, budget, seed=0, fold="t")
    assert out.summary["event_durations"]["SIT_TO_LIE"]["used"] is False
    assert "stand alone" in out.summary["event_durations"]["SIT_TO_LIE"]["reason"]


def test_the_timing_whose_windows_look_like_the_class_is_chosen():
    """Class 1's timed samples are copies of its real windows, its untimed ones copies of class 0's:
    a forest on the timed ones recognises the real class-1 windows, so they are chosen."""
    from types import SimpleNamespace

    from vsmp_imu.har.windows import Windows
    from vsmp_imu.pipeline.fold import WindowSet, choose_timing

    rng = np.random.default_rng(0)
    n, t = 60, 64
    real = np.concatenate([rng.normal(0, 1, (n, t, 6)), rng.normal(0, 1, (n, t, 6)) * 4 + 3])
    y_real = np.repeat([0, 1], n)
    train = Windows(real, y_real, np.full(2 * n, "1"), ("a", "b"), tuple(f"c{i}" for i in range(6)), 50.0)
    info = SimpleNamespace(label_names=train.label_names)  # all the choice reads of the dataset
    synth = np.concatenate([real[:n], real[n:], real[:n]]) + rng.normal(0, 0.05, (3 * n, t, 6))
    y = np.repeat([0, 1, 1], n)
    timed = np.repeat([False, True, False], n)

    def record(is_timed):
        controls = {"event_duration": {"scale": 1.5}} if is_timed else {}
        return SimpleNamespace(provenance=SimpleNamespace(motion=SimpleNamespace(controls=controls)),
                               verdicts=[], kept=True)

    records = [record(v) for v in timed]
    found = {"b": {"used": True}}
    keep = choose_timing(info, train, None, WindowSet(synth.astype(np.float32), y, records),
                         np.ones(3 * n, bool), found, seed=0, fold="t")
    assert found["b"]["chosen"] == "timed"
    assert found["b"]["scores"]["timed"] > found["b"]["scores"]["untimed"]
    np.testing.assert_array_equal(keep, ~((y == 1) & ~timed))
    assert all(r.verdicts[0].filter == "timing" and not r.kept for r, k in zip(records, keep, strict=True) if not k)


def test_generate_prints_each_class_durations_and_choice():
    from vsmp_imu.cli.common import console
    from vsmp_imu.cli.generate import _print_summary

    summary = {"tau_cls": 0.5, "per_class": {}, "event_durations": {
        "SIT_TO_LIE": {"used": True, "events": 52, "median_s": 4.1, "q10_s": 3.2, "q90_s": 5.3, "chosen": "both",
                       "scores": {"both": 0.61, "timed": 0.6, "untimed": 0.58}},
        "LIE_TO_SIT": {"used": False, "reason": "3 event(s) in the training windows, fewer than 5"}}}
    with console.capture() as captured:
        _print_summary(summary)
    text = " ".join(captured.get().split())
    assert ("event durations SIT_TO_LIE: every other round of samples timed to one of 52 real events (median "
            "4.10 s, 10-90 % 3.20-5.30 s); kept: both (Macro-F1 on the real windows: both 0.610, timed 0.600, "
            "untimed 0.580)") in text
    assert "event durations LIE_TO_SIT: the SMP's timing (3 event(s) in the training windows, fewer than 5)" in text
