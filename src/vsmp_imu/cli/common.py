"""Shared pieces of the command line: consoles, option helpers and the checks of output paths."""

from __future__ import annotations

import contextlib
import functools
import inspect
import math
import os
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import typer
from rich.console import Console, ConsoleOptions, RenderableType, RenderResult
from rich.errors import MarkupError
from rich.markup import escape
from rich.segment import Segment
from rich.text import Text

from vsmp_imu.errors import ConfigError, VsmpError
from vsmp_imu.pipeline.spec import INTENSITY, GenerationSpec, intensity_bounds
from vsmp_imu.terminal import safe_text


def parse_csv(value: str, allowed: tuple[str, ...] | None = None, option: str = "") -> list[str]:
    """Split 'a,b,c' and check every item against `allowed`."""
    items = [v.strip() for v in value.split(",") if v.strip()]
    if not items:
        raise ConfigError("must name at least one value", field=option)
    if allowed is not None:
        bad = [v for v in items if v not in allowed]
        if bad:
            raise ConfigError(f"unknown value(s) {', '.join(bad)}", field=option, allowed=", ".join(allowed))
    return items


# -- number options: a range checked by the option's callback, before any work, in one wording --
def finite_range(lo: float, hi: float, *, low_open: bool = False) -> Callable[[float | None], float | None]:
    """The callback of a float option in lo..hi (`low_open`: above lo, at most hi): NaN and inf
    are refused as not finite (typer's own min/max check calls NaN larger than the maximum)."""

    def check(value: float | None) -> float | None:
        if value is not None and not _finite_in(value, lo, hi, low_open):
            raise typer.BadParameter(f"must be {_finite_text(lo, hi, low_open)}, not {value:g}")
        return value

    return check


def finite_list(lo: float, hi: float) -> Callable[[str], str]:
    """The callback of an option that lists numbers ('0.1,0.5'): each a finite number in lo..hi.
    The text passes unchanged (`parse_csv` splits it); an empty list is left to `parse_csv`."""

    def check(text: str) -> str:
        for item in (v.strip() for v in text.split(",")):
            try:
                ok = not item or _finite_in(float(item), lo, hi, False)
            except ValueError:
                ok = False
            if not ok:
                raise typer.BadParameter(f"each value must be {_finite_text(lo, hi, False)}, not '{item}'")
        return text

    return check


def int_range(lo: int, hi: int | None = None) -> Callable[[int | None], int | None]:
    """The callback of an integer option in lo..hi (None: no upper bound); typer's own min/max
    would also change the option's help (it shows the range)."""

    def check(value: int | None) -> int | None:
        if value is not None and not (lo <= value and (hi is None or value <= hi)):
            allowed = f"an integer >= {lo}" if hi is None else f"an integer in {lo}..{hi}"
            raise typer.BadParameter(f"must be {allowed}, not {value}")
        return value

    return check


def _finite_in(value: float, lo: float, hi: float, low_open: bool) -> bool:
    return math.isfinite(value) and (lo < value if low_open else lo <= value) and value <= hi


def _finite_text(lo: float, hi: float, low_open: bool) -> str:
    if low_open:
        return f"a finite number above {lo:g} and at most {hi:g}"
    return f"a finite number in {lo:g}..{hi:g}"


def library_dirs(library: list[Path] | None) -> list[Path]:
    """The user's extra activity-library folders given by --library (repeatable), each an
    existing folder (checked before any work, whether or not the run reads the library)."""
    for folder in library or []:
        if not folder.is_dir():
            raise ConfigError("not found" if not folder.exists() else "is not a folder", file=folder,
                              field="--library", allowed="a folder of activity files (docs/smp.md)")
    return list(library or [])


# every command that reads the activity library (checked by library_dirs)
LIBRARY_OPTION = typer.Option(None, "--library", help="Extra activity-library folder (repeatable).")


@contextlib.contextmanager
def naming(file: Path | str | None) -> Iterator[None]:
    """Errors about an input's fields raised without a file (deep in synthesis, say) name the
    user's `file`; None: nothing to name (an activity name, a prompt)."""
    try:
        yield
    except VsmpError as exc:
        if file is None or exc.file is not None:
            raise
        raise exc.in_file(file) from exc


