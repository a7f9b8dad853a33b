"""Evidence floors (grounding.floors): one table in code and in docs/pipeline.md, read by every stage."""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.grounding import floors
from vsmp_imu.grounding.split import stat_rank_split
from vsmp_imu.pipeline.spec import GenerationSpec

DOC = Path(__file__).resolve().parents[2] / "docs" / "pipeline.md"


def _doc_rows() -> list[list[str]]:
    """The cells of the table under "## Evidence floors" (header and rule left out)."""
    text = DOC.read_text(encoding="utf-8").split("\n## Evidence floors\n", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in text.splitlines() if line.startswith("|")]
    return [[cell.strip().strip("`") for cell in row.strip("|").split("|")] for row in rows[2:]]


def test_the_doc_table_is_floors():
    expected = [[f.stage, f.evidence, str(f.floor), f.unit, f.switch, f.below,
                 "-" if (n := floors.windows_for(f)) is None else str(n)] for f in floors.FLOORS]
    assert _doc_rows() == expected


def test_each_floor_counts_known_evidence_in_its_unit_and_names_a_spec_switch():
    names = [f.stage for f in floors.FLOORS]
    assert len(set(names)) == len(names)
    spec = GenerationSpec()
    for f in floors.FLOORS:
        assert f.evidence in floors.EVIDENCE and f.evidence.endswith(f.unit)
        assert isinstance(getattr(spec, f.switch), bool), f.switch
        assert f.floor >= 1


def test_floors_the_chain_shares():
    # motion fit fits against the class's own D_stat statistics; the validator and tau_nn both
    # take GenerationSpec.min_validator_windows
    assert floors.MOTION_FIT.floor == floors.STAT_TARGET.floor
    assert floors.REDUNDANCY.floor == floors.VALIDATOR.floor == GenerationSpec().min_validator_windows


# Run in a fresh interpreter with every floor moved: each stage's constant or default must follow.
_PROBE = """
import dataclasses, inspect, json
from vsmp_imu.grounding import floors
for i, name in enumerate(["STAT_TARGET", "MOTION_FIT", "EVENT_DURATIONS", "CADENCE", "TEXTURE",
                          "RANK_MAP", "WINDOW_LEVELS", "PLAUSIBILITY", "VALIDATOR", "SEEN_INTENSITY"]):
    setattr(floors, name, dataclasses.replace(getattr(floors, name), floor=1000 + i))
floors.NN_MIN_WINDOWS = 999
from vsmp_imu.filtering import faithfulness, plausibility
from vsmp_imu.grounding import cadence, durations, intensity, levels, rank, stats, texture
from vsmp_imu.pipeline import motionfit, spec
print(json.dumps({
    "STAT_TARGET": [stats.TargetStatistics(50.0).min_windows],
    "MOTION_FIT": [motionfit.MIN_FIT_WINDOWS],
    "EVENT_DURATIONS": [durations.MIN_EVENTS],
    "CADENCE": [cadence.MIN_WINDOWS],
    "TEXTURE": [texture.TextureModel(50.0).min_class_windows],
    "RANK_MAP": [rank.RankGrounder().min_class_samples],
    "WINDOW_LEVELS": [levels.MIN_WINDOWS, levels.LevelMap().min_windows],
    "PLAUSIBILITY": [plausibility.MIN_CLASS_WINDOWS, plausibility.MotionPlausibilityFilter().min_class_windows],
    "VALIDATOR": [spec.GenerationSpec().min_validator_windows],
    "SEEN_INTENSITY": [intensity.MATCH_MIN_WINDOWS],
    "NN_MIN_WINDOWS": [inspect.signature(faithfulness.nn_thresholds).parameters["min_class_windows"].default],
}))
"""


