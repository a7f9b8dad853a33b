"""The strictly matched caption--SMP 2x2 (paper, "Strictly Matched Caption--SMP Ablation
Protocol" and appendix "Matched caption--SMP prompt construction").

Four conditions per source SMP S_i (refined) and generation slot k:

| id | prompt Z_ik | what the backend receives |
| --- | --- | --- |
| C0 | C_i (the activity's generic caption, verbatim) | text |
| C1 | C_i (+) A_ik (`caption_plus_attributes`) | text |
| S0 | T_HY(S_i) | the refined SMP |
| S1 | T_HY(S_i^(k)) | the slot's constrained variant |

K = 4 slots: 1 the reference execution, 2 a tempo intervention, 3 an
amplitude intervention, 4 one more activity-valid intervention (repetitions,
primitive duration, symmetry, dominant side or displacement: a seeded choice
among those the SMP's constraints allow). A slot whose intervention the SMP
does not allow (static postures list no variant field) is the reference
execution. A_ik = `attribute_phrase(S_i^(k))` is inserted verbatim in the C1
prompt and is part of the S1 verbalization.

Requested values stay inside the uncertainty-conditioned ranges of
augmentation (appendix "SMP perturbation ranges"): a change of at least half
and at most all of the radius Delta(u) = (1 - u) Delta_max, in a seeded
direction.

A *block* is the four conditions' samples for one (source, slot, replicate)
generated with one seed shared by the four. It enters the synthetic set only
when all four samples pass the filters; otherwise the whole block is
generated again with the next seed of the fold's shared reserve-seed list.
Replicates (new blocks with new seeds) are added to a class while any
condition has fewer retained windows than the class's budget (only once a
block of the class has passed: until then its failed blocks are retried).
Finally every condition gives the same number of windows per class,
min(budget, fewest retained windows over the four conditions), taken
round-robin over the accepted blocks in one seeded order shared by the four
conditions, so the selected windows come from the same blocks (and identical
samples give identical windows). With the procedural backend a block whose
C0 or C1 prompt names no library activity (its text parser is deterministic:
every seed fails alike) is tried once and then counted as unresolvable.

Filters: the full method's quality filter (appendix "Quality Filtering";
thresholds from the fold's real training windows, the same for the four
conditions), applied to every window of a sample as in the pipeline: motion
plausibility of the skeleton, inertial plausibility of the window, class
faithfulness (tau_cls fixed, default 0.60, not re-selected per condition) and
redundancy against the windows the same condition has already retained in the
class. A sample *passes* when its motion passes and at least one of its
windows (and at least `min_window_share` of them) passes every window filter;
it contributes only those windows. Rank grounding is fitted per condition on
its first-round samples (F_v of that condition, G_r = D_rank) and then kept
fixed, so a decision never changes afterwards.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.filtering.faithfulness import TAU_DEFAULT, class_verdicts
from vsmp_imu.filtering.verdict import Verdict
from vsmp_imu.grounding.rank import RankGrounder
from vsmp_imu.har.dataset import DatasetInfo
from vsmp_imu.har.features import ecdf_features
from vsmp_imu.har.windows import Windows
from vsmp_imu.pipeline.fold import (
    channel_index,
    fit_filters,
    fit_rank_grounders,
    make_filter_job,
    prepare,
    window,
)
from vsmp_imu.pipeline.sample import SampleResult, SampleTask, cached_synthesize
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import SMP
from vsmp_imu.smp.augment import (
    AMPLITUDE_MAX_LEVELS,
    DISPLACEMENT_MAX_FRACTION,
    DURATION_MAX_FRACTION,
    REPETITION_MAX_CYCLES,
    TEMPO_MAX_LEVELS,
)
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import Refiner
from vsmp_imu.smp.verbalize import (
    attribute_phrase,
    caption_plus_attributes,
    generic_caption,
    verbalize,
)

CONDITIONS = ("C0", "C1", "S0", "S1")
CONDITION_TITLES = {
    "C0": "C0: Generic caption",
    "C1": "C1: Caption + matched attributes",
    "S0": "S0: Unaugmented refined SMP",
    "S1": "S1: Constrained augmented SMP",
}
# Paper: "a reference execution, a tempo intervention, an amplitude intervention, and one
# additional activity-valid intervention".
SLOT_KINDS = ("reference", "tempo", "amplitude", "extra")
EXTRA_KINDS = ("repetitions", "duration", "symmetry", "dominant_side", "displacement")
MIN_CHANGE = 0.5  # a requested change is at least half of the allowed radius
DECIMALS = 4
_UNCERTAINTY_FIELD = {"tempo": "tempo", "amplitude": "amplitude", "repetitions": "repetition_count",
                      "duration": "primitive_duration", "symmetry": "symmetry",
                      "dominant_side": "dominant_side", "displacement": "global_displacement"}


# -- slot requests ------------------------------------------------------------------------------
@dataclass(frozen=True)
class SlotRequest:
    """What slot k asks for: the kind of intervention, the variant S^(k) and its phrase A."""

    slot: int
    kind: str  # reference | tempo | amplitude | repetitions | duration | symmetry | ...
    smp: SMP
    phrase: str
    requested: dict[str, Any] = field(default_factory=dict)  # field -> {before, after}
    note: str = ""

    @property
    def phase_durations(self) -> bool:
        return self.kind == "duration"

    def as_dict(self) -> dict[str, Any]:
        return {"slot": self.slot, "kind": self.kind, "phrase": self.phrase, "requested": self.requested,
                "note": self.note, "smp_id": self.smp.smp_id}


def _radius(smp: SMP, kind: str, conditioned: bool) -> float:
    return 1.0 - float(getattr(smp.uncertainty, _UNCERTAINTY_FIELD[kind])) if conditioned else 1.0


def allowed_interventions(smp: SMP, uncertainty_conditioned: bool = True) -> list[str]:
    """The interventions the SMP's constraints allow (variant field, known value, radius > 0)."""
    variant = set(smp.constraints.variant_fields)
    ea, ts = smp.execution_attributes, smp.temporal_structure
    extent = smp.displacement_extent_m()
    applicable = {
        "tempo": "tempo" in variant and smp.tempo_level() is not None,
        "amplitude": "amplitude" in variant and smp.amplitude_level() is not None,
        "repetitions": ("repetition_count" in variant and ts.is_repetitive
                        and smp.repetition_count() is not None
                        and math.floor(_radius(smp, "repetitions", uncertainty_conditioned)
                                       * REPETITION_MAX_CYCLES) >= 1),
        "duration": "primitive_duration" in variant and len(smp.primitive_sequence) > 1,
        "symmetry": "symmetry" in variant and ea.symmetry in ("symmetric", "asymmetric"),
        "dominant_side": "dominant_side" in variant and ea.dominant_side in ("left", "right"),
        "displacement": "global_displacement" in variant and extent is not None and extent > 0,
    }
    return [k for k, ok in applicable.items() if ok and _radius(smp, k, uncertainty_conditioned) > 0]


