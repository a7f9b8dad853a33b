"""A sample that cannot be made is recorded; a bug in a sample fails the run."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

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

    monkeypatch.setattr(sample_mod, "_prepare_location", broken)
    with pytest.raises(TypeError, match="unsupported operand"):
        synthesize(_task())
    with pytest.raises(TypeError, match="unsupported operand"):  # through the executor as well
        LocalExecutor(1, show_progress=False).map(sample_mod.cached_synthesize, [(_task(), None)])


POOL_BUG = """
import sys
from dataclasses import replace
sys.path.insert(0, sys.argv[1])
import vsmp_imu.pipeline.sample as sample_mod
from test_sample_errors import _task
from vsmp_imu.executor import LocalExecutor

def broken(motion, task, loc):
    raise TypeError("unsupported operand")

sample_mod._prepare_location = broken
tasks = [(_task(), None), (replace(_task(), key="f/WALKING/0001", seed=4), None)]
try:
    LocalExecutor(2, show_progress=False).map(sample_mod.cached_synthesize, tasks)
except TypeError as exc:
    print("raised:", exc)
"""


def test_a_programming_error_in_a_pool_worker_fails_the_run():
    """The local pool forks its workers after the patch: the bug is in the workers too. Run in a
    fresh interpreter: forked after other tests' threads (Ray's gRPC, torch's OpenMP pool), a
    worker can inherit a lock held at the fork and never start."""
    done = subprocess.run([sys.executable, "-c", POOL_BUG, str(Path(__file__).parent)], capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "raised: unsupported operand" in done.stdout


def test_sample_error_is_a_vsmp_error():
    from vsmp_imu.errors import VsmpError

    assert issubclass(SampleError, VsmpError)
