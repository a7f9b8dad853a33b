"""The side from evidence (pipeline.side): a class's real windows choose which way its variants turn."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.executor import LocalExecutor
from vsmp_imu.har.dataset import mirror_matrix
from vsmp_imu.har.datasets import load_dataset
from vsmp_imu.pipeline.fold import FoldGenerator, prepare
from vsmp_imu.pipeline.side import MIN_SEPARATION, SideEvidence, side_is_free, with_side
from vsmp_imu.pipeline.sources import LibrarySmpSource
from vsmp_imu.pipeline.spec import GenerationSpec
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.library import ActivityLibrary

LYING = ("SIT_TO_LIE", "LIE_TO_SIT", "STAND_TO_LIE", "LIE_TO_STAND")
STAIRS = {"WALKING_UPSTAIRS": "left", "WALKING_DOWNSTAIRS": "right"}  # the way HAPT's stairwell turns
TRAIN_SUBJECTS = ["2", "3", "4", "5", "6", "7"]


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def sit_to_lie(library):
    return library.get("sit_to_lie").smp


def _evidence(windows, left=(0.0, 0.0, -0.4), right=(0.0, 0.0, 0.4), rms=0.8) -> SideEvidence:
    return SideEvidence(np.array(left), np.array(right), rms, np.asarray(windows, float).reshape(-1, 3))


def test_windows_that_lean_left_choose_left_with_their_share(sit_to_lie):
    windows = [(0, 0, -0.3)] * 8 + [(0, 0, 0.3)] * 2 + [(0.5, 0, 0.01)] * 5  # the last five do not vote
    smp, rec = _evidence(windows).decide(sit_to_lie)
    assert rec["used"] and (rec["votes_left"], rec["votes_right"]) == (8, 2)
    assert rec["p_right"] == pytest.approx(3 / 12, abs=1e-4) and rec["side"] == "left"
    assert smp.execution_attributes.dominant_side == "left"
    assert smp.uncertainty.dominant_side == pytest.approx(1 - 2 * 3 / 12, abs=1e-4)


def test_the_variants_take_the_minority_side_with_its_probability(sit_to_lie):
    """The uncertainty the evidence sets makes the augmenter swap with the minority's share."""
    windows = [(0, 0, 0.3)] * 18 + [(0, 0, -0.3)] * 4
    smp, rec = _evidence(windows).decide(sit_to_lie)
    variants = SMPAugmenter().augment(smp, 2000, seed=3)
    left = np.mean([v.execution_attributes.dominant_side == "left" for v in variants])
    assert rec["side"] == "right"
    assert left == pytest.approx(1 - rec["p_right"], abs=0.03)  # 5 / 24 = 0.21


def test_no_window_or_no_separation_keeps_the_smp(sit_to_lie):
    for evidence, reason in ((_evidence(np.zeros((0, 3))), "no real window"),
                             (_evidence([(0, 0, 1.0)] * 5, left=(0, 0, 0.0), right=(0, 0, 0.01)), "does not show")):
        smp, rec = evidence.decide(sit_to_lie)
        assert smp == sit_to_lie and not rec["used"] and reason in rec["reason"]
    # the separation is relative to the probes' gyroscope RMS
    below = _evidence([(0, 0, 1.0)], left=(0, 0, -0.09), right=(0, 0, 0.09), rms=1.0).decide(sit_to_lie)[1]
    above = _evidence([(0, 0, 1.0)], left=(0, 0, -0.09), right=(0, 0, 0.09), rms=0.5).decide(sit_to_lie)[1]
    assert below["separation"] == pytest.approx(0.09) and MIN_SEPARATION > 0.09 and not below["used"]
    assert above["separation"] == pytest.approx(0.18) and above["used"]


def test_a_tie_keeps_the_smps_side_and_swaps_half():
    smp = with_side(ActivityLibrary.load().get("lie_to_sit").smp, "left")
    out, rec = _evidence([(0, 0, 0.3), (0, 0, -0.3)]).decide(smp)
    assert rec["p_right"] == 0.5 and out.execution_attributes.dominant_side == "left"
    assert out.uncertainty.dominant_side == 0.0


# -- on real HAPT windows ------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def hapt12():
    ds = load_dataset("hapt12")
    return ds.info, ds.windows().where_subjects(TRAIN_SUBJECTS)