def _level(value: float, radius: float, rng: np.random.Generator) -> float:
    """A new 0..2 level at distance in [MIN_CHANGE, 1] x radius, in a seeded direction."""
    step = radius * rng.uniform(MIN_CHANGE, 1.0)
    sign = 1.0 if rng.random() < 0.5 else -1.0
    if not 0.0 <= value + sign * step <= 2.0:
        sign = -sign
    return round(min(2.0, max(0.0, value + sign * step)), DECIMALS)


def _factor(radius: float, rng: np.random.Generator) -> float:
    step = radius * rng.uniform(MIN_CHANGE, 1.0)
    return round(1.0 + (step if rng.random() < 0.5 else -step), DECIMALS)


def _apply(smp: SMP, kind: str, rng: np.random.Generator, conditioned: bool,
           central_primitive: str | None) -> tuple[SMP, dict[str, Any]]:
    """The SMP with one intervention of `kind` and the field it changed."""
    radius = _radius(smp, kind, conditioned)
    d = smp.model_dump(mode="json")
    ea = d["execution_attributes"]
    if kind in ("tempo", "amplitude"):
        level = smp.tempo_level() if kind == "tempo" else smp.amplitude_level()
        dmax = TEMPO_MAX_LEVELS if kind == "tempo" else AMPLITUDE_MAX_LEVELS
        ea[kind] = _level(float(level), radius * dmax, rng)
        return SMP.model_validate(d), {f"execution_attributes.{kind}": {"before": level, "after": ea[kind]}}
    if kind == "repetitions":
        count = smp.repetition_count()
        top = max(1, math.floor(radius * REPETITION_MAX_CYCLES))
        delta = int(rng.integers(max(1, math.ceil(MIN_CHANGE * top)), top + 1))
        new = count + delta if rng.random() < 0.5 or count - delta < 1 else count - delta
        return (intervene(smp, "repetitions", new),
                {"temporal_structure.repetition_count": {"before": count, "after": new}})
    if kind == "duration":
        factor = _factor(radius * DURATION_MAX_FRACTION, rng)
        new = intervene(smp, "duration", factor, central_primitive)
        return new, {"primitive_durations": {"before": smp.primitive_durations.model_dump(mode="json"),
                                             "after": new.primitive_durations.model_dump(mode="json"),
                                             "central_factor": factor}}
    if kind == "symmetry":
        other = "asymmetric" if ea["symmetry"] == "symmetric" else "symmetric"
        return (intervene(smp, "symmetry", other),
                {"execution_attributes.symmetry": {"before": ea["symmetry"], "after": other}})
    if kind == "dominant_side":
        before = ea["dominant_side"]
        ea["dominant_side"] = "left" if before == "right" else "right"
        return SMP.model_validate(d), {"execution_attributes.dominant_side": {"before": before,
                                                                              "after": ea["dominant_side"]}}
    if kind == "displacement":
        extent = smp.displacement_extent_m()
        ea["global_displacement"] = round(extent * _factor(radius * DISPLACEMENT_MAX_FRACTION, rng), DECIMALS)
        return SMP.model_validate(d), {"execution_attributes.global_displacement": {
            "before": smp.execution_attributes.global_displacement, "after": ea["global_displacement"]}}
    raise ValidationError(f"unknown intervention {kind!r}", field="kind",
                          allowed=", ".join(("tempo", "amplitude", *EXTRA_KINDS)))


