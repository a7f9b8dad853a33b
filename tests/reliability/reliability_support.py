"""Helpers of the reliability tests: a small real dataset, the CLI as a subprocess, file checks."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

# HAPT classes kept in the small dataset -> library activity names (used as labels)
CLASSES = {"WALKING": "walking", "SITTING": "sitting", "STANDING": "standing"}
SEGMENT_S = 12.0
DATASET_YAML = """name: hapt_small
description: six HAPT subjects, walking / sitting / standing, waist phone
data: data
fs_hz: 50
labels: [walking, sitting, standing]
locations:
  - name: waist
    acc: [ax, ay, az]
    gyr: [gx, gy, gz]
    acc_unit: m/s^2
    gyr_unit: rad/s
    axes: [up, forward, left]
    axes_source: measured
    gravity_included: true
"""
# what atomic_path names its temporary files: .<name>.<host>~<pid>.<random><suffix>
TEMP_NAME = re.compile(r"^\..+\.[A-Za-z0-9_-]*~\d+\.")


def make_small_dataset(folder: Path, subjects: tuple[str, ...] = ("1", "2", "3", "4", "5", "6")) -> Path:
    """Real HAPT data of a few subjects in the generic format, plus the library SMPs of its classes.

    Each recording keeps the first stretch (at most 12 s) of each class. Returns the YAML path.
    """
    from vsmp_imu.har.datasets.hapt import HAPT
    from vsmp_imu.smp import save_smp
    from vsmp_imu.smp.library import ActivityLibrary

    (folder / "data").mkdir(parents=True, exist_ok=True)
    ds = HAPT().get_subset(list(subjects))
    names = ds.info.label_names
    for rec in ds.recordings():
        parts = []
        for idx, label in enumerate(names):
            if label not in CLASSES:
                continue
            rows = np.flatnonzero(rec.labels == idx)
            if not len(rows):
                continue
            end = rows[0] + int(np.argmax(np.diff(np.r_[rows, -5]) != 1))
            seg = np.arange(rows[0], min(end + 1, rows[0] + int(SEGMENT_S * 50)))
            df = pd.DataFrame(rec.data[seg], columns=["ax", "ay", "az", "gx", "gy", "gz"])
            df.insert(0, "label", CLASSES[label])
            df.insert(0, "subject", rec.subject)
            parts.append(df)
        if parts:
            pd.concat(parts).to_csv(folder / "data" / f"{rec.recording_id}.csv", index=False,
                                    float_format="%.5f")
    (folder / "dataset.yaml").write_text(DATASET_YAML)
    library = ActivityLibrary.load()
    for name in CLASSES.values():
        save_smp(library.get(name).smp, folder / "smps" / f"{name}.json")
    return folder / "dataset.yaml"


def cli_command(*args: str) -> list[str]:
    """The installed `vsmp-imu` console script (or the same entry point through Python)."""
    script = Path(sys.executable).with_name("vsmp-imu")
    head = [str(script)] if script.exists() else [sys.executable, "-c",
                                                   "from vsmp_imu.cli import main; main()"]
    return head + [str(a) for a in args]


def run_cli(*args: str, timeout: float = 300, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(cli_command(*args), capture_output=True, text=True, timeout=timeout,
                          env={**os.environ, **(env or {})})


def kill_at(args: list[str], after_s: float, env: dict | None = None) -> bool:
    """Start the CLI in its own process group and SIGKILL the group after `after_s` seconds.

    Returns True when the kill hit a running process, False when it had finished first.
    """
    proc = subprocess.Popen(cli_command(*args), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True, env={**os.environ, **(env or {})})
    try:
        proc.wait(timeout=after_s)
        return False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
        _wait_group_gone(proc.pid)
        return True


def _wait_group_gone(pgid: int, timeout_s: float = 10.0) -> None:
    """Pool workers of the killed group die with it; wait until none is left."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            os.killpg(pgid, 0)
        except ProcessLookupError:
            return
        time.sleep(0.02)


def _stat(pid: int) -> list[str] | None:
    """/proc/PID/stat fields after the command name (state first), or None when gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def children_of(pid: int) -> list[tuple[int, str]]:
    """Live child processes of `pid` (Linux /proc), each as (pid, start time): the start time
    tells the process from a later one that reuses its pid."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        child = int(stat.parent.name)
        fields = _stat(child)
        if fields is not None and int(fields[1]) == pid and fields[0] != "Z":
            out.append((child, fields[19]))
    return out


def descendants_of(pid: int) -> list[tuple[int, str]]:
    """Live children of `pid`, their children, and so on."""
    found, todo = [], [pid]
    while todo:
        kids = children_of(todo.pop())
        found += kids
        todo += [k for k, _ in kids]
    return found


def alive(process: tuple[int, str]) -> bool:
    """Whether the process (pid, start time) still runs; a zombie does not count."""
    fields = _stat(process[0])
    return fields is not None and fields[0] != "Z" and fields[19] == process[1]


def end(processes) -> list[tuple[int, str]]:
    """The processes still alive, after killing them (a failing test leaves no orphan behind)."""
    survivors = [p for p in processes if alive(p)]
    for pid, _ in survivors:
        os.kill(pid, signal.SIGKILL)
    return survivors


def wait_for(condition, timeout_s: float, step_s: float = 0.05) -> bool:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(step_s)
    return condition()


def leftovers(folder: Path) -> list[Path]:
    """Partial files: atomic-write temporaries and anything ending in .tmp."""
    return sorted(p for p in folder.rglob("*") if p.is_file()
                  and (TEMP_NAME.match(p.name) or p.name.endswith(".tmp")))


def tree_bytes(folder: Path, names: tuple[str, ...]) -> dict[str, bytes]:
    """Relative path -> bytes of the files and folders named (folders recursively)."""
    out = {}
    for name in names:
        path = folder / name
        files = sorted(p for p in path.rglob("*") if p.is_file()) if path.is_dir() else [path]
        for f in files:
            out[str(f.relative_to(folder))] = f.read_bytes()
    return out
