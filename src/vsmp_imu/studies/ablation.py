"""Ablations (paper, "Ablation Study"): the strictly matched caption--SMP 2x2, component
ablations, the sensor-grounding ablation and the sensitivity to alpha.

Every part runs through the HAR harness (`har.evaluate.Evaluation`) with one
`EvalConfig` per part, so every variant sees the same folds, seeds, protocol,
label budget, backbone and synthetic budget:

- `caption`: Real-only and the four matched conditions C0, C1, S0, S1
  (`studies.matched`), each registered as a synthetic source (`matched-c0` ...)
  that returns its condition's windows; the four are generated jointly, once
  per fold.
- `components`: Real-only, VSMP-IMU and the registered variants w/o
  refinement, w/o uncertainty-aware constraints, w/o IMU adaptation, w/o
  filtering.
- `grounding`: raw (no simulation-in-the-loop, no rank grounding),
  simulation-in-the-loop only, rank grounding only, both (= VSMP-IMU).
- `alpha`: VSMP-IMU at alpha in {0.1, 0.25, 0.5, 1.0, 2.0}.

Components and grounding share one evaluation (VSMP-IMU and the raw variant
appear in both tables). Records are written per part under `runs/`, so an
interrupted study resumes; generated samples are cached in `cache/`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows
from vsmp_imu.io import write_json
from vsmp_imu.methods import REGISTRY, register_all
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.studies.matched import (
    CONDITION_TITLES,
    CONDITIONS,
    MatchedBlockGenerator,
    MatchedConfig,
)
from vsmp_imu.studies.methods import (
    load_study_dataset,
    paired_evaluation,
    resolve_dataset_name,
    spec_settings,
)

Progress = Callable[[int, int, str], None]

PARTS = ("caption", "components", "grounding", "alpha")
COMPONENT_METHODS = ("real", "vsmp", "vsmp-no-refine", "vsmp-no-uncertainty", "vsmp-no-adaptation",
                     "vsmp-no-filter")
COMPONENT_TITLES = {
    "real": "Real-only",
    "vsmp": "VSMP-IMU (full, S1)",
    "vsmp-no-refine": "w/o semantic refinement",
    "vsmp-no-uncertainty": "w/o uncertainty-aware constraints",
    "vsmp-no-adaptation": "w/o IMU adaptation",
    "vsmp-no-filter": "w/o quality filtering",
}
GROUNDING_METHODS = ("vsmp-no-adaptation", "vsmp-sim-only", "vsmp-rank-only", "vsmp")
GROUNDING_TITLES = {
    "vsmp-no-adaptation": "Raw IMUSim only",
    "vsmp-sim-only": "Simulation-in-the-loop only",
    "vsmp-rank-only": "Rank-based grounding only",
    "vsmp": "Simulation-in-the-loop + rank-based grounding",
}
ALPHAS = (0.1, 0.25, 0.5, 1.0, 2.0)  # paper, Table "Sensitivity to the synthetic-to-real mixing ratio"
CONDITION_METHODS = {c: f"matched-{c.lower()}" for c in CONDITIONS}
# paired differences reported for the 2x2
PAIRS = (("C1", "C0"), ("S0", "C0"), ("S1", "S0"), ("S1", "C1"), ("S1", "real"))


def fold_name(protocol: str, budget: float | None, seed: int, fold: str) -> str:
    """The fold key the pipeline uses (`pipeline.method.fold_key`) from plain values."""
    label = "full" if budget is None else f"{budget:g}pct"
    return f"{protocol}-{label}-s{seed}-fold{fold}"


class MatchedSource:
    """The four matched conditions of a fold, generated jointly once and served per condition.

    Each fold's accounting (and prompts, and every attempted block) is written
    to `accounting_dir/<fold key>.json` as soon as the fold is generated.
    """

    def __init__(self, config: MatchedConfig, options: GenerationSpec, library: ActivityLibrary,
                 accounting_dir: Path) -> None:
        self.config = config
        self.options = options
        self.library = library
        self.accounting_dir = Path(accounting_dir)
        self._key: str | None = None
        self._windows: dict[str, Windows] = {}

    def windows(self, context: FoldContext, condition: str) -> Windows:
        from vsmp_imu.pipeline.method import fold_key, make_smp_source

        key = fold_key(context)
        if key != self._key:
            info = context.dataset
            sources = make_smp_source(self.options.source, self.library).smps(info.name, info.label_names)
            executor = self.options.make_executor(show_progress=False)
            cache = Path(self.options.cache_dir) if self.options.cache_dir else None
            out = MatchedBlockGenerator(self.config, executor, cache, self.library).generate(
                info, context.train, sources, context.budget_vector(), context.seed, f"matched-{key}")
            out.summary["windows_per_class"] = {  # what each condition hands to training
                cond: {n: int(c) for n, c in zip(info.label_names, np.bincount(
                    w.y, minlength=info.n_classes), strict=True)} for cond, w in out.windows.items()}
            out.summary["identical_windows"] = {
                f"{a}={b}": bool(np.array_equal(out.windows[a].X, out.windows[b].X)
                                 and np.array_equal(out.windows[a].y, out.windows[b].y))
                for a, b in (("S0", "C0"), ("S1", "C1"), ("S1", "S0"))}
            write_json(self.accounting_dir / f"{key}.json", {
                "fold": context.fold, "seed": context.seed, "summary": out.summary,
                "prompts": [row for plan in out.plans for row in plan.prompts()],
                "attempts": out.attempts})
            self._key, self._windows = key, out.windows
        return self._windows[condition]


@dataclass
class MatchedCondition:
    """One condition of the matched 2x2 as a synthetic source of the harness."""

    condition: str
    shared: MatchedSource

    @property
    def name(self) -> str:
        return CONDITION_METHODS[self.condition]

    def generate(self, context: FoldContext) -> Windows:
        return self.shared.windows(context, self.condition)


@dataclass
class AblationResults:
    settings: dict[str, Any]
    parts: dict[str, Any] = field(default_factory=dict)
    elapsed_s: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return {"settings": self.settings, "parts": self.parts, "elapsed_s": self.elapsed_s}


@dataclass
class AblationStudy:
    """The ablation study (see module doc). `run(out_dir, progress)` -> AblationResults."""

    dataset: str = "hapt12"
    data_dir: Path | None = None
    protocol: str = "low-resource"
    budget: float | None = 5.0
    folds: tuple[str, ...] | None = None
    seeds: int = 1
    backbone: str = "rf"
    alpha: float = 0.5
    alphas: tuple[float, ...] = ALPHAS
    parts: tuple[str, ...] = PARTS
    options: GenerationSpec = field(default_factory=GenerationSpec)
    backbone_params: dict[str, Any] = field(default_factory=dict)
    max_rounds: int = 6  # of matched-block generation (replenishment rounds)
    matched: MatchedConfig | None = None

    def __post_init__(self) -> None:
        unknown = [p for p in self.parts if p not in PARTS]
        if unknown:
            raise ConfigError(f"unknown part(s) {', '.join(unknown)}", field="--parts", allowed=", ".join(PARTS))
        if self.seeds < 1:
            raise ConfigError(f"{self.seeds} is out of range", field="--seeds", allowed="an integer >= 1")
        if self.protocol != "low-resource":
            self.budget = None
        elif self.budget is None:
            raise ConfigError("the low-resource protocol needs a label budget", field="--budget",
                              allowed="a percentage in 0.01..100")
        self.dataset = resolve_dataset_name(self.dataset)

    # -- set-up ------------------------------------------------------------------------------
    def _config(self, methods: tuple[str, ...], alpha: float, extra_params: dict[str, Any] | None = None):
        from vsmp_imu.har.evaluate import EvalConfig

        params = {m: REGISTRY[m].params(self.options) for m in methods if m in REGISTRY and REGISTRY[m].generative}
        params.update(extra_params or {})
        return EvalConfig(
            dataset=self._ds.info.name, protocol=self.protocol,
            budgets=(self.budget,) if self.protocol == "low-resource" else (None,),
            backbones=(self.backbone,), methods=methods, folds=self.folds,
            seeds=tuple(range(self.seeds)), alpha=alpha,
            backbone_params={self.backbone: dict(self.backbone_params)} if self.backbone_params else {},
            method_params=params)

    def _matched_config(self) -> MatchedConfig:
        if self.matched is not None:
            return self.matched
        return MatchedConfig.from_spec(self.options, max_rounds=self.max_rounds)

    def _settings(self, folds: list[str]) -> dict[str, Any]:
        info = self._ds.info
        return {
            "dataset": info.name, "data_dir": self.data_dir, "classes": list(info.label_names),
            "protocol": self.protocol, "label_budget_percent": self.budget, "folds": folds,
            "seeds": list(range(self.seeds)), "backbone": self.backbone,
            "backbone_params": self.backbone_params, "alpha": self.alpha, "alphas": list(self.alphas),
            "parts": list(self.parts), "generation": spec_settings(self.options),
            "matched": self._matched_config().as_dict(), "dataset_notes": self._study_ds.notes,
            "label_map": self._study_ds.label_map,
        }

    # -- running -----------------------------------------------------------------------------
    def run(self, out_dir: str | Path, progress: Progress | None = None) -> AblationResults:
        from vsmp_imu.har.evaluate import Evaluation

        start = time.perf_counter()
        out = Path(out_dir)
        register_all()
        library = ActivityLibrary.load([Path(d) for d in self.options.library_dirs])
        self._study_ds = load_study_dataset(self.dataset, self.data_dir, library)
        self._ds = self._study_ds.dataset
        if self.options.cache_dir is None:
            self.options = replace(self.options, cache_dir=str(out / "cache"))
        plans = self._plans()
        probe = Evaluation(self._config(("real",), self.alpha), self._ds)
        folds = probe.folds(self._ds.windows(probe.config.window_s, probe.config.overlap))
        total = sum(len(methods) for _, methods, _ in plans) * len(folds) * self.seeds
        results = AblationResults(self._settings(folds))
        done = 0
        runs: dict[str, Any] = {}
        for name, methods, alpha in plans:
            extra = None
            if name == "caption":
                extra = self._register_matched(library, out / "runs" / "caption" / "matched")
            evaluation = paired_evaluation(self._config(methods, alpha, extra), self._ds, out / "runs" / name)

            def update(description: str, d: int, t: int, _name: str = name, _base: int = done) -> None:
                if progress:
                    progress(_base + d, total, f"{_name}: {description}")

            runs[name] = evaluation.run(update)
            done += len(methods) * len(folds) * self.seeds
        results.parts = self._collect(runs, folds, out, library)
        results.elapsed_s = time.perf_counter() - start
        return results

    def _plans(self) -> list[tuple[str, tuple[str, ...], float]]:
        """(run name, methods, alpha) of each evaluation the chosen parts need."""
        plans = []
        if "caption" in self.parts:
            plans.append(("caption", ("real", *CONDITION_METHODS.values()), self.alpha))
        methods: list[str] = []
        if "components" in self.parts:
            methods += COMPONENT_METHODS
        if "grounding" in self.parts:
            methods += ["real", *GROUNDING_METHODS]
        if methods:
            plans.append(("components", tuple(dict.fromkeys(methods)), self.alpha))
        if "alpha" in self.parts:
            for a in self.alphas:
                if methods and "vsmp" in methods and np.isclose(a, self.alpha):
                    continue  # the components run holds VSMP-IMU at this alpha
                plans.append((f"alpha-{a:g}", ("vsmp",), a))
        return plans

    def _register_matched(self, library: ActivityLibrary, accounting_dir: Path) -> dict[str, Any]:
        from vsmp_imu.har.synthetic import register_method

        config = self._matched_config()
        shared = MatchedSource(config, self.options, library, accounting_dir)
        params = {}
        for cond, method in CONDITION_METHODS.items():
            register_method(method, lambda _c=cond, **_: MatchedCondition(_c, shared), CONDITION_TITLES[cond])
            # the records' digest covers every setting of the matched generation
            params[method] = {"matched": config.as_dict(), "source": self.options.source,
                              "cache_dir": self.options.cache_dir}
        return params

    # -- summaries ---------------------------------------------------------------------------
    def _collect(self, runs: dict[str, Any], folds: list[str], out: Path, library) -> dict[str, Any]:
        parts: dict[str, Any] = {}
        if "caption" in runs:
            parts["caption"] = self._caption(runs["caption"], folds, out / "runs" / "caption" / "matched")
        if "components" in runs:
            res = runs["components"]
            if "components" in self.parts:
                parts["components"] = _table(res, COMPONENT_METHODS, COMPONENT_TITLES, "vsmp")
                parts["components"]["refinement_changed"] = self._refinement_changes(library)
            if "grounding" in self.parts:
                parts["grounding"] = _table(res, GROUNDING_METHODS, GROUNDING_TITLES, "vsmp")
        if "alpha" in self.parts:
            rows = []
            for a in self.alphas:
                res = runs.get(f"alpha-{a:g}") or runs.get("components")
                row = _row(res, "vsmp")
                rows.append({"alpha": a, **row})
            parts["alpha"] = {"rows": rows, "best_alpha": _best(rows, "alpha")}
        return parts

    def _caption(self, res, folds: list[str], accounting_dir: Path) -> dict[str, Any]:
        methods = {"real": "real", **CONDITION_METHODS}
        rows = {c: _row(res, m) for c, m in methods.items()}
        means = {c: rows[c]["macro_f1_mean"] for c in CONDITIONS}
        effects = None
        if all(v is not None for v in means.values()):
            effects = {
                "representation": ((means["S0"] + means["S1"]) - (means["C0"] + means["C1"])) / 2,
                "variation": ((means["C1"] + means["S1"]) - (means["C0"] + means["S0"])) / 2,
                "interaction": (means["S1"] - means["S0"]) - (means["C1"] - means["C0"]),
            }
        paired = {f"{a}-{b}": _paired(res, methods[a], methods[b]) for a, b in PAIRS}
        accounting, prompts = [], []
        for seed in range(self.seeds):
            for fold in folds:
                path = accounting_dir / f"{fold_name(self.protocol, self.budget, seed, fold)}.json"
                if path.exists():
                    import json

                    data = json.loads(path.read_text(encoding="utf-8"))
                    accounting.append({"fold": fold, "seed": seed, **data["summary"]})
                    if not prompts:
                        prompts = data["prompts"]
        return {"rows": rows, "effects": effects, "paired": paired, "accounting": accounting,
                "accounting_pooled": _pool_accounting(accounting), "prompts": prompts,
                "identical": {f"{a}={b}": _identical(res, methods[a], methods[b])
                              for a, b in (("S0", "C0"), ("S1", "C1"))},
                "identical_windows": {pair: sum(bool(f.get("identical_windows", {}).get(pair)) for f in accounting)
                                      for pair in ("S0=C0", "S1=C1", "S1=S0")}}

    def _refinement_changes(self, library: ActivityLibrary) -> dict[str, Any]:
        """How many of the source SMPs semantic refinement changes (0: w/o refinement = full)."""
        from vsmp_imu.pipeline.method import make_smp_source
        from vsmp_imu.smp.refine import Refiner

        info = self._ds.info
        try:
            sources = make_smp_source(self.options.source, library).smps(info.name, info.label_names)
        except Exception as exc:  # reported, not fatal: the evaluation itself already ran
            return {"error": str(exc)}
        smps = [s for items in sources.values() for _, s in items if hasattr(s, "smp_id")]
        changed = [s.activity_label for s in smps if Refiner(library).refine(s).smp.smp_id != s.smp_id]
        return {"sources": len(smps), "changed": len(changed), "changed_labels": changed}


# -- helpers on EvalResults --------------------------------------------------------------------
def _records(res, method: str) -> list[dict[str, Any]]:
    return [r for r in res.records if r["method"] == method]


def _row(res, method: str) -> dict[str, Any]:
    from vsmp_imu.har.metrics import mean_std

    recs = _records(res, method) if res is not None else []
    mean, std, n = mean_std([r["macro_f1"] for r in recs])
    acc_mean, acc_std, _ = mean_std([r["accuracy"] for r in recs])
    return {"method": method, "macro_f1_mean": mean, "macro_f1_std": std, "n": n,
            "accuracy_mean": acc_mean, "accuracy_std": acc_std,
            "n_synthetic_mean": float(np.mean([r["n_synthetic"] for r in recs])) if recs else None,
            "per_record": [{"fold": r["fold"], "seed": r["seed"], "macro_f1": r["macro_f1"],
                            "n_synthetic": r["n_synthetic"]} for r in recs]}


def _paired(res, a: str, b: str) -> dict[str, Any]:
    """Mean and std of the per-(fold, seed) Macro-F1 difference a - b, and wins/ties/losses."""
    from vsmp_imu.har.metrics import mean_std

    left = {(r["fold"], r["seed"]): r["macro_f1"] for r in _records(res, a)}
    right = {(r["fold"], r["seed"]): r["macro_f1"] for r in _records(res, b)}
    diffs = [left[k] - right[k] for k in left if k in right and left[k] is not None and right[k] is not None]
    mean, std, n = mean_std(diffs)
    return {"mean": mean, "std": std, "n": n, "wins": sum(d > 1e-12 for d in diffs),
            "ties": sum(abs(d) <= 1e-12 for d in diffs), "losses": sum(d < -1e-12 for d in diffs)}


def _identical(res, a: str, b: str) -> bool:
    """Same predictions on every record (equal confusion matrices and Macro-F1)."""
    left = {(r["fold"], r["seed"]): (r["macro_f1"], r["confusion"]) for r in _records(res, a)}
    right = {(r["fold"], r["seed"]): (r["macro_f1"], r["confusion"]) for r in _records(res, b)}
    return bool(left) and left.keys() == right.keys() and all(left[k] == right[k] for k in left)


def _table(res, methods: tuple[str, ...], titles: dict[str, str], reference: str) -> dict[str, Any]:
    rows = []
    for m in methods:
        row = {"title": titles[m], **_row(res, m)}
        if m != reference:
            row["delta_vs_full"] = _paired(res, m, reference)
            row["identical_to_full"] = _identical(res, m, reference)
        rows.append(row)
    return {"rows": rows}


def _best(rows: list[dict[str, Any]], key: str) -> Any:
    scored = [r for r in rows if r["macro_f1_mean"] is not None]
    return max(scored, key=lambda r: r["macro_f1_mean"])[key] if scored else None


def _pool_accounting(folds: list[dict[str, Any]]) -> dict[str, Any]:
    """Mean and std over folds of the generation accounting; pooled acceptance rates."""
    if not folds:
        return {}

    def ms(key: str) -> dict[str, float]:
        values = np.array([f.get(key, 0) for f in folds], dtype=float)
        return {"mean": float(values.mean()), "std": float(values.std(ddof=1)) if len(values) > 1 else 0.0}

    attempted = sum(f["attempted_blocks"] for f in folds)
    out = {
        "folds": len(folds), "classes": ms("classes"), "source_smps": ms("source_smps"),
        "target_blocks": ms("target_blocks"), "attempted_blocks": ms("attempted_blocks"),
        "accepted_blocks": ms("accepted_blocks"), "unfilled_blocks": ms("unfilled_blocks"),
        "retained_motions_per_condition": ms("retained_motions_per_condition"),
        "selected_windows_per_condition": ms("selected_windows_per_condition"),
        "block_acceptance": sum(f["accepted_blocks"] for f in folds) / attempted if attempted else None,
        "unresolvable_blocks": ms("unresolvable_blocks"), "independent_acceptance": {}, "rejected_by": {},
        "per_class": {},
    }
    labels = list(dict.fromkeys(label for f in folds for label in f["per_class"]))
    for label in labels:
        rows = [f["per_class"][label] for f in folds if label in f["per_class"]]
        out["per_class"][label] = {
            key: {"mean": float(np.mean([r[key] for r in rows])),
                  "std": float(np.std([r[key] for r in rows], ddof=1)) if len(rows) > 1 else 0.0}
            for key in ("budget", "attempted_blocks", "accepted_blocks", "selected_windows", "shortfall")}
    for cond in CONDITIONS:
        passed = sum(f["per_condition"][cond]["passed_samples"] for f in folds)
        tried = sum(f["per_condition"][cond]["attempted_samples"] for f in folds)
        out["independent_acceptance"][cond] = passed / tried if tried else None
        reasons: dict[str, int] = {}
        for f in folds:
            for k, v in f["per_condition"][cond]["rejected_by"].items():
                reasons[k] = reasons.get(k, 0) + v
        out["rejected_by"][cond] = reasons
    resolution = [r for f in folds[:1] for r in f.get("prompt_resolution", [])]
    if resolution:
        out["prompt_resolution"] = {
            cond: {"prompts": sum(r["condition"] == cond for r in resolution),
                   "mismatch": sum(r["condition"] == cond and not r["match"] for r in resolution),
                   "examples": sorted({f"{r['expected']} -> {r['resolved']}" for r in resolution
                                       if r["condition"] == cond and not r["match"]})}
            for cond in ("C0", "C1")}
    return out
