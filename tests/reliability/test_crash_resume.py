"""SIGKILL at random points, then resume: the outputs are byte-identical to an uninterrupted run.

`vsmp-imu generate` and `vsmp-imu evaluate` (with the generative `vsmp`
method) run as subprocesses in their own process group on a small real
dataset (six HAPT subjects, three classes); the whole group (driver and pool
workers) is killed with SIGKILL at a random moment, several times in a row,
alternating 1 and 2 workers; a last run completes. Its files must equal
those of one uninterrupted run, byte for byte, and no partial file (an
atomic-write temporary, `*.tmp`) may be left anywhere, cache included.
"""

from __future__ import annotations

import random
import shutil
import time

import pytest
from reliability_support import kill_at, leftovers, run_cli, tree_bytes

GENERATE_FILES = ("synthetic.parquet", "summary.json", "prompts.jsonl", "smps", "motions")
FAST_KILLS, SLOW_KILLS = 3, 20


def _generate_args(dataset, out, workers: int) -> list[str]:
    return ["generate", "--dataset", dataset, "--holdout", "1", "--source", f"smp:{dataset.parent / 'smps'}",
            "--alpha", "0.3", "--k", "1", "--workers", str(workers), "-o", out]


def _evaluate_args(dataset, out, workers: int) -> list[str]:
    return ["evaluate", "--dataset", dataset, "--methods", "vsmp", "--source",
            f"smp:{dataset.parent / 'smps'}", "--k", "1", "--alpha", "0.5", "--backbones", "rf",
            "--jobs", "1", "--folds", "1", "--workers", str(workers), "-o", out]


def _timed(args) -> float:
    start = time.monotonic()
    done = run_cli(*args)
    assert done.returncode == 0, done.stderr[-2000:]
    return time.monotonic() - start


def _kill_repeatedly(make_args, dataset, out, n_kills: int, t_max: float, seed: int) -> list[float]:
    """SIGKILL n_kills runs at random times in (0.05 s, t_max); runs that finish first do not count."""
    rng = random.Random(seed)
    kills: list[float] = []
    for _ in range(6 * n_kills):
        if len(kills) == n_kills:
            break
        at = rng.uniform(0.05, t_max)
        if kill_at(make_args(dataset, out, rng.choice((1, 2))), at):
            kills.append(at)
    assert len(kills) == n_kills, f"only {len(kills)} of {n_kills} runs were still running when killed"
    return kills


@pytest.fixture(scope="module")
def generate_reference(small_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("generate") / "reference"
    elapsed = _timed(_generate_args(small_dataset, out, 1))
    return out, elapsed


def _check_generate_resume(small_dataset, generate_reference, out, n_kills, seed):
    reference, elapsed = generate_reference
    kills = _kill_repeatedly(_generate_args, small_dataset, out, n_kills, elapsed, seed)
    _timed(_generate_args(small_dataset, out, 2))
    expected = tree_bytes(reference, GENERATE_FILES)
    got = tree_bytes(out, GENERATE_FILES)
    assert len(expected) > 20  # parquet, summary, prompts, one SMP and one motion per sample
    assert sorted(got) == sorted(expected)
    assert [k for k in expected if got[k] != expected[k]] == [], f"differs after kills at {kills}"
    assert leftovers(out) == []


def test_generate_resumes_byte_identical_after_sigkills(small_dataset, generate_reference, tmp_path):
    _check_generate_resume(small_dataset, generate_reference, tmp_path / "out", FAST_KILLS, seed=0)


@pytest.mark.slow
def test_generate_resumes_after_twenty_sigkills(small_dataset, generate_reference, tmp_path):
    _check_generate_resume(small_dataset, generate_reference, tmp_path / "out", SLOW_KILLS, seed=1)


def _check_evaluate_resume(small_dataset, tmp_path, n_kills, seed):
    # the output folder is part of the settings (cache path): the reference runs there first
    out = tmp_path / "run"
    elapsed = _timed(_evaluate_args(small_dataset, out, 1))
    reference = tmp_path / "reference"
    out.rename(reference)
    kills = _kill_repeatedly(_evaluate_args, small_dataset, out, n_kills, elapsed, seed)
    _timed(_evaluate_args(small_dataset, out, 1))
    names = ("results.json", "results.md", *sorted(p.name for p in reference.glob("*.png")))
    expected, got = tree_bytes(reference, names), tree_bytes(out, names)
    assert len(expected) == 3  # json, md, the confusion matrix
    assert [k for k in expected if got.get(k) != expected[k]] == [], f"differs after kills at {kills}"
    assert sorted(p.name for p in (out / "records").iterdir()) == \
        sorted(p.name for p in (reference / "records").iterdir())
    assert leftovers(out) == []
    shutil.rmtree(reference)


def test_evaluate_with_vsmp_resumes_after_sigkills(small_dataset, tmp_path):
    _check_evaluate_resume(small_dataset, tmp_path, 2, seed=2)


@pytest.mark.slow
def test_evaluate_with_vsmp_resumes_after_many_sigkills(small_dataset, tmp_path):
    _check_evaluate_resume(small_dataset, tmp_path, 10, seed=3)
