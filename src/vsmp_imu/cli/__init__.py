"""The `vsmp-imu` command. It parses arguments, builds objects and calls them;
the logic lives in the rooms. Each sub-module registers its own commands."""

from __future__ import annotations

import errno
import signal
import sys
import threading

import typer

from vsmp_imu.cli import cache, data, demo, generate, har, imu, motion, report, smp, study, video
from vsmp_imu.cli.common import console_err, shown
from vsmp_imu.errors import VsmpError

app = typer.Typer(
    name="vsmp-imu",
    help="Turn activity videos or activity names into synthetic wearable IMU data, "
    "and measure honestly how much it helps HAR models.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)

for module in (smp, motion, imu, har, generate, video, study, demo, report, cache, data):
    module.register(app)

# Errors of the file system around a path the user gave (a folder we may not write in, a disk
# that is full or read-only): a one-paragraph message and exit 2, as for any user mistake.
FILE_SYSTEM_ERRNOS = (errno.EACCES, errno.EPERM, errno.EISDIR, errno.ENOTDIR, errno.EEXIST, errno.EROFS,
                      errno.ENOSPC, errno.EDQUOT, errno.ENAMETOOLONG)


def _say(text: str) -> None:
    console_err.print(f"[bold red]error:[/] {shown(text)}", highlight=False, soft_wrap=True)


# What a stopped command keeps for its next run; the others have nothing to resume.
_RESUME = "run the same command again to resume"
KEPT_ON_STOP = {
    "evaluate": f"finished samples and folds are kept; {_RESUME}",
    "generate": f"finished samples are kept; {_RESUME}",
    "study ablation": f"finished samples and records are kept; {_RESUME}",
    "study granularity": f"finished samples and records are kept; {_RESUME}",
    "study realism": "finished samples are cached; the same command run again reuses them",
    "demo": "finished samples are cached; the same command run again reuses them",
}


class Interrupted(BaseException):
    """Ctrl-C (SIGINT) or SIGTERM: unwinds the run like an error, so that atomic writes drop
    their temporaries and the pool stops its workers; finished work stays for a resume."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _interrupt(signum: int, frame: object) -> None:
    raise Interrupted(signum)


def _handle_stop_signals() -> dict[int, object]:
    """Route SIGINT and SIGTERM to `Interrupted` (main thread only); the previous handlers."""
    if threading.current_thread() is not threading.main_thread():
        return {}
    return {sig: signal.signal(sig, _interrupt) for sig in (signal.SIGINT, signal.SIGTERM)}


def stop_message(signum: int, argv: list[str]) -> str:
    """What to say when `vsmp-imu ARGV` is stopped by `signum`: a resume hint only for the
    commands that resume."""
    words = [a for a in argv[:2] if not a.startswith("-")]
    command = " ".join(words) if words[:1] == ["study"] else " ".join(words[:1])
    kept = KEPT_ON_STOP.get(command)
    return f"[bold yellow]stopped[/] by {signal.Signals(signum).name}" + (f": {kept}." if kept else ".")


def main(argv: list[str] | None = None) -> None:
    """Console-script entry point: user mistakes exit 2 with a one-paragraph message; Ctrl-C
    and SIGTERM stop cleanly with 128 + the signal number."""
    previous = _handle_stop_signals()
    try:
        app(args=argv, standalone_mode=True)
    except Interrupted as exc:
        console_err.print(stop_message(exc.signum, sys.argv[1:] if argv is None else argv), highlight=False,
                          soft_wrap=True)
        sys.exit(128 + exc.signum)
    except VsmpError as exc:
        _say(exc.render())
        sys.exit(2)
    except OSError as exc:
        if exc.errno not in FILE_SYSTEM_ERRNOS:
            raise
        where = f"{exc.filename}: " if exc.filename else ""
        _say(f"{where}{exc.strerror or exc}. Allowed: a path you may write to, on a disk with room.")
        sys.exit(2)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