def plan_slots(smp: SMP, seed: int, key: str, k: int = 4, uncertainty_conditioned: bool = True,
               central_primitive: str | None = None) -> list[SlotRequest]:
    """The K slot requests of one source SMP (see module doc); seeded by (seed, key)."""
    if not 1 <= k <= len(SLOT_KINDS):
        raise ConfigError(f"the matched ablation has {len(SLOT_KINDS)} slot kinds; k={k}", field="k",
                          allowed=f"1..{len(SLOT_KINDS)}")
    allowed = allowed_interventions(smp, uncertainty_conditioned)
    extras = [e for e in EXTRA_KINDS if e in allowed]
    out = []
    for slot, kind in enumerate(SLOT_KINDS[:k]):
        rng = rng_for(seed, "matched-slot", key, slot)
        if kind == "extra":
            kind = extras[int(rng.integers(len(extras)))] if extras else "extra"
        if kind == "reference":
            out.append(SlotRequest(slot, "reference", smp, attribute_phrase(smp)))
            continue
        if kind not in allowed:
            what = "no further intervention" if kind == "extra" else f"no {kind} change"
            out.append(SlotRequest(slot, "reference", smp, attribute_phrase(smp),
                                   note=f"the SMP's constraints allow {what}: reference execution"))
            continue
        variant, requested = _apply(smp, kind, rng, uncertainty_conditioned, central_primitive)
        out.append(SlotRequest(slot, kind, variant, attribute_phrase(variant, kind == "duration"),
                               requested))
    return out


@dataclass(frozen=True)
class SourcePlan:
    """One source SMP of a class: its caption, refined SMP and slot requests."""

    label: str
    label_index: int
    source: str
    caption: str
    smp: SMP  # refined base S_i
    slots: tuple[SlotRequest, ...]
    refinement_changed: bool = False

    def inputs(self, slot: int) -> dict[str, tuple[str, str]]:
        """Per condition: (SMP JSON or "", prompt) of generation slot `slot`."""
        req = self.slots[slot]
        return {
            "C0": ("", self.caption),
            "C1": ("", caption_plus_attributes(self.caption, req.phrase)),
            "S0": (self.smp.canonical_json(), verbalize(self.smp)),
            "S1": (req.smp.canonical_json(), verbalize(req.smp, req.phase_durations)),
        }

    def prompts(self) -> list[dict[str, Any]]:
        return [{"class": self.label, "source": self.source, **self.slots[s].as_dict(),
                 **{c: p for c, (_, p) in self.inputs(s).items()}} for s in range(len(self.slots))]


def source_plans(sources: dict[str, list[tuple[str, Any]]], label_names: tuple[str, ...], seed: int,
                 fold: str, library: ActivityLibrary, k: int = 4, refine: bool = True,
                 uncertainty_conditioned: bool = True) -> list[SourcePlan]:
    """A SourcePlan per (class, source SMP); sources that are not SMPs are refused."""
    refiner = Refiner(library)
    plans = []
    for i, label in enumerate(label_names):
        for src, base in sources.get(label, []):
            if not isinstance(base, SMP):
                raise ConfigError(f"the matched caption-SMP ablation needs source SMPs; '{src}' is not one",
                                  field="source", allowed="library, smp:DIR, video:DIR")
            smp = refiner.refine(base).smp if refine else base
            try:
                entry = library.resolve(smp.activity_label)
            except ValidationError:
                entry = None
            caption = generic_caption(entry if entry is not None else smp, library)
            central = entry.central_primitive if entry is not None else None
            slots = plan_slots(smp, seed, f"{fold}/{label}/{src}", k, uncertainty_conditioned, central)
            plans.append(SourcePlan(label, i, src, caption, smp, tuple(slots),
                                    refinement_changed=smp.smp_id != base.smp_id))
    return plans


