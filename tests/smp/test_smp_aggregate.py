"""Aggregation of several responses: votes, medians, sequence choice, uncertainty, discard."""

from __future__ import annotations

import json

import pytest
from smp_helpers import make_smp, simple_smp

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp.aggregate import KAPPA, aggregate, edit_similarity


def test_edit_similarity():
    assert edit_similarity([], []) == 1.0
    assert edit_similarity(["a", "b", "c"], ["a", "b", "c"]) == 1.0
    assert edit_similarity(["a", "b", "c"], ["a", "c"]) == pytest.approx(2 / 3)
    assert edit_similarity(["a"], ["b"]) == 0.0
    assert edit_similarity(["open", "close"], ["close", "open"]) == 0.0
    assert edit_similarity(["jump_open"], ["jump_openx"]) == 0.0  # whole items, not characters


def test_identical_responses_give_the_same_smp():
    s = simple_smp()
    result = aggregate([s] * 5)
    assert result.smp == s
    assert result.n_total == result.n_valid == 5
    assert not result.discarded and not result.any_disagreement
    assert set(result.disagreement.values()) == {0.0}


def test_majority_vote_for_categorical_fields():
    s = simple_smp()
    smps = [make_smp(s, **{"execution_attributes.symmetry": sym,
                           "execution_attributes.dominant_side": side,
                           "temporal_structure.periodicity": per})
            for sym, side, per in [("symmetric", "left", "cyclic"),
                                   ("asymmetric", "left", "cyclic"),
                                   ("symmetric", "right", "unknown"),
                                   ("symmetric", "unknown", "unknown"),
                                   ("asymmetric", "unknown", "single")]]
    result = aggregate(smps)
    ea = result.smp.execution_attributes
    assert ea.symmetry == "symmetric"  # 3 of 5
    assert ea.dominant_side == "left"  # 2 of the 3 that know it
    assert result.smp.temporal_structure.periodicity == "cyclic"  # unknown abstains
    assert result.disagreement["execution_attributes.symmetry"] == pytest.approx(0.4)
    assert result.disagreement["execution_attributes.dominant_side"] == pytest.approx(0.6)


def test_label_vote_ignores_case_and_spelling_ties_go_to_the_anchor():
    s = simple_smp()
    labels = ["Arm Circles", "arm_circles", "arm circles", "arm circles", "arm swings"]
    smps = [make_smp(s, activity_label=lab) for lab in labels]
    # one activity, 4 of 5; its spellings tie 2 vs 2: the anchor's (response 0) wins
    result = aggregate(smps)
    assert result.anchor_index == 0 and result.n_agreeing == 4
    assert result.smp.activity_label == "Arm Circles"
    assert result.disagreement["activity_label"] == pytest.approx(0.2)


@pytest.mark.parametrize("labels", [["jumping jacks", "walking", "sitting"],
                                    ["jumping jacks", "jumping jacks", "walking", "walking", "sitting"],
                                    ["arm circles", "arm circles", "arm swings", "arm swings"]])
def test_responses_without_a_majority_activity_discard_the_clip(labels):
    s = simple_smp()
    result = aggregate([make_smp(s, activity_label=lab) for lab in labels])
    assert result.discarded and result.smp is None
    assert result.reason.startswith(f"no activity is named by a majority of the {len(labels)} valid responses")
    assert f"'{labels[0]}' {labels.count(labels[0])}" in result.reason


def test_only_the_majority_activity_gives_the_fields(library):
    from vsmp_imu.smp.aggregate import library_activity

    walk, jj = library.get("walking").smp, library.get("jumping_jacks").smp
    walks = [make_smp(walk, activity_label=lab, **{"execution_attributes.tempo": t})
             for lab, t in (("walking", "slow"), ("Walk", "slow"), ("walkin", "medium"))]
    fast_jj = make_smp(jj, **{"execution_attributes.tempo": "fast"})
    result = aggregate([fast_jj, walks[0], fast_jj, walks[1], walks[2]],
                       activity_of=library_activity(library))
    assert result.n_valid == 5 and result.n_agreeing == 3 and result.anchor_index in (1, 3, 4)
    smp = result.smp
    assert smp.activity_label == "walking" and smp.primitive_sequence == walk.primitive_sequence
    assert smp.execution_attributes.tempo == "slow"  # the jumping jacks' "fast" is not counted
    assert smp.body_parts.mandatory == walk.body_parts.mandatory
    assert result.disagreement["activity_label"] == pytest.approx(0.4)
    # by spelling alone, walking 1, walk 1, walkin 1 and jumping jacks 2: no majority
    assert aggregate([fast_jj, walks[0], fast_jj, walks[1], walks[2]]).discarded


