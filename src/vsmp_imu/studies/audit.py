"""SMP extraction audit (paper, "SMP Extraction Audit Protocol", appendix "SMP audit metrics").

Inputs: per clip, the raw VLM responses and an adjudicated reference SMP.
Every clip is evaluated at three stages: each raw response on its own
(repaired with `smp.repair`), the aggregate of the responses
(`smp.aggregate`), and the refined aggregate (`smp.refine`).

Field metrics (a reference field that is `unknown` is not evaluated; a
predicted `unknown` against a known reference is wrong):
- exact accuracy: activity label (equal names, or both naming the same
  library activity by name or alias), periodicity, dominant side, symmetry,
  global displacement (as a category: stationary, small, large);
- ordinal accuracy: tempo and amplitude (numbers are rounded to the nearest
  level word);
- set F1, per clip: precision |P & R| / |P|, recall |P & R| / |R|, F1 their
  harmonic mean, 1 when both sets are empty and 0 when only one is; Macro-F1
  is the mean over clips. Sets: body parts (`body_parts.mandatory`,
  normalized to the 17-part vocabulary), object/contact (the union of
  objects, body, environment and required contacts), invariant fields,
  variant fields;
- primitive sequence: exact accuracy of the name sequence and normalized edit
  similarity Sim = 1 - d_edit / max(|P^|, |P|) (`smp.aggregate.edit_similarity`);
- repetition count: mean absolute error over clips whose reference count is
  known and whose prediction gives one (coverage is reported).

Failure accounting: malformed JSON (not one clean JSON object: fenced,
truncated, prose), missing mandatory field (no label or no primitives),
invalid value (a value outside the schema, reset by the repair) and
rejected (unusable) over received responses, as `smp.repair` reports them;
request failures (no text) over all queries.
Over clips: five-response disagreement (the valid responses differ in at
least one aggregated field), deterministic schema repair (at least one
response needed repair), semantic consistency correction (refinement
changed or flagged at least one field), discard (fewer than 3 valid
responses), residual refined-SMP error (at least one evaluated field of the
refined SMP differs from the reference; over the clips that were not
discarded).

Uncertainty calibration (refined SMPs): every evaluated field that has an
uncertainty entry is one (uncertainty, error) pair; a set field is wrong
when its F1 is below 1. Bins [0, .2), [.2, .4), [.4, .6), [.6, .8),
[.8, 1]; Spearman correlation between uncertainty and error; AUROC of
uncertainty as a detector of wrong fields; ECE = sum over bins of
(n_b / N) |mean uncertainty_b - error rate_b|.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.errors import InputFileError, ValidationError
from vsmp_imu.io import read_text
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.aggregate import aggregate, edit_similarity, library_activity
from vsmp_imu.smp.bodyparts import normalize_body_parts
from vsmp_imu.smp.io import load_smp
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import Refiner
from vsmp_imu.smp.repair import parse_response
from vsmp_imu.smp.schema import (
    AMPLITUDE_LEVELS,
    SMP,
    TEMPO_LEVELS,
    UNKNOWN,
    displacement_word,
    ordinal_word,
)

STAGES = ("raw", "aggregated", "refined")
MIN_VALID = 3  # paper appendix: fewer than three valid outputs -> discard
UNCERTAINTY_BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
EXACT_FIELDS = ("activity_label", "periodicity", "dominant_side", "symmetry", "global_displacement")
ORDINAL_FIELDS = ("tempo", "amplitude")
SET_FIELDS = ("body_parts", "object_contact", "invariant_fields", "variant_fields")
FIELDS = (*EXACT_FIELDS[:1], "primitive_sequence", *SET_FIELDS[:1], *EXACT_FIELDS[1:2],
          "repetition_count", *ORDINAL_FIELDS, *EXACT_FIELDS[2:], *SET_FIELDS[1:])
# evaluated field -> the SMP uncertainty entry that covers it (invariant/variant have none)
UNCERTAINTY_OF = {
    "activity_label": "activity_label", "primitive_sequence": "motion_primitives",
    "body_parts": "body_parts", "periodicity": "temporal_structure",
    "repetition_count": "repetition_count", "tempo": "tempo", "amplitude": "amplitude",
    "dominant_side": "dominant_side", "symmetry": "symmetry",
    "global_displacement": "global_displacement", "object_contact": "object_contact",
}
RESPONSE_FILE = re.compile(r"^response_(\d+)\.(txt|json)$")
REFERENCE_SUFFIXES = (".json", ".yaml", ".yml")


@dataclass
class AuditClip:
    """One audited clip: its raw responses (None = the request failed), reference and group."""

    clip_id: str
    responses: list[str | None]
    reference: SMP
    group: str | None = None


@dataclass
class FieldScore:
    """One evaluated field: correct or not, and a graded score (F1, similarity, |error|)."""

    correct: bool
    score: float


@dataclass
class ClipAudit:
    """Everything measured on one clip."""

    clip_id: str
    group: str | None
    n_responses: int
    request_failures: int
    malformed_json: int
    missing_mandatory: int
    invalid_value: int
    rejected: int
    valid: int
    repaired: int
    discarded: bool
    disagreement: bool
    semantic_correction: bool
    raw_scores: list[dict[str, FieldScore]] = field(default_factory=list)
    scores: dict[str, dict[str, FieldScore]] = field(default_factory=dict)  # stage -> field -> score
    calibration: list[tuple[str, float, bool]] = field(default_factory=list)  # (field, u, wrong)
    corrections: list[dict[str, Any]] = field(default_factory=list)

    @property
    def residual_fields(self) -> list[str]:
        return [f for f, s in self.scores.get("refined", {}).items() if not s.correct]

    def to_dict(self) -> dict[str, Any]:
        return {
            "clip": self.clip_id, "group": self.group, "responses": self.n_responses,
            "request_failures": self.request_failures, "malformed_json": self.malformed_json,
            "missing_mandatory": self.missing_mandatory, "invalid_value": self.invalid_value,
            "rejected": self.rejected, "valid": self.valid, "repaired": self.repaired, "discarded": self.discarded,
            "five_response_disagreement": self.disagreement,
            "semantic_correction": self.semantic_correction,
            "residual_error": bool(self.residual_fields) if not self.discarded else None,
            "residual_fields": self.residual_fields,
            "scores": {stage: {f: {"correct": s.correct, "score": s.score} for f, s in fields.items()}
                       for stage, fields in self.scores.items()},
            "corrections": self.corrections,
        }


# -- inputs -------------------------------------------------------------------------------
def _clip_name(path: Path) -> str:
    return path.name[: -len(".raw")] if path.name.endswith(".raw") else path.name


def read_responses(folder: str | Path) -> list[str | None]:
    """The raw responses of one clip folder.

    `smp extract` layout (`response_K.txt` per answer, `response_K.json` per
    answer or failed request): one entry per K, None where only the JSON
    (a failed request) exists. Otherwise every `*.txt` file, in name order.
    """
    folder = Path(folder)
    indexed: dict[int, str | None] = {}
    for path in folder.iterdir():
        m = RESPONSE_FILE.match(path.name)
        if m:
            k = int(m.group(1))
            if m.group(2) == "txt":
                indexed[k] = read_text(path)
            else:
                indexed.setdefault(k, None)
    if indexed:
        return [indexed[k] for k in sorted(indexed)]
    texts = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() == ".txt")
    return [read_text(p) for p in texts]


def read_groups(path: str | Path) -> dict[str, str]:
    """clip -> group from a CSV with columns `clip` and `group`."""
    path = Path(path)
    text = read_text(path)
    reader = csv.DictReader(text.splitlines())
    if reader.fieldnames is None or not {"clip", "group"} <= set(reader.fieldnames):
        raise InputFileError("expected a CSV with columns 'clip' and 'group'", file=path)
    return {row["clip"].strip(): row["group"].strip() for row in reader if row.get("clip")}


def load_audit_inputs(pred_dir: str | Path, ref_dir: str | Path,
                      groups_file: str | Path | None = None) -> list[AuditClip]:
    """Pair every clip folder of `pred_dir` (`CLIP.raw/` or `CLIP/`) with `ref_dir/CLIP.{json,yaml}`.

    Groups come from `groups_file`, else from `pred_dir/clips.csv` when present.
    """
    pred, ref = Path(pred_dir), Path(ref_dir)
    for folder, name in ((pred, "--pred"), (ref, "--ref")):
        if not folder.is_dir():
            raise InputFileError(f"{name} must be a folder", file=folder)
    if groups_file is None and (pred / "clips.csv").exists():
        groups_file = pred / "clips.csv"
    groups = read_groups(groups_file) if groups_file is not None else {}
    folders = sorted(p for p in pred.iterdir() if p.is_dir())
    if not folders:
        raise InputFileError("no clip folders (CLIP.raw/ or CLIP/ with raw response files)", file=pred)
    clips = []
    for folder in folders:
        clip = _clip_name(folder)
        refs = [ref / f"{clip}{s}" for s in REFERENCE_SUFFIXES if (ref / f"{clip}{s}").exists()]
        if not refs:
            raise InputFileError(f"no reference SMP for clip '{clip}' (expected {clip}.json or "
                                 f"{clip}.yaml)", file=ref)
        responses = read_responses(folder)
        if not responses:
            raise InputFileError("no raw responses in the clip folder", file=folder)
        clips.append(AuditClip(clip, responses, load_smp(refs[0]), groups.get(clip)))
    return clips


# -- field comparison ---------------------------------------------------------------------
def set_f1(predicted: Sequence[str], reference: Sequence[str]) -> float:
    """Set F1 of one clip: 1 when both sets are empty, 0 when only one is."""
    p, r = set(predicted), set(reference)
    if not p and not r:
        return 1.0
    if not p or not r:
        return 0.0
    hit = len(p & r)
    if hit == 0:
        return 0.0
    precision, recall = hit / len(p), hit / len(r)
    return 2 * precision * recall / (precision + recall)


def _labels_match(a: str, b: str, library: ActivityLibrary) -> bool:
    if norm_name(a) == norm_name(b):
        return True
    if a in library and b in library:
        return library.get(a).name == library.get(b).name
    return False


def _body(smp: SMP) -> list[str]:
    parts, unknown = normalize_body_parts(list(smp.body_parts.mandatory))
    return parts + [norm_name(u) for u in unknown]


def _contacts(smp: SMP) -> list[str]:
    o = smp.object_contact
    return [norm_name(x) for x in (*o.objects, *o.body_contact, *o.environment_contact,
                                   *o.required_contact)]


def _exact(pred: Any, ref: Any) -> FieldScore | None:
    if ref == UNKNOWN:
        return None
    ok = pred == ref
    return FieldScore(ok, float(ok))


def compare_smps(pred: SMP, ref: SMP, library: ActivityLibrary) -> dict[str, FieldScore]:
    """Field scores of a predicted SMP against a reference (unknown reference fields skipped)."""
    out: dict[str, FieldScore | None] = {}
    ok = _labels_match(pred.activity_label, ref.activity_label, library)
    out["activity_label"] = FieldScore(ok, float(ok))
    p_seq = [norm_name(n) for n in pred.primitive_sequence]
    r_seq = [norm_name(n) for n in ref.primitive_sequence]
    out["primitive_sequence"] = FieldScore(p_seq == r_seq, edit_similarity(p_seq, r_seq))
    pt, rt = pred.temporal_structure, ref.temporal_structure
    out["periodicity"] = _exact(pt.periodicity, rt.periodicity)
    if rt.repetition_count != UNKNOWN and pt.repetition_count != UNKNOWN:
        err = abs(int(pt.repetition_count) - int(rt.repetition_count))
        out["repetition_count"] = FieldScore(err == 0, float(err))
    elif rt.repetition_count != UNKNOWN:
        out["repetition_count"] = FieldScore(False, float("nan"))
    pa, ra = pred.execution_attributes, ref.execution_attributes
    for name, levels in (("tempo", TEMPO_LEVELS), ("amplitude", AMPLITUDE_LEVELS)):
        r, p = getattr(ra, name), getattr(pa, name)
        if r != UNKNOWN:
            hit = p != UNKNOWN and ordinal_word(p, levels) == ordinal_word(r, levels)
            out[name] = FieldScore(hit, float(hit))
    out["dominant_side"] = _exact(pa.dominant_side, ra.dominant_side)
    out["symmetry"] = _exact(pa.symmetry, ra.symmetry)
    if ra.global_displacement != UNKNOWN:
        p = UNKNOWN if pa.global_displacement == UNKNOWN else displacement_word(pa.global_displacement)
        out["global_displacement"] = _exact(p, displacement_word(ra.global_displacement))
    for name, pv, rv in (
        ("body_parts", _body(pred), _body(ref)),
        ("object_contact", _contacts(pred), _contacts(ref)),
        ("invariant_fields", list(pred.constraints.invariant_fields), list(ref.constraints.invariant_fields)),
        ("variant_fields", list(pred.constraints.variant_fields), list(ref.constraints.variant_fields)),
    ):
        f1 = set_f1(pv, rv)
        out[name] = FieldScore(f1 == 1.0, f1)
    return {k: v for k, v in out.items() if v is not None}


# -- summaries ----------------------------------------------------------------------------
def calibration(pairs: Sequence[tuple[float, bool]]) -> dict[str, Any]:
    """Uncertainty bins, Spearman(u, error), AUROC and ECE of (uncertainty, wrong) pairs."""
    from scipy.stats import spearmanr
    from sklearn.metrics import roc_auc_score

    u = np.array([p[0] for p in pairs], dtype=float)
    wrong = np.array([p[1] for p in pairs], dtype=float)
    edges = UNCERTAINTY_BINS
    bins, ece = [], 0.0
    for i in range(len(edges) - 1):
        lo, hi = edges[i], edges[i + 1]
        last = i == len(edges) - 2
        mask = (u >= lo) & ((u <= hi) if last else (u < hi))
        n = int(mask.sum())
        mean_u = float(u[mask].mean()) if n else float("nan")
        err = float(wrong[mask].mean()) if n else float("nan")
        if n:
            ece += n / len(u) * abs(mean_u - err)
        bins.append({"bin": f"[{lo:.1f}, {hi:.1f}{']' if last else ')'}", "fields": n,
                     "mean_uncertainty": mean_u, "error_rate": err})
    both = len(u) > 1 and 0 < wrong.sum() < len(wrong)
    rho = float(spearmanr(u, wrong).statistic) if both and np.ptp(u) > 0 else float("nan")
    auroc = float(roc_auc_score(wrong, u)) if both else float("nan")
    return {"fields": len(u), "bins": bins, "spearman": rho, "auroc": auroc,
            "ece": float(ece) if len(u) else float("nan"),
            "error_rate": float(wrong.mean()) if len(u) else float("nan")}


def field_summary(score_lists: dict[str, list[FieldScore]]) -> dict[str, dict[str, Any]]:
    """Per field: the paper's metric (accuracy, Macro-F1, MAE) and the number evaluated."""
    out: dict[str, dict[str, Any]] = {}
    for name in FIELDS:
        scores = score_lists.get(name, [])
        if name == "repetition_count":
            errors = [s.score for s in scores if np.isfinite(s.score)]
            out[name] = {"metric": "MAE", "value": float(np.mean(errors)) if errors else float("nan"),
                         "n": len(scores), "answered": len(errors)}
        elif name in SET_FIELDS:
            out[name] = {"metric": "Macro-F1",
                         "value": float(np.mean([s.score for s in scores])) if scores else float("nan"),
                         "n": len(scores)}
        elif name == "primitive_sequence":
            out[name] = {"metric": "exact accuracy",
                         "value": float(np.mean([s.correct for s in scores])) if scores else float("nan"),
                         "edit_similarity": float(np.mean([s.score for s in scores])) if scores
                         else float("nan"), "n": len(scores)}
        else:
            metric = "ordinal accuracy" if name in ORDINAL_FIELDS else "accuracy"
            out[name] = {"metric": metric,
                         "value": float(np.mean([s.correct for s in scores])) if scores else float("nan"),
                         "n": len(scores)}
    return out


