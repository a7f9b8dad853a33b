"""The synthetic methods the studies evaluate, registered in the HAR harness exactly as
`vsmp-imu evaluate` registers them and given the same parameters, so a study's
records are comparable with an `evaluate` run of the same settings."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vsmp_imu.errors import ConfigError, VsmpError
from vsmp_imu.methods import OPTION_FIELDS, REGISTRY, register_all
from vsmp_imu.methods import method as registered
from vsmp_imu.pipeline.spec import GenerationSpec


def method_names() -> tuple[str, ...]:
    return tuple(REGISTRY)


def method_display(name: str) -> str:
    from vsmp_imu.har.synthetic import METHOD_DISPLAY

    register_all()
    return METHOD_DISPLAY.get(name, name)


def spec_settings(spec: GenerationSpec) -> dict[str, Any]:
    """The generation options a study records in its settings."""
    return {**{name: getattr(spec, name) for name in OPTION_FIELDS}, "clips": spec.clips}


def study_params(name: str, spec: GenerationSpec, own: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """A method's parameters in a study: the spec's, as `evaluate` gives them, and its own
    (`own`, per method: imugpt's describer_url and describer_model), as `evaluate` adds them."""
    return {**registered(name).params(spec), **own.get(name, {})}


def check_methods(names: Sequence[str]) -> list[str]:
    """The names, or a ConfigError naming the unknown ones."""
    known = method_names()
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ConfigError(f"unknown method(s) {', '.join(unknown)}", field="--methods",
                          allowed=", ".join(known))
    return list(dict.fromkeys(names))


def unavailable_reason(name: str, options: GenerationSpec, dataset: str,
                       label_names: Sequence[str], library) -> str | None:
    """Why a method cannot run on this dataset with these options (None when it can)."""
    from vsmp_imu.pipeline.sources import entries_for

    if registered(name).needs_videos and not options.clips:
        return ("IMUTube-style synthesis estimates pose from source clips of every class; no clips "
                "were given (--clips DIR, one folder of clips per activity)")
    if registered(name).needs_videos and not Path(options.clips).is_dir():
        return f"clip folder {options.clips} not found"
    if registered(name).kind == "vsmp" and options.source == "library":
        from vsmp_imu.pipeline.sources import LibrarySmpSource

        try:
            LibrarySmpSource(library).smps(dataset, label_names)
        except VsmpError as exc:
            return str(exc)
    if name == "imugpt":
        try:
            if not entries_for(dataset, label_names, library):
                return "the activity library names no class of this dataset"
        except VsmpError as exc:
            return str(exc)
    return None


def resolve_dataset_name(name: str) -> str:
    """A registered dataset name ('utd_mhad' and 'utd-mhad' both name UTD-MHAD) or a YAML path."""
    from vsmp_imu.har.datasets import DATASETS

    if name in DATASETS or name.lower().endswith((".yaml", ".yml")):
        return name
    alias = name.lower().replace("_", "-")
    return alias if alias in DATASETS else name


@dataclass
class StudyDataset:
    """A dataset as a study runs it: maybe renamed and relabelled to the activity library's
    spellings (`label_map`: loader label -> label used in the run), with notes saying so."""

    dataset: Any
    label_map: dict[str, str]
    notes: list[str]

    @property
    def info(self):
        return self.dataset.info

    def original(self, label: str) -> str:
        """The loader's label of a run label."""
        back = {v: k for k, v in self.label_map.items()}
        return back.get(label, label)


def load_study_dataset(name: str, data_dir: str | Path | None, library) -> StudyDataset:
    """The dataset, spelled so that the activity library finds its classes.

    The pipeline looks a class up by the dataset's name and the label the
    library file declares for that dataset. The UTD-MHAD loader is named
    'utd-mhad' and labels classes by library names ('right_arm_swipe_left'),
    while the library declares 'utd_mhad' labels such as 'right arm swipe to
    the left'; such a dataset is run under the library's spellings (a class
    whose loader label names a library entry by name or alias takes the label
    that entry declares), and the report says so.
    """
    from vsmp_imu.har.dataset import with_info
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.pipeline.sources import entries_for, library_key

    ds = load_dataset(resolve_dataset_name(name), data_dir)
    info, notes = ds.info, []
    key = None
    for candidate in (info.name, info.name.replace("-", "_")):
        try:
            key = library_key(candidate, library)
            break
        except ConfigError:
            continue
    if key is None:
        return StudyDataset(ds, {n: n for n in info.label_names}, notes)
    new_name = info.name if key == library_key_or_none(info.name, library) else key
    found = entries_for(key, info.label_names, library)
    label_map = {}
    for label in info.label_names:
        declared = None
        if label not in found:
            try:
                declared = library.resolve(label).datasets.get(key)
            except VsmpError:
                declared = None
        label_map[label] = declared or label
    if len(set(label_map.values())) != len(label_map):
        label_map = {n: n for n in info.label_names}
    if new_name != info.name:
        notes.append(f"dataset '{info.name}' is run as '{new_name}', the name under which the activity "
                     "library declares its labels")
    renamed = [f"{a} -> '{b}'" for a, b in label_map.items() if a != b]
    if renamed:
        notes.append(f"{len(renamed)} class(es) carry the label the activity library declares for them "
                     f"(e.g. {renamed[0]}); tables show the loader's labels")
    if new_name != info.name or renamed:
        ds = with_info(
            ds, name=new_name, label_names=tuple(label_map[n] for n in info.label_names),
            min_share={label_map.get(k, k): v for k, v in info.min_share.items()},
            groups={g: tuple(label_map.get(m, m) for m in ms) for g, ms in info.groups.items()},
            location_by_label=None if info.location_by_label is None else
            {label_map.get(k, k): v for k, v in info.location_by_label.items()})
    return StudyDataset(ds, label_map, notes)


def library_key_or_none(name: str, library) -> str | None:
    from vsmp_imu.pipeline.sources import library_key

    try:
        return library_key(name, library)
    except ConfigError:
        return None


def paired_evaluation(config, dataset, output_dir):
    """An `Evaluation` whose backbones share one random state per (fold, seed, budget) across
    methods (common random numbers): two methods with the same training windows train the
    same model, so a difference between variants is the data's, not the seed's. (The plain
    harness derives the backbone seed from the method name as well.)"""
    from vsmp_imu.har.evaluate import Evaluation

    class PairedEvaluation(Evaluation):
        def _fit_one(self, split, train, n_syn, backbone, method, fold, seed, budget, groups, tell=None):
            record = super()._fit_one(split, train, n_syn, backbone, "paired", fold, seed, budget, groups,
                                      tell)
            record["method"] = method
            return record

    return PairedEvaluation(config, dataset, output_dir)