# -- the matched generator --------------------------------------------------------------------
# The full method's spec with the 2x2's own sizes: retained windows wanted per condition, per
# budgeted window (oversample) and generation rounds (first attempt plus replenishments).
MATCHED_SPEC = GenerationSpec(oversample=1.0, max_rounds=6)
# The spec fields the 2x2 uses (recorded in its settings).
MATCHED_SPEC_FIELDS = ("k", "backend", "refine", "uncertainty_conditioned", "sim_in_the_loop", "rank_grounding",
                       "per_class_rank", "estimate_mounting", "noise", "quality_filter", "min_validator_windows",
                       "oversample", "max_rounds", "hop_fraction", "val_fraction", "duration_s", "library_dirs")


@dataclass(frozen=True)
class MatchedConfig:
    """Settings of the matched 2x2: a generation spec (switches as the full method's) and the
    2x2's own rules."""

    spec: GenerationSpec = MATCHED_SPEC
    tau_cls: float = TAU_DEFAULT  # appendix "Quality Filtering": 0.60, the same for the four conditions
    # a sample passes when at least one of its windows, and at least this share, pass every filter
    min_window_share: float = 0.0
    max_replicates: int = 12

    def __post_init__(self) -> None:
        if not 1 <= self.spec.k <= len(SLOT_KINDS):
            raise ConfigError(f"k must be 1..{len(SLOT_KINDS)}, got {self.spec.k}", field="k")
        if not 0.0 <= self.min_window_share <= 1.0:
            raise ConfigError("min_window_share must be in [0, 1]", field="min_window_share")
        if self.spec.max_rounds < 1 or self.max_replicates < 1:
            raise ConfigError("max_rounds and max_replicates must be >= 1", field="max_rounds")

    @classmethod
    def from_spec(cls, spec: GenerationSpec, **changes: Any) -> MatchedConfig:
        """The 2x2 of a study's spec: its k, backend, rank grounding and library with the 2x2's
        sizes; `changes` set spec fields or the 2x2's own."""
        own = {k: changes.pop(k) for k in list(changes) if k in ("tau_cls", "min_window_share", "max_replicates")}
        base = replace(MATCHED_SPEC, k=spec.k, backend=spec.backend, per_class_rank=spec.per_class_rank,
                       library_dirs=spec.library_dirs)
        return cls(replace(base, **changes), **own)

    def as_dict(self) -> dict[str, Any]:
        return {**{name: getattr(self.spec, name) for name in MATCHED_SPEC_FIELDS}, "tau_cls": self.tau_cls,
                "min_window_share": self.min_window_share, "max_replicates": self.max_replicates}


@dataclass
class Block:
    """One (source, slot, replicate) of a class; `attempt` counts its regenerations."""

    plan: int  # index into the source plans
    slot: int
    replicate: int
    seed: int
    attempt: int = 0
    accepted: bool = False


@dataclass
class MatchedOutput:
    """Per-condition windows of one fold, every attempted block and the accounting."""

    windows: dict[str, Windows]
    attempts: list[dict[str, Any]]
    plans: list[SourcePlan]
    summary: dict[str, Any]


class _Pool:
    """Retained windows and their normalized validator embeddings, per condition and class;
    each window remembers its sample key and its block (the same for the four conditions)."""

    def __init__(self) -> None:
        self.X: dict[tuple[str, int], list[np.ndarray]] = {}
        self.z: dict[tuple[str, int], list[np.ndarray]] = {}
        self.keys: dict[tuple[str, int], list[str]] = {}
        self.blocks: dict[tuple[str, int], list[str]] = {}

    def count(self, cond: str, cls: int) -> int:
        return len(self.X.get((cond, cls), []))

    def embeddings(self, cond: str, cls: int) -> np.ndarray:
        z = self.z.get((cond, cls), [])
        return np.stack(z) if z else np.zeros((0, 0))

    def add(self, cond: str, cls: int, X: np.ndarray, z: np.ndarray, key: str, block: str) -> None:
        self.X.setdefault((cond, cls), []).extend(X)
        self.z.setdefault((cond, cls), []).extend(z)
        self.keys.setdefault((cond, cls), []).extend([key] * len(X))
        self.blocks.setdefault((cond, cls), []).extend([block] * len(X))

    def block_order(self, cls: int) -> list[str]:
        """The accepted blocks of a class, in acceptance order (the same in every condition)."""
        return list(dict.fromkeys(self.blocks.get((CONDITIONS[0], cls), [])))


def matched_selection(blocks: list[str], order: list[str], n: int) -> np.ndarray:
    """Indices of `n` windows (of a condition whose windows come from `blocks`, one entry per
    window) taken round-robin over the blocks in the shared `order`: the first window of every
    block, then the second, and so on. The same order in every condition keeps the selected
    windows coming from the same blocks, and identical pools give identical selections."""
    per_block: dict[str, list[int]] = {}
    for i, b in enumerate(blocks):
        per_block.setdefault(b, []).append(i)
    picked: list[int] = []
    depth = 0
    while len(picked) < n:
        row = [per_block[b][depth] for b in order if b in per_block and depth < len(per_block[b])]
        if not row:
            break
        picked += row[: n - len(picked)]
        depth += 1
    return np.sort(np.array(picked, dtype=int))