def test_median_for_ordinal_and_numeric_fields():
    s = simple_smp()
    rows = [("slow", "small", 4, "stationary"), ("fast", "large", 8, "small"),
            ("fast", "medium", 10, "large"), ("medium", "large", 6, "small"),
            ("unknown", "unknown", "unknown", "unknown")]
    smps = [make_smp(s, **{"execution_attributes.tempo": t, "execution_attributes.amplitude": a,
                           "temporal_structure.repetition_count": r,
                           "execution_attributes.global_displacement": g})
            for t, a, r, g in rows]
    smp = aggregate(smps).smp
    assert smp.execution_attributes.tempo == "medium"  # lower median of slow, medium, fast, fast
    assert smp.execution_attributes.amplitude == "medium"  # lower median of small, medium, large, large
    assert smp.temporal_structure.repetition_count == 6  # lower median of 4, 6, 8, 10
    assert smp.execution_attributes.global_displacement == "small"
    numeric = [make_smp(s, **{"execution_attributes.tempo": v}) for v in (0.5, 1.5, 2.0)]
    assert aggregate(numeric).smp.execution_attributes.tempo == 1.5
    mixed = [make_smp(s, **{"execution_attributes.tempo": v}) for v in ("slow", 1.2, "fast", 1.6)]
    assert aggregate(mixed).smp.execution_attributes.tempo == pytest.approx(1.4)


def test_primitive_durations_elementwise_median():
    s = simple_smp()
    values = [[0.3, 0.5, 0.2], [0.2, 0.6, 0.2], [0.4, 0.4, 0.2], [0.3, 0.5, "unknown"]]
    smps = [make_smp(s, **{"primitive_durations.values": v}) for v in values]
    assert aggregate(smps).smp.primitive_durations.values == [0.3, 0.5, 0.2]


def test_sequence_with_highest_pairwise_agreement_is_chosen():
    s = simple_smp()
    odd = make_smp(s, primitive_sequence=["circle_arms", "raise_arms", "lower_arms"])
    short = make_smp(s, primitive_sequence=["raise_arms", "circle_arms"],
                     motion_primitives=[p.model_dump() for p in s.motion_primitives[:2]],
                     **{"primitive_durations.values": [0.4, 0.6]})
    other = make_smp(s, primitive_sequence=["raise_arms", "shake_arms", "lower_arms"],
                     **{"motion_primitives.1.name": "shake_arms"})
    result = aggregate([odd, short, s, other])
    assert result.anchor_index == 2
    assert result.smp.primitive_sequence == s.primitive_sequence
    assert [p.name for p in result.smp.motion_primitives] == s.primitive_sequence
    assert result.disagreement["primitive_sequence"] == pytest.approx(0.75)


def test_sets_by_majority_membership():
    s = simple_smp()
    lists = [["left_upper_arm", "right_upper_arm", "torso"], ["left_upper_arm", "right_upper_arm"],
             ["left_upper_arm", "head"], ["Right Upper Arm", "left_upper_arm"]]
    smps = [make_smp(s, **{"body_parts.mandatory": m}) for m in lists]
    result = aggregate(smps)
    # right_upper_arm: 3 of 4 (case-insensitive); torso, head: 1 of 4
    assert result.smp.body_parts.mandatory == ["left_upper_arm", "right_upper_arm"]
    vf = [["tempo", "amplitude"], ["tempo"], ["tempo", "amplitude"], ["amplitude", "symmetry"]]
    smps = [make_smp(s, **{"constraints.variant_fields": v}) for v in vf]
    # amplitude 3/4 kept, symmetry 1/4 dropped
    assert aggregate(smps).smp.constraints.variant_fields == ["tempo", "amplitude"]
    half = [["tempo", "symmetry"], ["tempo"], ["tempo", "symmetry"], ["tempo"]]
    smps = [make_smp(s, **{"constraints.variant_fields": v}) for v in half]
    assert aggregate(smps).smp.constraints.variant_fields == ["tempo"]  # 2 of 4 is no majority


