"""Benchmark tables: the table a benchmark script writes, rebuilt from its committed JSON."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.bench_records import BenchTable
from vsmp_imu.har.published import Publication

REPO_ROOT = Path(__file__).resolve().parents[2]
SOURCE = "benchmarks/results/run_all.json"
CATALOGUE = f"tables:\n  - id: bench:stages\n    records: run_all\n    kind: benchmark\n    source: {SOURCE}\n"


def test_the_committed_table_is_what_the_script_writes_from_the_committed_json():
    rendered = BenchTable(REPO_ROOT, "bench:stages", SOURCE).render()
    assert rendered.startswith((REPO_ROOT / "benchmarks/results/run_all.md").read_text() + "\n")
    assert f"Records: `{SOURCE}`" in rendered


def _root(tmp_path: Path, stages: dict) -> Path:
    (tmp_path / "benchmarks/results").mkdir(parents=True)
    shutil.copy(REPO_ROOT / "benchmarks/run_all.py", tmp_path / "benchmarks/run_all.py")
    results = {"command": "python benchmarks/run_all.py --stages cem", "started": "2026-01-01T00:00:00",
               "stages": stages}
    (tmp_path / SOURCE).write_text(json.dumps(results))
    (tmp_path / "results").mkdir()
    (tmp_path / "results/tables.yaml").write_text(CATALOGUE)
    (tmp_path / "BENCHMARKS.md").write_text("<!-- report:bench:stages -->\nold\n<!-- /report -->\n")
    return tmp_path


def test_write_then_check_and_a_changed_figure_differs(tmp_path):
    root = _root(tmp_path, {"smp_augment": {"unit": "SMP variants", "per_s_per_core": 1234.5}})
    Publication(root).check(write=True)
    text = (root / "BENCHMARKS.md").read_text()
    assert "| SMP augmentation [SMP variants/s per core] | 1234.5 |" in text
    assert not Publication(root).check().differing
    (root / "BENCHMARKS.md").write_text(text.replace("1234.5", "2000.0"))
    assert Publication(root).check().differing == ["BENCHMARKS.md: table 'bench:stages'"]


def test_unknown_sources_and_missing_results_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="no benchmark script renders"):
        BenchTable(tmp_path, "b:x", "benchmarks/results/other.json")
    with pytest.raises(InputFileError, match="not committed"):
        BenchTable(tmp_path, "b:x", SOURCE).render()
    (tmp_path / "results").mkdir()
    (tmp_path / "results/tables.yaml").write_text(CATALOGUE.replace(f"    source: {SOURCE}\n", ""))
    with pytest.raises(ConfigError, match="needs the source JSON"):
        Publication(tmp_path)