def test_every_stage_takes_its_floor_from_floors():
    """A module that hard-coded its floor (even the same number) would not follow a moved one."""
    src = str(Path(floors.__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([src, os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, check=True)
    seen = json.loads(out.stdout.strip().splitlines()[-1])
    moved = ["STAT_TARGET", "MOTION_FIT", "EVENT_DURATIONS", "CADENCE", "TEXTURE", "RANK_MAP",
             "WINDOW_LEVELS", "PLAUSIBILITY", "VALIDATOR", "SEEN_INTENSITY"]
    assert seen == {**{name: [1000 + i] * len(seen[name]) for i, name in enumerate(moved)},
                    "NN_MIN_WINDOWS": [999]}


def test_the_modules_hold_the_floors_values():
    from vsmp_imu.filtering import plausibility
    from vsmp_imu.grounding import cadence, durations, intensity, levels, rank, stats, texture
    from vsmp_imu.pipeline import fold, motionfit

    assert levels.MIN_WINDOWS == floors.WINDOW_LEVELS.floor == 5
    assert rank.RankGrounder().min_class_samples == floors.RANK_MAP.floor == 200
    assert stats.TargetStatistics(50.0).min_windows == floors.STAT_TARGET.floor == 20
    assert texture.TextureModel(50.0).min_class_windows == floors.TEXTURE.floor == 20
    assert intensity.MATCH_MIN_WINDOWS == floors.SEEN_INTENSITY.floor == 20
    assert cadence.MIN_WINDOWS == floors.CADENCE.floor == 5
    assert durations.MIN_EVENTS == floors.EVENT_DURATIONS.floor == 5
    assert motionfit.MIN_FIT_WINDOWS == floors.MOTION_FIT.floor == 20
    assert plausibility.MIN_CLASS_WINDOWS == floors.PLAUSIBILITY.floor == 100
    assert GenerationSpec().min_validator_windows == floors.VALIDATOR.floor == 10
    assert floors.NN_MIN_WINDOWS == 2 and floors.SIDE_EVIDENCE.floor == floors.MOUNTING.floor == 1
    # the fold reads these two where it decides (no constant of their own)
    assert "floors.MOUNTING" in inspect.getsource(fold.nominal_mountings)
    assert "floors.SIDE_EVIDENCE" in inspect.getsource(fold.FoldGenerator.sides_from_evidence)


@pytest.mark.parametrize("floor", floors.FLOORS, ids=lambda f: f.stage)
def test_stages_for_at_the_floor_and_one_below(floor):
    counts = dict.fromkeys(floors.EVIDENCE, 10**6)
    below = floors.stages_for({**counts, floor.evidence: floor.floor - 1})
    at = floors.stages_for({**counts, floor.evidence: floor.floor})
    assert floor.stage in below.below and floor.stage not in below.on
    assert floor.stage in at.on and floor.stage not in at.below
    for stages in (below, at):  # every stage lands on one side, in chain order
        assert sorted(stages.on + stages.below) == sorted(f.stage for f in floors.FLOORS)
        assert list(stages.on) == [f.stage for f in floors.FLOORS if f.stage in stages.on]


def test_stages_for_needs_every_counted_kind():
    with pytest.raises(ValueError, match="D_rank samples"):
        floors.stages_for({k: 5 for k in floors.EVIDENCE if k != floors.D_RANK_SAMPLES})
    assert floors.stages_for(dict.fromkeys(floors.EVIDENCE, 0)).on == ()


def test_class_evidence_splits_as_the_split_does():
    for n in range(0, 42):
        stat, rank = stat_rank_split(np.zeros(n, int), seed=3)
        got = floors.class_evidence(n, window_samples=128, validator_share=0.5, events=2)
        assert (got[floors.D_STAT_WINDOWS], got[floors.D_RANK_WINDOWS]) == (len(stat), len(rank))
        assert got[floors.D_RANK_SAMPLES] == 128 * len(rank)
        assert got[floors.TRAINING_WINDOWS] == n and got[floors.VALIDATOR_WINDOWS] == n // 2
        assert got[floors.TRAINING_EVENTS] == 2
    assert floors.class_evidence(10)[floors.VALIDATOR_WINDOWS] == 8  # 1 - val_fraction 0.2
    with pytest.raises(ValueError):
        floors.class_evidence(-1)


@pytest.mark.parametrize("floor", floors.FLOORS, ids=lambda f: f.stage)
def test_stages_for_windows_switches_each_stage_on_once(floor):
    n = floors.windows_for(floor)
    if n is None:  # events: no window count brings them
        assert floor.evidence == floors.TRAINING_EVENTS
        assert floor.stage in floors.stages_for_windows(10**4).below
        assert floor.stage in floors.stages_for_windows(10, events=floor.floor).on
        return
    assert floor.stage in floors.stages_for_windows(n).on
    if n > 0:
        assert floor.stage in floors.stages_for_windows(n - 1).below
    assert all(floor.stage in floors.stages_for_windows(m).on for m in range(n, n + 50))


def test_a_label_budget_of_ten_windows():
    """2 s at 50 Hz: D_stat 5, D_rank 5 (500 samples), 8 windows on the validator's side."""
    on, below = floors.stages_for_windows(10)
    assert on == ("nominal mounting", "side from evidence", "cadence", "per-class rank map", "window levels",
                  "redundancy tau_nn")
    assert "D_stat statistics" in below and "class faithfulness" in below


def test_class_evidence_counts_no_events_unless_given():
    assert floors.class_evidence(500)[floors.TRAINING_EVENTS] == 0  # sampled window by window
    assert floors.class_evidence(500, events=7)[floors.TRAINING_EVENTS] == 7


def test_a_negative_window_count_is_named_in_the_error():
    with pytest.raises(ValueError, match=r"^n_windows must be >= 0, got -3$"):
        floors.class_evidence(-3)


def test_stages_for_names_every_missing_kind():
    counts = {k: 5 for k in floors.EVIDENCE if k not in (floors.D_RANK_SAMPLES, floors.VALIDATOR_WINDOWS)}
    with pytest.raises(ValueError, match=r"^no count for D_rank samples, validator windows$"):
        floors.stages_for(counts)


def _training_floor(n):
    return floors.Floor("probe", floors.TRAINING_WINDOWS, n, "windows", "texture", "-")


def test_windows_for_searches_up_to_its_limit_and_no_further():
    assert floors.windows_for(_training_floor(10_000), validator_share=0.8) == 10_000  # the default limit
    assert floors.windows_for(_training_floor(10_001), validator_share=0.8) is None
    assert floors.windows_for(_training_floor(7), limit=7, validator_share=0.8) == 7
    assert floors.windows_for(_training_floor(8), limit=7, validator_share=0.8) is None


def test_windows_for_passes_the_evidence_options_on():
    # 200 D_rank samples: 2 windows of 100 samples (n = 4), 4 of 50 (n = 8)
    assert floors.windows_for(floors.RANK_MAP) == 4
    assert floors.windows_for(floors.RANK_MAP, window_samples=50) == 8
    # 10 validator windows: floor(0.8 n) >= 10 at n = 13, floor(0.5 n) >= 10 at n = 20
    assert floors.windows_for(floors.VALIDATOR) == 13
    assert floors.windows_for(floors.VALIDATOR, validator_share=0.5) == 20
    assert floors.windows_for(floors.EVENT_DURATIONS, events=5) == 0
