"""Benchmark tables rebuilt from the JSON a benchmark script commits (benchmarks/results/).

A `benchmark` table names the JSON (`source`, relative to the repository
root); the table is the script's own Markdown of it: for
`benchmarks/results/run_all.json`, `table_rows` and `markdown` of
`benchmarks/run_all.py` (what `run_all.py --report` writes to run_all.md).
A table with a `view` is one of the script's `VIEWS`: a function of the JSON
giving the Markdown and a line on the measurements it shows (which stages, by
which command, when). A `.jsonl` source is a history, one JSON object per run
(`benchmarks/results/scaling_history.jsonl`), shown through a view only.
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path
from types import ModuleType

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.io import read_text

# the script that writes (and renders) each benchmark JSON, relative to the repository root
SCRIPTS = {"benchmarks/results/run_all.json": "benchmarks/run_all.py",
           "benchmarks/results/motion_controls.json": "benchmarks/study_motion_controls.py",
           "benchmarks/results/extract_clips.json": "benchmarks/bench_extract.py",
           "benchmarks/results/scaling_history.jsonl": "benchmarks/run_all.py"}


def _script(path: Path) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"_bench_{path.stem}", path)
    if spec is None or spec.loader is None or not path.is_file():
        raise InputFileError("the benchmark script that renders this table is missing", file=path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _load(path: Path) -> dict | list[dict]:
    """A benchmark JSON, or a JSON Lines history (`.jsonl`: one object per run, oldest first)."""
    text = read_text(path)
    try:
        if path.suffix == ".jsonl":
            return [json.loads(line) for line in text.splitlines() if line.strip()]
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputFileError(f"not valid JSON: {exc}", file=path) from exc


class BenchTable:
    """Render the benchmark table of one committed benchmark JSON (or one of its script's views),
    with its source line."""

    def __init__(self, root: str | Path, table_id: str, source: str, view: str | None = None) -> None:
        if source not in SCRIPTS:
            raise ConfigError(f"table '{table_id}': no benchmark script renders '{source}'",
                              field="source", allowed=", ".join(SCRIPTS))
        self.root = Path(root)
        self.table_id = table_id
        self.source = source
        self.view = view

    def render(self) -> str:
        path = self.root / self.source
        if not path.is_file():
            raise InputFileError(f"table '{self.table_id}': the benchmark results are not committed", file=path)
        results = _load(path)
        script = _script(self.root / SCRIPTS[self.source])
        if self.view is not None:
            return self._view(script, results)
        if isinstance(results, list):
            raise ConfigError(f"table '{self.table_id}': a history ({self.source}) is shown through a view",
                              field="view")
        table = script.markdown(script.table_rows(results)).rstrip("\n")
        updates = results.get("updates", [])
        later = f" and {len(updates)} later `--update` runs (listed in its `updates`)" if updates else ""
        return (f"{table}\n\nRecords: `{self.source}`, from `{results.get('command')}` (started "
                f"{results.get('started')}){later}; rebuilt by `vsmp-imu report --write`.\n")

    def _view(self, script: ModuleType, results: dict) -> str:
        views = getattr(script, "VIEWS", {})
        if self.view not in views:
            raise ConfigError(f"table '{self.table_id}': {SCRIPTS[self.source]} has no view '{self.view}'",
                              field="view", allowed=", ".join(views) or "none")
        table, provenance = views[self.view](results)
        return f"{table.rstrip()}\n\nRecords: {provenance}; rebuilt by `vsmp-imu report --write`.\n"


def record_parts(path: Path, script: str, argv: list[str], parts: list[str], measure, machine: dict) -> dict:
    """Measure each part (`measure(part)` -> figures) into the benchmark record at `path`.

    Each part is stored with the command that ran it, its start (UTC), wall time, the load
    average at its start and end, and `machine`; the record is written after every part, so
    an interrupted run keeps the parts it finished. Parts measured earlier stay as they were.
    """
    import datetime as dt
    import os
    import time

    from vsmp_imu.io import write_json

    record = json.loads(path.read_text()) if path.exists() else {}
    command = " ".join(["python", script, *argv])
    for part in parts:
        started = dt.datetime.now(dt.UTC)
        load = os.getloadavg()
        start = time.perf_counter()
        figures = measure(part)
        record[part] = {**figures, "command": command, "started": started.isoformat(timespec="seconds"),
                        "wall_s": time.perf_counter() - start, "load_avg_at_start": list(load),
                        "load_avg_at_end": list(os.getloadavg()), "machine": machine}
        write_json(path, record)
    return record
