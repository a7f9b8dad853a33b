"""Executors return results in task order whatever the worker count."""

from __future__ import annotations

import multiprocessing
import os
import socket
import threading
import time

import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.executor import LocalExecutor, _chunks, check_reachable, make_executor, thread_map
from vsmp_imu.seeding import key_entropy

# Workers must import the mapped function, so use one of the package's own.
_work = key_entropy


def test_local_pool_matches_in_process():
    tasks = list(range(12))
    one = LocalExecutor(1, show_progress=False).map(_work, tasks)
    two = LocalExecutor(2, show_progress=False).map(_work, tasks)
    assert one == two
    assert len({r for r in one}) == 12


def test_local_pool_keeps_order_with_chunks():
    tasks = list(range(101))  # 2 workers: chunks of up to 8 consecutive tasks, shrinking to one
    assert LocalExecutor(2, show_progress=False).map(_work, tasks) == [_work(t) for t in tasks]


def test_a_started_item_runs_beside_the_caller_and_gives_its_result():
    one = LocalExecutor(1, show_progress=False).start(_work, 7)
    assert one.pool is None and one.result() == _work(7)  # one worker: run there and then
    started = LocalExecutor(2, show_progress=False).start(_work, 7)
    worker = next(iter(started.pool._processes.values()))
    assert worker.pid != os.getpid()  # a process of its own
    assert started.result() == _work(7) and started.result() == _work(7)  # collected once, kept
    worker.join(timeout=5)
    assert not worker.is_alive()  # its process ends once the result is in


def test_maps_share_the_pool_of_a_pending_started_item(monkeypatch):
    """While a started item is pending, `map` runs on its pool (no process beyond `workers`); once
    its result is in, the pool ends and the next `map` makes its own."""
    executor, pools = LocalExecutor(2, show_progress=False), []
    make = executor._pool
    monkeypatch.setattr(executor, "_pool", lambda: pools.append(make()) or pools[-1])
    started = executor.start(time.sleep, 0.5)
    assert executor.map(_work, list(range(20))) == [_work(t) for t in range(20)]
    assert len(pools) == 1 and len(started.pool._processes) == 2  # the started item's pool, still up
    assert started.result() is None and executor._shared is None
    assert not multiprocessing.active_children()  # the shared pool ended with the result
    assert executor.map(_work, list(range(5))) == [_work(t) for t in range(5)] and len(pools) == 2
    assert not multiprocessing.active_children()  # a map's own pool ends with the map


def test_a_started_item_that_fails_raises_at_result():
    started = LocalExecutor(2, show_progress=False).start(int, "not a number")
    with pytest.raises(ValueError, match="not a number"):
        started.result()


def test_cancel_ends_a_started_item_at_once():
    started = LocalExecutor(2, show_progress=False).start(time.sleep, 60)
    worker = next(iter(started.pool._processes.values()))
    begun = time.monotonic()
    started.cancel()
    worker.join(timeout=5)
    assert not worker.is_alive() and time.monotonic() - begun < 10
    started.cancel()  # a second cancel is harmless


@pytest.mark.parametrize(("n", "cpus", "first"), [(1, 2, 1), (12, 2, 2), (100, 2, 8), (40, 2, 5), (922, 16, 8),
                                                  (5, 1, 2)])
def test_chunks_cover_the_tasks_in_order_and_shrink_to_one(n, cpus, first):
    chunks = _chunks(list(range(n)), cpus)
    assert [t for _, chunk in chunks for t in chunk] == list(range(n))
    assert [start for start, _ in chunks] == [t for _, chunk in chunks for t in chunk[:1]]
    sizes = [len(c) for _, c in chunks]
    assert sizes[0] == first and max(sizes) <= 8
    assert sizes == sorted(sizes, reverse=True)  # guided: the last units are the smallest
    assert sizes[-1] == 1


def test_chunks_of_one_when_asked():
    assert [len(c) for _, c in _chunks(list(range(100)), 2, max_chunk=1)] == [1] * 100


@pytest.mark.parametrize("threads", [1, 2, 8])
def test_thread_map_keeps_order(threads):
    items = list(range(20))
    assert thread_map(_work, items, threads) == [_work(i) for i in items]
    assert thread_map(_work, [], threads) == []


@pytest.mark.ray
def test_ray_matches_in_process():
    pytest.importorskip("ray")
    import ray

    tasks = list(range(6))
    try:
        executor = make_executor("ray", workers=2, show_progress=False)
        got = executor.map(_work, tasks)
        assert executor.start(_work, 7).result() == _work(7)
    finally:
        ray.shutdown()
    assert got == LocalExecutor(1, show_progress=False).map(_work, tasks)


def test_bad_executor_names():
    with pytest.raises(ConfigError):
        make_executor("spark")
    with pytest.raises(ConfigError):
        LocalExecutor(0)
    assert isinstance(_work(1), int)


def _server(reply: bytes | None):
    """A local TCP server that accepts and then says `reply` (None: says nothing)."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(4)

    def serve():
        while True:
            try:
                conn, _ = srv.accept()
            except OSError:
                return
            if reply is not None:
                conn.recv(64)
                conn.sendall(reply)
            threading.Timer(3.0, conn.close).start()

    threading.Thread(target=serve, daemon=True).start()
    return srv, f"127.0.0.1:{srv.getsockname()[1]}"


@pytest.mark.parametrize("reply", [None, b"HTTP/1.1 400 Bad Request\r\n\r\n"], ids=["silent", "http1"])
def test_a_port_that_is_not_ray_fails_fast(reply):
    srv, address = _server(reply)
    try:
        with pytest.raises(ConfigError) as err:
            check_reachable(address, timeout_s=0.5)
        assert err.value.field == "--address" and address in str(err.value)
    finally:
        srv.close()


def test_a_grpc_server_passes():
    srv, address = _server(b"\x00\x00\x00\x04\x00\x00\x00\x00\x00")  # an HTTP/2 SETTINGS frame
    try:
        check_reachable(address, timeout_s=2.0)
        check_reachable("ray://" + address, timeout_s=2.0)
    finally:
        srv.close()


def test_closed_ports_and_malformed_addresses():
    closed = socket.socket()
    closed.bind(("127.0.0.1", 0))
    port = closed.getsockname()[1]
    closed.close()  # nothing listens there now
    for address in (f"127.0.0.1:{port}", f"ray://127.0.0.1:{port}", "host:notaport", "ray://", ":80",
                    "http://127.0.0.1:80", "127.0.0.1:70000"):
        with pytest.raises(ConfigError) as err:
            check_reachable(address, timeout_s=0.5)
        assert err.value.field == "--address", address
    check_reachable("auto")  # left to Ray, which fails fast when no local instance runs
