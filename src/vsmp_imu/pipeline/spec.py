"""The generation spec: everything that decides a synthetic set, in one frozen object.

The command line builds one `GenerationSpec` from its options and passes it
down; the fold generator, the VSMP-IMU method, the baselines and the studies
read their settings from it. Ablation variants and the studies' settings are
`dataclasses.replace(spec, ...)` of it (see `vsmp_imu.methods`).

The fields fall in three groups:

- budget: `source`, `alpha`, `policy`, `clips` (what the set is made from and how big);
- pipeline: Algorithm 1's switches and sizes (`PIPELINE_FIELDS`, the
  `config` of a generation's summary.json);
- run: `executor`, `workers`, `address`, `cache_dir`, `gpus_per_task` (where it
  runs; the same seed gives the same bytes whatever they are).

Light module: no heavy imports, so the command line can build a spec cheaply.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.grounding import floors

BUDGET_FIELDS = ("source", "alpha", "policy", "clips")
RUN_FIELDS = ("executor", "workers", "address", "cache_dir", "gpus_per_task")
EXECUTORS = ("local", "ray")
INTENSITY = (0.7, 2.0)  # the measured intensity spread of a class without real windows


# the largest intensity factor: ten times a window's gyroscope deviations is beyond any human
# execution of one activity (a factor of 1e9 was taken and made windows of 1e9 rad/s)
MAX_INTENSITY = 10.0


def intensity_bounds(text: str | None, field: str = "--unseen-intensity") -> tuple[float, float] | None:
    """`--unseen-intensity`: "off" (None) or "LO,HI" with 0 < LO <= HI <= MAX_INTENSITY."""
    if text is None or text.strip().lower() == "off":
        return None
    try:
        lo, hi = (float(p) for p in text.split(","))
    except ValueError:
        lo = hi = math.nan
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi <= MAX_INTENSITY):
        raise ConfigError(f"'{text}' is not an intensity range", field=field,
                          allowed=f"off, or LO,HI with 0 < LO <= HI <= {MAX_INTENSITY:g} (e.g. 0.7,2.0)")
    return lo, hi


@dataclass(frozen=True)
class GenerationSpec:
    """What decides a synthetic set (defaults: the paper's, except the budget's alpha and policy)."""

    # -- budget ---------------------------------------------------------------------------------
    source: str = "library"  # library | smp:DIR | video:DIR
    # synthetic windows = alpha x real training windows (the paper: 0.5, uniform; 2.0 with the
    # scarcity policy is what measured a gain here, docs/results.md)
    alpha: float = 2.0
    policy: str = "scarcity"  # budget per class: uniform | tail | scarcity
    clips: str | None = None  # source clips of the IMUTube-style baseline (video:DIR layout)
    # -- pipeline (Algorithm 1) -----------------------------------------------------------------
    k: int = 16  # SMP variants per base SMP (the paper's K is 4; 16 measured in docs/results.md)
    # ... for a class with no real training window (an unseen class), whose samples rest on its
    # SMP alone: more draws cover the SMP's variant range (measured in docs/results.md)
    k_unseen: int = 16
    backend: str = "procedural"
    refine: bool = True
    uncertainty_conditioned: bool = True
    sim_in_the_loop: bool = True
    # sim-in-the-loop also for a class with no D_stat statistics of its own (an unseen class),
    # against the pooled statistics of the other classes; off: such a class keeps eta nominal
    pooled_calibration: bool = True
    # ... except a held posture (the SMP's periodicity "none") with no real window, which keeps the
    # nominal sensor (pipeline.fold.unseen_postures; measured in docs/results.md)
    nominal_unseen_postures: bool = True
    # each selected window of a class with no real training window gets its gyroscope's deviations
    # from the window mean scaled by a factor ~ U(lo, hi): the intensity spread its SMP alone
    # lacks (grounding.intensity; measured in docs/results.md); None: off
    unseen_intensity: tuple[float, float] | None = INTENSITY
    # each selected window of a class with real training windows gets its gyroscope's deviations
    # from the window mean scaled by exp(s z), z ~ N(0, 1), where s is the log-intensity spread the
    # class's synthetic windows lack against its real ones (grounding.intensity)
    seen_intensity: bool = False
    # half the samples of a discrete event (an SMP with periodicity "single") whose class has real
    # events in the training windows are timed to one of them, and per class the timed windows, the
    # untimed ones or both are kept (grounding.durations, pipeline.fold.choose_timing; measured in
    # docs/results.md)
    event_durations: bool = False
    # every sample of a gait (a cyclic SMP whose procedural recipe walks) whose class has real
    # training windows steps at one real window's step rate (grounding.cadence; measured in
    # docs/results.md: TSTR's gait classes gain, level next to real windows)
    cadence: bool = True
    # where the side shows in the sensor, the side a class's real training windows support
    # (pipeline.side; measured in docs/results.md)
    side_evidence: bool = True
    # motion-level simulation-in-the-loop: per class, fit the motion's free parameters to D_stat
    motion_fit: bool = False
    # movement texture: the 3-12 Hz content procedural motion lacks, added in proportion to each
    # sample's own 0.3-3 Hz motion by ratios fitted on D_stat (grounding.texture; docs/results.md)
    texture: bool = True
    rank_grounding: bool = True
    # after windowing, each event class's window means mapped onto its real windows' means where it
    # has real windows enough (grounding.levels; measured in docs/results.md, "Window levels")
    window_levels: bool = True
    # the window's equal parts whose means window levels map, each on its own (1: the whole
    # window's mean; measured in docs/results.md, "Window levels per quarter"); grounding.levels.PARTS,
    # written out so that this module stays free of numpy (tests/grounding/test_levels.py)
    level_parts: int = 1
    # window levels also for each class whose SMP holds a posture: a still window's mean is where
    # gravity points in the sensor, which sets sitting apart from standing (measured in
    # docs/results.md, "Window levels for the postures": TSTR gains, the long tail's tail does not)
    posture_levels: bool = False
    # one rank map per class where the class has real windows enough (RankGrounder's
    # min_class_samples), the pooled map otherwise (the paper's); measured in docs/results.md
    per_class_rank: bool = True
    # after the rank map, give each sample's accelerometer its gravity magnitude back
    # (grounding.gravity; measured in docs/results.md)
    gravity_norm: bool = False
    estimate_mounting: bool = True  # nominal dataset mounting frame from D_stat class means
    # the validator judges a class only after training on at least this many of its real windows
    min_validator_windows: int = floors.VALIDATOR.floor
    quality_filter: bool = True  # all three filters; the two below switch single ones off
    class_filter: bool = True
    redundancy_filter: bool = True
    noise: bool = True
    oversample: float = 2.0  # raw windows generated per budgeted window
    max_rounds: int = 4
    # extra passes for classes whose kept windows fall short of their budget: each synthesizes
    # as many samples as the class's pass rate says it needs, then grounds and filters again
    refill: int = 0
    hop_fraction: float = 0.5  # synthetic window hop, as a fraction of the window
    val_fraction: float = 0.2  # training subjects held aside to choose tau_cls
    duration_s: float | None = None  # None: each activity's natural duration
    library_dirs: tuple[str, ...] = ()
    # -- run --------------------------------------------------------------------------------------
    executor: str = "local"  # local | ray
    workers: int = 1
    address: str | None = None  # Ray cluster address
    cache_dir: str | None = None  # per-sample cache (a killed run resumes)
    gpus_per_task: float | None = None  # GPUs a Ray task reserves (None: the backend's default)

    def __post_init__(self) -> None:
        object.__setattr__(self, "library_dirs", tuple(str(d) for d in self.library_dirs))
        if self.unseen_intensity is not None:
            object.__setattr__(self, "unseen_intensity", intensity_bounds(",".join(map(str, self.unseen_intensity)),
                                                                        "unseen_intensity"))
        for name in ("k", "k_unseen", "level_parts"):
            if getattr(self, name) < 1:
                raise ConfigError(f"{name} must be >= 1, got {getattr(self, name)}", field=name)
        if not self.oversample >= 1.0:
            raise ConfigError(f"oversample must be >= 1, got {self.oversample}", field="oversample")
        if self.refill < 0:
            raise ConfigError(f"refill must be >= 0, got {self.refill}", field="refill")
        if not 0 < self.hop_fraction <= 1:
            raise ConfigError(f"hop_fraction must be in (0, 1], got {self.hop_fraction}", field="hop_fraction")
        if self.workers < 1:
            raise ConfigError(f"{self.workers} is out of range", field="workers", allowed="an integer >= 1")
        if self.executor not in EXECUTORS:
            raise ConfigError(f"unknown executor '{self.executor}'", field="executor",
                              allowed=", ".join(EXECUTORS))

    # -- views --------------------------------------------------------------------------------------
    def variants_for(self, class_windows: int | None) -> int:
        """K for a class: `k_unseen` where the class has no real training window, else `k`."""
        return self.k_unseen if class_windows == 0 else self.k

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)

    def pipeline_dict(self) -> dict[str, Any]:
        """The pipeline fields (the `config` a generation's summary.json records)."""
        return {name: getattr(self, name) for name in PIPELINE_FIELDS}

    def changed(self) -> dict[str, Any]:
        """The fields that differ from the defaults."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) != f.default}

    def gpus(self) -> float:
        """GPUs a Ray task reserves: as given, else 1 for HY-Motion on Ray, else 0."""
        if self.gpus_per_task is not None:
            return self.gpus_per_task
        return 1.0 if self.backend == "hymotion" and self.executor == "ray" else 0.0

    def make_executor(self, show_progress: bool = True):
        from vsmp_imu.executor import make_executor

        return make_executor(self.executor, self.workers, self.address, show_progress=show_progress,
                             num_gpus_per_task=self.gpus())


PIPELINE_FIELDS = tuple(f.name for f in fields(GenerationSpec)
                        if f.name not in BUDGET_FIELDS + RUN_FIELDS)