def test_uncertainty_is_mean_plus_disagreement():
    s = simple_smp()
    agree = [make_smp(s, **{"uncertainty.tempo": u}) for u in (0.1, 0.2, 0.3)]
    assert aggregate(agree).smp.uncertainty.tempo == pytest.approx(0.2)
    disagree = [make_smp(s, **{"uncertainty.tempo": u, "execution_attributes.tempo": t})
                for u, t in ((0.1, "slow"), (0.2, "fast"), (0.3, "fast"))]
    result = aggregate(disagree)
    assert result.disagreement["execution_attributes.tempo"] == pytest.approx(1 / 3)
    assert result.smp.uncertainty.tempo == pytest.approx(0.2 + KAPPA / 3)
    assert result.any_disagreement
    high = [make_smp(s, **{"uncertainty.symmetry": 0.9, "execution_attributes.symmetry": v})
            for v in ("symmetric", "asymmetric", "asymmetric", "symmetric", "symmetric")]
    assert aggregate(high).smp.uncertainty.symmetry == 1.0  # clipped


@pytest.mark.parametrize("n_valid,discarded", [(0, True), (2, True), (3, False), (5, False)])
def test_discard_below_three_valid(n_valid, discarded):
    s = simple_smp()
    smps = [s] * n_valid + [None] * (5 - n_valid)
    result = aggregate(smps)
    assert result.discarded is discarded
    assert result.n_total == 5 and result.n_valid == n_valid
    if discarded:
        assert result.smp is None and f"only {n_valid} of 5" in result.reason
    else:
        assert result.smp == s and result.reason is None


def test_min_valid_parameter_and_result_serializes():
    s = simple_smp()
    assert not aggregate([s, None], min_valid=1).discarded
    with pytest.raises(ValidationError):
        aggregate([s], min_valid=0)
    assert json.loads(json.dumps(aggregate([s, s, s]).to_dict()))["n_valid"] == 3


def test_body_parts_vote_in_the_vocabulary_and_empty_lists_abstain():
    s = simple_smp()
    lists = [["arms"], ["both arms"], [], [], ["left_upper_arm", "right_upper_arm"]]
    smps = [make_smp(s, **{"body_parts.mandatory": m}) for m in lists]
    result = aggregate(smps)
    # 3 responses give a list; upper arms are named by all 3, forearms and hands by 2 of 3
    assert result.smp.body_parts.mandatory == ["left_upper_arm", "right_upper_arm", "left_forearm",
                                               "right_forearm", "left_hand", "right_hand"]
    # objects: an empty list is a real answer ("no object"), so one hallucinated object loses
    objs = [make_smp(s, **{"object_contact.objects": o}) for o in ([], [], ["dumbbell"])]
    assert aggregate(objs).smp.object_contact.objects == []


def test_recorded_responses_end_to_end(shared_responses, library):
    from vsmp_imu.smp.refine import refine
    from vsmp_imu.smp.repair import parse_response

    results = [parse_response(p.read_bytes()) for p in shared_responses]
    assert [r.valid for r in results] == [True, True, True, False, True]
    agg = aggregate([r.smp for r in results])
    assert agg.n_valid == 4 and not agg.discarded
    smp = agg.smp
    assert smp.activity_label == "jumping jacks"
    assert smp.primitive_sequence == ["stand", "jump_open", "jump_close"]
    assert (smp.execution_attributes.tempo, smp.execution_attributes.amplitude) == ("fast", "large")
    assert smp.temporal_structure.repetition_count == 8  # lower median of 8, 10, 8, 9
    assert smp.object_contact.objects == []  # one response saw a dumbbell
    assert "left_upper_arm" in smp.body_parts.mandatory
    assert smp.uncertainty.repetition_count > 0.25  # the responses disagree on the count
    final = refine(smp, library).smp
    assert refine(final, library).corrections == []
