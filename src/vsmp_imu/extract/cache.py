"""A response cache on disk: one JSON file per request, named by the hash of its key.

The key is a dict of everything that defines a request's answer (clip hash,
frame-sampling settings, prompt hash, model, query index, ...), never the
API key. Entries are written atomically, so a killed run leaves only whole
entries behind and a re-run resumes where it stopped.
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path
from typing import Any

from vsmp_imu.io import write_json

CACHE_FORMAT = "vsmp-imu/vlm-cache/1"
log = logging.getLogger(__name__)


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

    def lookup(self, fields: dict[str, Any]) -> tuple[dict[str, Any] | None, str | None]:
        """(record, None) on a hit; (None, why) for an entry that cannot be used (it is
        overwritten on the next put); (None, None) when there is none."""
        path = self._path(cache_key(fields))
        if path is None or not path.exists():
            return None, None
        record, problem = _load(path)
        if problem is None and (not isinstance(record, dict) or record.get("format") != CACHE_FORMAT):
            problem = "not a cache entry of this format"
        elif problem is None and record.get("key") != fields:
            problem = "the entry holds another request's key"
        return (record, None) if problem is None else (None, f"{path}: {problem}")

    def get(self, fields: dict[str, Any]) -> dict[str, Any] | None:
        """The stored record for these key fields, or None (missing or unusable)."""
        return self.lookup(fields)[0]

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
        if not path.exists():
            return {}
        data, problem = _load(path)
        if problem is None and not isinstance(data, dict):
            problem = "not a JSON object"
        if problem is not None:
            log.warning("ignored %s: %s (it is rewritten when needed)", path, problem)
            return {}
        return data

    def write_json(self, name: str, data: dict[str, Any]) -> None:
        if self.root is not None:
            write_json(Path(self.root) / name, data)


def _load(path: Path) -> tuple[Any, str | None]:
    """The JSON in `path`, or (None, why it cannot be read)."""
    try:
        return json.loads(path.read_text(encoding="utf-8")), None
    except OSError as exc:
        return None, f"unreadable ({exc.strerror or exc})"
    except UnicodeDecodeError:
        return None, "not UTF-8 text"
    except (ValueError, RecursionError):
        return None, "not JSON (or nested too deeply)"