@contextlib.contextmanager
def option_names(options: dict[str, str]) -> Iterator[None]:
    """Errors raised deep in a command that name a setting by its internal name (field
    'backend') name the option the user typed instead ('--backend'); `options` maps the one to
    the other. Also a decorator of a command."""
    try:
        yield
    except VsmpError as exc:
        if exc.field not in options:
            raise
        raise exc.in_field(options[exc.field]) from exc


def executor_options(executor: str, address: str | None) -> None:
    """`--executor` / `--address` checked before any work (an address without Ray is not ignored)."""
    from vsmp_imu.executor import check_executor_options

    check_executor_options(executor, address)


# the imugpt baseline's describer (evaluate, study granularity, study realism; see describer_options)
DESCRIBER_URL_OPTION = typer.Option(
    None, "--describer-url", show_default=False, metavar="URL",
    help="imugpt: an OpenAI-compatible endpoint (e.g. http://localhost:8000/v1; the key is read from "
         "VSMP_VLM_API_KEY or OPENAI_API_KEY) whose chat model writes the activity descriptions "
         "[default: none: the baseline's built-in templated descriptions, library captions x modifiers]")
DESCRIBER_MODEL_OPTION = typer.Option(
    None, "--describer-model", show_default=False, metavar="NAME",
    help="imugpt: the model --describer-url serves that writes the descriptions [default: an empty "
         "name, which a server of one model takes]")


def describer_options(url: str | None, model: str | None, methods: tuple[str, ...]) -> dict[str, dict[str, Any]]:
    """`--describer-url` / `--describer-model` as the imugpt method's parameters (recorded with
    the run, part of its settings); none without a URL."""
    from vsmp_imu.extract.client import api_key_from_env, check_base_url

    if url is None:
        if model is not None:
            raise ConfigError("--describer-model names the model of a describer endpoint", field="--describer-model",
                              allowed="it together with --describer-url URL")
        return {}
    if "imugpt" not in methods:
        raise ConfigError("only the imugpt method asks a describer", field="--describer-url",
                          allowed="--methods with imugpt, or no --describer-url")
    with option_names({"base_url": "--describer-url"}):
        check_base_url(url)
    api_key_from_env()  # a key a request could not carry fails now, not in the first fold
    return {"imugpt": {"describer_url": url, "describer_model": model or ""}}


# -- output paths: checked before any work, so a run never fails at its end ------------------
def output_file(path: Path | None, option: str = "--output") -> Path | None:
    """Check that a file can be written at `path` (None: nothing to check)."""
    if path is None:
        return None
    if _is_dir(path, option):
        raise ConfigError("is a folder, not a file name", file=path, field=option,
                          allowed="the path of a file to write (a new one, or one to replace)")
    _check_parent(path, option)
    return path


def output_suffix(path: Path | None, suffix: str | tuple[str, ...], what: str, option: str = "--output") -> None:
    """The file a command writes in one format must be named for it: a motion written to
    'x.parquet' would be a zip under a name that says otherwise. `suffix`: one, or the suffixes
    of the formats the writer picks by name ('.json', '.yaml', '.yml'). None: no file asked for."""
    if path is None:
        return
    suffixes = (suffix,) if isinstance(suffix, str) else suffix
    if path.suffix.lower() not in suffixes:
        given = f"'{path.suffix}'" if path.suffix else "a name without one"
        named = suffixes[0] if len(suffixes) == 1 else f"{', '.join(suffixes[:-1])} or {suffixes[-1]}"
        raise ConfigError(f"{what} is written as {named}, not under {given}", file=path,
                          field=option, allowed=f"a file name ending in {named}")


def output_dir(path: Path | None, option: str = "--output") -> Path | None:
    """Check that `path` is, or can become, a folder we may write in (None: nothing to check)."""
    if path is None:
        return None
    if _exists(path, option) and not _is_dir(path, option):
        raise ConfigError("exists and is a file, not a folder", file=path, field=option,
                          allowed="a folder: a new one, or one of an earlier run to resume")
    if _is_dir(path, option):
        _check_writable(path, path, option)
    else:
        _check_parent(path, option)
    return path


