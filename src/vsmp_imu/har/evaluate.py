"""The evaluation harness: protocols x backbones x methods x folds x seeds.

Each (budget, method, backbone, fold, seed) gives one record, written at once
to `DIR/records/` (atomically), so a run killed midway resumes where it
stopped and ends with the same `results.json`. Nothing of the held-out
subject reaches training, normalisation, validation or a synthetic source:
`protocols.split_fold` keeps its windows in `test` only.
"""

from __future__ import annotations

import hashlib
import json
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.backbones import BACKBONES, make_backbone
from vsmp_imu.har.backbones import RUN_PARAMS as BACKBONE_RUN_PARAMS
from vsmp_imu.har.dataset import HarDataset
from vsmp_imu.har.holdout import longest_recording, require_windows, source_of
from vsmp_imu.har.metrics import evaluate_predictions, group_macro_f1, mean_std, unseen_metrics
from vsmp_imu.har.noharm import (
    HARM_P,
    MIN_OWN_VALIDATION,
    ShareSelector,
    check_mode,
    choice_record,
    dropped_summary,
    shares_vector,
    take_shares,
)
from vsmp_imu.har.protocols import (
    BUDGETED,
    DEFAULT_BUDGETS,
    DEFAULT_RHO,
    DEFAULT_VAL_FRACTION,
    MAX_RHO,
    check_protocol,
    parse_budgets,
    require_two_classes,
    require_two_subjects,
    resolve_unseen,
    split_fold,
)
from vsmp_imu.har.records import RUN_KEYS, SPLIT_KEYS, UNSEEN_KEYS
from vsmp_imu.har.synthetic import (
    ALPHA_RANGE,
    BUDGET_POLICIES,
    METHODS,
    PAPER_ALPHA,
    RUN_PARAMS,
    UNSEEN_CAPABLE,
    FoldContext,
    check_synthetic,
    is_synthetic,
    make_method,
    mix,
    synthetic_budget,
    take_budget,
    unseen_budget,
)
from vsmp_imu.har.weights import check_synthetic_weight, source_weights, takes_sample_weight
from vsmp_imu.har.windows import Windows, concat_windows, natural_key
from vsmp_imu.io import dumps_json, remove_stale_temps, write_json
from vsmp_imu.progress import LOG_INTERVAL_S
from vsmp_imu.seeding import child_seed, rng_for

RESULT_FIELDS = (
    *RUN_KEYS,
    "macro_f1",
    "accuracy",
    "per_class_f1",
    "head_macro_f1",
    "tail_macro_f1",
)
SUMMARY_KEYS = ("dataset", "protocol", "budget", "backbone", "method")
UNSEEN_METRICS = ("unseen_macro_f1", "seen_macro_f1", "seen_as_unseen", "unseen_as_seen")
# Bumped whenever the harness changes how a record is computed (invalidates old records).
HARNESS_VERSION = 1


def _check_known(names: Sequence[str], known: Sequence[str], what: str, field: str) -> None:
    """A ConfigError naming the entries of `names` that are not in `known`."""
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ConfigError(
            f"unknown {what}(s) {', '.join(unknown)}", field=field, allowed=", ".join(known)
        )


