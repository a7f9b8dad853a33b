"""The on-disk cache: evaluations keep their samples there (not in the output folder), under a
size cap; `vsmp-imu cache info` and `cache clear`, which touch only the project's folders."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.cache import (
    CACHE_FOLDERS,
    cache_contents,
    cache_dir,
    cache_folder,
    clear_cache,
    max_cache_bytes,
    prune_cache,
    samples_dir,
    vlm_dir,
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
    assert {u.name: (u.files, u.bytes) for u in cache_contents().folders}["samples"] == (2, 500)
    code, out, _ = cli("cache", "info")
    assert code == 0 and "samples" in out and "500 B" in out and "hapt" in out
    code, out, _ = cli("cache", "clear", "--only", "samples")
    assert code == 0 and "removed 2 files (500 B)" in out
    assert not samples_dir().exists() and (cache_dir() / "hapt").is_dir()
    code, _, err = cli("cache", "clear", "--only", "nothing")
    assert code == 2 and "--only" in err and "hapt" in err
    removed, left = clear_cache()
    assert [(u.name, u.files, u.bytes) for u in removed] == [("hapt", 1, 50)] and left == []
    assert cache_contents().folders == []


def test_evaluation_caches_samples_outside_the_output_folder(tmp_path):
    from vsmp_imu.app import EvalRequest, evaluation
    from vsmp_imu.pipeline.spec import GenerationSpec

    run = evaluation(GenerationSpec(), EvalRequest(dataset="hapt", output=tmp_path / "out", methods=("real", "vsmp")))
    assert run.config.method_params["vsmp"]["cache_dir"] == str(samples_dir())
    assert not str(samples_dir()).startswith(str(tmp_path / "out"))


def _user_folder(root: Path, elsewhere: Path) -> None:
    """A folder a user might point $VSMP_IMU_CACHE at: the project's folders next to their own."""
    _fill(root / "samples", [300, 200])
    _fill(root / "hapt", [50])
    (root / "my_thesis/chapters").mkdir(parents=True)
    (root / "my_thesis/chapters/intro.tex").write_text("draft")
    (root / ".git").mkdir()
    (root / ".git/HEAD").write_text("ref: refs/heads/main")
    (root / "notes.txt").write_text("important")
    _fill(elsewhere, [70])
    (root / "linked").symlink_to(elsewhere, target_is_directory=True)


def test_clear_removes_only_the_project_folders(cli, tmp_path, monkeypatch):
    root, elsewhere = tmp_path / "cache", tmp_path / "elsewhere"
    monkeypatch.setenv("VSMP_IMU_CACHE", str(root))
    _user_folder(root, elsewhere)
    code, out, _ = cli("cache", "info")
    assert code == 0 and "not the project's, left alone: .git/, linked (link), my_thesis/, notes.txt" in out
    assert "Removing any of it is safe" not in out
    code, out, _ = cli("cache", "clear")
    assert code == 0
    assert f"removed 2 files (500 B) from {root / 'samples'}" in out and f"removed 1 files (50 B) from {root / 'hapt'}" in out
    assert "not the project's, left alone: .git/, linked (link), my_thesis/, notes.txt" in out
    assert sorted(p.name for p in root.iterdir()) == [".git", "linked", "my_thesis", "notes.txt"]
    assert (root / "my_thesis/chapters/intro.tex").read_text() == "draft" and (root / ".git/HEAD").exists()
    assert len(list(elsewhere.iterdir())) == 1


@pytest.mark.parametrize("name", ["my_thesis", ".git", "linked", "notes.txt"])
def test_only_allows_only_the_project_folders(cli, tmp_path, monkeypatch, name):
    root = tmp_path / "cache"
    monkeypatch.setenv("VSMP_IMU_CACHE", str(root))
    _user_folder(root, tmp_path / "elsewhere")
    code, _, err = cli("cache", "clear", "--only", name)
    assert code == 2 and f"'{name}'" in err and "Allowed: samples, hapt, vlm." in err
    assert "my_thesis" not in err.replace(f"'{name}'", "")
    assert (root / name).exists() and len(list((tmp_path / "elsewhere").iterdir())) == 1


def test_a_linked_project_folder_is_left_alone_and_not_counted(cli, tmp_path, monkeypatch):
    root, theirs = tmp_path / "cache", tmp_path / "theirs"
    monkeypatch.setenv("VSMP_IMU_CACHE", str(root))
    _fill(theirs, [100, 100])
    _fill(root / "hapt", [50])
    (root / "samples").symlink_to(theirs, target_is_directory=True)
    assert [u.name for u in cache_contents().folders] == ["hapt"]
    code, out, _ = cli("cache", "clear", "--only", "samples")
    assert code == 0 and "nothing to remove" in out and "left alone: samples (link)" in out
    code, out, _ = cli("cache", "clear")
    assert code == 0 and "removed 1 files (50 B)" in out and "left alone: samples (link)" in out
    assert "200 B" not in out and len(list(theirs.iterdir())) == 2 and (root / "samples").is_symlink()


