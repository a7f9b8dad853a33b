"""Evidence floors: how much real evidence a class needs before a stage fits something of its own.

Each grounding stage (and the quality filter) fits per class only where the class has enough real
evidence, and otherwise falls back: to the pooled fit of all classes, or to what the SMP says.
The floors count different things (D_stat windows, D_rank samples, events, ...); each is one
`Floor` here, and the stages' modules take their values from it, so a floor changes in one
place. `FLOORS` lists them in chain order; docs/pipeline.md ("Evidence floors") is the same
table (tests/grounding/test_floors.py holds the two together).

`stages_for` says which stages a class with given evidence gets and which fall back;
`class_evidence` gives the evidence of a class with N real training windows in a fold (D_stat and
D_rank as `grounding.split` divides them), `stages_for_windows` both at once, and `windows_for`
the fewest training windows that reach a floor.

Light module: no heavy imports (`pipeline.spec` reads a default from it).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import NamedTuple

# What a floor counts, per class (in a fold; per location where the stage works per location).
TRAINING_WINDOWS = "training windows"  # the fold's real training windows
D_STAT_WINDOWS = "D_stat windows"  # the training windows in D_stat (grounding.split)
D_RANK_WINDOWS = "D_rank windows"  # ... in D_rank
D_RANK_SAMPLES = "D_rank samples"  # D_rank windows x the window length
VALIDATOR_WINDOWS = "validator windows"  # training windows of the subjects the validator trains on
TRAINING_EVENTS = "training events"  # runs of training windows one hop apart in one recording
EVIDENCE = (TRAINING_WINDOWS, D_STAT_WINDOWS, D_RANK_WINDOWS, D_RANK_SAMPLES, VALIDATOR_WINDOWS,
            TRAINING_EVENTS)


@dataclass(frozen=True)
class Floor:
    """A stage's floor: the class needs `floor` of `evidence` (counted in `unit`) for its own fit;
    `switch` is the GenerationSpec field that turns the stage on, `below` what a class under the
    floor gets."""

    stage: str
    evidence: str
    floor: int
    unit: str
    switch: str
    below: str

    def met(self, count: int) -> bool:
        """Whether `count` of the evidence reaches the floor."""
        return count >= self.floor


STAT_TARGET = Floor("D_stat statistics", D_STAT_WINDOWS, 20, "windows", "sim_in_the_loop",
                    "the CEM's target is the pooled D_stat statistics of all classes "
                    "(eta nominal with pooled_calibration off)")
MOUNTING = Floor("nominal mounting", D_STAT_WINDOWS, 1, "windows", "estimate_mounting",
                 "the class's mean is left out of the mounting fit (fewer than two classes left: "
                 "the declared frame)")
SIDE_EVIDENCE = Floor("side from evidence", TRAINING_WINDOWS, 1, "windows", "side_evidence",
                      "the SMP keeps its side, its variants 50/50")
# fits against the class's own D_stat statistics, so the same floor
MOTION_FIT = Floor("motion fit", D_STAT_WINDOWS, STAT_TARGET.floor, "windows", "motion_fit",
                   "the SMP's defaults")
EVENT_DURATIONS = Floor("event durations", TRAINING_EVENTS, 5, "events", "event_durations",
                        "the SMP's timing (also when under half its windows lie in runs)")
CADENCE = Floor("cadence", TRAINING_WINDOWS, 5, "windows", "cadence", "the SMP's tempo")
TEXTURE = Floor("movement texture", D_STAT_WINDOWS, 20, "windows", "texture",
                "the pooled kappa of all classes")
RANK_MAP = Floor("per-class rank map", D_RANK_SAMPLES, 200, "samples", "per_class_rank",
                 "the pooled map (also under 200 synthetic samples; none without a training window)")
WINDOW_LEVELS = Floor("window levels", D_RANK_WINDOWS, 5, "windows", "window_levels",
                      "the windows keep their means (also under 5 synthetic windows)")
PLAUSIBILITY = Floor("plausibility thresholds", TRAINING_WINDOWS, 100, "windows", "quality_filter",
                     "the all-class thresholds")
VALIDATOR = Floor("class faithfulness", VALIDATOR_WINDOWS, 10, "windows", "class_filter",
                  "its windows pass the class filter unjudged")
# the chain passes the same GenerationSpec.min_validator_windows to both
REDUNDANCY = Floor("redundancy tau_nn", TRAINING_WINDOWS, VALIDATOR.floor, "windows",
                   "redundancy_filter", "the pooled tau_nn of all classes")
SEEN_INTENSITY = Floor("intensity match", TRAINING_WINDOWS, 20, "windows", "seen_intensity",
                       "no intensity factor (also under 20 selected synthetic windows)")

FLOORS = (STAT_TARGET, MOUNTING, SIDE_EVIDENCE, MOTION_FIT, EVENT_DURATIONS, CADENCE, TEXTURE,
          RANK_MAP, WINDOW_LEVELS, PLAUSIBILITY, VALIDATOR, REDUNDANCY, SEEN_INTENSITY)

# `filtering.faithfulness.nn_thresholds`' own default (a 5th percentile of nearest-neighbour
# distances needs two windows); the chain passes REDUNDANCY's floor instead
NN_MIN_WINDOWS = 2
# `class_evidence`'s default window length: 2 s at 50 Hz (HAPT, UTD-MHAD)
WINDOW_SAMPLES = 100


class Stages(NamedTuple):
    """The stages a class fits on its own evidence (`on`) and those it falls back in (`below`)."""

    on: tuple[str, ...]
    below: tuple[str, ...]


def stages_for(counts: Mapping[str, int]) -> Stages:
    """Which stages a class with `counts` (evidence kind -> count, every kind in EVIDENCE that a
    floor counts) gets, in chain order."""
    missing = sorted({f.evidence for f in FLOORS} - set(counts))
    if missing:
        raise ValueError(f"no count for {', '.join(missing)}")
    return Stages(tuple(f.stage for f in FLOORS if f.met(counts[f.evidence])),
                  tuple(f.stage for f in FLOORS if not f.met(counts[f.evidence])))


def class_evidence(n_windows: int, window_samples: int = WINDOW_SAMPLES,
                   validator_share: float | None = None, events: int = 0) -> dict[str, int]:
    """The evidence of a class with `n_windows` real training windows: D_stat gets ceil(n / 2) of
    them and D_rank the rest (`grounding.split.stat_rank_split`), D_rank's samples are its windows
    x `window_samples`. The validator trains on the windows of the subjects not held aside for
    tau_cls; the split is by subject, so `validator_share` (default 1 - GenerationSpec's
    val_fraction) is a guess. `events`: the class's runs of windows (none for a class sampled
    window by window, as the low-resource protocol samples)."""
    if n_windows < 0:
        raise ValueError(f"n_windows must be >= 0, got {n_windows}")
    if validator_share is None:
        from vsmp_imu.pipeline.spec import GenerationSpec

        validator_share = 1.0 - GenerationSpec.val_fraction
    d_stat = math.ceil(n_windows * 0.5)
    d_rank = n_windows - d_stat
    return {TRAINING_WINDOWS: n_windows, D_STAT_WINDOWS: d_stat, D_RANK_WINDOWS: d_rank,
            D_RANK_SAMPLES: d_rank * window_samples,
            VALIDATOR_WINDOWS: math.floor(n_windows * validator_share + 1e-9),
            TRAINING_EVENTS: events}


def stages_for_windows(n_windows: int, **kwargs) -> Stages:
    """`stages_for` of `class_evidence(n_windows, **kwargs)`: the stages a class with N real
    training windows (a label budget's share of its windows) switches on."""
    return stages_for(class_evidence(n_windows, **kwargs))


def windows_for(floor: Floor, limit: int = 10_000, **kwargs) -> int | None:
    """The fewest real training windows whose `class_evidence(n, **kwargs)` reaches `floor`;
    None where no count up to `limit` does (events: a count of windows says nothing of them)."""
    return next((n for n in range(limit + 1) if floor.met(class_evidence(n, **kwargs)[floor.evidence])), None)