@dataclass
class EvalConfig:
    """One evaluation: a dataset under one protocol, several budgets/backbones/methods."""

    dataset: str
    protocol: str = "lopo"
    budgets: tuple[float | None, ...] = (None,)
    backbones: tuple[str, ...] = ("rf",)
    methods: tuple[str, ...] = ("real",)
    folds: tuple[str, ...] | None = None
    seeds: tuple[int, ...] = (0,)
    # the harness's own defaults are the paper's (the studies rely on them); the command line
    # and `app.evaluation` fill them from the GenerationSpec, whose defaults are the working ones
    alpha: float = PAPER_ALPHA
    policy: str = "uniform"
    window_s: float = 2.0
    overlap: float = 0.5
    rho: float = DEFAULT_RHO
    val_fraction: float = DEFAULT_VAL_FRACTION
    backbone_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    method_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    report_groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    # unseen protocol: class and group names (one unseen set), or ("each",) (one set per class)
    unseen: tuple[str, ...] = ()
    # do no harm (`noharm`): off | method | class
    share_selection: str = "off"
    # None: a window's weight is its backbone's class weight; S: the classes weigh alike and a
    # class's synthetic windows together S times its real ones (`weights`, needs balanced backbones)
    synthetic_weight: float | None = None

    def __post_init__(self) -> None:
        """Normalise the budgets: none given is the default budgets for low-resource and (None,)
        elsewhere; given ones are parsed where a protocol takes them (others are left for `check`)."""
        if all(b is None for b in self.budgets):
            self.budgets = DEFAULT_BUDGETS if self.protocol == "low-resource" else (None,)
        elif self.protocol in BUDGETED:
            self.budgets = parse_budgets(",".join(f"{b:g}" for b in self.budgets), self.protocol)

    def check(self) -> EvalConfig:
        """Validate the settings (changes nothing); returns self."""
        check_protocol(self.protocol, field="--protocol")
        if self.protocol not in BUDGETED and any(b is not None for b in self.budgets):
            raise ConfigError(
                "label budgets apply to the low-resource and tstr protocols only",
                field="--budgets",
                allowed="use --protocol low-resource or tstr",
            )
        if self.unseen and self.protocol != "unseen":
            raise ConfigError("unseen classes apply to the unseen protocol only", field="--unseen",
                              allowed="use --protocol unseen")
        if self.protocol == "unseen" and not self.unseen:
            raise ConfigError("the unseen protocol needs the classes to hold out of training",
                              field="--unseen", allowed="CLASS[,CLASS...], a group name, or each")
        _check_known(self.backbones, BACKBONES, "backbone", "--backbones")
        _check_known(self.methods, METHODS, "method", "--methods")
        if not ALPHA_RANGE[0] <= self.alpha <= ALPHA_RANGE[1]:
            raise ConfigError(
                f"alpha {self.alpha:g} out of range",
                field="--alpha",
                allowed=f"{ALPHA_RANGE[0]:g} <= alpha <= {ALPHA_RANGE[1]:g}",
            )
        if self.policy not in BUDGET_POLICIES:
            raise ConfigError(
                f"unknown budget policy '{self.policy}'",
                field="--policy",
                allowed=", ".join(BUDGET_POLICIES),
            )
        if not self.seeds:
            raise ConfigError("need at least one seed", field="--seeds", allowed="N >= 1")
        if not 1 < self.rho <= MAX_RHO:  # NaN fails it
            raise ConfigError(f"rho {self.rho:g} out of range", field="--rho", allowed=f"1 < rho <= {MAX_RHO:g}")
        check_mode(self.share_selection)
        if self.protocol == "tstr" and self.share_selection != "off":
            raise ConfigError("tstr trains on synthetic windows only: there is no real-only model to weigh "
                              "them against", field="--share-selection", allowed="off under tstr")
        self._check_synthetic_weight()
        return self

    def _check_synthetic_weight(self) -> None:
        """A synthetic weight balances the classes itself: every backbone must be balanced
        (so Real-only is the same model) and take per-window weights."""
        check_synthetic_weight(self.synthetic_weight)
        if self.synthetic_weight is None:
            return
        unbalanced = [b for b in self.backbones if self.backbone_params.get(b, {}).get("class_weight") != "balanced"]
        if unbalanced:
            raise ConfigError(f"a synthetic weight needs balanced classes; {', '.join(unbalanced)} not balanced",
                              field="--synthetic-weight", allowed="with --class-weight balanced")
        unweighable = [b for b in self.backbones if not takes_sample_weight(BACKBONES[b])]
        if unweighable:
            raise ConfigError(f"backbone(s) {', '.join(unweighable)} take no per-window weights",
                              field="--synthetic-weight", allowed="backbones whose fit takes sample_weight")


@dataclass
class EvalResults:
    records: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    class_summary: list[dict[str, Any]]
    config: dict[str, Any]
    label_names: tuple[str, ...]

    def to_json(self) -> dict[str, Any]:
        return {
            "config": self.config,
            "label_names": list(self.label_names),
            "records": self.records,
            "summary": self.summary,
            "class_summary": self.class_summary,
        }


Progress = Callable[[str, int, int], None]


