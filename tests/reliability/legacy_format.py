"""Write small pickles in the exact format of HAPT's pandas-1.0 file (protocol 2).

The shipped `HAPT.pkl.gz` is 100 MB unpacked, too large to mutate thousands of
times. `legacy_pickle_bytes` writes the same opcode structure for a few small
frames: `copy_reg._reconstructor` over `__builtin__.object` for the DataFrame
and its BlockManager (state tuple whose item 3 holds the "0.14.1" axes and
blocks), `pandas.core.indexes.base._new_Index` for the column Index (object
array of names) and the RangeIndex, numpy arrays by
`numpy.core.multiarray._reconstruct` with `_codecs.encode` latin-1 payloads.
Only the names of the classes are written, never pandas objects themselves.
"""

from __future__ import annotations

import copyreg
import io
import pickle
from dataclasses import dataclass

import numpy as np

COLUMNS = ("acc-x", "acc-y", "acc-z", "gyro-x", "gyro-y", "gyro-z", "sequence", "label")


class _Global:
    """A name written as a pickle GLOBAL (module, name); never imported here."""

    def __init__(self, module: str, name: str) -> None:
        self.module, self.name = module, name

    def __call__(self, *args):  # pragma: no cover - only its name is pickled
        raise TypeError("a placeholder")


DATAFRAME = _Global("pandas.core.frame", "DataFrame")
BLOCK_MANAGER = _Global("pandas.core.internals.managers", "BlockManager")
NEW_INDEX = _Global("pandas.core.indexes.base", "_new_Index")
INDEX = _Global("pandas.core.indexes.base", "Index")
RANGE_INDEX = _Global("pandas.core.indexes.range", "RangeIndex")
# numpy 1.x's name for it; numpy 2 pickles arrays under numpy._core, which the file never has
RECONSTRUCT = _Global("numpy.core.multiarray", "_reconstruct")


@dataclass
class _Frame:
    columns: tuple[str, ...]
    values: np.ndarray  # (n_columns, n_rows) float64, one block


@dataclass
class _Manager:
    frame: _Frame


@dataclass
class _ColumnIndex:
    names: tuple[str, ...]


@dataclass
class _Range:
    stop: int


class _LegacyPickler(pickle._Pickler):
    """Reduces the stand-ins above the way pandas 1.0 reduced its objects."""

    def save_global(self, obj, name=None):
        if isinstance(obj, _Global):
            self.write(pickle.GLOBAL + f"{obj.module}\n{obj.name}\n".encode("ascii"))
            self.memoize(obj)
            return
        super().save_global(obj, name)

    def save(self, obj, save_persistent_id=True):
        if isinstance(obj, _Global):
            memo = self.memo.get(id(obj))
            if memo is not None:
                self.write(self.get(memo[0]))
                return
            self.save_global(obj)
            return
        super().save(obj, save_persistent_id)

    def reducer_override(self, obj):
        if isinstance(obj, np.ndarray):
            _, args, state = obj.__reduce__()
            return RECONSTRUCT, args, state
        if isinstance(obj, _Frame):
            return copyreg._reconstructor, (DATAFRAME, object, None), {"_data": _Manager(obj)}
        if isinstance(obj, _Manager):
            n_cols, n_rows = obj.frame.values.shape
            extra = {"0.14.1": {
                "axes": [_ColumnIndex(obj.frame.columns), _Range(n_rows)],
                "blocks": [{"values": obj.frame.values, "mgr_locs": slice(0, n_cols, 1)}],
            }}
            state = ([_ColumnIndex(obj.frame.columns), _Range(n_rows)], [obj.frame.values], [], extra)
            return copyreg._reconstructor, (BLOCK_MANAGER, object, None), state
        if isinstance(obj, _ColumnIndex):
            return NEW_INDEX, (INDEX,
                                           {"data": np.array(obj.names, dtype=object), "name": None})
        if isinstance(obj, _Range):
            return NEW_INDEX, (RANGE_INDEX,
                                           {"start": 0, "stop": obj.stop, "step": 1, "name": None})
        return NotImplemented


def legacy_pickle_bytes(recordings: dict[int, list[np.ndarray]]) -> bytes:
    """subject -> list of (T, 8) arrays in COLUMNS order -> pickle bytes (HAPT's format)."""
    payload = {s: [_Frame(COLUMNS, np.ascontiguousarray(np.asarray(r, dtype=np.float64).T)) for r in recs]
               for s, recs in recordings.items()}
    buf = io.BytesIO()
    _LegacyPickler(buf, protocol=2).dump(payload)
    return buf.getvalue()


def small_recordings(seed: int = 0, subjects: tuple[int, ...] = (1, 2), n: int = 300) -> dict[int, list]:
    """A few 50 Hz recordings: acc in g (x reads ~1 g), gyro rad/s, labels 1..6."""
    rng = np.random.default_rng(seed)
    out = {}
    for s in subjects:
        data = rng.normal(0, 0.05, (n, 8))
        data[:, 0] += 1.0
        data[:, 6] = np.arange(n)
        data[:, 7] = np.repeat([1, 4, 5], n // 3 + 1)[:n]
        out[s] = [data]
    return out
