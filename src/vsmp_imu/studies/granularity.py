"""Activity granularity (paper, "Activity-Granularity Evaluation Protocol" and
"Performance Across UTD-MHAD Activity Granularity").

Real-only and the synthetic methods are evaluated with the HAR harness on
identical folds, seeds, backbone and synthetic budget; per class, precision,
recall and F1 are averaged over folds x seeds; a group's Macro-F1 is the mean
F1 of its classes in one (fold, seed) (classes present in the held-out
subject's truth or predictions), averaged over folds x seeds.

The grouping is a taxonomy file (YAML: group name -> list of class labels).
The package ships the paper's UTD-MHAD taxonomy (four groups) and a HAPT12
taxonomy (locomotion, static postures, postural transitions); any dataset can
be grouped with `--taxonomy FILE`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.io import read_structured
from vsmp_imu.methods import register_all
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.studies.methods import (
    check_methods,
    load_study_dataset,
    paired_evaluation,
    spec_settings,
    study_params,
    unavailable_reason,
)

Progress = Callable[[int, int, str], None]
TAXONOMY_DIR = Path(__file__).resolve().parent / "taxonomies"
DEFAULT_TAXONOMIES = {"utd-mhad": "utd_mhad.yaml", "utd_mhad": "utd_mhad.yaml", "hapt12": "hapt12.yaml",
                      "hapt": "hapt12.yaml"}
DEFAULT_METHODS = ("real", "imutube", "imugpt", "vsmp")


def default_taxonomy(dataset: str) -> Path | None:
    """The shipped taxonomy of a dataset (None when none ships)."""
    name = DEFAULT_TAXONOMIES.get(str(dataset).lower())
    return TAXONOMY_DIR / name if name else None


def load_taxonomy(path: str | Path) -> dict[str, tuple[str, ...]]:
    """Read a taxonomy file: a mapping of group names to non-empty lists of class labels,
    each label in one group only."""
    path = Path(path)
    data = read_structured(path)
    if not isinstance(data, dict) or not data:
        raise ValidationError("a taxonomy is a mapping of group names to lists of class labels",
                              file=path, allowed="GROUP: [LABEL, LABEL, ...]")
    groups: dict[str, tuple[str, ...]] = {}
    seen: dict[str, str] = {}
    for group, labels in data.items():
        if not isinstance(labels, list) or not labels or not all(isinstance(x, str) and x.strip()
                                                                   for x in labels):
            raise ValidationError(f"group '{group}' must list at least one class label", file=path,
                                  field=str(group), allowed="a list of class labels")
        for label in labels:
            if norm_name(label) in seen:
                raise ValidationError(f"class '{label}' is in groups '{seen[norm_name(label)]}' and "
                                      f"'{group}'", file=path, field=str(group))
            seen[norm_name(label)] = str(group)
        groups[str(group)] = tuple(x.strip() for x in labels)
    return groups


def match_taxonomy(groups: dict[str, tuple[str, ...]], label_names: tuple[str, ...],
                   run_labels: tuple[str, ...], file: Path | None = None) -> dict[str, tuple[str, ...]]:
    """The taxonomy in the labels of the run (case- and separator-insensitive match against
    the loader's or the run's labels); unknown labels are refused. Groups whose classes the
    dataset lacks entirely are dropped."""
    lookup = {}
    for loader, run in zip(label_names, run_labels, strict=True):
        lookup[norm_name(loader)] = run
        lookup[norm_name(run)] = run
    out, unknown = {}, []
    for group, labels in groups.items():
        members = []
        for label in labels:
            if norm_name(label) in lookup:
                members.append(lookup[norm_name(label)])
            else:
                unknown.append(label)
        if members:
            out[group] = tuple(members)
    if unknown and len(unknown) == sum(len(v) for v in groups.values()):
        raise ValidationError(f"no taxonomy label is a class of this dataset ({', '.join(unknown[:5])} ...)",
                              file=file, allowed=", ".join(label_names))
    if unknown and not _known_subset(unknown, groups):
        raise ValidationError(f"taxonomy labels not in the dataset: {', '.join(unknown)}", file=file,
                              allowed=", ".join(label_names))
    return out


def _known_subset(unknown: list[str], groups: dict[str, tuple[str, ...]]) -> bool:
    """True when the unknown labels fill whole groups (e.g. transitions for 6-class HAPT)."""
    unknown_set = {norm_name(u) for u in unknown}
    return all(all(norm_name(x) in unknown_set for x in labels) or
               not any(norm_name(x) in unknown_set for x in labels) for labels in groups.values())


@dataclass
class GranularityResults:
    settings: dict[str, Any]
    taxonomy: dict[str, list[str]]  # loader labels
    ungrouped: list[str]
    skipped: dict[str, str]
    overall: list[dict[str, Any]] = field(default_factory=list)
    groups: list[dict[str, Any]] = field(default_factory=list)
    per_class: list[dict[str, Any]] = field(default_factory=list)
    elapsed_s: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class GranularityStudy:
    """Per-class and per-group results of several methods (see module doc)."""

    dataset: str = "hapt12"
    data_dir: Path | None = None
    taxonomy: Path | None = None
    methods: tuple[str, ...] = DEFAULT_METHODS
    backbone: str = "rf"
    protocol: str = "lopo"
    budget: float | None = None
    folds: tuple[str, ...] | None = None
    seeds: int = 1
    alpha: float = 0.5
    options: GenerationSpec = field(default_factory=GenerationSpec)
    backbone_params: dict[str, Any] = field(default_factory=dict)
    # per method, parameters of its own beside the spec's (imugpt's describer_url and describer_model)
    method_options: dict[str, dict[str, Any]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.methods = tuple(check_methods(self.methods))
        if self.seeds < 1:
            raise ConfigError(f"{self.seeds} is out of range", field="--seeds", allowed="an integer >= 1")
        if self.protocol == "low-resource" and self.budget is None:
            raise ConfigError("the low-resource protocol needs a label budget", field="--budget")
        if self.protocol != "low-resource":
            self.budget = None

    def _taxonomy_path(self, names: tuple[str, ...]) -> Path:
        if self.taxonomy is not None:
            if not Path(self.taxonomy).is_file():
                raise ConfigError("taxonomy file not found", file=self.taxonomy, field="--taxonomy")
            return Path(self.taxonomy)
        for name in names:
            path = default_taxonomy(name)
            if path is not None:
                return path
        raise ConfigError(f"no taxonomy ships for dataset '{names[0]}'", field="--taxonomy",
                          allowed="a YAML file mapping group names to class labels")

    def run(self, out_dir: str | Path, progress: Progress | None = None) -> GranularityResults:
        from vsmp_imu.har.evaluate import EvalConfig

        start = time.perf_counter()
        out = Path(out_dir)
        register_all()
        library = ActivityLibrary.load([Path(d) for d in self.options.library_dirs])
        study_ds = load_study_dataset(self.dataset, self.data_dir, library)
        ds, info = study_ds.dataset, study_ds.info
        loader_labels = tuple(study_ds.original(n) for n in info.label_names)
        tax_path = self._taxonomy_path((self.dataset, info.name))
        groups = match_taxonomy(load_taxonomy(tax_path), loader_labels, info.label_names, tax_path)
        options = self.options
        if options.cache_dir is None:
            options = replace(options, cache_dir=str(out / "cache"))
        skipped = {}
        for m in self.methods:
            if m == "real":
                continue
            reason = unavailable_reason(m, options, info.name, info.label_names, library)
            if reason:
                skipped[m] = reason
        methods = tuple(m for m in self.methods if m not in skipped)
        if not methods:
            raise ConfigError("none of the requested methods can run", field="--methods",
                              allowed="; ".join(f"{k}: {v}" for k, v in skipped.items()))
        config = EvalConfig(
            dataset=info.name, protocol=self.protocol,
            budgets=(self.budget,) if self.protocol == "low-resource" else (None,),
            backbones=(self.backbone,), methods=methods, folds=self.folds,
            seeds=tuple(range(self.seeds)), alpha=self.alpha,
            backbone_params={self.backbone: dict(self.backbone_params)} if self.backbone_params else {},
            method_params={m: study_params(m, options, self.method_options) for m in methods if m != "real"},
            report_groups=dict(groups))

        def update(description: str, done: int, total: int) -> None:
            if progress:
                progress(done, total, description)

        evaluation = paired_evaluation(config, ds, out / "runs")
        res = evaluation.run(update)
        folds = sorted({r["fold"] for r in res.records}, key=lambda f: (len(f), f))
        grouped = {m for ms in groups.values() for m in ms}
        results = GranularityResults(
            settings={"dataset": info.name, "data_dir": self.data_dir, "protocol": self.protocol,
                      "label_budget_percent": self.budget, "folds": folds,
                      "seeds": list(range(self.seeds)), "backbone": self.backbone,
                      "backbone_params": self.backbone_params, "alpha": self.alpha,
                      "methods": list(methods), "requested_methods": list(self.methods),
                      "taxonomy_file": str(tax_path), "generation": spec_settings(options),
                      "method_options": self.method_options,
                      "dataset_notes": study_ds.notes},
            taxonomy={g: [study_ds.original(m) for m in ms] for g, ms in groups.items()},
            ungrouped=[study_ds.original(n) for n in info.label_names if n not in grouped],
            skipped=skipped)
        self._summaries(results, res, methods, groups, study_ds)
        results.elapsed_s = time.perf_counter() - start
        return results

    @staticmethod
    def _summaries(results: GranularityResults, res, methods, groups, study_ds) -> None:
        from vsmp_imu.har.metrics import mean_std

        by_method = {m: [r for r in res.records if r["method"] == m] for m in methods}
        real = {(r["fold"], r["seed"]): r for r in by_method.get("real", [])}
        for m, recs in by_method.items():
            mean, std, n = mean_std([r["macro_f1"] for r in recs])
            results.overall.append({"method": m, "macro_f1_mean": mean, "macro_f1_std": std, "n": n})
            for g in groups:
                values = [(r.get("group_macro_f1") or {}).get(g) for r in recs]
                mean, std, n = mean_std(values)
                row = {"method": m, "group": g, "macro_f1_mean": mean, "macro_f1_std": std, "n": n}
                if m != "real" and real:
                    diffs = [(r["group_macro_f1"] or {}).get(g) - (real[k]["group_macro_f1"] or {}).get(g)
                             for r in recs if (k := (r["fold"], r["seed"])) in real
                             and (r["group_macro_f1"] or {}).get(g) is not None
                             and (real[k]["group_macro_f1"] or {}).get(g) is not None]
                    d_mean, d_std, d_n = mean_std(diffs)
                    row["delta_vs_real"] = {"mean": d_mean, "std": d_std, "n": d_n}
                results.groups.append(row)
            group_of = {c: g for g, ms in groups.items() for c in ms}
            for label in study_ds.info.label_names:
                row = {"method": m, "class": study_ds.original(label), "group": group_of.get(label)}
                for metric in ("precision", "recall", "f1"):
                    mean, std, n = mean_std([(r.get(f"per_class_{metric}") or {}).get(label) for r in recs])
                    row[f"{metric}_mean"], row[f"{metric}_std"] = mean, std
                    row["n"] = n
                row["support"] = int(np.sum([(r.get("per_class_support") or {}).get(label, 0) for r in recs]))
                results.per_class.append(row)