def failure_summary(clips: Sequence[ClipAudit]) -> dict[str, Any]:
    """The failure-accounting rates (responses and clips, as the module docstring defines)."""
    received = sum(c.n_responses - c.request_failures for c in clips)
    evaluated = [c for c in clips if not c.discarded]

    def rate(k: int, n: int) -> float:
        return k / n if n else float("nan")

    return {
        "responses": sum(c.n_responses for c in clips),
        "received_responses": received,
        "clips": len(clips),
        "request_failure": rate(sum(c.request_failures for c in clips), sum(c.n_responses for c in clips)),
        "malformed_json": rate(sum(c.malformed_json for c in clips), received),
        "missing_mandatory_field": rate(sum(c.missing_mandatory for c in clips), received),
        "invalid_field_value": rate(sum(c.invalid_value for c in clips), received),
        "rejected": rate(sum(c.rejected for c in clips), received),
        "five_response_disagreement": rate(sum(c.disagreement for c in clips), len(clips)),
        "schema_repair": rate(sum(c.repaired > 0 for c in clips), len(clips)),
        "semantic_correction": rate(sum(c.semantic_correction for c in clips), len(clips)),
        "discarded": rate(sum(c.discarded for c in clips), len(clips)),
        "residual_error": rate(sum(bool(c.residual_fields) for c in evaluated), len(evaluated)),
        "evaluated_clips": len(evaluated),
    }