def probe_folder(path: Path, option: str = "--output") -> None:
    """Create and remove a small file in `path`, or in the nearest existing folder above it: a
    folder that only looks writable (root on /proc, a full or read-only disk) is found before
    any work, where `os.access` says yes."""
    above = path.absolute()
    while not _exists(above, option) and above != above.parent:
        above = above.parent
    try:
        fd, probe = tempfile.mkstemp(prefix=".vsmp-imu-probe-", dir=above)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ConfigError(f"cannot write in '{above}' ({exc.strerror})", file=path, field=option,
                          allowed="a folder you may write to") from exc


def path_text(text: str) -> Path:
    """A path option's text as a Path (typer's `parser`); an empty one is refused, not taken
    as the current folder."""
    if not text.strip():
        raise typer.BadParameter("is empty; give a path ('.' for the current folder)")
    return Path(text)


def _check_parent(path: Path, option: str) -> None:
    """The nearest existing folder above `path` must be a folder we may write in."""
    above = path.absolute().parent
    while not _exists(above, option) and above != above.parent:
        above = above.parent
    if not _is_dir(above, option):
        raise ConfigError(f"'{above}' is a file, so nothing can be written under it", file=path,
                          field=option, allowed="a path whose parent folders are folders")
    _check_writable(above, path, option)


def _check_writable(folder: Path, path: Path, option: str) -> None:
    if not os.access(folder, os.W_OK | os.X_OK):
        raise ConfigError(f"no permission to write in '{folder}' (or its disk is read-only)", file=path,
                          field=option, allowed="a folder you may write to")


def _exists(path: Path, option: str) -> bool:
    try:
        return os.path.lexists(path)
    except OSError as exc:  # pragma: no cover - lexists returns False on most errors
        raise ConfigError(f"cannot look at the path ({exc.strerror})", file=path, field=option) from exc


def _is_dir(path: Path, option: str) -> bool:
    try:
        return path.is_dir()
    except OSError as exc:  # a folder above it that we may not enter
        raise ConfigError(f"cannot look at the path ({exc.strerror})", file=path, field=option,
                          allowed="a folder you may enter and write to") from exc


# -- inputs and outputs of one command: never the same file ---------------------------------
def distinct_files(outputs: dict[str, Path | None],
                   inputs: dict[str, Path | str | list[Path] | None] | None = None) -> None:
    """Refuse an output that is one of the command's inputs or another of its outputs, whatever
    the spelling (links and '..' resolved). Keys name the options or inputs; an input that is
    not an existing file (an activity name) has nothing to lose; None is skipped."""
    seen: dict[object, str] = {}
    for label, value in (inputs or {}).items():
        for path in value if isinstance(value, list) else [value]:
            if path is not None and os.path.isfile(path):
                seen.setdefault(_file_key(Path(path)), label)
    for option, path in outputs.items():
        if path is None:
            continue
        first = seen.setdefault(_file_key(path), option)
        if first != option:
            raise ConfigError(f"{first} and {option} name the same file", file=path, field=option,
                              allowed="a file of its own for each output, never one of the inputs")


def _file_key(path: Path) -> object:
    """What makes two paths one file: device and inode when it exists, else its resolved path."""
    with contextlib.suppress(OSError):
        info = path.stat()
        return info.st_dev, info.st_ino
    try:
        return str(path.resolve())
    except (OSError, RuntimeError):  # a symlink loop
        return str(path.absolute())


# -- untrusted text: printed with its control characters escaped ----------------------------
def shown(text: object) -> str:
    """User text (a file name, a label) to put in a console message that has markup: printed
    as written ('[red]x.json' stays '[red]x.json'), its control characters escaped."""
    return escape(safe_text(text))


class _Escaped:
    """A renderable whose text segments are escaped; rich's own styles and cursor controls
    (separate segments) pass unchanged. The net under `_Console.render_str`, for Text objects
    made from user text: escaping after layout widens a line past its wrap."""

    def __init__(self, renderable: RenderableType) -> None:
        self.renderable = renderable

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        for segment in console.render(self.renderable, options):
            if segment.control:
                yield segment
                continue
            style = segment.style
            if style is not None and style.link:  # '[link=...]' in a label: no terminal hyperlink
                style = style.update_link(None)
            yield Segment(safe_text(segment.text), style)


class _EscapeHook:
    """Every console print goes through here: labels, file contents and model answers in
    messages and tables reach the terminal with their control characters escaped."""

    def process_renderables(self, renderables: list[RenderableType]) -> list[RenderableType]:
        return [_Escaped(r) for r in renderables]


