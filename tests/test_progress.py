"""Progress reporting: a live bar on a terminal, throttled timestamped lines in a log."""

from __future__ import annotations

import io
import re

import pytest
from rich.console import Console

from vsmp_imu import progress as progress_mod
from vsmp_imu.executor import LocalExecutor
from vsmp_imu.progress import clock, progress


def _console(terminal: bool) -> tuple[Console, io.StringIO]:
    buf = io.StringIO()
    return Console(file=buf, force_terminal=terminal, width=120), buf


class FakeClock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


@pytest.fixture
def fake_time(monkeypatch) -> FakeClock:
    fake = FakeClock()
    monkeypatch.setattr(progress_mod.time, "monotonic", fake)
    return fake


def test_log_lines_are_throttled_but_never_miss_a_stage_or_the_end(fake_time):
    console, buf = _console(terminal=False)
    with progress("evaluation", 10, console=console, interval_s=30) as update:
        update(1, stage="fold 1")  # first update: printed
        fake_time.now += 5
        update(2, stage="fold 1")  # same stage within 30 s: quiet
        update(3, stage="fold 2")  # new stage: printed
        fake_time.now += 31
        update(4, stage="fold 2")  # same stage after 30 s: printed
        fake_time.now += 1
        update(10, stage="fold 2")  # done: printed at once
        update(10, stage="fold 2")  # the same end again: quiet
    assert buf.getvalue().splitlines() == [
        "[0:00] evaluation",
        "[0:00] evaluation: fold 1 1/10",
        "[0:05] evaluation: fold 2 3/10",
        "[0:36] evaluation: fold 2 4/10",
        "[0:37] evaluation: fold 2 10/10",
    ]


def test_log_lines_take_a_total_that_arrives_with_the_updates(fake_time):
    console, buf = _console(terminal=False)
    with progress("pose frames", console=console) as update:
        update(3)
        fake_time.now += 3600 + 61
        update(7, 12)
    assert buf.getvalue().splitlines()[1:] == ["[0:00] pose frames 3", "[1:01:01] pose frames 7/12"]


def test_a_terminal_gets_a_live_bar_and_disable_prints_nothing():
    console, buf = _console(terminal=True)
    with progress("synthesis", 4, console=console, transient=False) as update:
        for i in range(4):
            update(i + 1, stage="walking")
    out = buf.getvalue()
    assert "synthesis: walking" in out and "4/4" in out
    assert not re.search(r"^\[\d+:\d\d\]", out, re.MULTILINE)  # no log lines on a terminal

    console, buf = _console(terminal=False)
    with progress("quiet", 3, console=console, disable=True) as update:
        update(3)
    assert buf.getvalue() == ""


@pytest.mark.parametrize("seconds, text", [(0, "0:00"), (59.9, "0:59"), (61, "1:01"), (3600, "1:00:00"),
                                           (36000 + 62, "10:01:02")])
def test_clock(seconds, text):
    assert clock(seconds) == text


def test_executor_logs_its_progress_to_a_file(capsys):
    assert LocalExecutor(1).map(abs, [-1, -2, -3], desc="samples") == [1, 2, 3]
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "[0:00] samples" and lines[-1].endswith("samples 3/3")
    assert LocalExecutor(1, show_progress=False).map(abs, [-1]) == [1]
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("terminal", [False, True])
def test_a_name_from_a_file_cannot_drive_the_terminal(terminal):
    """A clip's or a model's name in the description or a stage is printed with its control
    characters escaped, on a live bar as in log lines."""
    console, buf = _console(terminal=terminal)
    with progress("pose \x1b]0;owned\x07frames", 2, console=console, transient=False) as update:
        update(1, stage="walking/\x1b[2Jclip\u202e.mp4")
        update(2, stage="walking/\x1b[2Jclip\u202e.mp4")
    text = buf.getvalue()
    assert "\x1b]0;" not in text and "\x1b[2J" not in text and "\u202e" not in text and "\x07" not in text
    assert "\\x1b]0;owned\\x07frames" in text and "\\x1b[2Jclip\\u202e.mp4" in text
