"""The on-disk cache: evaluations keep their samples there (not in the output folder), under a
size cap; `vsmp-imu cache info` and `cache clear`."""

from __future__ import annotations

import os

import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.cache import (
    cache_dir,
    cache_usage,
    clear_cache,
    max_cache_bytes,
    prune_cache,
    samples_dir,
)


def _fill(folder, sizes):
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, size in enumerate(sizes):
        path = folder / f"{i:02d}.parquet"
        path.write_bytes(b"x" * size)
        os.utime(path, (1000 + i, 1000 + i))  # 00 is the least recently used
        paths.append(path)
    return paths


def test_prune_removes_the_least_recently_used_until_under_the_cap(tmp_path):
    paths = _fill(tmp_path / "samples", [100] * 10)
    os.utime(paths[0], (5000, 5000))  # a cache hit refreshed the oldest file
    assert prune_cache(tmp_path / "samples", 650) == (4, 400)
    left = sorted(p.name for p in (tmp_path / "samples").iterdir())
    assert left == ["00.parquet", "05.parquet", "06.parquet", "07.parquet", "08.parquet", "09.parquet"]
    assert prune_cache(tmp_path / "samples", 650) == (0, 0)


def test_cap_from_the_environment(monkeypatch):
    monkeypatch.setenv("VSMP_IMU_CACHE_MAX_GB", "0.5")
    assert max_cache_bytes() == 500_000_000
    monkeypatch.setenv("VSMP_IMU_CACHE_MAX_GB", "-1")
    with pytest.raises(ConfigError) as err:
        max_cache_bytes()
    assert err.value.field == "VSMP_IMU_CACHE_MAX_GB"


def test_cache_info_and_clear_commands(cli, tmp_path, monkeypatch):
    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "cache"))
    _fill(samples_dir(), [300, 200])
    _fill(cache_dir() / "hapt", [50])
    assert {u.name: (u.files, u.bytes) for u in cache_usage()}["samples"] == (2, 500)
    code, out, _ = cli("cache", "info")
    assert code == 0 and "samples" in out and "500 B" in out and "hapt" in out
    code, out, _ = cli("cache", "clear", "--only", "samples")
    assert code == 0 and "removed 2 files (500 B)" in out
    assert not samples_dir().exists() and (cache_dir() / "hapt").is_dir()
    code, _, err = cli("cache", "clear", "--only", "nothing")
    assert code == 2 and "--only" in err and "hapt" in err
    assert clear_cache().files == 1 and cache_usage() == []


def test_evaluation_caches_samples_outside_the_output_folder(tmp_path):
    from vsmp_imu.app import EvalRequest, evaluation
    from vsmp_imu.pipeline.spec import GenerationSpec

    run = evaluation(GenerationSpec(), EvalRequest(dataset="hapt", output=tmp_path / "out", methods=("real", "vsmp")))
    assert run.config.method_params["vsmp"]["cache_dir"] == str(samples_dir())
    assert not str(samples_dir()).startswith(str(tmp_path / "out"))