class _Console(Console):
    """A label such as '[/x]' inside a message is text, not broken markup: printed plainly.
    Strings (messages, table cells) have their control characters escaped before they are
    laid out, so lines wrap at their printed width."""

    def print(self, *objects: Any, **kwargs: Any) -> None:
        try:
            super().print(*objects, **kwargs)
        except MarkupError:
            super().print(*objects, **{**kwargs, "markup": False})

    def render_str(self, text: str, **kwargs: Any) -> Text:
        return super().render_str(safe_text(text), **kwargs)


def _console(stderr: bool = False) -> Console:
    out = _Console(stderr=stderr)
    out.push_render_hook(_EscapeHook())
    return out


console = _console()
console_err = _console(stderr=True)


def print_warnings(lines: list[str]) -> None:
    """Print each warning (e.g. a dataset's undeclared axes) as one paragraph on stderr."""
    for line in lines:
        console_err.print(f"[bold yellow]warning:[/] {shown(line)}", highlight=False, soft_wrap=True)

# What the generation spec's errors call a setting -> the option of `generate` and `evaluate`
# that sets it (`option_names`).
SPEC_OPTIONS = {"source": "--source", "backend": "--backend", "k": "--k", "k_unseen": "--k-unseen",
                "level_parts": "--level-parts", "refill": "--refill", "workers": "--workers",
                "executor": "--executor", "unseen_intensity": "--unseen-intensity"}

# The windows of `evaluate`, `generate`, `dataset info` and `data check` (one definition, one help text).
MAX_OVERLAP = 0.9  # a hop of a tenth of a window: ten times the windows of no overlap
WINDOW_S = typer.Option(2.0, "--window-s", callback=finite_range(0.5, 30.0), help="window length in seconds, 0.5..30")
OVERLAP = typer.Option(0.5, "--overlap", callback=finite_range(0.0, MAX_OVERLAP),
                       help=f"overlap of neighbouring windows, 0..{MAX_OVERLAP:g}")

# Grounding options shared by `generate` and `evaluate` (one definition, one help text).
PER_CLASS_RANK = typer.Option(True, "--per-class-rank/--pooled-rank",
                              help="rank grounding per class where a class has real windows enough "
                                   "(--pooled-rank: one map for all, the paper's)")
GRAVITY_NORM = typer.Option(False, "--gravity-norm",
                            help="after the rank map, give each sample's accelerometer its gravity magnitude back")
SIDE_EVIDENCE = typer.Option(True, "--side-evidence/--no-side-evidence",
                             help="where the side shows in the sensor (a turn to lie down), give a class's "
                                  "variants the side its real training windows support (--no-side-evidence: 50/50)")
TEXTURE = typer.Option(True, "--texture/--no-texture",
                       help="add the 3-12 Hz movement texture procedural motion lacks, in proportion to each "
                            "sample's own motion, by ratios fitted on the real training windows (VSMP-IMU)")
WINDOW_LEVELS = typer.Option(True, "--window-levels/--no-window-levels",
                             help="shift each transition's windows so that their means follow its real "
                                  "training windows' (classes with 5 real windows or more)")
LEVEL_PARTS = typer.Option(1, "--level-parts", min=1, max=16,
                           help="window levels: the window's equal parts whose means follow the real "
                                "windows', each on its own (1: the whole window's mean; 4: its quarters)")
POSTURE_LEVELS = typer.Option(False, "--posture-levels/--no-posture-levels",
                              help="window levels also for the held postures (sitting, standing, lying): "
                                   "each still window's mean follows the real windows' of its class "
                                   "(gains on TSTR, not on the long tail)")
POOLED_CALIBRATION = typer.Option(
    True, "--pooled-calibration/--no-pooled-calibration",
    help="sim-in-the-loop for a class with no real training windows (an unseen class) against the other "
         "classes' pooled statistics (--no-pooled-calibration: such a class keeps the nominal sensor)")
NOMINAL_UNSEEN_POSTURES = typer.Option(
    True, "--nominal-unseen-postures/--calibrate-unseen-postures",
    help="a held posture with no real training windows keeps the nominal sensor (--calibrate-unseen-postures: "
         "sim-in-the-loop against the other classes' pooled statistics, as a moving class)")
