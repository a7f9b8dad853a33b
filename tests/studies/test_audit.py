"""The extraction audit on the hand-written fixture (tests/fixtures/audit), numbers by hand."""

from __future__ import annotations

import json
import shutil

import pytest
from study_support import AUDIT_DIR

from vsmp_imu.errors import InputFileError
from vsmp_imu.smp.io import smp_from_dict
from vsmp_imu.studies.audit import (
    ExtractionAudit,
    calibration,
    compare_smps,
    load_audit_inputs,
    read_responses,
    set_f1,
)
from vsmp_imu.studies.audit_report import write_audit_outputs

PRED, REF = AUDIT_DIR / "pred", AUDIT_DIR / "ref"


@pytest.fixture(scope="module")
def audit(library):
    return ExtractionAudit(library).run(load_audit_inputs(PRED, REF))


def by_clip(results):
    return {c.clip_id: c for c in results.clips}


def test_set_f1_by_hand():
    assert set_f1([], []) == 1.0 and set_f1(["a"], []) == 0.0 and set_f1(["a"], ["b"]) == 0.0
    # P = 2/3, R = 2/4 -> F1 = 2 * (2/3) * (1/2) / (2/3 + 1/2) = 4/7
    assert set_f1(["a", "b", "c"], ["a", "b", "d", "e"]) == pytest.approx(4 / 7)


def test_calibration_by_hand():
    """u = .1 .1 .5 .9, wrong = F F T T: ECE = .5 * .1 + .25 * .5 + .25 * .1 = .2; AUROC 1;
    Spearman = 4 / sqrt(4.5 * 4) (ranks 1.5 1.5 3 4 against 1.5 1.5 3.5 3.5)."""
    cal = calibration([(0.1, False), (0.1, False), (0.5, True), (0.9, True)])
    assert cal["ece"] == pytest.approx(0.2)
    assert cal["auroc"] == pytest.approx(1.0)
    assert cal["spearman"] == pytest.approx(4 / 18**0.5)
    assert [b["fields"] for b in cal["bins"]] == [2, 0, 1, 0, 1]
    assert cal["bins"][-1]["bin"] == "[0.8, 1.0]"  # the last bin is closed
    one_class = calibration([(0.1, False), (0.3, False)])
    assert one_class["auroc"] != one_class["auroc"]  # nan: no wrong field to detect


def test_read_responses_layouts():
    raw = read_responses(PRED / "pamap2_ironing_s102.raw")
    assert len(raw) == 5 and raw[1] is None  # response_1.json only: the request failed
    plain = read_responses(PRED / "mmfit_curls_w02")
    assert len(plain) == 5 and all(t.lstrip().startswith("{") for t in plain)


def test_inputs_pair_clips_groups_and_references():
    clips = load_audit_inputs(PRED, REF)
    assert [c.clip_id for c in clips] == ["mmfit_curls_w02", "mmfit_squats_w01", "pamap2_ironing_s102",
                                          "pamap2_walking_s101", "utd_boxing_s2", "utd_wave_s1"]
    assert {c.group for c in clips} == {"mmfit", "pamap2", "utd_mhad"}


def test_missing_reference_is_a_clear_error(tmp_path):
    shutil.copytree(REF, tmp_path / "ref")
    (tmp_path / "ref" / "utd_wave_s1.yaml").unlink()
    with pytest.raises(InputFileError, match="utd_wave_s1"):
        load_audit_inputs(PRED, tmp_path / "ref")


def test_failure_accounting_by_hand(audit):
    """30 queries, 1 failed request. Malformed: the fenced wave answer, the truncated squats answer
    and the ironing prose (3 / 29). Missing mandatory: walking without primitives, walking without
    a label, ironing with a label only (3 / 29). Invalid value: squats 'glacial' tempo and
    amplitude 7 in one response (1 / 29). Discarded: ironing (1 / 6). Residual errors in 3 of the
    5 aggregated clips: curls (tempo, side), squats (body parts), boxing (count, symmetry)."""
    f = audit.failures["overall"]
    assert (f["responses"], f["received_responses"], f["clips"]) == (30, 29, 6)
    assert f["request_failure"] == pytest.approx(1 / 30)
    assert f["malformed_json"] == pytest.approx(3 / 29)
    assert f["missing_mandatory_field"] == pytest.approx(3 / 29)
    assert f["invalid_field_value"] == pytest.approx(1 / 29)
    assert f["discarded"] == pytest.approx(1 / 6)
    assert f["residual_error"] == pytest.approx(3 / 5)
    assert f["schema_repair"] == pytest.approx(2 / 6)  # wave (fence, key) and squats (truncated, invalid)
    clips = by_clip(audit)
    assert sorted(clips["mmfit_curls_w02"].residual_fields) == ["dominant_side", "tempo"]
    assert clips["mmfit_squats_w01"].residual_fields == ["body_parts"]
    assert sorted(clips["utd_boxing_s2"].residual_fields) == ["repetition_count", "symmetry"]
    assert clips["utd_wave_s1"].residual_fields == []
    assert clips["pamap2_ironing_s102"].discarded and "refined" not in clips["pamap2_ironing_s102"].scores
    pamap2 = audit.failures["pamap2"]
    assert pamap2["discarded"] == 0.5 and pamap2["residual_error"] == 0.0


