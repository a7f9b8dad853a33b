"""Where the base SMPs S of each target class come from.

- `library`: the activity library's reviewed SMP of each class (by the
  dataset labels the library files declare);
- `smp:DIR`: the user's SMP files (JSON/YAML), matched to classes by their
  activity label (dataset label, library name or alias);
- `video:DIR`: SMPs extracted from clips (see `vsmp_imu.extract`), one folder
  per class.

A source returns, per dataset class name, a list of (source id, SMP).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from vsmp_imu.errors import ConfigError, ValidationError, VsmpError
from vsmp_imu.smp import SMP, load_smp
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry

SOURCE_KINDS = ("library", "smp", "video")


def library_key(dataset: str, library: ActivityLibrary) -> str:
    """The dataset key the library uses ('hapt12' shares the 'hapt' labels)."""
    known = set(library.datasets())
    if dataset in known:
        return dataset
    stripped = dataset.rstrip("0123456789")
    if stripped in known:
        return stripped
    raise ConfigError(f"the activity library declares no labels for dataset '{dataset}'",
                      field="dataset", allowed=", ".join(sorted(known)))


def entries_for(dataset: str, label_names: Sequence[str], library: ActivityLibrary) -> dict[str, LibraryEntry]:
    """Library entry of each dataset class: the label a library file declares for this dataset
    (`datasets:`), else the activity whose name, alias or SMP label the class carries
    (case-insensitive). Classes neither links are left out."""
    try:
        declared = library.for_dataset(library_key(dataset, library))
    except ConfigError:  # a dataset no library file names: its labels link by activity name
        declared = {}
    by_label = {norm_name(k): e for k, e in declared.items()}
    out = {}
    for name in label_names:
        if norm_name(name) in by_label:
            out[name] = by_label[norm_name(name)]
        elif name in library:
            out[name] = library.get(name)
    return out


LINK_HINT = ("name the class after a library activity or alias (vsmp-imu smp library list), declare "
             "`datasets: {{{dataset}: <class>}}` in a library file passed with --library DIR, or give your own "
             "SMP files with --source smp:DIR (see docs/tutorial.md)")


class LibrarySmpSource:
    """One reviewed library SMP per class."""

    name = "library"

    def __init__(self, library: ActivityLibrary) -> None:
        self.library = library

    def smps(self, dataset: str, label_names: Sequence[str]) -> dict[str, list[tuple[str, SMP]]]:
        found = entries_for(dataset, label_names, self.library)
        missing = [n for n in label_names if n not in found]
        if missing:
            raise ConfigError(
                f"no library activity for class(es) {', '.join(missing)} of dataset '{dataset}'",
                field="source", allowed=LINK_HINT.format(dataset=dataset))
        return {name: [(f"library:{entry.name}", entry.smp)] for name, entry in found.items()}


class SmpDirSource:
    """The user's SMP files, assigned to classes by activity label."""

    name = "smp"

    def __init__(self, folder: Path, library: ActivityLibrary) -> None:
        self.folder = Path(folder)
        self.library = library

    def _class_of(self, smp: SMP, dataset: str, label_names: Sequence[str]) -> str | None:
        wanted = {norm_name(n): n for n in label_names}
        label = norm_name(smp.activity_label)
        if label in wanted:
            return wanted[label]
        try:
            entry = self.library.resolve(smp.activity_label)
        except VsmpError:
            return None
        try:
            declared = entry.datasets.get(library_key(dataset, self.library))
        except ConfigError:  # a dataset no library file names
            declared = None
        if declared is None and norm_name(entry.name) in wanted:
            return wanted[norm_name(entry.name)]
        return wanted.get(norm_name(declared)) if declared else None

    def smps(self, dataset: str, label_names: Sequence[str]) -> dict[str, list[tuple[str, SMP]]]:
        if not self.folder.is_dir():
            raise ConfigError("SMP source folder not found", file=self.folder, field="source")
        files = sorted(p for p in self.folder.rglob("*") if p.suffix.lower() in (".json", ".yaml", ".yml"))
        out: dict[str, list[tuple[str, SMP]]] = {}
        unmatched = []
        for path in files:
            smp = load_smp(path)
            cls = self._class_of(smp, dataset, label_names)
            if cls is None:
                unmatched.append(f"{path.name} ('{smp.activity_label}')")
                continue
            out.setdefault(cls, []).append((str(path.relative_to(self.folder)), smp))
        if not out:
            raise ValidationError(
                "no SMP file matches a class of the dataset"
                + (f" (unmatched: {', '.join(unmatched[:5])})" if unmatched else ""),
                file=self.folder, allowed=", ".join(label_names))
        return out


def parse_source(text: str) -> tuple[str, Path | None]:
    """'library' | 'smp:DIR' | 'video:DIR' -> (kind, folder)."""
    kind, _, rest = text.partition(":")
    kind = kind.strip().lower()
    if kind not in SOURCE_KINDS:
        raise ConfigError(f"unknown source '{text}'", field="source", allowed="library, smp:DIR, video:DIR")
    if kind == "library":
        return kind, None
    if not rest:
        raise ConfigError(f"source '{kind}' needs a folder: {kind}:DIR", field="source")
    return kind, Path(rest)


def check_source(text: str, field: str = "source") -> None:
    """Refuse, before any work, a source `make_smp_source` would not take: an unknown kind, a
    kind without its folder, a folder that is not there (`field`: the option that named it)."""
    try:
        kind, folder = parse_source(text)
    except ConfigError as exc:
        raise exc.in_field(field) from None
    if folder is not None and not folder.is_dir():
        raise ConfigError(f"{'SMP' if kind == 'smp' else kind} source folder not found", file=folder, field=field,
                          allowed="library, smp:DIR, video:DIR (an existing folder)")
