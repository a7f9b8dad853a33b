"""Executors return results in task order whatever the worker count."""

from __future__ import annotations

import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.executor import LocalExecutor, make_executor
from vsmp_imu.seeding import key_entropy

# Workers must import the mapped function, so use one of the package's own.
_work = key_entropy


def test_local_pool_matches_in_process():
    tasks = list(range(12))
    one = LocalExecutor(1, show_progress=False).map(_work, tasks)
    two = LocalExecutor(2, show_progress=False).map(_work, tasks)
    assert one == two
    assert len({r for r in one}) == 12


@pytest.mark.ray
def test_ray_matches_in_process():
    pytest.importorskip("ray")
    import ray

    tasks = list(range(6))
    try:
        got = make_executor("ray", workers=2, show_progress=False).map(_work, tasks)
    finally:
        ray.shutdown()
    assert got == LocalExecutor(1, show_progress=False).map(_work, tasks)


def test_bad_executor_names():
    with pytest.raises(ConfigError):
        make_executor("spark")
    with pytest.raises(ConfigError):
        LocalExecutor(0)
    assert isinstance(_work(1), int)