@dataclass
class AuditResults:
    clips: list[ClipAudit]
    groups: list[str]
    fields: dict[str, dict[str, dict[str, Any]]]  # stage -> field -> summary (all clips)
    fields_by_group: dict[str, dict[str, dict[str, Any]]]  # group -> field -> summary (refined)
    failures: dict[str, dict[str, Any]]  # "overall" and each group
    calibration: dict[str, Any]
    settings: dict[str, Any]


class ExtractionAudit:
    """Audit extracted SMPs against references; `run(clips)` gives AuditResults.

    library: the activity library used for label matching and refinement
    (None: the built-in one); min_valid: responses needed to aggregate.
    """

    def __init__(self, library: ActivityLibrary | None = None, min_valid: int = MIN_VALID) -> None:
        self.library = library
        self.min_valid = min_valid

    def audit_clip(self, clip: AuditClip, library: ActivityLibrary) -> ClipAudit:
        parsed = [parse_response(text) if text is not None else None for text in clip.responses]
        received = [p for p in parsed if p is not None]
        reports = [p.report for p in received]
        audit = ClipAudit(
            clip.clip_id, clip.group, len(parsed), sum(p is None for p in parsed),
            sum(r.malformed_json for r in reports), sum(bool(r.missing_mandatory) for r in reports),
            sum(bool(r.invalid_values) for r in reports), sum(r.rejected for r in reports),
            sum(p.smp is not None for p in received),
            sum(r.repaired for r in reports), discarded=False, disagreement=False,
            semantic_correction=False)
        audit.raw_scores = [compare_smps(p.smp, clip.reference, library) for p in received
                            if p.smp is not None]
        agg = aggregate([p.smp if p is not None else None for p in parsed], min_valid=self.min_valid,
                        activity_of=library_activity(library))
        audit.disagreement = agg.any_disagreement
        if agg.smp is None:
            audit.discarded = True
            return audit
        refined = Refiner(library).refine(agg.smp)
        audit.semantic_correction = refined.corrected
        audit.corrections = [c.to_dict() for c in refined.corrections]
        audit.scores["aggregated"] = compare_smps(agg.smp, clip.reference, library)
        audit.scores["refined"] = compare_smps(refined.smp, clip.reference, library)
        u = refined.smp.uncertainty
        for name, score in audit.scores["refined"].items():
            if name in UNCERTAINTY_OF:
                audit.calibration.append((name, float(getattr(u, UNCERTAINTY_OF[name])), not score.correct))
        return audit

    def run(self, clips: Sequence[AuditClip]) -> AuditResults:
        if not clips:
            raise ValidationError("no clips to audit", field="clips")
        library = self.library if self.library is not None else ActivityLibrary.load()
        audits = [self.audit_clip(c, library) for c in clips]
        fields = {stage: field_summary(_collect(audits, stage)) for stage in STAGES}
        groups = sorted({a.group for a in audits if a.group is not None})
        by_group = {g: field_summary(_collect([a for a in audits if a.group == g], "refined"))
                    for g in groups}
        failures = {"overall": failure_summary(audits)}
        for g in groups:
            failures[g] = failure_summary([a for a in audits if a.group == g])
        pairs = [(u, wrong) for a in audits for _, u, wrong in a.calibration]
        cal = calibration(pairs) if pairs else {"fields": 0}
        cal["per_field"] = {
            name: {"fields": len(v), "mean_uncertainty": float(np.mean([x[0] for x in v])),
                   "error_rate": float(np.mean([x[1] for x in v]))}
            for name in UNCERTAINTY_OF
            if (v := [(u, w) for a in audits for f, u, w in a.calibration if f == name])}
        settings = {"min_valid": self.min_valid, "stages": list(STAGES),
                    "calibration_stage": "refined", "uncertainty_bins": list(UNCERTAINTY_BINS)}
        return AuditResults(audits, groups, fields, by_group, failures, cal, settings)


def _collect(audits: Sequence[ClipAudit], stage: str) -> dict[str, list[FieldScore]]:
    out: dict[str, list[FieldScore]] = {}
    for a in audits:
        score_sets = a.raw_scores if stage == "raw" else ([a.scores[stage]] if stage in a.scores else [])
        for scores in score_sets:
            for name, s in scores.items():
                out.setdefault(name, []).append(s)
    return out
