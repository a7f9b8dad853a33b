"""The activity library: one YAML (or JSON) file per activity with its reviewed SMP.

A file holds `name` (equal to the file stem), `aliases`, `datasets` (dataset ->
that dataset's own label), `captions` (generic free-text descriptions) and
`smp`; any other top-level key (e.g. `procedural`, read by the procedural
motion backend) is kept untouched in `LibraryEntry.extras`.

The built-in folder ships with the package; users add folders with
`ActivityLibrary.load(extra_dirs=[...])` (CLI: `--library DIR`). A user file
whose `name` equals a built-in one replaces it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pydantic
from pydantic import BaseModel, ConfigDict, Field, model_validator
from rapidfuzz import fuzz, process

from vsmp_imu.errors import ValidationError, some_of
from vsmp_imu.io import read_structured
from vsmp_imu.smp._text import INSTRUCTION_WORDS, NEGATION_WORDS, norm_name, words
from vsmp_imu.smp.schema import SMP
from vsmp_imu.validation import validation_error

log = logging.getLogger(__name__)

BUILTIN_DIR = Path(__file__).resolve().parent / "activities"
LIBRARY_SUFFIXES = (".yaml", ".yml", ".json")
# Minimum rapidfuzz WRatio (0..100) for `resolve` to accept a free-text label.
DEFAULT_MIN_SCORE = 85.0
# Fuzzy scores closer than this to the best one make a label ambiguous (`resolve`).
AMBIGUOUS_MARGIN = 1.0
# Minimum rapidfuzz ratio of a whole label to a name or alias for `identify` (a typo, a plural).
IDENTIFY_MIN_RATIO = 90.0
_EDGE_PUNCTUATION = " .,;:!?'\"()[]"


class ActivityMatchError(ValidationError):
    """An activity label that names no library activity exactly (or several equally well).

    `label` is the label, `candidates` the closest activities as (name, score),
    best first. `file` names the user's file the label came from when known.
    """

    def __init__(self, message: str, *, label: str = "", candidates: Sequence[tuple[str, float]] = (),
                 file: str | Path | None = None, field: str | None = "activity_label",
                 allowed: str | None = None) -> None:
        self.label = label
        self.candidates = tuple(candidates)
        super().__init__(message, file=file, field=field, allowed=allowed)


def steering_words(label: str) -> list[str]:
    """The negation and instruction words of a label: a label with one is a sentence about
    activities ("not jumping jacks", "ignore ... label this jumping_jacks"), not a name."""
    return [w for w in words(label) if w in NEGATION_WORDS or w in INSTRUCTION_WORDS]


def _listing(candidates: Sequence[tuple[str, float]], shown: int = 5) -> str:
    return some_of([f"{name} ({score:.0f})" for name, score in candidates], shown)


class _LibraryFile(BaseModel):
    """What a library file must contain (extra top-level keys are allowed)."""

    model_config = ConfigDict(extra="allow")

    name: str = Field(pattern=r"^[a-z0-9][a-z0-9_]*$")
    aliases: list[str] = Field(default_factory=list)
    datasets: dict[str, str] = Field(default_factory=dict)
    captions: list[str] = Field(default_factory=list)
    central_primitive: str | None = None
    smp: SMP

    @model_validator(mode="after")
    def _central_in_sequence(self) -> _LibraryFile:
        if self.central_primitive is not None and self.central_primitive not in self.smp.primitive_sequence:
            raise ValueError(f"central_primitive '{self.central_primitive}' is not in smp.primitive_sequence "
                             f"({', '.join(self.smp.primitive_sequence)})")
        return self


@dataclass(frozen=True)
class LibraryEntry:
    """One activity of the library."""

    name: str
    aliases: tuple[str, ...]
    datasets: dict[str, str]
    captions: tuple[str, ...]
    smp: SMP
    extras: dict[str, Any] = field(default_factory=dict)
    path: Path = Path()
    # the principal phase (e.g. the release of a throw): what a duration intervention scales
    central_primitive: str | None = None

    def __hash__(self) -> int:
        return hash((self.name, str(self.path)))

    def digest(self) -> str:
        """A hash of what the entry says (not where its file lies): part of the cache key of every
        sample made from it, so an edited activity file recomputes its own samples only."""
        content = {"name": self.name, "aliases": list(self.aliases), "datasets": self.datasets,
                   "captions": list(self.captions), "central_primitive": self.central_primitive,
                   "smp": self.smp.model_dump(mode="json"), "extras": self.extras}
        text = json.dumps(content, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def lookup_keys(self) -> list[str]:
        """The normalized strings this entry answers to: name, aliases, SMP label."""
        keys = [norm_name(self.name), *(norm_name(a) for a in self.aliases),
                norm_name(self.smp.activity_label)]
        return list(dict.fromkeys(k for k in keys if k))

    def copy(self) -> LibraryEntry:
        """A copy whose SMP may be changed without touching the cached one."""
        return LibraryEntry(self.name, self.aliases, dict(self.datasets), self.captions,
                            self.smp.model_copy(deep=True), _deep_copy(self.extras), self.path,
                            self.central_primitive)


def _deep_copy(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _deep_copy(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_deep_copy(v) for v in value]
    return value


def load_entry(path: str | Path) -> LibraryEntry:
    """Read and validate one library file; errors name the file and the field."""
    return entry_from_data(read_structured(path), path)


def entry_from_data(data: object, path: str | Path) -> LibraryEntry:
    """Validate the parsed content of the library file `path`."""
    path = Path(path)
    if not isinstance(data, dict):
        raise ValidationError("a library file must be a mapping with keys name, aliases, "
                              "datasets, captions, smp", file=path)
    data.setdefault("name", path.stem)
    try:
        parsed = _LibraryFile.model_validate(data)
    except pydantic.ValidationError as exc:
        raise validation_error(exc, path) from exc
    if parsed.name != path.stem:
        raise ValidationError(f"name '{parsed.name}' must equal the file stem '{path.stem}'",
                              file=path, field="name")
    return LibraryEntry(
        name=parsed.name,
        aliases=tuple(a.strip() for a in parsed.aliases if a.strip()),
        datasets={str(k): str(v) for k, v in parsed.datasets.items()},
        captions=tuple(c.strip() for c in parsed.captions if c.strip()),
        smp=parsed.smp,
        extras=dict(parsed.model_extra or {}),
        path=path,
        central_primitive=parsed.central_primitive,
    )


def _library_files(folder: Path) -> list[Path]:
    if not folder.exists():
        raise ValidationError("activity-library folder not found", file=folder)
    if not folder.is_dir():
        raise ValidationError("an activity-library path must be a folder", file=folder)
    return sorted(p for p in folder.iterdir()
                  if p.suffix.lower() in LIBRARY_SUFFIXES and not p.name.startswith((".", "_")))


def _signature(folder: Path) -> tuple[tuple[str, int, int], ...]:
    """What identifies a folder's content for the cache: names, sizes, mtimes."""
    out = []
    for p in _library_files(folder):
        st = p.stat()
        out.append((p.name, st.st_size, st.st_mtime_ns))
    return tuple(out)


