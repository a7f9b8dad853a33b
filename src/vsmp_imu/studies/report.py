"""Shared output helpers of the studies: report files, figures, tables and a result cache.

Every study writes `report.md` (for people) and `results.json` (for
programs) into its output folder, both atomically, and its figures next to
them. Numbers go through `fmt_*` so that a missing value prints as `n/a`
and JSON never holds NaN.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.io import atomic_path, dumps_json, write_figure, write_json, write_text

NA = "n/a"


def to_jsonable(obj: Any) -> Any:
    """Plain JSON types: numpy scalars and arrays to numbers and lists, NaN and inf to None."""
    if is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable(asdict(obj))
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (list, tuple, set)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        value = float(obj)
        return value if math.isfinite(value) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def write_report(out_dir: str | Path, markdown: str, results: Mapping[str, Any]) -> tuple[Path, Path]:
    """Write `report.md` and `results.json` into `out_dir` (atomically); returns both paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    md = write_text(out / "report.md", markdown.rstrip() + "\n")
    js = write_json(out / "results.json", to_jsonable(results))
    return md, js


def save_figure(fig: Any, path: str | Path, dpi: int = 200) -> Path:
    """Save a matplotlib figure atomically (format from the suffix) and close it."""
    import matplotlib.pyplot as plt

    try:
        return write_figure(fig, path, dpi=dpi, bbox_inches="tight")
    finally:
        plt.close(fig)


def _missing(value: Any) -> bool:
    return value is None or (isinstance(value, (float, np.floating)) and not math.isfinite(value))


def fmt_num(value: Any, digits: int = 2) -> str:
    """A number with `digits` decimals; `n/a` when missing."""
    return NA if _missing(value) else f"{float(value):.{digits}f}"


def fmt_pct(value: Any, digits: int = 1) -> str:
    """A fraction as a percentage (0.917 -> 91.7%); `n/a` when missing."""
    return NA if _missing(value) else f"{100.0 * float(value):.{digits}f}%"


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[Any]],
                   align: Sequence[str] | None = None) -> str:
    """A GitHub-markdown table; `align` holds 'l', 'r' or 'c' per column (default: first l, rest r)."""
    n = len(headers)
    align = list(align) if align is not None else ["l"] + ["r"] * (n - 1)
    marks = {"l": ":---", "r": "---:", "c": ":---:"}
    lines = ["| " + " | ".join(str(h) for h in headers) + " |",
             "| " + " | ".join(marks[a] for a in align) + " |"]
    for row in rows:
        cells = [NA if _missing(c) else str(c) for c in row]
        if len(cells) != n:
            raise ValueError(f"row has {len(cells)} cells, table has {n} columns")
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return "\n".join(lines)


def describer_lines(settings: Mapping[str, Any]) -> list[str]:
    """The report's line on the endpoint that wrote the IMUGPT descriptions (none without one;
    the URL is in results.json)."""
    own = (settings.get("method_options") or {}).get("imugpt") or {}
    if not own.get("describer_url"):
        return []
    model = f"model `{own['describer_model']}`" if own.get("describer_model") else "the only model"
    return [f"- **IMUGPT 2.0 descriptions** written by {model} of the describer endpoint (`--describer-url`), "
            "not templated from the library captions."]


def cache_key(**parts: Any) -> str:
    """A stable hex key for a unit of cached work (sha256 of its canonical JSON)."""
    text = json.dumps(to_jsonable(parts), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:24]


class ResultCache:
    """A folder of cached results: one `.npz` of arrays plus JSON metadata per key.

    `get(key)` returns (arrays, meta) or None; `put(key, arrays, meta)` writes
    atomically, so a killed run leaves only complete entries.
    """

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)

    def _path(self, key: str) -> Path:
        return self.folder / f"{key}.npz"

    def get(self, key: str) -> tuple[dict[str, np.ndarray], dict[str, Any]] | None:
        path = self._path(key)
        if not path.exists():
            return None
        try:
            with np.load(path, allow_pickle=False) as data:
                arrays = {k: data[k] for k in data.files if k != "__meta__"}
                meta = json.loads(str(data["__meta__"])) if "__meta__" in data.files else {}
        except (OSError, ValueError, json.JSONDecodeError):
            return None  # a damaged entry is recomputed
        return arrays, meta

    def put(self, key: str, arrays: Mapping[str, np.ndarray], meta: Mapping[str, Any]) -> Path:
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self._path(key)
        payload = {k: np.asarray(v) for k, v in arrays.items()}
        payload["__meta__"] = np.asarray(dumps_json(to_jsonable(meta)))
        with atomic_path(path, suffix=".npz") as tmp, open(tmp, "wb") as fh:
            np.savez(fh, **payload)
        return path