UNSEEN_INTENSITY = typer.Option(
    ",".join(map(str, INTENSITY)), "--unseen-intensity",
    help="LO,HI: each synthetic window of a class with no real training windows gets its gyroscope's "
         "deviations from the window mean scaled by a factor drawn from [LO, HI] (the intensity spread "
         "its SMP alone lacks) | off")
SEEN_INTENSITY = typer.Option(
    False, "--seen-intensity/--no-seen-intensity",
    help="each synthetic window of a class with real training windows gets its gyroscope's deviations from "
         "the window mean scaled by a random factor, so the windows' spread of intensity is as wide as the "
         "class's real windows'")
EVENT_DURATIONS = typer.Option(
    False, "--event-durations/--no-event-durations",
    help="time half the synthetic samples of a discrete event (a transition, one gesture) to the duration of "
         "one of its class's real events, read from consecutive real training windows; per class keep the "
         "timed windows, the untimed ones or both, whichever a synthetic-only forest scores best on the real "
         "windows")
CADENCE = typer.Option(
    True, "--cadence/--no-cadence",
    help="every synthetic sample of a gait (walking, stairs) whose class has real training windows steps at "
         "the step rate of one of its class's real windows (the peak of the accelerometer magnitude's "
         "spectrum), instead of the SMP's tempo")
K = typer.Option(GenerationSpec.k, "--k", min=1, max=64,
                 help="SMP variants per base SMP for a class with real training windows (the paper's K is 4)")
K_UNSEEN = typer.Option(
    GenerationSpec.k_unseen, "--k-unseen", min=1, max=64,
    help="SMP variants per base SMP for a class with no real training windows (an unseen class, whose "
         "samples rest on its SMP alone; --k for the others)")
MOTION_FIT = typer.Option(False, "--motion-fit",
                          help="fit each class's motion parameters to D_stat before synthesis (VSMP-IMU)")

# The grounding options in the order the help lists them: parameter -> (type, option).
GROUNDING_OPTIONS: dict[str, tuple[type, Any]] = {
    "per_class_rank": (bool, PER_CLASS_RANK), "gravity_norm": (bool, GRAVITY_NORM), "motion_fit": (bool, MOTION_FIT),
    "texture": (bool, TEXTURE), "window_levels": (bool, WINDOW_LEVELS), "level_parts": (int, LEVEL_PARTS),
    "posture_levels": (bool, POSTURE_LEVELS), "pooled_calibration": (bool, POOLED_CALIBRATION),
    "nominal_unseen_postures": (bool, NOMINAL_UNSEEN_POSTURES), "unseen_intensity": (str, UNSEEN_INTENSITY),
    "seen_intensity": (bool, SEEN_INTENSITY), "event_durations": (bool, EVENT_DURATIONS), "cadence": (bool, CADENCE),
    "side_evidence": (bool, SIDE_EVIDENCE),
}


def option_group(name: str, options: dict[str, tuple[Any, Any]]) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """A decorator of commands that share a run of options: the command's parameter `name`
    stands for `options` (parameter -> (type, typer option)). Its command line has them in that
    parameter's place, with the same names, defaults, help and order wherever they are used, and
    the command gets their values as one dict, `name`."""

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        signature = inspect.signature(command, eval_str=True)
        if name not in signature.parameters:
            raise TypeError(f"{command.__name__} has no parameter '{name}' to put its options in")
        params: list[inspect.Parameter] = []
        for param in signature.parameters.values():
            if param.name != name:
                params.append(param)
                continue
            params += [inspect.Parameter(option, param.kind, default=info, annotation=kind)
                       for option, (kind, info) in options.items()]

        @functools.wraps(command)
        def run(**values: Any) -> Any:
            group = {option: values.pop(option) for option in options}
            return command(**values, **{name: group})

        run.__signature__ = signature.replace(parameters=params)  # type: ignore[attr-defined]
        run.__annotations__ = {p.name: p.annotation for p in params}
        return run

    return decorate


# `generate` and `evaluate`: the parameter `grounding` stands for the grounding options.
grounding_options = option_group("grounding", GROUNDING_OPTIONS)


def grounding_spec(grounding: dict[str, Any]) -> dict[str, Any]:
    """The grounding options' values as GenerationSpec fields (--unseen-intensity parsed)."""
    return {**grounding, "unseen_intensity": intensity_bounds(grounding["unseen_intensity"])}
