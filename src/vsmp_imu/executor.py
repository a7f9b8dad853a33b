"""Where the per-sample work runs: in-process, a local process pool, or a Ray cluster.

Every executor maps a top-level function over a list of tasks and returns the
results in task order, so the output never depends on the number of workers
or on which worker finished first. Randomness lives in the tasks (each carries
its own seed), never in the executor.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

from vsmp_imu.errors import ConfigError, DependencyError

EXECUTORS = ("local", "ray")


def _progress(disable: bool) -> Progress:
    return Progress(
        TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(),
        disable=disable, transient=True,
    )


class LocalExecutor:
    """`workers=1` runs in this process; more workers use a process pool."""

    def __init__(self, workers: int = 1, show_progress: bool = True) -> None:
        if workers < 1:
            raise ConfigError(f"workers must be >= 1, got {workers}", field="workers")
        self.workers = workers
        self.show_progress = show_progress

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], desc: str = "working") -> list[Any]:
        results: list[Any] = [None] * len(tasks)
        with _progress(not self.show_progress) as progress:
            bar = progress.add_task(desc, total=len(tasks))
            if self.workers == 1 or len(tasks) <= 1:
                for i, task in enumerate(tasks):
                    results[i] = fn(task)
                    progress.advance(bar)
                return results
            ctx = multiprocessing.get_context(_start_method())
            with ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx,
                                     initializer=_limit_threads) as pool:
                futures = {pool.submit(fn, task): i for i, task in enumerate(tasks)}
                for future in as_completed(futures):
                    results[futures[future]] = future.result()
                    progress.advance(bar)
        return results


def _start_method() -> str:
    """'fork' where available: scripts need no `if __name__ == "__main__"` guard, and
    workers start without re-importing the project. Workers never touch torch."""
    methods = multiprocessing.get_all_start_methods()
    return "fork" if "fork" in methods else "spawn"


def _limit_threads() -> None:
    """One BLAS/OpenMP thread per worker: the pool provides the parallelism."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover - threadpoolctl ships with scikit-learn
        pass


class RayExecutor:
    """Tasks as Ray remote functions on a local instance or an existing cluster.

    `address=None` starts (or joins) a local instance; `"auto"` or
    `"ray://host:10001"` joins a cluster. `num_gpus` per task places GPU work
    (e.g. HY-Motion) on GPU nodes.
    """

    def __init__(self, address: str | None = None, num_cpus: int | None = None,
                 num_gpus_per_task: float = 0.0, show_progress: bool = True) -> None:
        self.address = address
        self.num_cpus = num_cpus
        self.num_gpus_per_task = num_gpus_per_task
        self.show_progress = show_progress

    def _ray(self):
        try:
            import ray
        except ImportError as exc:
            raise DependencyError("the Ray executor needs Ray: pip install -e .[ray]") from exc
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                      "configure_logging": False}
            if self.address:
                kwargs["address"] = self.address
            elif self.num_cpus:
                kwargs["num_cpus"] = self.num_cpus
            os.environ.setdefault("RAY_AUTH_MODE", "disabled")
            ray.init(**kwargs)
        return ray

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], desc: str = "working") -> list[Any]:
        ray = self._ray()
        if self.num_gpus_per_task > 0 and ray.cluster_resources().get("GPU", 0) < self.num_gpus_per_task:
            # a task asking for a GPU no node has would wait forever
            raise DependencyError(
                f"the Ray cluster has {ray.cluster_resources().get('GPU', 0):g} GPU(s); each task needs "
                f"{self.num_gpus_per_task:g}", field="--gpus-per-task",
                allowed="a cluster with GPU nodes, or --gpus-per-task 0 for CPU-only backends")
        remote = ray.remote(num_cpus=1, num_gpus=self.num_gpus_per_task)(fn)
        refs = [remote.remote(task) for task in tasks]
        index = {ref: i for i, ref in enumerate(refs)}
        results: list[Any] = [None] * len(tasks)
        pending = list(refs)
        with _progress(not self.show_progress) as progress:
            bar = progress.add_task(desc, total=len(tasks))
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    results[index[ref]] = ray.get(ref)
                    progress.advance(bar)
        return results


def make_executor(name: str = "local", workers: int = 1, address: str | None = None,
                  show_progress: bool = True, num_gpus_per_task: float = 0.0):
    """The executor named by `--executor` (local | ray)."""
    if name == "local":
        return LocalExecutor(workers, show_progress)
    if name == "ray":
        return RayExecutor(address, num_cpus=workers if address is None else None,
                           num_gpus_per_task=num_gpus_per_task, show_progress=show_progress)
    raise ConfigError(f"unknown executor '{name}'", field="executor", allowed=", ".join(EXECUTORS))