def _run_name(seed: int, fold: str, budget: float | None, method: str, backbone: str | None,
              unseen: str | None = None) -> str:
    """'seed 0 fold 3 5% vsmp/dclstm': one record of the evaluation, for progress lines (without
    a backbone: the method's windows, shared by its backbones; `unseen`: `_unseen_label`)."""
    share = "" if budget is None else f" {budget:g}%"
    hidden = "" if unseen is None else f" unseen {unseen}"
    model = "" if backbone is None else f"/{backbone}"
    return f"seed {seed} fold {fold}{share}{hidden} {method}{model}"


def _unseen_label(unseen: tuple[str, ...] | None, groups: dict[str, tuple[str, ...]]) -> str | None:
    """The unseen classes as progress lines name them: a report group's name where the set is one
    ('transitions'), else the classes joined by '+'."""
    if unseen is None:
        return None
    named = [name for name, members in groups.items() if set(members) == set(unseen)]
    return named[0] if named else "+".join(unseen)


def _stage_teller(progress: Progress | None, run: str, done: int, total: int) -> Callable[[str], None] | None:
    """tell(stage): a progress line 'RUN: STAGE' while record `done + 1` is under way."""
    if progress is None:
        return None
    return lambda stage: progress(f"{run}: {stage}", done, total)


def _watch_epochs(model, tell: Callable[[str], None] | None, stage: str) -> bool:
    """Let a network that trains for epochs (`on_epoch`) tell them, at most one line per
    LOG_INTERVAL_S seconds; True when the model has epochs to tell."""
    if tell is None or not hasattr(model, "on_epoch"):
        return False
    last = time.monotonic()

    def on_epoch(row: dict[str, float]) -> None:
        nonlocal last
        if time.monotonic() - last < LOG_INTERVAL_S:
            return
        last = time.monotonic()
        score = f", validation Macro-F1 {100 * row['val_macro_f1']:.2f}" if "val_macro_f1" in row else ""
        tell(f"{stage}, epoch {row['epoch']}/{model.max_epochs}{score}")

    model.on_epoch = on_epoch
    return True


def _slug(text: Any) -> str:
    return re.sub(r"[^A-Za-z0-9.=-]+", "-", str(text)).strip("-")


def _budget_slug(budget: float | None) -> str:
    return "full" if budget is None else f"{budget:g}pct"


