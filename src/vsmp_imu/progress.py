"""Progress of long work: a live bar on a terminal, plain timestamped lines in a log.

Under nohup, a batch scheduler or CI the output goes to a file, where a live
bar shows nothing until the work ends (an evaluation can run for hours). There
each update becomes one line instead, at most one per `interval_s` seconds
unless the stage changes or the work is done.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from vsmp_imu.terminal import safe_text

# update(done, total=None, stage=None): `total` None keeps the last known total
Update = Callable[..., None]

LOG_INTERVAL_S = 30.0


@contextmanager
def progress(description: str, total: int | None = None, *, console: Console | None = None,
             disable: bool = False, transient: bool = True,
             interval_s: float = LOG_INTERVAL_S) -> Iterator[Update]:
    """Yield an `update(done, total=None, stage=None)` callback for work named `description`;
    the description and stages (a clip's or a model's name) are printed with their control
    characters escaped."""
    console = console or Console(stderr=True)
    description = safe_text(description)
    if disable:
        yield lambda *_, **__: None
    elif console.is_terminal:
        with _bar(description, total, console, transient) as update:
            yield update
    else:
        yield _lines(description, total, console, interval_s)


@contextmanager
def _bar(description: str, total: int | None, console: Console, transient: bool) -> Iterator[Update]:
    # markup=False: a description may hold a clip's or a model's name
    columns = (TextColumn("{task.description}", markup=False), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
               TimeRemainingColumn())
    with Progress(*columns, console=console, transient=transient) as bar:
        task = bar.add_task(description, total=total)

        def update(done: int, total_now: int | None = None, stage: str | None = None) -> None:
            bar.update(task, completed=done, total=total_now,  # None keeps the total
                       description=f"{description}: {safe_text(stage)}" if stage else description)

        yield update


def _lines(description: str, total: int | None, console: Console, interval_s: float) -> Update:
    start = time.monotonic()
    state: dict = {"total": total, "stage": None, "done": None, "printed": -math.inf}
    console.print(f"[{clock(0)}] {description}", markup=False, highlight=False, soft_wrap=True)

    def update(done: int, total_now: int | None = None, stage: str | None = None) -> None:
        state["total"] = total_now or state["total"]
        now = time.monotonic()
        finished = state["total"] is not None and done >= state["total"]
        same = stage == state["stage"]
        if same and (done == state["done"] or (not finished and now - state["printed"] < interval_s)):
            return
        state["stage"], state["done"], state["printed"] = stage, done, now
        count = f"{done}/{state['total']}" if state["total"] else str(done)
        name = f"{description}: {safe_text(stage)}" if stage else description
        console.print(f"[{clock(now - start)}] {name} {count}", markup=False, highlight=False, soft_wrap=True)

    return update


def clock(seconds: float) -> str:
    """'m:ss' under an hour, 'h:mm:ss' from there."""
    whole = int(seconds)
    hours, rest = divmod(whole, 3600)
    minutes, secs = divmod(rest, 60)
    return f"{hours}:{minutes:02d}:{secs:02d}" if hours else f"{minutes}:{secs:02d}"
