"""`evaluate --processes N`: the folds side by side, their records merged, a failed fold kept apart."""

from __future__ import annotations

import json
import multiprocessing
import os
import re
import signal
import threading
import time

import pytest

from vsmp_imu.app import EvalRequest
from vsmp_imu.har.fanout import LOG_NAME, fold_folder, merge_records, run_folds
from vsmp_imu.pipeline.spec import GenerationSpec


def _records(folder) -> dict[str, dict]:
    """Record files by name, without the one field that is a timing."""
    out = {}
    for path in sorted((folder / "records").glob("*.json")):
        record = json.loads(path.read_text())
        record.pop("fit_seconds")
        out[path.name] = record
    return out


def _break(output, fold: str) -> None:
    """Make a fold's process fail: a file where its records folder goes."""
    folder = fold_folder(output, fold)
    folder.mkdir(parents=True)
    (folder / "records").write_text("not a folder")


def _slow_fold(spec, request, log_path) -> None:
    """A fold's process that would take a minute (imported by name in the spawned process); it
    says in its log that it runs."""
    log_path.write_text("running")
    time.sleep(60)


def _interrupt_once_running(logs, done: threading.Event) -> None:
    """Ctrl-C to this process once every fold's process runs (however long a loaded machine takes
    to spawn them), unless `run_folds` has already returned."""
    deadline = time.monotonic() + 60
    while not done.is_set() and time.monotonic() < deadline and not all(p.exists() for p in logs):
        time.sleep(0.05)
    if not done.is_set():
        os.kill(os.getpid(), signal.SIGINT)


def test_stopping_the_command_stops_the_folds_processes(fixtures_dir, tmp_path):
    request = EvalRequest(dataset=str(fixtures_dir / "generic" / "dataset.yaml"), output=tmp_path / "run")
    logs = [fold_folder(request.output, fold) / LOG_NAME for fold in ("p1", "p2")]
    done = threading.Event()
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # as the command line has it
    threading.Thread(target=_interrupt_once_running, args=(logs, done), daemon=True).start()
    try:
        with pytest.raises(KeyboardInterrupt):
            run_folds(GenerationSpec(), request, ["p1", "p2"], 2, target=_slow_fold)
    finally:
        done.set()
        signal.signal(signal.SIGINT, previous)
    assert all(p.read_text() == "running" for p in logs)
    assert not multiprocessing.active_children()


def test_fold_folders_stay_inside_the_output_and_apart(tmp_path):
    folders = [fold_folder(tmp_path, f) for f in ("3", "..", "a/b", "a-b", "a b")]
    assert folders[0] == tmp_path / ".folds" / "fold-3"
    assert len(set(folders)) == len(folders)
    assert all(f.parent == tmp_path / ".folds" and f.name.startswith("fold-") for f in folders)


def test_merge_copies_record_files_only(tmp_path):
    source = tmp_path / "fold"
    (source / "records").mkdir(parents=True)
    (source / "records" / "a.json").write_text("{}")
    (source / "results.json").write_text("{}")
    assert merge_records(source, tmp_path / "out") == 1
    assert [p.name for p in (tmp_path / "out").rglob("*.json")] == ["a.json"]
    assert merge_records(tmp_path / "nothing", tmp_path / "out") == 0


def test_each_fold_runs_in_its_process_and_a_failure_stays_its_own(fixtures_dir, tmp_path):
    out = tmp_path / "run"
    request = EvalRequest(dataset=str(fixtures_dir / "generic" / "dataset.yaml"), output=out,
                          backbone_params={"rf": {"n_estimators": 5, "n_jobs": 1}})
    _break(out, "p2")
    seen = []
    outcomes = run_folds(GenerationSpec(), request, ["p1", "p2"], 2, lambda o, n, total: seen.append((o.fold, n, total)))
    assert [o.fold for o in outcomes] == ["p1", "p2"]
    done, failed = outcomes
    assert done.ok and done.records == 1 and (out / "records" / "lopo_full_real_rf_fold-p1_seed-0.json").is_file()
    assert done.last_line() == "done: 1 record(s)"
    assert failed.exit_code == 1 and failed.records == 0
    assert "Traceback" in (fold_folder(out, "p2") / LOG_NAME).read_text()
    assert str(fold_folder(out, "p2") / "records") in failed.last_line()  # the error, for the console
    assert sorted(f for f, _, _ in seen) == ["p1", "p2"] and sorted(n for _, n, _ in seen) == [1, 2]
    assert all(total == 2 for _, _, total in seen)
    assert [p.name for p in (out / "records").iterdir()] == ["lopo_full_real_rf_fold-p1_seed-0.json"]


@pytest.mark.slow
def test_the_command_resumes_a_failed_fold_and_writes_the_records_one_process_would(cli, fixtures_dir, tmp_path):
    dataset = fixtures_dir / "generic" / "dataset.yaml"
    alone, side = tmp_path / "alone", tmp_path / "side"
    code, _, _ = cli("evaluate", "--dataset", dataset, "--methods", "real,classical", "-o", alone)
    assert code == 0
    _break(side, "p3")
    code, out, err = cli("evaluate", "--dataset", dataset, "--methods", "real,classical", "--processes", "2",
                         "-o", side)
    assert code == 1 and "fold p3 failed" in err and "run the same command again" in err
    assert not (side / "results.json").exists() and len(_records(side)) == 4
    (fold_folder(side, "p3") / "records").unlink()
    code, out, _ = cli("evaluate", "--dataset", dataset, "--methods", "real,classical", "--processes", "2",
                       "-o", side)
    assert code == 0 and re.search(r"fold p3: 2 record\(s\) [123]/3", out)
    assert _records(side) == _records(alone)
    assert json.loads((side / "results.json").read_text())["summary"] == \
        json.loads((alone / "results.json").read_text())["summary"]
