"""A sample that cannot be made is recorded; a bug in a sample fails the run."""

from __future__ import annotations

from dataclasses import replace

import pytest

import vsmp_imu.pipeline.sample as sample_mod
from vsmp_imu.errors import SampleError
from vsmp_imu.executor import LocalExecutor
from vsmp_imu.grounding.align import Convention
from vsmp_imu.pipeline.sample import LocationTask, SampleTask, synthesize


def _task(prompt: str = "a person walks", smp_json: str = "") -> SampleTask:
    conv = Convention(axes=("left", "up", "forward"), gravity_included=True).as_dict()
    return SampleTask(key="f/WALKING/0000", label="WALKING", label_index=0, source="test", variant=0,
                      smp_json=smp_json, prompt=prompt, backend="procedural", seed=3, fs_hz=50.0,
                      locations=(LocationTask("waist", conv, True, None),), duration_s=2.0)


def test_a_made_sample_has_signals_and_no_error():
    result = synthesize(_task())
    assert result.error is None and result.signals["waist"].shape[1] == 6


def test_a_prompt_naming_no_activity_is_a_recorded_failure():
    result = synthesize(_task(prompt="qwzx plorth"))
    assert result.signals == {} and result.error and result.error.startswith("ValidationError")
    assert result.provenance.as_dict() == {"source": "test", "label": "WALKING"}


def test_an_smp_field_out_of_range_is_a_sample_error():
    result = synthesize(_task(smp_json='{"schema_version": "1"}'))
    assert result.error is not None and result.error.startswith("SampleError")


def test_a_non_finite_motion_is_a_sample_error(monkeypatch):
    real = sample_mod.backend_for

    class NanBackend:
        def generate(self, *args):
            motion = real("procedural", ()).generate(*args)
            motion.positions[3, 2, 1] = float("nan")
            return motion

    monkeypatch.setattr(sample_mod, "backend_for", lambda *_: NanBackend())
    result = synthesize(_task())
    assert result.error == ("SampleError: field 'motion': the motion has non-finite joint positions "
                            "or rotations.")


def test_a_programming_error_in_a_sample_fails_the_run(monkeypatch):
    def broken(motion, task, loc):
        raise TypeError("unsupported operand")

    monkeypatch.setattr(sample_mod, "_location_signal", broken)
    with pytest.raises(TypeError, match="unsupported operand"):
        synthesize(_task())
    with pytest.raises(TypeError, match="unsupported operand"):  # through the executor as well
        LocalExecutor(1, show_progress=False).map(sample_mod.cached_synthesize, [(_task(), None)])


def test_a_programming_error_in_a_pool_worker_fails_the_run(monkeypatch):
    """The local pool forks its workers after the patch: the bug is in the workers too."""
    def broken(motion, task, loc):
        raise TypeError("unsupported operand")

    monkeypatch.setattr(sample_mod, "_location_signal", broken)
    tasks = [(_task(), None), (replace(_task(), key="f/WALKING/0001", seed=4), None)]
    with pytest.raises(TypeError, match="unsupported operand"):
        LocalExecutor(2, show_progress=False).map(sample_mod.cached_synthesize, tasks)


def test_sample_error_is_a_vsmp_error():
    from vsmp_imu.errors import VsmpError

    assert issubclass(SampleError, VsmpError)