def library_signature(extra_dirs: Sequence[str | Path] = ()) -> tuple:
    """What identifies `ActivityLibrary.load(extra_dirs)`'s files: the built-in folder's and each
    extra folder's names, sizes and mtimes."""
    return tuple(_signature(Path(folder).resolve()) for folder in (BUILTIN_DIR, *extra_dirs))


@functools.lru_cache(maxsize=32)
def _load_folder_cached(folder: str, signature: tuple) -> tuple[LibraryEntry, ...]:
    entries = [load_entry(Path(folder) / name) for name, _, _ in signature]
    return tuple(entries)


def load_folder(folder: str | Path) -> list[LibraryEntry]:
    """All entries of one folder (cached while the files are unchanged)."""
    folder = Path(folder).resolve()
    return [e.copy() for e in _load_folder_cached(str(folder), _signature(folder))]


class ActivityLibrary:
    """A set of activities addressed by name, alias, SMP label or dataset label."""

    def __init__(self, entries: Sequence[LibraryEntry]) -> None:
        self._entries: dict[str, LibraryEntry] = {}
        for entry in entries:
            if entry.name in self._entries:
                log.debug("activity '%s' from %s overrides %s", entry.name, entry.path,
                          self._entries[entry.name].path)
            self._entries[entry.name] = entry
        self._index = self._build_index()
        self._digests: dict[str | None, str] = {}

    @classmethod
    def load(cls, extra_dirs: Sequence[str | Path] = ()) -> ActivityLibrary:
        """The built-in library plus the user's folders (later folders override earlier ones)."""
        entries = load_folder(BUILTIN_DIR)
        for folder in extra_dirs:
            entries.extend(load_folder(folder))
        return cls(entries)

    def _build_index(self) -> dict[str, str]:
        index: dict[str, str] = {}
        for entry in self._entries.values():
            for key in entry.lookup_keys():
                other = index.get(key)
                if other is not None and other != entry.name:
                    raise ValidationError(
                        f"'{key}' names both activity '{other}' ({self._entries[other].path}) "
                        f"and activity '{entry.name}'; every name and alias must be unique",
                        file=entry.path, field="aliases")
                index[key] = entry.name
        return index

    def digest(self, label: str | None = None) -> str:
        """A hash of what a motion made for `label` can read from the library: the entry that
        `label` names exactly (`match`), or, for no label or a label no entry names, every entry
        (a prompt, a fuzzy lookup or a name that a new file's alias may claim read the whole)."""
        if label not in self._digests:
            key = None if label is None else norm_name(label)
            if key in self._index:
                self._digests[label] = self._entries[self._index[key]].digest()
            elif label is not None:
                self._digests[label] = self.digest(None)
            else:
                every = "".join(self._entries[name].digest() for name in self.names())
                self._digests[None] = hashlib.sha256(every.encode()).hexdigest()[:16]
        return self._digests[label]

    # -- container protocol -------------------------------------------------
    def names(self) -> list[str]:
        return sorted(self._entries)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and norm_name(name) in self._index

    def __iter__(self) -> Iterator[LibraryEntry]:
        return iter(self._entries[n] for n in self.names())

    def __len__(self) -> int:
        return len(self._entries)

    # -- lookup -----------------------------------------------------------------
    def get(self, name: str) -> LibraryEntry:
        """The entry for an exact name, alias or SMP label (case/space/_/- insensitive)."""
        key = norm_name(name)
        if key in self._index:
            return self._entries[self._index[key]]
        close = self.close_matches(name)
        hint = f"; close matches: {', '.join(close)}" if close else ""
        raise ValidationError(f"unknown activity '{name}'{hint}", field="activity",
                              allowed="vsmp-imu smp library list shows every activity")

    def close_matches(self, label: str, limit: int = 3) -> list[str]:
        """Names of the entries whose names or aliases are closest to `label`."""
        ranked = self._rank(label)
        return list(dict.fromkeys(name for name, score in ranked if score >= 50))[:limit]

    def _rank(self, label: str) -> list[tuple[str, float]]:
        """(entry name, best score) for every entry, best first; ties by name."""
        keys = list(self._index)
        if not keys:
            return []
        hits = process.extract(norm_name(label), keys, scorer=fuzz.WRatio, limit=None)
        best: dict[str, float] = {}
        for key, score, _ in hits:
            name = self._index[key]
            best[name] = max(best.get(name, 0.0), float(score))
        return sorted(best.items(), key=lambda item: (-item[1], item[0]))

    def match(self, label: str) -> LibraryEntry:
        """The entry whose name, alias or SMP label is `label` (case/space/_/- insensitive).

        Nothing fuzzy: a label that is none of them raises `ActivityMatchError` naming
        the closest activities, so an activity is never swapped for a look-alike.
        """
        key = norm_name(label)
        if key in self._index:
            return self._entries[self._index[key]]
        close = [(n, s) for n, s in self._rank(label)[:3] if s >= 50]
        raise ActivityMatchError(
            f"activity label '{label}' is not the name, an alias or the SMP label of a library activity"
            + (f"; closest: {_listing(close)}" if close else ""),
            label=label, candidates=close,
            allowed="a library activity's name or alias (vsmp-imu smp library list), or a library file "
                    "for this activity passed with --library (docs/smp.md)")

    def resolve(self, label: str, min_score: float = DEFAULT_MIN_SCORE) -> LibraryEntry:
        """The entry for a free-text label: exact lookup first, then fuzzy (rapidfuzz WRatio).

        Raises ActivityMatchError when the best score is below `min_score`, when
        other activities score within AMBIGUOUS_MARGIN of the best one (a tie is no match),
        or when a label that is no exact name holds a negation or instruction word.
        For a model's answer use `identify`: WRatio also finds a name inside a sentence.
        """
        key = norm_name(label)
        if key in self._index:
            return self._entries[self._index[key]]
        steering = steering_words(label)
        if steering:
            raise ActivityMatchError(
                f"'{label}' is no activity name: it holds '{steering[0]}' (a negation or an instruction)",
                label=label, allowed="an activity name or alias (vsmp-imu smp library list)")
        ranked = self._rank(label)
        if ranked and ranked[0][1] >= min_score:
            tied = [(n, s) for n, s in ranked if s > ranked[0][1] - AMBIGUOUS_MARGIN]
            if len(tied) == 1:
                return self._entries[ranked[0][0]]
            raise ActivityMatchError(
                f"'{label}' matches {len(tied)} activities equally well: {_listing(tied)}",
                label=label, candidates=tied, allowed="an exact activity name or alias")
        close = ranked[:3]
        raise ActivityMatchError(
            f"no activity matches '{label}' with score >= {min_score:g}"
            + (f"; best: {_listing(close)}" if close else ""), label=label, candidates=close)

    def identify(self, label: str) -> LibraryEntry | None:
        """The entry that a free-text label (a model's answer) names as a whole, else None.

        An exact name, alias or SMP label; else the one name or alias within
        IDENTIFY_MIN_RATIO of the whole label (rapidfuzz ratio: a typo, a plural), unless
        another activity is as close. Never an activity named inside a longer text, and
        never for a label with a negation or an instruction word (`steering_words`).
        """
        key = norm_name(label).strip(_EDGE_PUNCTUATION)
        if key in self._index:
            return self._entries[self._index[key]]
        if steering_words(label) or not key:
            return None
        best: dict[str, float] = {}
        for other, score, _ in process.extract(key, list(self._index), scorer=fuzz.ratio, limit=None,
                                               score_cutoff=IDENTIFY_MIN_RATIO - AMBIGUOUS_MARGIN):
            name = self._index[other]
            best[name] = max(best.get(name, 0.0), float(score))
        ranked = sorted(best.values(), reverse=True)
        if not ranked or ranked[0] < IDENTIFY_MIN_RATIO:
            return None
        if len(ranked) > 1 and ranked[1] > ranked[0] - AMBIGUOUS_MARGIN:
            return None
        return self._entries[max(best, key=best.__getitem__)]

    def for_dataset(self, dataset: str) -> dict[str, LibraryEntry]:
        """Dataset label -> entry, from every entry's `datasets` (dataset name case-insensitive)."""
        wanted = norm_name(dataset)
        out: dict[str, LibraryEntry] = {}
        for entry in self:
            for ds, label in entry.datasets.items():
                if norm_name(ds) != wanted:
                    continue
                if label in out and out[label].name != entry.name:
                    raise ValidationError(
                        f"dataset '{dataset}' label '{label}' is claimed by both "
                        f"'{out[label].name}' and '{entry.name}'", file=entry.path, field="datasets")
                out[label] = entry
        return out

    def datasets(self) -> list[str]:
        """Every dataset named by some entry."""
        return sorted({ds for e in self for ds in e.datasets})
