"""Where the per-sample work runs: in-process, a local process pool, or a Ray cluster.

Every executor maps a top-level function over a list of tasks and returns the
results in task order, so the output never depends on the number of workers
or on which worker finished first. Randomness lives in the tasks (each carries
its own seed), never in the executor.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from typing import Any

from vsmp_imu.errors import ConfigError, DependencyError
from vsmp_imu.progress import progress

EXECUTORS = ("local", "ray")


def thread_map(fn: Callable[[Any], Any], items: Sequence[Any], threads: int = 1) -> list[Any]:
    """`[fn(x) for x in items]`, on `threads` threads when more than one: for the driver's own
    NumPy steps (sorting, interpolation, FFT, matmul release the GIL) while the workers idle."""
    if threads <= 1 or len(items) <= 1:
        return [fn(x) for x in items]
    with ThreadPoolExecutor(min(threads, len(items))) as pool:
        return list(pool.map(fn, items))


class LocalExecutor:
    """`workers=1` runs in this process; more workers use a process pool (one per `map`, or the
    pool of a pending `start`)."""

    def __init__(self, workers: int = 1, show_progress: bool = True) -> None:
        if workers < 1:
            raise ConfigError(f"workers must be >= 1, got {workers}", field="workers")
        self.workers = workers
        self.show_progress = show_progress
        self._shared: ProcessPoolExecutor | None = None  # the pool of a started item not yet collected

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], desc: str = "working") -> list[Any]:
        results: list[Any] = [None] * len(tasks)
        finished = 0
        with progress(desc, len(tasks), disable=not self.show_progress) as update:
            if self.workers == 1 or len(tasks) <= 1:
                for i, task in enumerate(tasks):
                    results[i] = fn(task)
                    update(i + 1)
                return results
            chunks = _chunks(tasks, self.workers)
            pool = self._shared or self._pool()
            try:
                submitted = _submit(pool, _run_chunk, [(fn, chunk) for _, chunk in chunks])
                futures = {future: start for future, (start, _) in zip(submitted, chunks, strict=True)}
                for future in as_completed(futures):
                    done = future.result()
                    results[futures[future]:futures[future] + len(done)] = done
                    finished += len(done)
                    update(finished)
            except BaseException:  # Ctrl-C, SIGTERM, a failed task: no worker outlives the run
                self.release(pool, stop=True)
                raise
            if pool is not self._shared:
                pool.shutdown(wait=True)
        return results

    def start(self, fn: Callable[[Any], Any], item: Any, desc: str = "working") -> Started:
        """`fn(item)` begun now, for the caller to collect later (`result()`): with one worker it
        runs here and then (under `desc`, as `map` shows its work); with more, on a pool that the
        `map` calls made before its result is collected share, so one long item overlaps the
        caller's own steps and takes one worker of those maps until it ends (no process beyond
        `workers`)."""
        if self.workers == 1:
            return Started(value=self.map(fn, [item], desc)[0])
        if self._shared is None:
            self._shared = self._pool()
        (future,) = _submit(self._shared, fn, [(item,)])
        return Started(future=future, pool=self._shared, owner=self)

    def release(self, pool: ProcessPoolExecutor, stop: bool = False) -> None:
        """End `pool` (at once with `stop`, else once its work is done); the next `map` makes its own."""
        if stop:
            _stop_workers(pool)
        else:
            pool.shutdown(wait=True)
        if pool is self._shared:
            self._shared = None

    def _pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=multiprocessing.get_context(_start_method()),
                                   initializer=_init_worker, initargs=(os.getpid(),))


def _submit(pool: ProcessPoolExecutor, fn: Callable, calls: list[tuple]) -> list:
    """`pool.submit(fn, *args)` for each args in `calls`. The workers start (fork) during the first
    submit: with the stop signals blocked until each has set its own handlers, a Ctrl-C then cannot
    hit a half-made worker."""
    blocked = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        return [pool.submit(fn, *args) for args in calls]
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, blocked)


class Started:
    """An item begun by an executor's `start`: `result()` waits for it (and re-raises its error);
    `cancel()` ends it, for a caller that no longer needs it (on an error or Ctrl-C)."""

    def __init__(self, value: Any = None, future=None, pool: ProcessPoolExecutor | None = None,
                 owner: LocalExecutor | None = None, ref=None) -> None:
        self.value, self.future, self.pool, self.owner, self.ref = value, future, pool, owner, ref

    def result(self) -> Any:
        if self.future is not None:
            try:
                self.value = self.future.result()
            except BaseException:
                self.owner.release(self.pool, stop=True)
                raise
            self.owner.release(self.pool)
            self.future = None
        elif self.ref is not None:
            import ray

            self.value, self.ref = ray.get(self.ref), None
        return self.value

    def cancel(self) -> None:
        if self.future is not None:
            self.owner.release(self.pool, stop=True)
            self.future = None
        elif self.ref is not None:
            import ray

            ray.cancel(self.ref, force=True)
            self.ref = None


def _stop_workers(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and end the workers now (the finished samples are cached)."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # no public handle on them
    for process in processes:
        if process.is_alive():
            process.terminate()
    for process in processes:
        process.join(timeout=5)
    # the pool's manager thread sees its workers gone and ends; waiting for it here leaves no
    # thread for the interpreter's exit hook to wake through a closed pipe
    pool.shutdown(wait=True, cancel_futures=True)


def _init_worker(driver_pid: int) -> None:
    """A pool worker: one BLAS thread, Ctrl-C left to the driver, and death with the driver."""
    _limit_threads()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the driver stops the pool on Ctrl-C
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the driver's handler, inherited by fork
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    die_with_parent(driver_pid)


STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}
PR_SET_PDEATHSIG = 1  # linux/prctl.h
PARENT_POLL_S = 1.0


def die_with_parent(parent_pid: int) -> None:
    """End this process when `parent_pid` (its parent) dies, even by SIGKILL: the kernel's
    parent-death signal on Linux, a thread watching the parent elsewhere."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
                if os.getppid() != parent_pid:  # the parent died before the signal was armed
                    os._exit(1)
                return
        except (OSError, AttributeError):  # pragma: no cover - no prctl: fall back to the watch
            pass
    threading.Thread(target=_watch_parent, args=(parent_pid,), daemon=True,
                     name="vsmp-parent-watch").start()