def _normalize(z: np.ndarray) -> np.ndarray:
    return z / (np.linalg.norm(z, axis=1, keepdims=True) + 1e-12)


def redundancy_against(z: np.ndarray, retained: np.ndarray, tau: float,
                       eligible: np.ndarray) -> list[Verdict]:
    """Greedy redundancy of one sample's windows (normalized embeddings `z`) against the
    windows already `retained` by its condition and its own earlier kept windows."""
    kept = list(retained) if len(retained) else []
    out = []
    for i in range(len(z)):
        if not eligible[i]:
            out.append(Verdict(False, "redundancy", "not considered (rejected earlier)", {"tau_nn": tau}))
            continue
        dist = float(np.sqrt(((np.asarray(kept) - z[i]) ** 2).sum(axis=1).min())) if kept else float("inf")
        values = {"nn_distance": dist if np.isfinite(dist) else -1.0, "tau_nn": tau}
        if dist <= tau:
            out.append(Verdict(False, "redundancy", f"near-duplicate (distance {dist:.3f} <= tau_nn {tau:.3f})",
                               values))
        else:
            kept.append(z[i])
            out.append(Verdict(True, "redundancy", "", values))
    return out


class MatchedBlockGenerator:
    """Generate the four matched conditions of one fold (see module doc).

    `generate(info, train, sources, budget, seed, fold)` takes the fold's real
    training windows only; `sources` maps class -> [(source id, base SMP)].
    """

    def __init__(self, config: MatchedConfig, executor, cache_dir: Path | None = None,
                 library: ActivityLibrary | None = None) -> None:
        self.config = config
        self.executor = executor
        self.cache_dir = cache_dir
        self.library = library

    # -- set-up -----------------------------------------------------------------------------
    def _filters(self, info: DatasetInfo, train: Windows, seed: int, fold: str) -> dict[str, Any]:
        c = self.config
        job = make_filter_job(info, train, seed, fold, c.spec.val_fraction, c.spec.min_validator_windows)
        models = fit_filters(job)
        return {"plausibility": {loc.name: (channel_index(info, loc), models.plausibility[loc.name])
                                 for loc in info.locations},
                "validator": models.validator, "validated": job.validated(),
                "thresholds": models.nn_thresholds}

    def _tasks(self, plans: list[SourcePlan], blocks: list[Block], fold: str, fs_hz: float,
               loc_tasks) -> list[SampleTask]:
        c = self.config
        tasks = []
        for b in blocks:
            plan = plans[b.plan]
            for cond, (smp_json, prompt) in plan.inputs(b.slot).items():
                tasks.append(SampleTask(
                    key=f"{fold}/{cond}/{plan.label}/{b.plan}/k{b.slot}/r{b.replicate}/a{b.attempt}",
                    label=plan.label, label_index=plan.label_index, source=plan.source, variant=b.slot,
                    smp_json=smp_json, prompt=prompt, backend=c.spec.backend, seed=b.seed, fs_hz=fs_hz,
                    locations=loc_tasks[plan.label], sim_in_the_loop=c.spec.sim_in_the_loop, noise=c.spec.noise,
                    duration_s=c.spec.duration_s, library_dirs=tuple(c.spec.library_dirs)))
        return tasks

    def _ground(self, samples: list[SampleResult], grounders: dict[str, RankGrounder]):
        out = []
        for r in samples:
            g = {}
            for name, sig in r.signals.items():
                if not self.config.spec.rank_grounding or name not in grounders:
                    g[name] = sig
                    continue
                # labels always, as the pipeline's stage 4 (`apply_rank_grounders`) passes them
                g[name] = grounders[name].transform(sig, np.full(len(sig), r.label_index))
            out.append(g)
        return out

    # -- one round ----------------------------------------------------------------------------
    def _judge(self, info, results: dict[str, SampleResult], grounders, filters,
               length: int, hop: int) -> dict[str, dict[str, Any]]:
        """Windows, embeddings and window verdicts (all but redundancy) of each sample."""
        c = self.config
        out: dict[str, dict[str, Any]] = {}
        for key, r in results.items():
            if r.error or not r.signals:
                out[key] = {"error": r.error or "no signal", "X": None}
        ok = [r for r in results.values() if not r.error and r.signals]
        if not ok:
            return out
        grounded = self._ground(ok, grounders)
        windows = window(info, ok, grounded, length, hop)  # the full method's stage 5
        X, y, records = windows.X, windows.y, windows.records
        by_sample: dict[str, list[int]] = {}
        for i, rec in enumerate(records):
            by_sample.setdefault(rec.sample, []).append(i)
        feats = ecdf_features(X) if len(X) else None  # once, for the probabilities and the embedding
        proba = filters["validator"].predict_proba_features(feats) if len(X) else np.zeros((0, info.n_classes))
        z = _normalize(filters["validator"].embed_features(feats)) if len(X) else np.zeros((0, 1))
        class_v = class_verdicts(proba, y, c.tau_cls, filters["validated"]) if len(X) else []
        for r in ok:
            idx = by_sample.get(r.key, [])
            verdicts = []
            for i in idx:
                v = [filters["plausibility"][name][1].check_window(X[i][:, filters["plausibility"][name][0]],
                                                                  int(y[i]))
                     for name in records[i].locations]
                verdicts.append([*v, class_v[i]])
            idx = np.array(idx, dtype=int)
            out[r.key] = {"error": None, "X": X[idx], "z": z[idx], "verdicts": verdicts,
                          "motion": r.provenance.motion_verdict}
        return out

    def _decide(self, judged: dict[str, Any], cond: str, cls: int, pool: _Pool, tau_nn: float) -> dict[str, Any]:
        """Pass or fail of one sample, the filter that failed it and the windows it keeps."""
        c = self.config
        if judged["X"] is None:
            return {"passed": False, "reason": "synthesis", "detail": judged["error"], "windows": 0}
        n = len(judged["X"])
        if n == 0:
            return {"passed": False, "reason": "no window", "detail": "shorter than one window", "windows": 0}
        if not c.spec.quality_filter:
            return {"passed": True, "reason": "", "detail": "", "windows": n, "kept": n,
                    "keep": np.ones(n, bool)}
        if not judged["motion"].passed:
            return {"passed": False, "reason": "motion", "detail": judged["motion"].reason, "windows": n,
                    "kept": 0}
        first = [next((v for v in vs if not v.passed), None) for vs in judged["verdicts"]]
        red = redundancy_against(judged["z"], pool.embeddings(cond, cls), tau_nn,
                                 np.array([f is None for f in first], dtype=bool))
        keep = np.array([f is None and r.passed for f, r in zip(first, red, strict=True)], dtype=bool)
        passed = bool(keep.any() and keep.mean() >= c.min_window_share)
        out = {"passed": passed, "reason": "", "detail": "", "windows": n, "kept": int(keep.sum()),
               "keep": keep}
        if not passed:
            failures = Counter((f or r).filter for f, r, k in zip(first, red, keep, strict=True) if not k)
            out["reason"] = failures.most_common(1)[0][0]
            out["detail"] = (f"{int(keep.sum())} of {n} windows pass; rejected by "
                             + ", ".join(f"{k} {v}" for k, v in sorted(failures.items())))
        return out

    # -- the fold -------------------------------------------------------------------------------
    def generate(self, info: DatasetInfo, train: Windows, sources: dict[str, list[tuple[str, Any]]],
                 budget: np.ndarray, seed: int, fold: str, progress=None) -> MatchedOutput:
        c = self.config
        budget = np.asarray(budget, dtype=np.int64)
        library = self.library if self.library is not None else ActivityLibrary.load(
            [Path(d) for d in c.spec.library_dirs])
        length = train.n_timesteps
        hop = max(1, int(round(c.spec.hop_fraction * length)))
        wanted = {n: sources[n] for i, n in enumerate(info.label_names) if budget[i] > 0 and n in sources}
        plans = source_plans(wanted, info.label_names, seed, fold, library, c.spec.k, c.spec.refine,
                             c.spec.uncertainty_conditioned)
        setup = prepare(c.spec, info, train, wanted, seed)  # the full method's stage 1
        loc_plan, d_rank, loc_tasks = setup.plan, setup.d_rank, setup.locations
        filters = self._filters(info, train, seed, fold)

        by_class: dict[int, list[int]] = {}
        for p, plan in enumerate(plans):
            by_class.setdefault(plan.label_index, []).append(p)
        replicates = dict.fromkeys(by_class, 0)
        reserve = _ReserveSeeds(seed, fold)
        resolution = prompt_resolution(plans, library) if c.spec.backend == "procedural" else []
        # (plan, slot) whose caption prompt names no library activity: the procedural backend's
        # parser is deterministic, so every seed fails the same way; tried once, never again
        dead = {(r["plan"], r["slot"]) for r in resolution if r["resolved"] is None}

        def new_blocks(cls: int) -> list[Block]:
            rep = replicates[cls]
            replicates[cls] += 1
            return [Block(p, s, rep, _primary_seed(seed, fold, plans[p], s, rep))
                    for p in by_class[cls] for s in range(len(plans[p].slots))
                    if rep == 0 or (p, s) not in dead]

        all_blocks: list[Block] = [b for cls in sorted(by_class) for b in new_blocks(cls)]
        pending = list(all_blocks)
        pool = _Pool()
        grounders: dict[str, dict[str, RankGrounder]] = {}
        attempts: list[dict[str, Any]] = []
        for round_index in range(c.spec.max_rounds):
            if not pending:
                break
            tasks = self._tasks(plans, pending, fold, info.fs_hz, loc_tasks)
            if progress:
                progress(round_index, c.spec.max_rounds, f"round {round_index + 1}: {len(pending)} blocks")
            cache = str(self.cache_dir) if self.cache_dir else None
            done = self.executor.map(cached_synthesize, [(t, cache) for t in tasks],
                                     desc=f"fold {fold}: {len(tasks)} matched samples")
            results = {cond: {} for cond in CONDITIONS}
            for task, result in zip(tasks, done, strict=True):
                results[task.key.split("/")[1]][task.key] = result
            for cond in CONDITIONS:
                if c.spec.rank_grounding and not grounders.get(cond):  # fitted once, on the first samples
                    ok = [r for r in results[cond].values() if not r.error and r.signals]
                    grounders[cond] = fit_rank_grounders(info, ok, d_rank, loc_plan, self.config.spec)
                grounders.setdefault(cond, {})
            judged = {cond: self._judge(info, results[cond], grounders[cond], filters, length, hop)
                      for cond in CONDITIONS}
            retry = []
            for b in pending:
                plan = plans[b.plan]
                tau_nn = filters["thresholds"].get(plan.label_index, filters["thresholds"][-1])
                keys = {cond: f"{fold}/{cond}/{plan.label}/{b.plan}/k{b.slot}/r{b.replicate}/a{b.attempt}"
                        for cond in CONDITIONS}
                decisions = {cond: self._decide(judged[cond][keys[cond]], cond, plan.label_index, pool, tau_nn)
                             for cond in CONDITIONS}
                b.accepted = all(d["passed"] for d in decisions.values())
                if b.accepted:
                    block = f"{b.plan}/k{b.slot}/r{b.replicate}"
                    for cond, d in decisions.items():
                        j, keep = judged[cond][keys[cond]], d["keep"]
                        pool.add(cond, plan.label_index, j["X"][keep], j["z"][keep], keys[cond], block)
                attempts.append({
                    "round": round_index, "class": plan.label, "source": plan.source, "slot": b.slot,
                    "kind": plan.slots[b.slot].kind, "replicate": b.replicate, "attempt": b.attempt,
                    "seed": b.seed, "accepted": b.accepted, "unresolvable_prompt": (b.plan, b.slot) in dead,
                    "conditions": {cond: {k: v for k, v in d.items() if k != "keep"}
                                   for cond, d in decisions.items()}})
                if not b.accepted and (b.plan, b.slot) not in dead:
                    # the whole block again, with the next reserve seed
                    b.seed, b.attempt = reserve.next(), b.attempt + 1
                    retry.append(b)
            pending = retry
            for cls in sorted(by_class):
                need = math.ceil(c.spec.oversample * budget[cls])
                have = min(pool.count(cond, cls) for cond in CONDITIONS)
                if have >= need or replicates[cls] >= c.max_replicates or round_index + 1 >= c.spec.max_rounds:
                    continue
                accepted = [a for a in attempts if a["class"] == info.label_names[cls] and a["accepted"]]
                if not accepted:  # no block of the class passed yet: its failed blocks are retried
                    continue
                per_block = have / len(accepted)
                n_blocks = sum(1 for p in by_class[cls] for s in range(len(plans[p].slots)) if (p, s) not in dead)
                if n_blocks == 0:
                    continue
                extra = min(c.max_replicates - replicates[cls],
                            max(1, math.ceil((need - have) / max(per_block * n_blocks, 1e-9))))
                for _ in range(extra):
                    fresh = new_blocks(cls)
                    all_blocks += fresh
                    pending += fresh
        if progress:
            progress(c.spec.max_rounds, c.spec.max_rounds, "selecting windows")
        windows, selected = self._select(info, pool, budget, seed, fold, length)
        summary = _accounting(info, plans, all_blocks, attempts, pool, budget, selected, replicates, c)
        summary["prompt_resolution"] = resolution
        summary["unresolvable_blocks"] = sum(1 for b in all_blocks if (b.plan, b.slot) in dead)
        return MatchedOutput(windows, attempts, plans, summary)

    def _select(self, info: DatasetInfo, pool: _Pool, budget: np.ndarray, seed: int, fold: str,
                length: int) -> tuple[dict[str, Windows], dict[int, int]]:
        """The same number of windows per class from every condition."""
        selected = {}
        for cls in range(info.n_classes):
            have = min(pool.count(cond, cls) for cond in CONDITIONS)
            selected[cls] = int(min(budget[cls], have))
        orders = {}
        for cls, n in selected.items():
            if n:  # one seeded block order per class, shared by the four conditions
                blocks = pool.block_order(cls)
                perm = rng_for(seed, fold, "matched-select", cls).permutation(len(blocks))
                orders[cls] = [blocks[i] for i in perm]
        out = {}
        for cond in CONDITIONS:
            xs, ys, keys = [], [], []
            for cls, n in selected.items():
                if n == 0:
                    continue
                X = np.stack(pool.X[(cond, cls)])
                idx = matched_selection(pool.blocks[(cond, cls)], orders[cls], n)
                xs.append(X[idx])
                ys.append(np.full(n, cls))
                keys += [pool.keys[(cond, cls)][i] for i in idx]
            X = np.concatenate(xs) if xs else np.zeros((0, length, len(info.channel_names)), np.float32)
            y = np.concatenate(ys) if ys else np.zeros(0, np.int64)
            out[cond] = Windows(X, y, np.full(len(y), "synthetic"), info.label_names, info.channel_names,
                                info.fs_hz, meta={"sample": np.array(keys, dtype=str)})
        return out, selected