def _sides(hapt12, library, train, tmp_path, **spec):
    info, _ = hapt12
    config = GenerationSpec(**spec)
    sources = LibrarySmpSource(library).smps("hapt12", info.label_names)
    setup = prepare(config, info, train, sources, 0)
    gen = FoldGenerator(config, LocalExecutor(1, show_progress=False), tmp_path, library=library)
    budget = np.ones(info.n_classes, int)
    return sources, *gen.sides_from_evidence(info, train, sources, setup, budget, 0, "test")


def _mirrored(info, train):
    """The training windows as the mirror image of the recorded people (left and right swapped)."""
    q = mirror_matrix(("up", "forward", "left"), ("up", "forward", "left"))
    X = train.X.copy()
    X[..., :3] = X[..., :3] @ q.T
    X[..., 3:6] = -(X[..., 3:6] @ q.T)
    return train.__class__(X, train.y, train.subjects, train.label_names, train.channel_names, train.fs_hz)


def test_hapt_lying_transitions_turn_right_and_their_mirror_image_left(hapt12, library, tmp_path):
    info, train = hapt12
    sources, out, records = _sides(hapt12, library, train, tmp_path)
    assert set(records) == set(LYING) | set(STAIRS)  # no other HAPT activity lets its variants change side
    for label in LYING:
        rec = records[label][0]
        assert rec["used"] and rec["side"] == "right" and rec["p_right"] > 0.6, rec
        assert out[label][0][1].uncertainty.dominant_side == pytest.approx(rec["uncertainty"])
    assert out["WALKING"] == sources["WALKING"]
    # the same people mirrored: every lying transition turns left (the mounting is estimated again
    # from the mirrored windows, so the shares need not mirror exactly)
    _, out, mirrored = _sides(hapt12, library, _mirrored(info, train), tmp_path)
    for label in LYING:
        rec = mirrored[label][0]
        assert rec["side"] == "left" and rec["p_right"] < 0.4, rec
        assert out[label][0][1].execution_attributes.dominant_side == "left"


def test_hapt_stairs_turn_each_their_own_way_and_their_mirror_image_the_other(hapt12, library, tmp_path):
    """HAPT's stairwell turns one way going up and the other coming down (recipe `turns`); the
    windows of each say so almost unanimously, and the mirrored windows say the opposite."""
    info, train = hapt12
    mirror = {"left": "right", "right": "left"}
    for windows, expected in ((train, STAIRS), (_mirrored(info, train), {k: mirror[v] for k, v in STAIRS.items()})):
        _, out, records = _sides(hapt12, library, windows, tmp_path)
        for label, side in expected.items():
            rec = records[label][0]
            assert rec["used"] and rec["side"] == side, rec
            assert min(rec["p_right"], 1 - rec["p_right"]) < 0.1, rec
            assert out[label][0][1].execution_attributes.dominant_side == side


def test_a_class_without_real_windows_keeps_its_50_50_variants(hapt12, library, tmp_path):
    info, train = hapt12
    seen = train[train.y != info.label_names.index("SIT_TO_LIE")]
    sources, out, records = _sides(hapt12, library, seen, tmp_path)
    assert records["SIT_TO_LIE"][0]["used"] is False and "no real window" in records["SIT_TO_LIE"][0]["reason"]
    assert out["SIT_TO_LIE"] == sources["SIT_TO_LIE"]


def test_switched_off_it_changes_nothing(hapt12, library, tmp_path):
    _, train = hapt12
    sources, out, records = _sides(hapt12, library, train, tmp_path, side_evidence=False)
    assert out == sources and records == {}


def test_only_a_named_variant_side_is_free(sit_to_lie):
    assert side_is_free(sit_to_lie)
    d = sit_to_lie.model_dump(mode="json")
    d["constraints"]["variant_fields"] = [f for f in d["constraints"]["variant_fields"] if f != "dominant_side"]
    assert not side_is_free(type(sit_to_lie).model_validate(d))
    assert not side_is_free(with_side(sit_to_lie, "bilateral"))


def test_generate_prints_each_decision_in_words():
    from vsmp_imu.cli.generate import side_text

    used = {"used": True, "side": "left", "p_right": 0.25, "votes_right": 2, "votes_left": 8, "windows": 15}
    assert side_text(used) == "left (p = 0.75: 2 real windows turn right, 8 left, of 15)"
    assert side_text({"used": False, "reason": "no real window of the class"}) == \
        "the SMP's side, variants either way (no real window of the class)"
