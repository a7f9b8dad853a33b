"""The strictly matched caption-SMP 2x2: slot requests, prompts, redundancy and selection."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.augment import AMPLITUDE_MAX_LEVELS, TEMPO_MAX_LEVELS
from vsmp_imu.smp.verbalize import generic_caption, verbalize
from vsmp_imu.studies.matched import (
    EXTRA_KINDS,
    MIN_CHANGE,
    MatchedConfig,
    allowed_interventions,
    matched_selection,
    plan_slots,
    redundancy_against,
    source_plans,
)


def test_four_slots_reference_tempo_amplitude_and_one_more(library):
    smp = library.get("two_arm_curl").smp
    slots = plan_slots(smp, seed=3, key="fold1/curl")
    assert [s.slot for s in slots] == [0, 1, 2, 3]
    assert [s.kind for s in slots[:3]] == ["reference", "tempo", "amplitude"]
    assert slots[3].kind in EXTRA_KINDS and slots[3].kind in allowed_interventions(smp)
    assert slots[0].smp == smp and slots[0].requested == {}
    for slot, field, dmax in ((slots[1], "tempo", TEMPO_MAX_LEVELS), (slots[2], "amplitude", AMPLITUDE_MAX_LEVELS)):
        change = slot.requested[f"execution_attributes.{field}"]
        radius = (1 - getattr(smp.uncertainty, field)) * dmax  # uncertainty-conditioned radius
        step = abs(change["after"] - change["before"])
        assert MIN_CHANGE * radius - 1e-3 <= step <= radius + 1e-3
        assert 0.0 <= change["after"] <= 2.0
    # seeded: the same key gives the same requests, another key other values
    assert [s.requested for s in plan_slots(smp, 3, "fold1/curl")] == [s.requested for s in slots]
    assert [s.requested for s in plan_slots(smp, 3, "fold2/curl")] != [s.requested for s in slots]


def test_a_static_posture_repeats_the_reference_execution(library):
    smp = library.get("sitting").smp
    assert allowed_interventions(smp) == []
    slots = plan_slots(smp, 0, "x")
    assert [s.kind for s in slots] == ["reference"] * 4
    assert all("reference execution" in s.note for s in slots[1:])


def test_k_outside_the_four_slots_is_refused(library):
    with pytest.raises(ConfigError, match="slot kinds"):
        plan_slots(library.get("walking").smp, 0, "x", k=5)
    with pytest.raises(ConfigError):
        MatchedConfig.from_spec(GenerationSpec(k=5))


def test_prompts_share_caption_base_smp_and_the_verbatim_attribute_phrase(library):
    names = ("walking", "two_arm_curl", "sit_to_stand")
    sources = {n: [(f"library:{n}", library.get(n).smp)] for n in names}
    plans = source_plans(sources, names, seed=0, fold="f1", library=library)
    assert [p.label for p in plans] == list(names)
    for plan in plans:
        entry = library.get(plan.label)
        assert plan.caption == generic_caption(entry, library)
        rows = plan.prompts()
        assert len(rows) == 4
        for row in rows:
            assert row["C0"] == plan.caption  # no attribute request
            assert row["S0"] == verbalize(plan.smp)  # the refined base SMP, every slot
            assert row["phrase"]
            assert row["C1"].startswith(plan.caption.rstrip(" ."))  # C (+) A keeps the caption
            assert row["C1"].endswith(f"They do this {row['phrase']}.")
            assert row["phrase"] in row["S1"]  # the same words in both conditions
        kinds = [r["kind"] for r in rows]
        assert kinds[:3] == ["reference", "tempo", "amplitude"]
        # the variants differ from each other (and tempo/amplitude from the reference)
        assert len({r["S1"] for r in rows}) == 4 and len({r["C1"] for r in rows}) == 4


def test_redundancy_against_retained_and_own_windows():
    z = np.array([[1.0, 0.0], [0.0, 1.0], [0.99, 0.141]])
    z /= np.linalg.norm(z, axis=1, keepdims=True)
    retained = np.array([[0.0, 1.0]])
    verdicts = redundancy_against(z, retained, tau=0.2, eligible=np.array([True, True, True]))
    # window 0 is new, window 1 duplicates a retained one, window 2 duplicates window 0
    assert [v.passed for v in verdicts] == [True, False, False]
    assert "near-duplicate" in verdicts[1].reason
    skipped = redundancy_against(z, retained, tau=0.2, eligible=np.array([False, True, True]))
    assert [v.passed for v in skipped] == [False, False, True]  # window 0 not considered
    assert all(v.passed for v in redundancy_against(z, np.zeros((0, 0)), 0.0, np.ones(3, bool)))


def test_selection_is_round_robin_over_the_shared_block_order():
    order = ["b2", "b0", "b1"]
    # condition A: 2, 3 and 1 windows in blocks b0, b1, b2; condition B: 1 window each
    a = ["b0", "b0", "b1", "b1", "b1", "b2"]
    b = ["b0", "b1", "b2"]
    assert matched_selection(a, order, 2).tolist() == [0, 5]  # first windows of b2, b0
    assert matched_selection(b, order, 2).tolist() == [0, 2]  # the same blocks b2, b0
    assert matched_selection(a, order, 4).tolist() == [0, 1, 2, 5]  # depth 1 of b0 after depth 0
    assert matched_selection(a, order, 6).tolist() == list(range(6))
    assert matched_selection(b, order, 5).tolist() == [0, 1, 2]  # never more than there is