def prompt_resolution(plans: list[SourcePlan], library: ActivityLibrary) -> list[dict[str, Any]]:
    """The library activity the procedural backend's text parser reads from each caption prompt
    (C0, C1), next to the activity of the source SMP."""
    from vsmp_imu.motion.prompt import resolve_activity

    out = []
    for index, plan in enumerate(plans):
        try:
            expected = library.resolve(plan.smp.activity_label).name
        except ValidationError:
            expected = plan.smp.activity_label
        for slot in range(len(plan.slots)):
            inputs = plan.inputs(slot)
            for cond in ("C0", "C1"):
                try:
                    resolved = resolve_activity(inputs[cond][1], library)[0].name
                except ValidationError:
                    resolved = None
                out.append({"plan": index, "class": plan.label, "source": plan.source, "slot": slot,
                            "condition": cond,
                            "expected": expected, "resolved": resolved, "match": resolved == expected})
    return out


class _ReserveSeeds:
    """The fold's shared reserve-seed list, handed out in order to regenerated blocks."""

    def __init__(self, seed: int, fold: str) -> None:
        self.seed, self.fold, self.used = seed, fold, 0

    def next(self) -> int:
        value = int(rng_for(self.seed, self.fold, "matched-reserve", self.used).integers(2**31))
        self.used += 1
        return value


