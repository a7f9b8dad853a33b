"""File helpers shared by every room: atomic writes, JSON and YAML."""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import signal
import socket
import stat
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

import yaml

from vsmp_imu.errors import ConfigError, InputFileError


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None, mode: int | None = None) -> Iterator[Path]:
    """Yield a temporary path next to `path`; rename it onto `path` on success.

    Nothing is left behind on failure: a reader never sees a partial file.
    `suffix` keeps the extension visible to writers that dispatch on it;
    `mode`: the file's permissions (None: the usual ones, 0666 less the umask).
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = ""
    try:  # armed before the file exists: a stop (Ctrl-C, SIGTERM) while it was made left it behind
        with stops_held():
            fd, tmp = tempfile.mkstemp(
                prefix=f".{path.name}.{_writer_tag()}.",
                suffix=suffix if suffix is not None else path.suffix + ".tmp",
                dir=path.parent,
            )
            os.close(fd)
        tmp_path = Path(tmp)
        yield tmp_path
        if tmp_path.exists():
            tmp_path.chmod(0o666 & ~_umask() if mode is None else mode)  # mkstemp makes 0600
        os.replace(tmp_path, path)
    finally:
        if tmp and os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def stops_held() -> Iterator[None]:
    """SIGINT and SIGTERM that arrive while the block runs are handled after it (mkstemp creates the
    file before it returns its name, and a stop between the two lost the name; a stop inside
    matplotlib's drawing came out as its ValueError). Held in Python, not
    with a signal mask: a signal to the process goes to any thread that does not block it (numpy's
    BLAS threads), and Python runs its handler in the main thread wherever that thread is."""
    stops = (signal.SIGINT, signal.SIGTERM)
    if threading.current_thread() is not threading.main_thread() or any(
            signal.getsignal(sig) is None for sig in stops):
        yield  # handlers run in the main thread only; one installed outside Python could not be put back
        return
    pending: list[int] = []
    previous = {sig: signal.signal(sig, lambda signum, _frame: pending.append(signum)) for sig in stops}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        for sig in pending:
            signal.raise_signal(sig)  # to the handler that was there before


# .<name>.<host>~<pid>.<random><suffix>, as written by atomic_path
_TEMP_NAME = re.compile(r"^\.(?P<name>.+)\.(?P<host>[A-Za-z0-9_-]*)~(?P<pid>\d+)\.")
STALE_FOREIGN_TEMP_S = 24 * 3600.0


def is_temp_name(name: str) -> bool:
    """Whether `name` is that of an `atomic_path` temporary."""
    return _TEMP_NAME.match(name) is not None


def _writer_tag() -> str:
    """host~pid of the writing process: tells a dead writer's leftovers from a live one's."""
    host = re.sub(r"[^A-Za-z0-9_-]", "-", socket.gethostname())[:40]
    return f"{host}~{os.getpid()}"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale_temps(folder: str | Path, max_foreign_age_s: float = STALE_FOREIGN_TEMP_S) -> list[Path]:
    """Delete temporary files that `atomic_path` left behind when its process was killed.

    A temp file of this host is stale when its writer process is gone; one
    written on another host (shared storage) when it is older than
    `max_foreign_age_s`. Files of live writers are kept. Returns what was removed.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    host, removed = _writer_tag().split("~")[0], []
    now = time.time()
    for tmp in folder.rglob(".*~*"):
        match = _TEMP_NAME.match(tmp.name)
        if match is None or not tmp.is_file():
            continue
        if match["host"] == host:
            stale = not _pid_alive(int(match["pid"])) or int(match["pid"]) == os.getpid()
        else:
            try:
                stale = now - tmp.stat().st_mtime > max_foreign_age_s
            except FileNotFoundError:
                continue
        if stale:
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
    return removed


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def file_name_part(text: object) -> str:
    """A user's text (a dataset, class or label name) as part of a file name: a path separator
    or a control character in it becomes '-'. A class 'sit/stand' or '../x' would put the file
    in another folder, or outside the output folder. Join the part to other text (a prefix), so
    that a name '..' alone never becomes the whole file name."""
    return re.sub(r"[/\\\x00-\x1f\x7f]", "-", str(text))


IMAGE_SUFFIXES = (".png", ".svg", ".pdf", ".jpg", ".jpeg", ".webp", ".tif", ".tiff", ".eps", ".ps")


def check_image_path(path: str | Path, field: str = "path") -> None:
    """The file's suffix names an image format a figure is written in (no suffix: PNG)."""
    suffix = Path(path).suffix.lower()
    if suffix and suffix not in IMAGE_SUFFIXES:
        raise ConfigError(f"'{suffix}' is not an image format a figure is written in", file=path,
                          field=field, allowed=", ".join(IMAGE_SUFFIXES))


def write_figure(fig: Any, path: str | Path, **savefig: Any) -> Path:
    """Write a matplotlib figure atomically in the format its suffix names (none: PNG)."""
    path = Path(path)
    check_image_path(path)
    with atomic_path(path, suffix=path.suffix or ".png") as tmp:
        fig.savefig(tmp, format=path.suffix.lower().lstrip(".") or "png", **savefig)
    return path


def file_sha256(path: str | Path, chunk: int = 1 << 20) -> str:
    """Content hash of a file (hex), read in chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            digest.update(block)
    return digest.hexdigest()


def write_bytes(path: str | Path, data: bytes, mode: int | None = None) -> Path:
    """Write bytes atomically (`mode` as `atomic_path` takes it)."""
    with atomic_path(path, mode=mode) as tmp:
        tmp.write_bytes(data)
    return Path(path)


@contextlib.contextmanager
def atomic_text(path: str | Path) -> Iterator[TextIO]:
    """A UTF-8 text stream for writing `path` piece by piece; the file appears, whole, only when
    the block succeeds (see `atomic_path`). Newlines are written as given."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as stream:
        yield stream


def write_text(path: str | Path, text: str, mode: int | None = None) -> Path:
    """Write UTF-8 text atomically (`mode` as `atomic_path` takes it)."""
    return write_bytes(path, text.encode("utf-8"), mode)


def dumps_json(obj: Any) -> str:
    """Canonical JSON: sorted keys, two-space indent, trailing newline."""
    return json.dumps(obj, indent=2, sort_keys=True, ensure_ascii=False) + "\n"


def write_json(path: str | Path, obj: Any) -> Path:
    return write_text(path, dumps_json(obj))


def write_yaml(path: str | Path, obj: Any) -> Path:
    return write_text(path, yaml.safe_dump(obj, sort_keys=False, allow_unicode=True))


# Limits checked before a structured file is parsed: the C YAML loader overflows its stack
# near 50 000 nested brackets and json.loads raises RecursionError near 1000; the files we
# read (SMPs, dataset and library YAML, configurations) are kilobytes, nested under 10 deep.
MAX_STRUCTURED_BYTES = 16 * 2**20
MAX_NESTING = 100
# YAML aliases repeat a node without repeating its text, so a small file can stand for an
# enormous document ("billion laughs"). Aliases may add at most this many nodes: results/tables.yaml,
# the largest file we read that uses them, adds about 3300 (19 600 nodes in all).
MAX_ALIAS_NODES = 1_000_000


_SPECIAL_FILES = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"),
                  (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


def check_regular_file(path: str | Path) -> None:
    """Refuse an input that is a FIFO, socket or device: opening a FIFO no one writes to waits
    for ever, and /dev/zero never ends (its size reads 0, so no size limit stops it)."""
    try:
        mode = os.stat(path).st_mode
    except OSError:  # missing or unreadable: the caller's own open says so
        return
    kind = next((name for test, name in _SPECIAL_FILES if test(mode)), None)
    if kind is not None:
        raise InputFileError(f"expected a file, found {kind}", file=path,
                             allowed="a regular file (a pipe or a device may never end)")


def read_text(path: str | Path, max_bytes: int | None = None, newline: str | None = None) -> str:
    """A UTF-8 text file; `newline` as `open` takes it (None: any line end read as LF, "": as written)."""
    path = Path(path)
    if not path.exists():
        raise InputFileError("file not found", file=path)
    if path.is_dir():
        raise InputFileError("expected a file, found a directory", file=path)
    check_regular_file(path)
    if max_bytes is not None and path.stat().st_size > max_bytes:
        raise InputFileError(f"the file has {path.stat().st_size} bytes, more than this kind of file may have",
                             file=path, allowed=f"at most {max_bytes // 2**20} MiB")
    try:
        with path.open(encoding="utf-8", newline=newline) as file:
            return file.read()
    except UnicodeDecodeError as exc:
        raise InputFileError(f"not UTF-8 text ({exc.reason})", file=path) from exc
    except OSError as exc:
        raise InputFileError(f"cannot read the file ({exc.strerror or exc})", file=path) from exc


# libyaml's safe loader where PyYAML was built with it (the wheels are): same documents, ~10x faster
YAML_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')
_BRACKET = re.compile(r"[\[\]{}]")
_BLOCK_INDENT = re.compile(r"^[ \t?:-]*", re.MULTILINE)
_OPENS = (yaml.SequenceStartEvent, yaml.MappingStartEvent)
_CLOSES = (yaml.SequenceEndEvent, yaml.MappingEndEvent)


def nesting_depth(text: str, kind: str, stop_above: int | None = None) -> int:
    """How deeply the JSON or YAML `text` nests lists and mappings, without building them;
    the count stops once it passes `stop_above`."""
    if kind == "JSON":
        events = (1 if ch in "[{" else -1 for ch in _BRACKET.findall(_JSON_STRING.sub("", text)))
    else:  # events only: libyaml's parser is iterative
        events = (1 if isinstance(e, _OPENS) else -1 if isinstance(e, _CLOSES) else 0
                  for e in yaml.parse(text, Loader=YAML_LOADER))
    depth = deepest = 0
    for step in events:
        depth += step
        deepest = max(deepest, depth)
        if stop_above is not None and deepest > stop_above:
            break
    return deepest


def _could_nest_deeper(text: str, limit: int) -> bool:
    """A cheap upper bound first: every flow level opens a bracket; every block level moves
    the indentation (or a '- ', '? ', ': ' lead) at least one column, a mapping in a list two."""
    flow = text.count("[") + text.count("{")
    block = max((len(m) for m in _BLOCK_INDENT.findall(text)), default=0)
    return flow + 2 * block + 2 > limit


def check_nesting(text: str, kind: str, path: Path, limit: int = MAX_NESTING) -> None:
    """Refuse a document nested deeper than `limit` before a recursive parser sees it."""
    if _could_nest_deeper(text, limit) and nesting_depth(text, kind, stop_above=limit) > limit:
        raise InputFileError(f"the {kind} document nests lists or mappings more than {limit} deep",
                             file=path, allowed=f"at most {limit} levels")


class _UniqueKeyLoader(YAML_LOADER):  # type: ignore[misc, valid-type]
    """The safe loader, refusing a mapping that names one key twice (the last would win silently)."""


def _unique_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> dict:
    first: dict = {}
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue
        key = loader.construct_object(key_node, deep=True)
        line = key_node.start_mark.line + 1
        if isinstance(key, str | int | float | bool) and key in first:
            raise yaml.constructor.ConstructorError(
                None, None, f"key '{key}' appears twice (lines {first[key]} and {line})")
        if isinstance(key, str | int | float | bool):
            first[key] = line
    return loader.construct_mapping(node, deep=True)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _unique_mapping)


class DuplicateKeyError(ValueError):
    """A JSON object that names one key twice."""


def _unique_object(pairs: list[tuple[str, Any]]) -> dict:
    out: dict = {}
    for key, value in pairs:
        if key in out:
            raise DuplicateKeyError(f"key '{key}' appears twice in one object")
        out[key] = value
    return out


class AliasExpansionError(yaml.YAMLError):
    """A YAML document whose aliases expand it beyond MAX_ALIAS_NODES, or into itself."""

    def __init__(self, message: str, allowed: str | None = None) -> None:
        super().__init__(message)
        self.allowed = allowed


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return node.value
    if isinstance(node, yaml.MappingNode):
        return [item for pair in node.value for item in pair]
    return []


def _expansion(root: yaml.Node, max_depth: int) -> tuple[int, int]:
    """(nodes with every alias written out, distinct nodes) of the composed document `root`.

    Aliases share node objects, so each distinct node is measured once. The walk refuses a
    document that aliases nest deeper than `max_depth` (an alias inside the node it names
    nests without end), which also bounds its recursion; a size stops growing at 2**62.
    """
    measured: dict[int, tuple[int, int]] = {}  # id -> (expanded size, nesting height)
    too_deep = AliasExpansionError(f"its aliases nest the document more than {max_depth} deep",
                                   allowed=f"at most {max_depth} levels")

    def measure(node: yaml.Node, depth: int) -> tuple[int, int]:
        known = measured.get(id(node))
        if known is not None:  # an alias (a node measured before) may sit deeper here
            if depth + known[1] > max_depth:
                raise too_deep
            return known
        if isinstance(node, yaml.ScalarNode):
            known = (1, 0)
        elif depth >= max_depth:
            raise too_deep
        else:
            size, height = 1, 0
            for child in _children(node):
                child_size, child_height = measure(child, depth + 1)
                size += child_size
                if child_height > height:
                    height = child_height
            known = (min(size, 2**62), height + 1)
        measured[id(node)] = known
        return known

    return measure(root, 0)[0], len(measured)


def check_aliases(root: yaml.Node, limit: int = MAX_ALIAS_NODES, max_depth: int = MAX_NESTING) -> None:
    """Refuse a composed YAML document whose aliases add more than `limit` nodes to it or
    nest it deeper than `max_depth`."""
    expanded, written = _expansion(root, max_depth)
    if expanded - written > limit:
        raise AliasExpansionError(f"its aliases expand the document by more than {limit:,} nodes",
                                  allowed=f"aliases that add at most {limit:,} nodes")


def load_yaml(text: str, loader: type = YAML_LOADER, limit: int = MAX_ALIAS_NODES) -> Any:
    """yaml.load with an alias budget: the node graph is checked before any object is built."""
    parser = loader(text)
    try:
        root = parser.get_single_node()
        if root is None:
            return None
        if "*" in text:  # an alias is written with '*'; without one nothing can expand
            check_aliases(root, limit)
        return parser.construct_document(root)
    finally:
        parser.dispose()


def _unconvertible(exc: ValueError, kind: str, path: Path) -> InputFileError:
    digits = sys.get_int_max_str_digits()
    if "integer string conversion" in str(exc):
        return InputFileError(f"not valid {kind}: an integer has more than {digits} digits", file=path,
                              allowed=f"integers of at most {digits} digits")
    return InputFileError(f"not valid {kind}: {exc}", file=path)


def read_structured(path: str | Path) -> Any:
    """Read a JSON or YAML file (chosen by extension; JSON is valid YAML too), refusing files
    larger than MAX_STRUCTURED_BYTES or nested deeper than MAX_NESTING before parsing, YAML
    whose aliases add more than MAX_ALIAS_NODES nodes, and a mapping that names one key twice."""
    path = Path(path)
    text = read_text(path, MAX_STRUCTURED_BYTES)
    kind = "JSON" if path.suffix.lower() == ".json" else "YAML"
    try:
        check_nesting(text, kind, path)
        if kind == "JSON":
            return json.loads(text, object_pairs_hook=_unique_object)
        return load_yaml(text, _UniqueKeyLoader)
    except AliasExpansionError as exc:
        raise InputFileError(f"not valid YAML: {exc}", file=path, allowed=exc.allowed) from exc
    except (json.JSONDecodeError, DuplicateKeyError, yaml.YAMLError) as exc:
        raise InputFileError(f"not valid {kind}: {exc}", file=path) from exc
    except ValueError as exc:  # a value the parser cannot convert, e.g. an integer too long for int()
        raise _unconvertible(exc, kind, path) from exc
    except RecursionError as exc:  # pragma: no cover - check_nesting stops this first
        raise InputFileError(f"the {kind} document nests too deeply", file=path) from exc


def write_structured(path: str | Path, obj: Any) -> Path:
    """Write JSON or YAML by extension (.json, .yaml, .yml)."""
    path = Path(path)
    if path.suffix.lower() in (".yaml", ".yml"):
        return write_yaml(path, obj)
    return write_json(path, obj)
