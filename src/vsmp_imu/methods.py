"""Every synthetic-data method the HAR harness can evaluate: one registry with capabilities.

The har room knows only the plug-in point (`vsmp_imu.har.synthetic`); this
module, above all rooms, names the sources: Classical Aug, the IMUTube- and
IMUGPT-2.0-style baselines, VSMP-IMU, its ablation variants and VSMP-IMU
combined with Classical Aug (`vsmp+classical`). Each entry
says what the method is (`kind`), what it needs and which generation-spec
fields it fixes (`switches`: an ablation variant's switched-off stages, a
baseline's chain). Modules are imported only when a method is used.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

from vsmp_imu.pipeline.spec import PIPELINE_FIELDS, GenerationSpec

# The spec fields every generative method is given in an evaluation's `method_params`
# (recorded with the run; the records' settings digest covers them but the run fields, which
# `vsmp_imu.har.synthetic.RUN_PARAMS` names); other pipeline fields go along only where they
# differ from the defaults.
OPTION_FIELDS = ("source", "k", "backend", "per_class_rank", "library_dirs", "workers", "executor",
                 "address", "cache_dir")
SPEC_FIELDS = frozenset(f.name for f in fields(GenerationSpec))
KINDS = ("real", "augmentation", "baseline", "vsmp")
VSMP_TARGET = "vsmp_imu.pipeline.method:VsmpMethod"
# The baselines' chain: no refinement, no sim-in-the-loop (sensor or motion), declared mounting, no
# movement texture, rank grounding without window levels, plausibility filter without the class
# validator, one variant per description, no refill, no intensity spread or match, the SMPs' own
# timing and tempo.
BASELINE_CHAIN: dict[str, Any] = {"k": 1, "refine": False, "sim_in_the_loop": False, "motion_fit": False,
                                  "side_evidence": False, "texture": False, "rank_grounding": True,
                                  "window_levels": False,
                                  "estimate_mounting": False, "quality_filter": True, "class_filter": False,
                                  "refill": 0, "unseen_intensity": None, "seen_intensity": False,
                                  "event_durations": False, "cadence": False}


@dataclass(frozen=True)
class Method:
    """One registered method and what it can do."""

    name: str
    display: str
    kind: str  # real | augmentation | baseline | vsmp
    target: str | None = None  # "module:attribute" of its factory (None: real-only)
    needs_videos: bool = False  # synthesizes from source clips
    unseen_classes: bool = False  # can make windows of a class with no real window
    switches: Mapping[str, Any] = field(default_factory=dict)  # spec fields the method fixes

    @property
    def generative(self) -> bool:
        """Whether it runs the generation pipeline (takes the generation spec's options)."""
        return self.kind in ("baseline", "vsmp")

    def spec(self, spec: GenerationSpec) -> GenerationSpec:
        """The spec the method runs with: the given one with the method's switches."""
        return replace(spec, **self.switches)

    def params(self, spec: GenerationSpec) -> dict[str, Any]:
        """The method's `method_params` in an evaluation (plain values, recorded)."""
        if not self.generative:
            return {}
        params = {name: getattr(self.spec(spec), name) for name in OPTION_FIELDS}
        params.update({name: value for name, value in spec.changed().items()
                       if name in PIPELINE_FIELDS and name not in OPTION_FIELDS and name not in self.switches})
        if self.kind == "vsmp":
            params["variant"] = self.name
        else:
            params["k"] = self.switches["k"]  # baselines draw no SMP variants
            if self.needs_videos and spec.clips:
                params["source"] = f"video:{spec.clips}"
        return params


def _vsmp(name: str, display: str, **switches: Any) -> Method:
    return Method(name, display, "vsmp", VSMP_TARGET, unseen_classes=True, switches=switches)


# Ablation variants (paper, "Ablation Study"): each switches stages of the full method off.
VSMP_VARIANTS = (
    _vsmp("vsmp", "VSMP-IMU"),
    _vsmp("vsmp-no-refine", "w/o refinement", refine=False),
    _vsmp("vsmp-no-uncertainty", "w/o uncertainty-aware constraints", uncertainty_conditioned=False),
    _vsmp("vsmp-no-adaptation", "w/o IMU adaptation", sim_in_the_loop=False, rank_grounding=False),
    _vsmp("vsmp-no-filter", "w/o filtering", quality_filter=False),
    _vsmp("vsmp-sim-only", "Simulation-in-the-loop only", rank_grounding=False),
    _vsmp("vsmp-rank-only", "Rank-based grounding only", sim_in_the_loop=False),
    _vsmp("vsmp-class-rank", "VSMP-IMU, per-class rank grounding", per_class_rank=True),
    _vsmp("vsmp-pooled-rank", "VSMP-IMU, pooled rank grounding", per_class_rank=False),
    _vsmp("vsmp-motion-fit", "VSMP-IMU, motion-level sim-in-the-loop", motion_fit=True),
    _vsmp("vsmp-no-texture", "VSMP-IMU, no movement texture", texture=False),
    _vsmp("vsmp-no-levels", "VSMP-IMU, no window levels", window_levels=False),
)
REGISTRY: dict[str, Method] = {m.name: m for m in (
    Method("real", "Real-only", "real"),
    Method("classical", "Classical Aug.", "augmentation", "vsmp_imu.baselines.classical:ClassicalAugmentation"),
    Method("imutube", "IMUTube", "baseline", "vsmp_imu.baselines.generative:ImuTubeMethod", needs_videos=True,
           unseen_classes=True, switches={**BASELINE_CHAIN, "redundancy_filter": False}),
    Method("imugpt", "IMUGPT 2.0", "baseline", "vsmp_imu.baselines.generative:ImuGptMethod",
           unseen_classes=True, switches={**BASELINE_CHAIN, "redundancy_filter": True}),
    *VSMP_VARIANTS,
    # VSMP-IMU windows and classical augmentation of the real and VSMP-IMU windows, one budget
    Method("vsmp+classical", "VSMP-IMU + Classical Aug.", "vsmp", "vsmp_imu.pipeline.combined:VsmpClassicalMethod",
           unseen_classes=True),
)}


def method(name: str) -> Method:
    """The registered method `name` (a ConfigError naming the known ones otherwise)."""
    from vsmp_imu.errors import ConfigError

    if name not in REGISTRY:
        raise ConfigError(f"unknown method '{name}'", field="--methods", allowed=", ".join(REGISTRY))
    return REGISTRY[name]


def add_method(entry: Method) -> None:
    """Make another synthetic source available."""
    REGISTRY[entry.name] = entry


def method_params(names, spec: GenerationSpec) -> dict[str, dict[str, Any]]:
    """`method_params` of the generative methods among `names`."""
    return {name: method(name).params(spec) for name in names if method(name).generative}


def make(name: str, spec: GenerationSpec | None = None, **params: Any):
    """The method `name`, built from a spec and/or its recorded `method_params`.

    A generative method gets `spec` with the spec fields among `params` and its own switches;
    the other parameters (e.g. `n_descriptions`) go to its factory as they are.
    """
    entry = method(name)
    if entry.target is None:
        return None
    module, attr = entry.target.split(":")
    factory = getattr(importlib.import_module(module), attr)
    if not entry.generative:
        return factory(**params)
    params.pop("variant", None)
    fields_ = {k: params.pop(k) for k in list(params) if k in SPEC_FIELDS}
    run_spec = entry.spec(replace(spec or GenerationSpec(), **fields_))
    return factory(spec=run_spec, name=name, **params)


def register_all() -> None:
    """Fill the harness's method registry (idempotent)."""
    from vsmp_imu.har.synthetic import METHODS, register_method

    for name, entry in REGISTRY.items():
        if name in METHODS or entry.target is None:
            continue

        def factory(_name: str = name, **params: Any):
            return make(_name, **params)

        register_method(name, factory, entry.display, unseen_classes=entry.unseen_classes)
