"""Outputs of the extraction audit: report.md, results.json and a per-clip CSV."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

from vsmp_imu.io import write_text
from vsmp_imu.studies.audit import FIELDS, SET_FIELDS, STAGES, AuditResults
from vsmp_imu.studies.report import fmt_num, fmt_pct, markdown_table, write_report

FIELD_TITLES = {
    "activity_label": "Activity label", "primitive_sequence": "Primitive sequence",
    "body_parts": "Body-part involvement", "periodicity": "Periodicity",
    "repetition_count": "Repetition count", "tempo": "Tempo", "amplitude": "Amplitude",
    "dominant_side": "Dominant side", "symmetry": "Symmetry",
    "global_displacement": "Global displacement", "object_contact": "Object/contact",
    "invariant_fields": "Invariant fields", "variant_fields": "Variant fields",
}
FAILURE_ROWS = (
    ("malformed_json", "Malformed JSON output", "raw responses"),
    ("missing_mandatory_field", "Missing mandatory field", "raw responses"),
    ("invalid_field_value", "Invalid field value", "raw responses"),
    ("rejected", "Rejected (unusable) response", "raw responses"),
    ("request_failure", "Request failed (no response)", "queries"),
    ("five_response_disagreement", "Five-response disagreement", "clips"),
    ("schema_repair", "Deterministic schema repair", "clips"),
    ("semantic_correction", "Semantic consistency correction", "clips"),
    ("discarded", "Discarded: fewer than three valid outputs", "clips"),
    ("residual_error", "Residual refined-SMP error", "evaluated clips"),
)


def _value(summary: dict[str, Any]) -> str:
    if summary["metric"] == "MAE" or summary["metric"] == "Macro-F1":
        return fmt_num(summary["value"])
    return fmt_pct(summary["value"])


def _field_rows(results: AuditResults) -> list[list[str]]:
    rows = []
    for name in FIELDS:
        cells = [FIELD_TITLES[name], results.fields["refined"][name]["metric"]]
        cells += [_value(results.fields[stage][name]) for stage in STAGES]
        cells += [_value(results.fields_by_group[g][name]) for g in results.groups]
        cells.append(str(results.fields["refined"][name]["n"]))
        rows.append(cells)
        if name == "primitive_sequence":
            sim = ["", "normalized edit similarity"]
            sim += [fmt_num(results.fields[stage][name]["edit_similarity"]) for stage in STAGES]
            sim += [fmt_num(results.fields_by_group[g][name]["edit_similarity"]) for g in results.groups]
            sim.append("")
            rows.append(sim)
    return rows


def render_markdown(results: AuditResults) -> str:
    overall = results.failures["overall"]
    groups = results.groups
    lines = [
        "# SMP extraction audit",
        "",
        f"{overall['clips']} clips, {overall['responses']} queries ({overall['received_responses']} "
        f"responses received); {overall['evaluated_clips']} clips aggregated (the others had fewer "
        f"than {results.settings['min_valid']} valid responses)."
        + (f" Groups: {', '.join(groups)}." if groups else ""),
        "",
        "## Field-level extraction accuracy",
        "",
        "*Raw*: every valid response on its own (averaged over responses); *aggregated*: the "
        "combination of a clip's responses; *refined*: after the four consistency checks. "
        + ("Group columns are refined SMPs. " if groups else "")
        + "Set fields: per-clip set F1 averaged over clips (Macro-F1). Repetition count: mean "
        "absolute error. A reference field that is `unknown` is not evaluated; *n* counts the "
        "refined SMPs evaluated on the field.",
        "",
        markdown_table(["SMP field", "Metric", "Raw", "Aggregated", "Refined", *groups, "n"],
                       _field_rows(results), align=["l", "l", *["r"] * (4 + len(groups))]),
        "",
        "## Failure and repair accounting",
        "",
        markdown_table(["Measure", "Unit", *groups, "Overall"],
                       [[title, unit, *(fmt_pct(results.failures[g][key]) for g in groups),
                         fmt_pct(overall[key])] for key, title, unit in FAILURE_ROWS],
                       align=["l", "l", *["r"] * (len(groups) + 1)]),
        "",
        "Response rates are over received responses (request failures over all queries); the "
        "residual error is over the clips that were aggregated; the other rates are over all clips.",
        "",
    ]
    cal = results.calibration
    if cal.get("fields"):
        lines += [
            "## Uncertainty calibration (refined SMPs)",
            "",
            markdown_table(["Uncertainty bin", "Fields", "Mean uncertainty", "Empirical error"],
                           [[b["bin"], b["fields"], fmt_num(b["mean_uncertainty"]), fmt_pct(b["error_rate"])]
                            for b in cal["bins"]]),
            "",
            f"Spearman rho(uncertainty, error) = {fmt_num(cal['spearman'])}; AUROC (uncertainty "
            f"detecting wrong fields) = {fmt_num(cal['auroc'])}; ECE = {fmt_num(cal['ece'], 3)} "
            f"(bins as above, |mean uncertainty - error rate| weighted by field counts); "
            f"{cal['fields']} fields, error rate {fmt_pct(cal['error_rate'])}.",
            "",
            markdown_table(["Field", "Fields", "Mean uncertainty", "Error rate"],
                           [[FIELD_TITLES.get(k, k), v["fields"], fmt_num(v["mean_uncertainty"]),
                             fmt_pct(v["error_rate"])] for k, v in cal["per_field"].items()]),
            "",
        ]
    lines += ["## Clips", "", markdown_table(
        ["Clip", "Group", "Valid", "Discarded", "Disagreement", "Repair", "Correction", "Residual errors"],
        [[c.clip_id, c.group or "", f"{c.valid}/{c.n_responses}", "yes" if c.discarded else "",
          "yes" if c.disagreement else "", "yes" if c.repaired else "",
          "yes" if c.semantic_correction else "",
          "n/a" if c.discarded else (", ".join(c.residual_fields) or "none")]
         for c in results.clips], align=["l", "l", "r", "c", "c", "c", "c", "l"]), ""]
    return "\n".join(lines)


def clips_csv(results: AuditResults) -> str:
    buf = io.StringIO()
    fields = ["clip", "group", "responses", "request_failures", "malformed_json", "missing_mandatory",
              "invalid_value", "rejected", "valid", "repaired", "discarded", "five_response_disagreement",
              "semantic_correction", "residual_error", "residual_fields"]
    writer = csv.DictWriter(buf, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    for clip in results.clips:
        row = clip.to_dict()
        writer.writerow({k: (";".join(row[k]) if k == "residual_fields" else
                             ("" if row[k] is None else row[k])) for k in fields})
    return buf.getvalue()


def write_audit_outputs(results: AuditResults, out_dir: str | Path) -> dict[str, Path]:
    out = Path(out_dir)
    payload = {
        "study": "extraction_audit",
        "settings": results.settings,
        "groups": results.groups,
        "fields": results.fields,
        "fields_by_group": results.fields_by_group,
        "set_fields": list(SET_FIELDS),
        "failures": results.failures,
        "calibration": results.calibration,
        "clips": [c.to_dict() for c in results.clips],
    }
    md, js = write_report(out, render_markdown(results), payload)
    return {"report": md, "results": js, "clips": write_text(out / "clips.csv", clips_csv(results))}