def test_field_metrics_by_hand(audit):
    """Squats: four responses give [descend, rise] -> aggregated sequence wrong (similarity 0 to the
    four-primitive reference), refinement replaces it with the library's -> right. So exact
    sequence accuracy goes 4/5 -> 5/5 and similarity 0.8 -> 1.0. Boxing counts 8 8 4 8 8 -> 8
    against 4: MAE over the 4 clips with a known count = 4 / 4 = 1. Squats body parts: 'legs'
    gives 6 of the 7 reference parts (no pelvis): F1 = 12/13."""
    agg, ref = audit.fields["aggregated"], audit.fields["refined"]
    assert agg["primitive_sequence"]["value"] == pytest.approx(0.8)
    assert agg["primitive_sequence"]["edit_similarity"] == pytest.approx(0.8)
    assert ref["primitive_sequence"]["value"] == 1.0
    assert ref["repetition_count"]["value"] == pytest.approx(1.0) and ref["repetition_count"]["n"] == 4
    squats = by_clip(audit)["mmfit_squats_w01"].scores["refined"]
    assert squats["body_parts"].score == pytest.approx(12 / 13)
    assert ref["body_parts"]["value"] == pytest.approx((4 + 12 / 13) / 5)
    assert ref["activity_label"]["value"] == 1.0  # 'boxing' x2 is outvoted by 'front boxing' x3
    assert ref["tempo"]["value"] == pytest.approx(4 / 5)  # curls: slow x3 against medium
    assert audit.fields_by_group["utd_mhad"]["symmetry"]["value"] == pytest.approx(0.5)
    # the raw stage counts every valid response: 5 + 5 + 5 + 3 + 5 valid responses of evaluated
    # clips plus the 2 valid ironing ones
    assert audit.fields["raw"]["activity_label"]["n"] == 25


def test_uncertainty_pairs_come_from_the_refined_smps(audit):
    cal = audit.calibration
    assert cal["fields"] == sum(len(c.calibration) for c in audit.clips) > 0
    assert sum(b["fields"] for b in cal["bins"]) == cal["fields"]
    wrong_u = [u for c in audit.clips for _, u, w in c.calibration if w]
    right_u = [u for c in audit.clips for _, u, w in c.calibration if not w]
    assert cal["auroc"] == pytest.approx(
        sum((a > b) + 0.5 * (a == b) for a in wrong_u for b in right_u) / (len(wrong_u) * len(right_u)))


def test_label_aliases_count_as_the_same_activity(library):
    base = {"motion_primitives": [{"name": "x", "order_index": 0}], "primitive_sequence": ["x"]}
    ref = smp_from_dict({"activity_label": "right hand wave", **base})
    alias = smp_from_dict({"activity_label": "waving the right hand", **base})
    other = smp_from_dict({"activity_label": "two arm curl", **base})
    assert compare_smps(alias, ref, library)["activity_label"].correct
    assert not compare_smps(other, ref, library)["activity_label"].correct


def test_outputs_and_cli(cli, tmp_path):
    code, out, err = cli("study", "audit", "--pred", PRED, "--ref", REF, "-o", tmp_path)
    assert code == 0, err
    assert "6 clips (5 aggregated)" in out
    report = (tmp_path / "report.md").read_text()
    for text in ("## Field-level extraction accuracy", "| Malformed JSON output | raw responses |",
                 "## Uncertainty calibration", "| utd_mhad |", "ECE"):
        assert text in report
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["failures"]["overall"]["discarded"] == pytest.approx(1 / 6)
    assert (tmp_path / "clips.csv").read_text().count("\n") == 7
    code, _, err = cli("study", "audit", "--pred", tmp_path / "nope", "--ref", REF, "-o", tmp_path)
    assert code == 2 and "--pred" in err


def test_write_outputs_without_groups(tmp_path, library):
    clips = load_audit_inputs(PRED, REF)
    for c in clips:
        c.group = None
    results = ExtractionAudit(library).run(clips)
    paths = write_audit_outputs(results, tmp_path)
    assert results.groups == [] and set(results.failures) == {"overall"}
    assert "| SMP field | Metric | Raw | Aggregated | Refined | n |" in paths["report"].read_text()
