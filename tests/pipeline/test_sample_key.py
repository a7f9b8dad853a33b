"""A sample's cache key holds what its activity file says, not where the file lies.

An edited activity file (a recipe's durations, an SMP) recomputes the samples of its own class
and no other; the same files in another folder reuse the cached samples; a sample made from a
prompt reads the whole library, so any edit recomputes it."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from vsmp_imu.grounding.align import Convention
from vsmp_imu.pipeline import sample
from vsmp_imu.pipeline.sample import LocationTask, SampleTask, cached_synthesize, library_for
from vsmp_imu.smp.library import BUILTIN_DIR, ActivityLibrary

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "hapt12_timed"


@pytest.fixture(autouse=True)
def _fresh_libraries(monkeypatch):
    """Each test loads its folders as a new process would, and sees each edit at once."""
    monkeypatch.setattr(sample, "LIBRARY_RECHECK_S", 0.0)
    sample.forget_libraries()
    yield
    sample.forget_libraries()


def _task(activity: str | None, dirs: tuple[str, ...] = (), prompt: str = "") -> SampleTask:
    smp_json = ActivityLibrary.load().get(activity).smp.model_dump_json() if activity else ""
    conv = Convention(axes=("left", "up", "forward"), gravity_included=True).as_dict()
    return SampleTask(key=f"f/{activity}/0", label=str(activity), label_index=0, source="test", variant=0,
                      smp_json=smp_json, prompt=prompt, backend="procedural", seed=1, fs_hz=50.0,
                      locations=(LocationTask("waist", conv, True, None),), duration_s=None,
                      library_dirs=dirs)


def _edited(folder: Path, name: str, scale: float) -> None:
    """Scale the first primitive duration of `name`'s recipe in `folder`."""
    path = folder / f"{name}.yaml"
    data = yaml.safe_load(path.read_text())
    first = next(iter(data["procedural"]["primitives"].values()))
    first["duration_s"] = round(first["duration_s"] * scale, 3)
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def _keys(dirs: tuple[str, ...]) -> dict[str, str]:
    return {name: _task(name, dirs).content_hash() for name in ("sit_to_lie", "walking")}


def test_an_edited_activity_file_changes_its_own_samples_keys_only(tmp_path):
    folder = tmp_path / "lib"
    shutil.copytree(EXAMPLE, folder)
    before = _keys((str(folder),))
    _edited(folder, "sit_to_lie", 1.5)
    after = _keys((str(folder),))
    assert after["sit_to_lie"] != before["sit_to_lie"]
    assert after["walking"] == before["walking"]


def test_the_same_files_in_another_folder_keep_the_keys(tmp_path):
    first, second = tmp_path / "a", tmp_path / "b"
    shutil.copytree(EXAMPLE, first)
    shutil.copytree(EXAMPLE, second)
    assert _keys((str(first),)) == _keys((str(second),))


def test_an_override_folder_changes_the_keys_of_the_classes_it_overrides():
    plain, timed = _keys(()), _keys((str(EXAMPLE),))
    assert timed["sit_to_lie"] != plain["sit_to_lie"]
    assert timed["walking"] == plain["walking"]


def test_a_prompt_sample_reads_the_whole_library(tmp_path):
    folder = tmp_path / "lib"
    shutil.copytree(EXAMPLE, folder)
    before = _task(None, (str(folder),), prompt="a person walks").content_hash()
    _edited(folder, "sit_to_lie", 1.5)
    assert _task(None, (str(folder),), prompt="a person walks").content_hash() != before


def test_the_folder_the_code_fingerprint_leaves_out_is_the_built_in_library():
    root = BUILTIN_DIR.parents[1]
    assert BUILTIN_DIR.relative_to(root) == sample._ACTIVITY_FILES


def test_a_cached_sample_is_not_reused_after_its_recipe_changes(tmp_path):
    """End to end through the sample cache: the edited recipe's motion is synthesized again."""
    folder, cache = tmp_path / "lib", tmp_path / "cache"
    shutil.copytree(EXAMPLE, folder)
    first = cached_synthesize((_task("sit_to_lie", (str(folder),)), str(cache)))
    assert len(list(cache.glob("*.parquet"))) == 1
    _edited(folder, "sit_to_lie", 1.5)
    second = cached_synthesize((_task("sit_to_lie", (str(folder),)), str(cache)))
    assert len(list(cache.glob("*.parquet"))) == 2
    assert first.signals["waist"].tobytes() != second.signals["waist"].tobytes()


def test_a_task_whose_smp_is_not_one_still_has_a_key():
    """A malformed variant is reported by `synthesize`; its key reads the whole library."""
    from dataclasses import replace

    broken = [replace(_task("walking"), smp_json=text) for text in ("{not json", "[1, 2]", '{"activity_label": 3}')]
    keys = {t.content_hash() for t in broken}
    assert len(keys) == 3
    assert all(t.activity_digest() == library_for(()).digest() for t in broken)


def test_a_long_lived_process_animates_and_keys_an_edited_activity_file(tmp_path, monkeypatch):
    """A notebook session that edits an activity file: within `LIBRARY_RECHECK_S` of its last look
    the process keeps the library it has; after it, the edited file's library and a backend on it."""
    folder = tmp_path / "lib"
    shutil.copytree(EXAMPLE, folder)
    dirs = (str(folder),)
    first, backend = library_for(dirs), sample.backend_for("procedural", dirs)
    monkeypatch.setattr(sample, "LIBRARY_RECHECK_S", 3600.0)
    _edited(folder, "sit_to_lie", 1.5)
    assert library_for(dirs) is first and sample.backend_for("procedural", dirs) is backend
    monkeypatch.setattr(sample, "LIBRARY_RECHECK_S", 0.0)
    edited = library_for(dirs)
    assert edited is not first and edited.digest("sit_to_lie") != first.digest("sit_to_lie")
    assert edited.digest("walking") == first.digest("walking")
    assert sample.backend_for("procedural", dirs) is not backend
    assert library_for(dirs) is edited  # files unchanged since: the same library
