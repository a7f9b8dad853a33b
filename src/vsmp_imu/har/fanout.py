"""One evaluation's folds in several processes side by side (`evaluate --processes N`).

A small network leaves most of a GPU idle, and a forest's fold uses a few cores: running one
process per held-out subject is how the long DeepConvLSTM protocols fit into minutes. Each fold
runs in its own spawned process with the same settings and its own output folder
(`OUTPUT/.folds/fold-<fold>`, its progress in `log.txt` there); at most `processes` run at once.
Each finished fold's records are copied into `OUTPUT/records`, where the evaluation over all
folds then finds them done and only writes the report. A fold that fails leaves the others'
records in place; rerunning the same command reruns that fold alone.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import re
import sys
import traceback
from collections.abc import Callable
from dataclasses import dataclass, replace
from multiprocessing.connection import wait
from pathlib import Path

from vsmp_imu.errors import VsmpError
from vsmp_imu.io import write_bytes

SCRATCH = ".folds"  # below the output folder: one folder per fold's process
LOG_NAME = "log.txt"
USER_ERROR, CRASH = 2, 1  # exit codes of a fold's process


@dataclass(frozen=True)
class FoldOutcome:
    """How one fold's process ended: its exit code (0: done), log and records copied."""

    fold: str
    exit_code: int
    log: Path
    records: int

    @property
    def ok(self) -> bool:
        return self.exit_code == 0

    def last_line(self) -> str:
        lines = self.log.read_text(errors="replace").strip().splitlines() if self.log.is_file() else []
        return lines[-1] if lines else "(no output)"


def fold_folder(output: Path, fold: str) -> Path:
    """`OUTPUT/.folds/fold-<fold>`; a fold id that is not a plain name (a subject column may hold
    `a/b` or `..`) is cleaned and told apart by a hash of the id."""
    fold = str(fold)
    name = re.sub(r"[^A-Za-z0-9_.-]+", "-", fold)
    if name != fold:
        name += "-" + hashlib.sha256(fold.encode()).hexdigest()[:8]
    return Path(output) / SCRATCH / f"fold-{name}"


def run_fold(spec, request, log_path: Path) -> None:
    """A fold's process: the evaluation of `request` (one fold), its progress lines (those
    `evaluate` prints when stderr is a file) in `log_path`."""
    from rich.console import Console

    from vsmp_imu.app import evaluate, evaluation
    from vsmp_imu.progress import progress

    with open(log_path, "a", encoding="utf-8") as log:
        console = Console(file=log, width=200)
        try:
            run = evaluation(spec, request)
            with progress(f"{run.dataset.info.name} {request.protocol}", console=console) as update:
                results, _ = evaluate(run, lambda stage, done, total: update(done, total, stage))
        except VsmpError as exc:
            log.write(f"error: {exc.render()}\n")
            sys.exit(USER_ERROR)
        except BaseException:  # noqa: BLE001 - a crash must reach the log, not a lost stderr
            log.write(traceback.format_exc())
            sys.exit(CRASH)
        log.write(f"done: {len(results.records)} record(s)\n")


def merge_records(source: Path, output: Path) -> int:
    """Copy a fold folder's record files into `output/records`; the number copied."""
    records = Path(source) / "records"
    if not records.is_dir():
        return 0
    target = Path(output) / "records"
    target.mkdir(parents=True, exist_ok=True)
    copied = 0
    for path in sorted(records.glob("*.json")):
        write_bytes(target / path.name, path.read_bytes())  # atomic: a stop never leaves half a record
        copied += 1
    return copied


def run_folds(spec, request, folds: list[str], processes: int,
              on_outcome: Callable[[FoldOutcome, int, int], None] | None = None,
              target: Callable = run_fold) -> list[FoldOutcome]:
    """Run each fold of `request` in its own process, at most `processes` at a time.

    Each process gets `request` with that one fold and its fold folder as output. As a process
    ends, its records are merged into `request.output` and `on_outcome(outcome, finished,
    total)` is called. Returns the outcomes in fold order.
    """
    context = multiprocessing.get_context("spawn")  # no forked CUDA or thread state
    waiting = list(folds)
    running: dict[int, tuple[str, Path, multiprocessing.Process]] = {}  # by the process's sentinel
    outcomes: dict[str, FoldOutcome] = {}
    try:
        while waiting or running:
            while waiting and len(running) < processes:
                fold = waiting.pop(0)
                folder = fold_folder(request.output, fold)
                folder.mkdir(parents=True, exist_ok=True)
                child = replace(request, folds=(fold,), output=folder)
                process = context.Process(target=target, args=(spec, child, folder / LOG_NAME), name=f"fold-{fold}")
                process.start()
                running[process.sentinel] = (fold, folder, process)
            for sentinel in wait(list(running)):
                fold, folder, process = running.pop(sentinel)
                process.join()
                code = process.exitcode if process.exitcode is not None else CRASH
                outcomes[fold] = FoldOutcome(fold, code, folder / LOG_NAME, merge_records(folder, request.output))
                if on_outcome:
                    on_outcome(outcomes[fold], len(outcomes), len(folds))
    finally:  # stopped (Ctrl-C, SIGTERM): the folds' processes stop too; their finished records stay
        for _, _, process in running.values():
            process.terminate()
            process.join()
    return [outcomes[f] for f in folds]
