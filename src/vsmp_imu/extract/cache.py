"""A response cache on disk: one JSON file per request, named by the hash of its key.

The key is a dict of everything that defines a request's answer (clip hash,
frame-sampling settings, prompt hash, model, query index, ...), never the
API key. Entries are written atomically, so a killed run leaves only whole
entries behind and a re-run resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

from vsmp_imu.io import write_json

CACHE_FORMAT = "vsmp-imu/vlm-cache/1"


def cache_key(fields: dict[str, Any]) -> str:
    """sha256 of the canonical JSON of `fields`."""
    text = json.dumps(fields, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class ResponseCache:
    """Files `<root>/<key[:2]>/<key>.json`; `root=None` disables caching."""

    def __init__(self, root: str | Path | None) -> None:
        self.root = root

    def _path(self, key: str) -> Path | None:
        return None if self.root is None else Path(self.root) / key[:2] / f"{key}.json"

    def get(self, fields: dict[str, Any]) -> dict[str, Any] | None:
        """The stored record for these key fields, or None (missing or unreadable)."""
        path = self._path(cache_key(fields))
        if path is None or not path.exists():
            return None
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return None  # a damaged entry is a miss; it is overwritten on the next put
        if not isinstance(record, dict) or record.get("format") != CACHE_FORMAT:
            return None
        if record.get("key") != fields:
            return None
        return record

    def put(self, fields: dict[str, Any], record: dict[str, Any]) -> None:
        path = self._path(cache_key(fields))
        if path is None:
            return
        write_json(path, {"format": CACHE_FORMAT, "key": fields, **record})

    def read_json(self, name: str) -> dict[str, Any]:
        """A side file of the cache folder (e.g. endpoint capabilities); {} when absent."""
        if self.root is None:
            return {}
        path = Path(self.root) / name
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return {}
        return data if isinstance(data, dict) else {}

    def write_json(self, name: str, data: dict[str, Any]) -> None:
        if self.root is not None:
            write_json(Path(self.root) / name, data)