def _watch_parent(parent_pid: int) -> None:
    while os.getppid() == parent_pid:
        time.sleep(PARENT_POLL_S)
    os._exit(1)


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
                check_reachable(self.address)
                kwargs["address"] = self.address
            elif self.num_cpus:
                kwargs["num_cpus"] = self.num_cpus
            os.environ.setdefault("RAY_AUTH_MODE", "disabled")
            try:
                ray.init(**kwargs)
            except (ConnectionError, TimeoutError, RuntimeError, ValueError) as exc:
                if not self.address:
                    raise
                raise ConfigError(f"cannot join the Ray cluster at '{self.address}': {exc}", field="--address",
                                  allowed=ADDRESS_HELP) from exc
        return ray

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], desc: str = "working") -> list[Any]:
        ray = self._ray()
        if self.num_gpus_per_task > 0 and ray.cluster_resources().get("GPU", 0) < self.num_gpus_per_task:
            # a task asking for a GPU no node has would wait forever
            raise DependencyError(
                f"the Ray cluster has {ray.cluster_resources().get('GPU', 0):g} GPU(s); each task needs "
                f"{self.num_gpus_per_task:g}", field="--gpus-per-task",
                allowed="a cluster with GPU nodes, or --gpus-per-task 0 for CPU-only backends")
        remote = ray.remote(num_cpus=1, num_gpus=self.num_gpus_per_task)(_run_chunk)
        cpus = int(ray.cluster_resources().get("CPU", 1))
        # GPU tasks (one model call each) are never grouped
        chunks = _chunks(tasks, cpus, max_chunk=1 if self.num_gpus_per_task > 0 else MAX_CHUNK)
        refs = [remote.remote(fn, chunk) for _, chunk in chunks]
        results: list[Any] = []
        with progress(desc, len(tasks), disable=not self.show_progress) as update:
            # in task order: a ray.wait over all pending refs per result would cost the driver
            # O(n) each time, CPU the workers need on a small machine
            for ref in refs:
                done = ray.get(ref)
                results += done
                update(len(results))
        return results

    def start(self, fn: Callable[[Any], Any], item: Any, desc: str = "working") -> Started:
        """`fn(item)` begun now as one task on the cluster (one CPU, as a `map` unit); `result()`
        collects it (`desc` is for the executors that run it at once)."""
        ray = self._ray()
        return Started(ref=ray.remote(num_cpus=1)(fn).remote(item))


MAX_CHUNK = 8
CHUNKS_PER_CPU = 4