def _primary_seed(seed: int, fold: str, plan: SourcePlan, slot: int, replicate: int) -> int:
    return int(rng_for(seed, fold, "matched", plan.label, plan.source, slot, replicate).integers(2**31))


def _accounting(info, plans, blocks, attempts, pool: _Pool, budget, selected, replicates, config) -> dict[str, Any]:
    """Generation accounting of one fold (appendix tables of the matched protocol)."""
    per_condition = {}
    for cond in CONDITIONS:
        passed = sum(a["conditions"][cond]["passed"] for a in attempts)
        rejected = Counter(a["conditions"][cond]["reason"] for a in attempts if not a["conditions"][cond]["passed"])
        per_condition[cond] = {
            "attempted_samples": len(attempts), "passed_samples": passed,
            "independent_acceptance": passed / len(attempts) if attempts else None,
            "rejected_by": dict(sorted(rejected.items())),
            "retained_windows": sum(pool.count(cond, c) for c in range(info.n_classes)),
        }
    accepted = sum(b.accepted for b in blocks)
    per_class = {}
    for cls, label in enumerate(info.label_names):
        mine = [a for a in attempts if a["class"] == label]
        if not mine:
            continue
        target = sum(1 for b in blocks if plans[b.plan].label_index == cls)
        per_class[label] = {
            "budget": int(budget[cls]), "sources": sum(1 for p in plans if p.label_index == cls),
            "replicates": replicates.get(cls, 0), "target_blocks": target,
            "attempted_blocks": len(mine), "accepted_blocks": sum(a["accepted"] for a in mine),
            "retained_windows": {cond: pool.count(cond, cls) for cond in CONDITIONS},
            "selected_windows": selected[cls], "shortfall": int(budget[cls] - selected[cls]),
            "slot_kinds": sorted({a["kind"] for a in mine}),
        }
    return {
        "classes": len(per_class), "source_smps": len(plans),
        "refined_changed": sum(p.refinement_changed for p in plans),
        "target_blocks": len(blocks), "attempted_blocks": len(attempts), "accepted_blocks": accepted,
        "block_acceptance": accepted / len(attempts) if attempts else None,
        "unfilled_blocks": len(blocks) - accepted,
        "retained_motions_per_condition": accepted,
        "selected_windows_per_condition": int(sum(selected.values())),
        "per_condition": per_condition, "per_class": per_class,
        "reserve_seeds_used": sum(1 for a in attempts if a["attempt"] > 0),
        "config": config.as_dict(),
    }
