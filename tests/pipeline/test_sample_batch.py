"""Samples made together are the samples made alone: the CEMs of a batch run in lockstep
(`SimInTheLoopCalibrator.calibrate_many`, `synthesize_many`), each drawing from its own
generator, and every result is byte for byte the one its task gets by itself, whatever
else is in the batch (a failed sample, an uncalibrated one, other conventions)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding.align import Convention
from vsmp_imu.grounding.calibrate import CemProblem, SimInTheLoopCalibrator
from vsmp_imu.grounding.stats import summarize_sequence
from vsmp_imu.imu import VirtualSensor, draw_noise, simulate_kinematics
from vsmp_imu.pipeline.fold import SAMPLES_PER_ITEM, run_item, sample_items
from vsmp_imu.pipeline.sample import (
    LocationTask,
    SampleTask,
    cached_synthesize,
    synthesize,
    synthesize_many,
)
from vsmp_imu.seeding import rng_for

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "imu"))
from imu_motions import make_motion, walking  # noqa: E402

FS = 50.0


def _target(seed: int) -> dict[str, list]:
    rng = np.random.default_rng(seed)
    x = rng.normal(0, 1, (600, 6)).cumsum(0) * 0.05 + np.array([0, 9.8, 0, 0, 0, 0])
    s = summarize_sequence(x, FS)
    return {k: getattr(s, k).tolist() for k in ("cov", "psd", "norms", "acf")}


def _task(key: str, seed: int, prompt: str = "a person walks", target: bool = True, axes=("left", "up", "forward"),
          two_locations: bool = False) -> SampleTask:
    conv = Convention(axes=axes, gravity_included=True).as_dict()
    tilt = tuple(Rotation.from_euler("x", 12, degrees=True).as_quat())
    locations = [LocationTask("waist", conv, True, _target(seed) if target else None, tilt)]
    if two_locations:
        locations.append(LocationTask("left_wrist", conv, True, _target(seed + 1)))
    return SampleTask(key=key, label="WALKING", label_index=0, source="test", variant=0, smp_json="",
                      prompt=prompt, backend="procedural", seed=seed, fs_hz=FS, locations=tuple(locations),
                      duration_s=3.0)


def _same(a, b) -> None:
    assert a.key == b.key and a.error == b.error
    assert a.provenance.as_dict() == b.provenance.as_dict()
    assert sorted(a.signals) == sorted(b.signals)
    for name in a.signals:
        assert a.signals[name].tobytes() == b.signals[name].tobytes()


@pytest.fixture(scope="module")
def tasks():
    return [_task("f/WALKING/0000", 1), _task("f/WALKING/0001", 2, prompt="qwzx plorth"),
            _task("f/WALKING/0002", 3, target=False), _task("f/WALKING/0003", 4, axes=("down", "right", "forward")),
            _task("f/WALKING/0004", 5, two_locations=True)]


def test_a_batch_gives_each_sample_what_it_gets_alone(tasks):
    together = synthesize_many(tasks, [None] * len(tasks))
    assert together[1].error and together[1].error.startswith("ValidationError")  # the failure stays its own
    assert together[0].provenance.locations["waist"].eta is not None
    assert together[2].provenance.locations["waist"].eta is None  # no target: no CEM
    for task, result in zip(tasks, together, strict=True):
        _same(result, synthesize(task))
    reordered = synthesize_many(tasks[::-1], [None] * len(tasks))
    for a, b in zip(together, reordered[::-1], strict=True):
        _same(a, b)


def test_cached_items_of_many_samples_read_and_write_the_per_sample_cache(tasks, tmp_path):
    cache = str(tmp_path)
    first = run_item((tuple(tasks[:2]), cache))  # two made and cached
    again = run_item((tuple(tasks), cache))  # two read, three made
    for a, b in zip(first, again[:2], strict=True):
        _same(a, b)
    for task, result in zip(tasks, again, strict=True):
        _same(result, cached_synthesize((task, cache)))  # every sample is in the cache now
    assert len(list(tmp_path.glob("*.parquet"))) == len(tasks)


@pytest.mark.parametrize("workers", [1, 2, 8])
def test_sample_items_cut_the_tasks_in_order_and_shorter_towards_the_end(tasks, workers):
    many = [t for t in tasks for _ in range(60)]
    items = sample_items(many, "c", workers)
    assert [t for item, _ in items for t in item] == many and {c for _, c in items} == {"c"}
    sizes = [len(item) for item, _ in items]
    assert max(sizes) <= SAMPLES_PER_ITEM and sizes == sorted(sizes, reverse=True) and sizes[-1] == 1
    assert len(sample_items([], None)) == 0


def _streams():
    """Waist streams of different lengths and conventions, with and without sensor noise."""
    root, local = walking()
    out = []
    for i, (duration, axes) in enumerate([(5.0, ("left", "up", "forward")), (7.0, ("down", "right", "forward")),
                                          (6.0, ("left", "up", "forward")), (4.5, ("forward", "left", "up"))]):
        kin = simulate_kinematics(make_motion(duration, 30.0, root, local), "waist", FS)
        noise = draw_noise(VirtualSensor.at("waist"), kin.n_samples, FS, i, "waist") if i != 2 else None
        out.append((kin, noise, axes))
    return out


@pytest.mark.parametrize("search", [False, True])
def test_calibrating_streams_together_gives_each_its_own_result(search):
    problems = []
    for i, (kin, noise, axes) in enumerate(_streams()):
        conv = Convention(axes=axes, gravity_included=bool(i % 2))
        base = Rotation.from_euler("zxy", [5 * i, -3 * i, 10], degrees=True).as_matrix()
        problems.append((kin, _target(10 + i), conv, base, noise))

    def problem(i, kin, target, conv, base, noise):
        from vsmp_imu.grounding.stats import StatSummary

        return CemProblem(kin, StatSummary(**{k: np.asarray(v) for k, v in target.items()}), conv,
                          rng_for(7, "cem", i), base, noise)

    cal = SimInTheLoopCalibrator(n_iterations=6, search_gravity=search)
    together = cal.calibrate_many([problem(i, *p) for i, p in enumerate(problems)])
    for i, (p, result) in enumerate(zip(problems, together, strict=True)):
        alone = cal.calibrate_many([problem(i, *p)])[0]
        assert result.eta == alone.eta and result.gravity_included == alone.gravity_included
        assert result.loss_history == alone.loss_history and result.loss_nominal == alone.loss_nominal
        assert result.readings.tobytes() == alone.readings.tobytes()
    assert len({r.loss_final for r in together}) == len(together)  # different streams, different fits