class Evaluation:
    """Run an `EvalConfig` on a dataset, optionally writing records to `output_dir`.

    `run(progress)` returns `EvalResults`; `progress(description, done, total)`
    is called after every record (the command line draws a progress bar), and with the
    same `done` as a long record's stages begin: its synthetic windows, the choice of each
    class's synthetic share, a network's training and every LOG_INTERVAL_S seconds its
    epochs ('seed 0 fold 1 vsmp/dclstm: training, epoch 12/60, validation Macro-F1 71.30').
    """

    def __init__(
        self, config: EvalConfig, dataset: HarDataset, output_dir: str | Path | None = None
    ) -> None:
        self.config = config.check()
        self.dataset = dataset
        self.output_dir = Path(output_dir) if output_dir is not None else None
        self.unseen_sets = self._unseen_sets()

    # -- set-up ----------------------------------------------------------------------------
    def _groups(self) -> dict[str, tuple[str, ...]]:
        groups = dict(self.dataset.info.groups)
        for name, members in self.config.report_groups.items():
            unknown = [m for m in members if m not in self.dataset.info.label_names]
            if unknown:
                raise ConfigError(
                    f"group '{name}' names unknown classes {', '.join(unknown)}",
                    field="--report-groups",
                    allowed=", ".join(self.dataset.info.label_names),
                )
            groups[name] = tuple(members)
        return groups

    def _unseen_sets(self) -> tuple[tuple[str, ...] | None, ...]:
        """The unseen class sets evaluated in turn ((None,) outside the unseen protocol)."""
        if self.config.protocol != "unseen":
            return (None,)
        info = self.dataset.info
        return resolve_unseen(self.config.unseen, info.label_names, self._groups())

    def _cells(self) -> list[tuple[float | None, tuple[str, ...] | None]]:
        """(label budget, unseen class set) pairs, each a separate split of every fold."""
        return [(b, u) for b in self.config.budgets for u in self.unseen_sets]

    def _unseen_indices(self, unseen: tuple[str, ...] | None) -> tuple[int, ...] | None:
        names = self.dataset.info.label_names
        return None if unseen is None else tuple(names.index(n) for n in unseen)

    def folds(self, windows: Windows) -> list[str]:
        available = windows.unique_subjects()
        require_two_subjects(available, self.dataset)
        require_two_classes(windows, self.dataset)
        # the subjects a dataset lists (a HarDataset; a stand-in without them names none)
        windowless = [s for s in getattr(self.dataset, "subjects", ()) if s not in available]
        if self.config.folds is None:
            if windowless:  # a subject dataset info lists would otherwise just be missing from the folds
                note = (f"{source_of(self.dataset) or self.config.dataset}: subject(s) {', '.join(windowless)} "
                        f"give no labelled window of {self.config.window_s:g} s and are no fold (recordings "
                        "shorter than a window, or no class labelled over one)")
                if note not in self.dataset.warnings:
                    self.dataset.warnings.append(note)
            return available
        wanted = [str(f) for f in self.config.folds]
        bad = [f for f in wanted if f not in available]
        if bad:
            empty = [f for f in bad if f in windowless]
            raise ConfigError(
                f"fold(s) {', '.join(bad)} not in dataset '{self.config.dataset}'" + (
                    f" ({', '.join(empty)}: in the recordings but no labelled window of "
                    f"{self.config.window_s:g} s; longest recording "
                    f"{longest_recording(self.dataset, empty[0])})" if empty else ""),
                field="--folds",
                allowed="all, or subjects " + ", ".join(available),
            )
        return sorted(dict.fromkeys(wanted), key=natural_key)

    def run_settings(self) -> dict[str, Any]:
        """The settings every record of this run depends on, whatever its backbone and method
        (the shared part of `_digest`)."""
        c = self.config
        return {
            "harness_version": HARNESS_VERSION,
            "dataset": c.dataset,
            "info": self.dataset.info.to_dict(),
            "window_s": c.window_s,
            "overlap": c.overlap,
            "alpha": c.alpha,
            "policy": c.policy,
            "rho": c.rho,
            "val_fraction": c.val_fraction,
        }

    def backbone_settings(self, backbone: str) -> dict[str, Any]:
        """The backbone's parameters a record depends on (its `RUN_PARAMS` left out)."""
        params = make_backbone(backbone, **self.config.backbone_params.get(backbone, {})).get_params()
        return {k: v for k, v in params.items() if k not in BACKBONE_RUN_PARAMS}

    def method_settings(self, method: str, with_run_params: bool = False) -> dict[str, Any]:
        """The method's parameters a record depends on (its `RUN_PARAMS` left out unless asked)."""
        params = self.config.method_params.get(method, {})
        return dict(params) if with_run_params else {k: v for k, v in params.items() if k not in RUN_PARAMS}

    def _digest(self, backbone: str, method: str, unseen: tuple[str, ...] | None = None,
                with_run_params: bool = False) -> str:
        """Hash of every setting a record depends on (besides its key).

        Settings that decide only where and how fast a record is computed (the backbones' and
        the methods' `RUN_PARAMS`) are left out; `with_run_params` keeps the methods' in, as
        records written before they were left out have it."""
        c = self.config
        payload = {
            **self.run_settings(),
            "backbone": backbone,
            "backbone_params": self.backbone_settings(backbone),
            "method": method,
            "method_params": self.method_settings(method, with_run_params),
        }
        if unseen is not None:  # absent otherwise: the other protocols' records stay valid
            payload["unseen"] = list(unseen)
        if c.share_selection != "off" and method != "real":  # absent when off: older records stay valid
            payload["share_selection"] = [c.share_selection, HARM_P] + (
                [MIN_OWN_VALIDATION] if c.share_selection == "class" else [])
        if c.synthetic_weight is not None and method != "real":  # Real-only has no synthetic window to weigh
            payload["synthetic_weight"] = c.synthetic_weight
        if method in UNSEEN_CAPABLE:  # windows made from motion: another code's or library's record is stale
            from vsmp_imu.pipeline.sample import code_fingerprint, library_for

            payload["code"] = code_fingerprint()
            dirs = c.method_params.get(method, {}).get("library_dirs", ())
            payload["library"] = library_for(tuple(str(d) for d in dirs)).digest()
        text = json.dumps(payload, sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def _record_path(self, budget, method, backbone, fold, seed, unseen=None) -> Path | None:
        if self.output_dir is None:
            return None
        hidden = () if unseen is None else ("unseen-" + "+".join(unseen),)
        name = "_".join(
            _slug(p)
            for p in (
                self.config.protocol,
                _budget_slug(budget),
                *hidden,
                method,
                backbone,
                f"fold-{fold}",
                f"seed-{seed}",
            )
        )
        return self.output_dir / "records" / f"{name}.json"

    @staticmethod
    def _load_record(path: Path | None, digest: str, older: str) -> dict[str, Any] | None:
        """The record at `path` if it was computed with these settings: its digest is `digest`,
        or `older` (the digest with the run-only settings, as older records have it; such a
        record is rewritten with `digest`)."""
        if path is None or not path.exists():
            return None
        try:
            record = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return None
        found = record.get("settings_digest")
        if found == older != digest:
            record["settings_digest"] = digest
            write_json(path, record)
            return record
        return record if found == digest else None

    # -- running ---------------------------------------------------------------------------
    def windows_and_folds(self) -> tuple[Windows, list[str]]:
        """The dataset's windows and the folds to run, checked (ConfigError or ValidationError)."""
        c = self.config
        windows = self.dataset.windows(c.window_s, c.overlap)
        require_windows(self.dataset, windows, c.window_s)
        return windows, self.folds(windows)

    def run(self, progress: Progress | None = None) -> EvalResults:
        c = self.config
        windows, folds = self.windows_and_folds()
        groups = self._groups()
        if self.output_dir is not None:
            remove_stale_temps(self.output_dir)  # leftovers of a killed run
        cells = self._cells()
        digests = {(m, b, u): self._digest(b, m, u)
                   for m in c.methods for b in c.backbones for _, u in cells}
        older = {(m, b, u): self._digest(b, m, u, with_run_params=True)
                 for m in c.methods for b in c.backbones for _, u in cells}
        total = len(c.seeds) * len(folds) * len(cells) * len(c.methods) * len(c.backbones)
        records: list[dict[str, Any]] = []
        done = 0
        for seed in c.seeds:
            for fold in folds:
                for budget, unseen in cells:
                    split = None
                    shown = _unseen_label(unseen, groups)
                    for method in c.methods:
                        pending = []
                        for backbone in c.backbones:
                            path = self._record_path(budget, method, backbone, fold, seed, unseen)
                            key = (method, backbone, unseen)
                            record = self._load_record(path, digests[key], older[key])
                            if record is not None:
                                # groups may differ from the run that wrote the record
                                record["group_macro_f1"] = group_macro_f1(
                                    record["confusion"], self.dataset.info.label_names, groups
                                )
                                records.append(record)
                                done += 1
                                if progress:
                                    run = _run_name(seed, fold, budget, method, backbone, shown)
                                    progress(f"{run} (cached)", done, total)
                            else:
                                pending.append((backbone, path))
                        if not pending:
                            continue
                        if split is None:
                            split = split_fold(
                                windows, fold, c.protocol, seed, budget, c.rho, c.val_fraction,
                                self._unseen_indices(unseen),
                            )
                        tell = _stage_teller(progress, _run_name(seed, fold, budget, method, None, shown),
                                             done, total)
                        if tell and method != "real":  # a first run generates for minutes
                            tell("synthetic windows")
                        train, n_syn, n_asked = self._training_windows(split, method, seed, budget)
                        for backbone, path in pending:
                            run = _run_name(seed, fold, budget, method, backbone, shown)
                            tell = _stage_teller(progress, run, done, total)
                            if tell and n_syn and c.share_selection != "off":
                                tell("choosing each class's synthetic share")
                            mixed, n_mixed, shares = self._select_shares(
                                split, train, backbone, method, fold, seed, budget, tell
                            )
                            record = self._fit_one(
                                split, mixed, n_mixed, backbone, method, fold, seed, budget, groups, tell
                            )
                            record["synthetic_shares"] = shares
                            record["n_synthetic_requested"] = n_asked
                            record.update(self._unseen_fields(split, train, method, record))
                            record["settings_digest"] = digests[(method, backbone, unseen)]
                            # the confusion matrix's order: an unfinished run's records say it themselves
                            record["label_names"] = list(self.dataset.info.label_names)
                            if path is not None:
                                write_json(path, record)
                            records.append(record)
                            done += 1
                            if progress:
                                f1 = 100 * record["macro_f1"]
                                progress(f"{run}: Macro-F1 {f1:.2f}", done, total)
        results = summarize(records, self.dataset.info.label_names, groups)
        results.config = self._config_dict()
        if self.output_dir is not None:
            write_json(self.output_dir / "results.json", results.to_json())
        return results

    def _config_dict(self) -> dict[str, Any]:
        config = asdict(self.config)
        config["folds"] = list(config["folds"]) if config["folds"] is not None else "all"
        return json.loads(dumps_json(config))

    def _training_windows(
        self, split, method: str, seed: int, budget: float | None
    ) -> tuple[Windows, int, int]:
        """The fit windows mixed with the method's synthetic windows (if any), the number of
        synthetic windows mixed in and the number the budget asked for."""
        c = self.config
        source = make_method(method, **c.method_params.get(method, {}))
        if source is None or len(split.fit) == 0:
            return split.fit, 0, 0
        wanted = self._budget(split)
        names = split.fit.label_names
        context = FoldContext(
            dataset=self.dataset.info,
            fold=split.fold,
            held_out_subject=split.fold,
            train=split.fit,
            train_subjects=tuple(split.fit.unique_subjects()),
            seed=seed,
            budget={names[i]: int(n) for i, n in enumerate(wanted) if n > 0},
            alpha=c.alpha,
            protocol=c.protocol,
            label_budget=budget,
            unseen=tuple(names[i] for i in split.unseen or ()),
        )
        synthetic = source.generate(context)
        check_synthetic(split.fit, synthetic, method)
        synthetic = take_budget(synthetic, wanted, rng_for(seed, "take-budget", split.fold, method))
        if c.protocol == "tstr":
            return synthetic_only(synthetic, method, split.fold), len(synthetic), int(np.sum(wanted))
        return mix(split.fit, synthetic, method), len(synthetic), int(np.sum(wanted))

    def _budget(self, split) -> np.ndarray:
        """Synthetic windows wanted per class (the unseen protocol's rule for its unseen classes)."""
        c, counts = self.config, split.fit.class_counts()
        if split.unseen is not None:
            return unseen_budget(counts, c.alpha, c.policy, split.unseen)
        return synthetic_budget(counts, c.alpha, c.policy, split.tail)

    @staticmethod
    def _unseen_fields(split, train: Windows, method: str, record: dict[str, Any]) -> dict[str, Any]:
        """The unseen protocol's record fields: the unseen classes, whether the method can make
        them, how many synthetic windows of them it mixed in, and `unseen_metrics`."""
        if split.unseen is None:
            return {}
        synthetic = is_synthetic(train)
        return {
            "unseen_classes": [split.test.label_names[i] for i in split.unseen],
            "unseen_capable": method in UNSEEN_CAPABLE,
            "n_synthetic_unseen": int(np.sum(synthetic & np.isin(train.y, split.unseen))),
            **unseen_metrics(record["confusion"], split.unseen),
        }
    def _select_shares(
        self, split, train: Windows, backbone: str, method: str, fold: str, seed: int, budget,
        tell: Callable[[str], None] | None = None,
    ) -> tuple[Windows, int, dict[str, dict] | None]:
        """Do no harm: the training windows with each class's chosen share of synthetic windows
        (`noharm`), their synthetic count and the choice per class (None when not chosen)."""
        c = self.config
        is_real = ~is_synthetic(train)
        if c.share_selection == "off" or is_real.all():
            return train, int((~is_real).sum()), None
        real, synthetic = train[np.flatnonzero(is_real)], train[np.flatnonzero(~is_real)]
        state = int(
            child_seed(seed, "share-selection", backbone, method, fold, _budget_slug(budget)).generate_state(1)[0]
        )
        params = {**c.backbone_params.get(backbone, {}), "random_state": state}
        val = split.val

        def fit(windows: Windows):
            model_params, weights = self._weighting(params, windows)
            model = make_backbone(backbone, **model_params)
            _watch_epochs(model, tell, "choosing each class's synthetic share")
            return model.fit(windows.X, windows.y, val.X if len(val) else None, val.y if len(val) else None,
                             **({} if weights is None else {"sample_weight": weights}))

        selector = ShareSelector(c.share_selection)
        choice = selector.choose(fit, real, synthetic, val)
        kept = take_shares(synthetic, shares_vector(choice, len(train.label_names)))
        mixed = concat_windows([real, kept]) if len(kept) else real
        return mixed, len(kept), choice_record(choice, train.label_names)

    def _weighting(self, params: dict[str, Any], train: Windows) -> tuple[dict[str, Any], np.ndarray | None]:
        """The backbone's parameters and the training windows' weights. With a synthetic weight
        and synthetic windows among them, per-source balanced weights (`source_weights`) take
        the place of the backbone's class weights; otherwise no per-window weights."""
        share = self.config.synthetic_weight
        if share is None:
            return params, None
        is_real = ~is_synthetic(train)
        if is_real.all():
            return params, None  # Real-only: the balanced backbone itself, record for record
        return {**params, "class_weight": None}, source_weights(train.y, is_real, len(train.label_names), share)

    def _fit_one(
        self,
        split,
        train: Windows,
        n_syn: int,
        backbone: str,
        method: str,
        fold: str,
        seed: int,
        budget: float | None,
        groups,
        tell: Callable[[str], None] | None = None,
    ) -> dict[str, Any]:
        c = self.config
        state = int(
            child_seed(
                seed, "backbone", backbone, method, fold, _budget_slug(budget)
            ).generate_state(1)[0]
        )
        params = {**c.backbone_params.get(backbone, {}), "random_state": state}
        val = split.val
        n_real = len(train) - n_syn  # tstr: none
        if not getattr(BACKBONES[backbone], "uses_validation", True) and len(val):
            # a backbone without early stopping trains on the validation subjects too
            train = concat_windows([train, val.with_meta(source=np.full(len(val), "real"))])
            n_real += len(val)
            val = val[:0]
        params, weights = self._weighting(params, train)
        model = make_backbone(backbone, **params)
        if _watch_epochs(model, tell, "training"):
            tell("training")
        start = time.perf_counter()
        has_val = len(val) > 0
        model.fit(train.X, train.y, val.X if has_val else None, val.y if has_val else None,
                  **({} if weights is None else {"sample_weight": weights}))
        fit_s = time.perf_counter() - start
        y_pred = model.predict(split.test.X)
        metrics = evaluate_predictions(
            split.test.y, y_pred, split.test.label_names, groups, split.head, split.tail
        )
        names = split.test.label_names
        return {
            "dataset": c.dataset,
            "protocol": c.protocol,
            "budget": budget,
            "backbone": backbone,
            "method": method,
            "fold": fold,
            "seed": seed,
            **metrics,
            "head_classes": [names[i] for i in split.head] if split.head is not None else None,
            "tail_classes": [names[i] for i in split.tail] if split.tail is not None else None,
            "n_train_real": n_real,
            "n_synthetic": n_syn,
            "n_val": len(val),
            "n_test": len(split.test),
            "val_subjects": list(split.val_subjects),
            "epochs": getattr(model, "n_epochs_", None),
            "best_epoch": getattr(model, "best_epoch_", None),
            "fit_seconds": round(fit_s, 3),
        }


def synthetic_only(synthetic: Windows, method: str, fold: str) -> Windows:
    """The training windows of protocol tstr: the method's synthetic windows, no real one."""
    if len(synthetic) == 0:
        raise ValidationError(
            f"method '{method}' made no synthetic window for fold {fold}; protocol tstr trains on "
            "synthetic windows only", field="--methods",
            allowed="a method that makes windows of the training classes, or another protocol")
    return mix(synthetic[:0], synthetic, method)


def summarize(
    records: Sequence[dict[str, Any]],
    label_names: Sequence[str],
    groups: dict[str, Sequence[str]] | None = None,
) -> EvalResults:
    """Mean +- std over folds and seeds per (dataset, protocol, budget, backbone, method)."""
    records = sorted(records, key=_record_sort_key)
    blocks: dict[tuple, list[dict[str, Any]]] = {}
    for r in records:
        blocks.setdefault(_summary_key(r), []).append(r)
    summary, class_summary = [], []
    for key, rs in blocks.items():
        row = dict(zip(SUMMARY_KEYS, key, strict=False))
        if key[-1] is not None:
            row |= _unseen_summary(key[-1], rs)
        for metric in ("macro_f1", "accuracy", "head_macro_f1", "tail_macro_f1"):
            mean, std, n = mean_std([r.get(metric) for r in rs])
            row[f"{metric}_mean"], row[f"{metric}_std"] = mean, std
            if metric == "macro_f1":
                row["n"] = n
        asked = [r.get("n_synthetic_requested") for r in rs]  # absent in records of older runs
        row["n_synthetic_mean"] = mean_std([r.get("n_synthetic") for r in rs])[0]
        row["n_synthetic_requested_mean"] = None if None in asked else mean_std(asked)[0]
        row["synthetic_shares"] = dropped_summary(rs)
        group_names = sorted({g for r in rs for g in (r.get("group_macro_f1") or {})})
        row["group_macro_f1"] = {}
        for g in group_names:
            mean, std, n = mean_std([(r.get("group_macro_f1") or {}).get(g) for r in rs])
            row["group_macro_f1"][g] = {"mean": mean, "std": std, "n": n}
        summary.append(row)
        per_class = {}
        for name in label_names:
            mean, std, n = mean_std([(r.get("per_class_f1") or {}).get(name) for r in rs])
            per_class[name] = {"f1_mean": mean, "f1_std": std, "n": n}
        confusion = np.sum([np.asarray(r["confusion"]) for r in rs if r.get("confusion")], axis=0)
        class_summary.append(
            {
                **dict(zip(SUMMARY_KEYS, key, strict=False)),
                **({} if key[-1] is None else {"unseen_classes": list(key[-1])}),
                "per_class": per_class,
                "confusion": np.asarray(confusion).tolist(),
            }
        )
    public = [{k: r.get(k) for k in RESULT_FIELDS} | _extra_fields(r) for r in records]
    return EvalResults(
        records=public,
        summary=summary,
        class_summary=class_summary,
        config={},
        label_names=tuple(label_names),
    )


def _summary_key(r: dict[str, Any]) -> tuple:
    """A summary row's key: SUMMARY_KEYS and the unseen classes (None outside the protocol)."""
    unseen = r.get("unseen_classes")
    return (*(r[k] for k in SUMMARY_KEYS), None if unseen is None else tuple(unseen))


def _unseen_summary(unseen: tuple[str, ...], rs: list[dict[str, Any]]) -> dict[str, Any]:
    """The unseen protocol's summary fields: its figures' mean and std over the runs."""
    row: dict[str, Any] = {"unseen_classes": list(unseen),
                           "unseen_capable": all(r.get("unseen_capable") for r in rs)}
    for metric in UNSEEN_METRICS:
        row[f"{metric}_mean"], row[f"{metric}_std"], _ = mean_std([r.get(metric) for r in rs])
    row["n_synthetic_unseen_mean"] = mean_std([r.get("n_synthetic_unseen") for r in rs])[0]
    return row


def _extra_fields(r: dict[str, Any]) -> dict[str, Any]:
    # wall times stay in the record files: results.json must not depend on them
    keep = (
        "group_macro_f1",
        "per_class_precision",
        "per_class_recall",
        "per_class_support",
        *SPLIT_KEYS,
        "val_subjects",
        "synthetic_shares",
        "epochs",
        "best_epoch",
    )
    if r.get("unseen_classes") is not None:
        keep += UNSEEN_KEYS
    return {k: r.get(k) for k in keep}


def _record_sort_key(r: dict[str, Any]) -> tuple:
    budget = r["budget"] if r["budget"] is not None else -1.0
    return (
        r["dataset"],
        r["protocol"],
        budget,
        r["backbone"],
        r["method"],
        tuple(r.get("unseen_classes") or ()),
        natural_key(r["fold"]),
        r["seed"],
    )