def _chunks(tasks: Sequence[Any], cpus: int, max_chunk: int = MAX_CHUNK) -> list[tuple[int, list[Any]]]:
    """(start, consecutive tasks) groups sent to a worker as one unit. Each unit costs the
    driver a few ms of pickling and messaging (10-15 % of a 30 ms procedural sample with one
    unit per sample), so units hold up to `max_chunk` tasks; sizes shrink towards the end
    (guided scheduling: the remaining tasks over CHUNKS_PER_CPU units per CPU) so that the
    workers' last units end close together."""
    units = max(1, cpus) * CHUNKS_PER_CPU
    out, start = [], 0
    while start < len(tasks):
        size = max(1, min(max_chunk, -(-(len(tasks) - start) // units)))
        out.append((start, list(tasks[start:start + size])))
        start += size
    return out


def _run_chunk(fn: Callable[[Any], Any], items: list[Any]) -> list[Any]:
    """One unit of work on a worker: `fn` over consecutive items, in order."""
    return [fn(x) for x in items]


ADDRESS_HELP = "'auto' (a cluster started on this machine), HOST:PORT of the head's GCS, or ray://HOST:PORT"
CONNECT_TIMEOUT_S = 5.0
DEFAULT_PORTS = {"": 6379, "ray": 10001}  # GCS, Ray client server


def check_reachable(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Fail fast, naming --address, when nothing answers at a HOST:PORT cluster address.

    ray.init retries an unreachable head for minutes before it gives up; a TCP
    connect with a timeout tells the user at once. 'auto' and 'local' are left
    to Ray (it fails fast when no local instance runs).
    """
    if address in ("auto", "local"):
        return
    scheme, _, rest = address.rpartition("://")
    if scheme not in DEFAULT_PORTS:
        raise ConfigError(f"unknown Ray address scheme '{scheme}://' in '{address}'", field="--address",
                          allowed=ADDRESS_HELP)
    host, sep, port_text = rest.rpartition(":")
    if not sep:
        host, port_text = rest, str(DEFAULT_PORTS[scheme])
    try:
        port = int(port_text)
        if not host or not 0 < port < 65536:
            raise ValueError
    except ValueError:
        raise ConfigError(f"'{address}' is not a Ray cluster address", field="--address",
                          allowed=ADDRESS_HELP) from None
    try:
        with socket.create_connection((host.strip("[]"), port), timeout=timeout_s) as sock:
            speaks_grpc = _answers_http2(sock, timeout_s)
    except OSError as exc:
        speaks_grpc, reason = False, exc.strerror or str(exc)
    else:
        reason = "something listens there, but it is not a Ray GCS or client server"
    if not speaks_grpc:
        raise ConfigError(f"no Ray cluster answers at '{address}' ({reason})", field="--address",
                          allowed="a running Ray head: start one with `ray start --head`, or leave out "
                                  "--address for a local instance")


HTTP2_PREFACE = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n"
HTTP2_EMPTY_SETTINGS = b"\x00\x00\x00\x04\x00\x00\x00\x00\x00"


def _answers_http2(sock: socket.socket, timeout_s: float) -> bool:
    """Whether the peer answers an HTTP/2 connection preface with a SETTINGS frame, as
    every gRPC server (Ray's GCS and client server) does. A silent or non-gRPC port
    would otherwise keep ray.init retrying for minutes."""
    sock.settimeout(timeout_s)
    sock.sendall(HTTP2_PREFACE + HTTP2_EMPTY_SETTINGS)
    head = b""
    while len(head) < 9:
        chunk = sock.recv(9 - len(head))
        if not chunk:
            return False
        head += chunk
    return head[3] == 0x04  # frame type SETTINGS


def check_executor_options(name: str, address: str | None) -> None:
    """`--executor` is known and `--address` goes with `--executor ray` only."""
    if name not in EXECUTORS:
        raise ConfigError(f"unknown executor '{name}'", field="--executor", allowed=", ".join(EXECUTORS))
    if address is not None and name != "ray":
        raise ConfigError(f"a cluster address ('{address}') needs the Ray executor", field="--address",
                          allowed="--executor ray --address ADDRESS, or no --address")


def make_executor(name: str = "local", workers: int = 1, address: str | None = None,
                  show_progress: bool = True, num_gpus_per_task: float = 0.0):
    """The executor named by `--executor` (local | ray)."""
    check_executor_options(name, address)
    if name == "local":
        return LocalExecutor(workers, show_progress)
    if name == "ray":
        return RayExecutor(address, num_cpus=workers if address is None else None,
                           num_gpus_per_task=num_gpus_per_task, show_progress=show_progress)
    raise ConfigError(f"unknown executor '{name}'", field="executor", allowed=", ".join(EXECUTORS))