def test_a_cache_folder_must_be_listed():
    with pytest.raises(ValueError, match="CACHE_FOLDERS"):
        cache_folder("my_new_cache")


def test_the_code_makes_only_listed_folders_under_the_cache(tmp_path, monkeypatch):
    """The code paths that write under the cache (the HAPT loader, the sample cache, the VLM
    client's default cache), run on an empty root, make only folders of CACHE_FOLDERS."""
    from vsmp_imu.cli.video import _client
    from vsmp_imu.har.datasets.hapt import load_hapt_arrays
    from vsmp_imu.pipeline.sample import SampleTask, cached_synthesize_many

    monkeypatch.setenv("HOME", str(tmp_path))
    for name in ("VSMP_IMU_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    load_hapt_arrays()
    task = SampleTask(key="f/WALKING/0000", label="WALKING", label_index=0, source="test", variant=0, smp_json="",
                      prompt="a person walks", backend="procedural", seed=1, fs_hz=50.0, locations=(),
                      duration_s=2.0)
    cached_synthesize_many((task,), str(samples_dir()))
    _client("http://localhost:1/v1", "m", None, False, 1.0, 0, False)._remember_text_only()
    assert sorted(p.name for p in cache_dir().iterdir()) == sorted(CACHE_FOLDERS)
    assert all(any(p.iterdir()) for p in cache_dir().iterdir())


def test_only_the_cache_module_places_files_under_the_cache_root():
    """Code elsewhere reaches the cache through cache_folder() (or samples_dir(), vlm_dir()), so
    a folder it makes there is one of CACHE_FOLDERS."""
    src = Path(__file__).resolve().parents[2] / "src" / "vsmp_imu"
    allowed = {src / "har" / "cache.py", src / "cli" / "cache.py"}
    pattern = re.compile(r"\bcache_dir\(\)|[\"'](VSMP_IMU_CACHE|XDG_CACHE_HOME|\.cache)[\"']")
    modules = [p for p in sorted(src.rglob("*.py")) if p not in allowed]
    assert len(modules) > 50
    assert [f"{p.relative_to(src)}: {m[0]}" for p in modules for m in pattern.finditer(p.read_text())] == []


def test_clear_keeps_the_vlm_answers_unless_asked(cli, tmp_path, monkeypatch):
    """VLM answers are paid requests whose answers may not come back the same: a plain `cache
    clear` keeps them and says so; `--all` or `--only vlm` removes them."""
    root = tmp_path / "cache"
    monkeypatch.setenv("VSMP_IMU_CACHE", str(root))
    _fill(root / "samples", [300])
    _fill(root / "vlm", [40, 60])
    code, out, _ = cli("cache", "clear")
    assert code == 0 and f"removed 1 files (300 B) from {root / 'samples'}" in out
    assert f"kept 2 files (100 B) in {root / 'vlm'}" in out and "--all or --only vlm removes them" in out
    assert len(list((root / "vlm").iterdir())) == 2
    code, out, _ = cli("cache", "clear")
    assert code == 0 and "nothing to remove" not in out and "kept 2 files" in out
    code, _, err = cli("cache", "clear", "--all", "--only", "vlm")
    assert code == 2 and "--all" in err and (root / "vlm").is_dir()
    code, out, _ = cli("cache", "clear", "--all")
    assert code == 0 and "removed 2 files (100 B)" in out and "kept" not in out
    assert cache_contents().folders == []
    _fill(root / "vlm", [10])
    assert [u.name for u in clear_cache(only="vlm")[0]] == ["vlm"]


def test_one_rule_places_the_cache_and_the_vlm_answers_in_it(cli, tmp_path, monkeypatch):
    """cache_dir() is $VSMP_IMU_CACHE, else $XDG_CACHE_HOME/vsmp-imu, else ~/.cache/vsmp-imu, and
    the VLM answers are its `vlm` folder, so `cache clear --all` finds them wherever it is."""
    from vsmp_imu.cli.video import _client

    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "mine"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert vlm_dir() == tmp_path / "mine" / "vlm"
    assert _client("http://localhost:1/v1", "m", None, False, 1.0, 0, False).cache_dir == vlm_dir()
    _fill(vlm_dir(), [10, 20])
    code, out, _ = cli("cache", "clear", "--all")
    assert code == 0 and f"removed 2 files (30 B) from {vlm_dir()}" in out and not vlm_dir().exists()
    monkeypatch.delenv("VSMP_IMU_CACHE")
    assert cache_dir() == tmp_path / "xdg" / "vsmp-imu" and vlm_dir() == cache_dir() / "vlm"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache_dir() == tmp_path / "home" / ".cache" / "vsmp-imu" and vlm_dir() == cache_dir() / "vlm"
