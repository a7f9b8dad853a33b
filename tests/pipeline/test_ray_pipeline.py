"""`vsmp-imu generate --executor ray` on a local Ray instance (2 CPUs).

The same fold generated with the local executor (1 worker, in-process) and on
Ray (2 workers) must leave byte-identical output: the Parquet file of windows
with provenance, the summary, the prompts, the SMP variants and the motions;
the per-sample cache written by the Ray workers holds the same entries. The
dataset is small and real: six HAPT subjects, three classes.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "reliability"))
from reliability_support import cli_command, make_small_dataset, tree_bytes  # noqa: E402

OUTPUT_FILES = ("synthetic.parquet", "summary.json", "prompts.jsonl", "smps", "motions")
UNREACHABLE_WAIT_S = 60

pytestmark = pytest.mark.ray


@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory) -> Path:
    return make_small_dataset(tmp_path_factory.mktemp("ray_small"))


@pytest.fixture(scope="module")
def ray_module():
    """Ray, shut down before (another test's instance) and after this module."""
    ray = pytest.importorskip("ray")
    if ray.is_initialized():
        ray.shutdown()
    yield ray
    ray.shutdown()


def _generate_args(dataset: Path, out: Path, *extra: str) -> list:
    return ["generate", "--dataset", dataset, "--holdout", "1", "--source", f"smp:{dataset.parent / 'smps'}",
            "--alpha", "0.1", "--k", "1", "--seed", "3", "-o", out, *extra]


def test_ray_generation_is_byte_identical_to_the_local_executor(cli, small_dataset, ray_module, tmp_path):
    local, on_ray = tmp_path / "local", tmp_path / "ray"
    code, _, err = cli(*_generate_args(small_dataset, local, "--executor", "local", "--workers", "1"))
    assert code == 0, err
    assert not ray_module.is_initialized()
    code, _, err = cli(*_generate_args(small_dataset, on_ray, "--executor", "ray", "--workers", "2"))
    assert code == 0, err
    # the run went through a local Ray instance with the 2 CPUs asked for
    assert ray_module.is_initialized()
    assert ray_module.cluster_resources().get("CPU") == 2

    expected, got = tree_bytes(local, OUTPUT_FILES), tree_bytes(on_ray, OUTPUT_FILES)
    assert {"synthetic.parquet", "summary.json", "prompts.jsonl"} <= set(expected)
    assert sum(k.startswith("motions/") for k in expected) >= 3  # one motion per sample
    assert sorted(got) == sorted(expected)
    assert [k for k in expected if got[k] != expected[k]] == []
    # the workers' per-sample cache: same content-addressed entries, same bytes
    cache_local, cache_ray = tree_bytes(local, ("cache",)), tree_bytes(on_ray, ("cache",))
    assert sorted(cache_ray) == sorted(cache_local)
    assert [k for k in cache_local if cache_ray[k] != cache_local[k]] == []


def test_a_gpu_task_on_a_cpu_only_ray_instance_is_a_user_error(cli, small_dataset, ray_module, tmp_path):
    """--gpus-per-task places tasks on GPU nodes; a cluster without one fails fast with exit 2."""
    code, _, err = cli(*_generate_args(small_dataset, tmp_path / "gpu", "--executor", "ray", "--workers", "2",
                                       "--gpus-per-task", "1"))
    assert code == 2
    assert "--gpus-per-task" in err and "GPU" in err
    assert not (tmp_path / "gpu" / "synthetic.parquet").exists()


def test_an_unreachable_ray_address_is_a_user_error(small_dataset, tmp_path):
    pytest.importorskip("ray")
    args = cli_command(*_generate_args(small_dataset, tmp_path / "out", "--executor", "ray",
                                       "--address", "127.0.0.1:9"))  # the discard port: nothing listens
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        _, stderr = proc.communicate(timeout=UNREACHABLE_WAIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"still waiting for the Ray cluster after {UNREACHABLE_WAIT_S} s")
    assert proc.returncode == 2, stderr[-2000:]
    assert "--address" in stderr and "Traceback" not in stderr


def test_a_real_gcs_passes_the_address_check(ray_module):
    """Positive control of `check_reachable`: a local Ray head's GCS answers the HTTP/2 preface."""
    from vsmp_imu.executor import check_reachable

    if ray_module.is_initialized():  # an earlier test's instance
        ray_module.shutdown()
    ray_module.init(num_cpus=1, include_dashboard=False, log_to_driver=False, configure_logging=False)
    try:
        check_reachable(ray_module.get_runtime_context().gcs_address)
    finally:
        ray_module.shutdown()
