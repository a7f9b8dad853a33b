"""Outputs of the controllability study: report.md, results.json, cases.csv and the figure.

The figure follows the paper's four panels: (a) requested tempo against the
measured motion tempo and grounded-IMU tempo, (b) requested against
detected repetitions (motion and grounded IMU) with the identity line, (c)
requested amplitude against motion range of motion and grounded-IMU energy,
(d) the motion-level symmetry confusion matrix. Tempo and amplitude values
are shown relative to the medium level of their matched set, so activities
measured in different units (Hz, rad/s, rad) share one axis.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

import numpy as np

from vsmp_imu.io import write_text
from vsmp_imu.motion.selfcheck import LEVELS
from vsmp_imu.studies.control import (
    ATTRIBUTES,
    CHECKPOINTS,
    TARGETS,
    CaseResult,
    ControlResults,
    relative_values,
)
from vsmp_imu.studies.report import fmt_num, fmt_pct, markdown_table, save_figure, write_report

FIGURE_NAME = "control_results.png"
CHECKPOINT_TITLES = {"motion": "motion", "raw_imu": "raw IMU", "grounded_imu": "grounded IMU"}
CONTROL_TITLES = {"tempo": "Tempo", "amplitude": "Amplitude", "repetitions": "Repetition count",
                  "duration": "Primitive duration", "symmetry": "Symmetry"}
MOTION_COLOR, GROUNDED_COLOR = "#2b6cb0", "#dd6b20"
# Paper, Table "End-to-end SMP controllability on UTD-MHAD" (HY-Motion backend).
PAPER_VALUES = {
    "tempo": ("rho=0.92", "81.7%", "rho=0.73", "rho=0.61", "97.1%"),
    "amplitude": ("rho=0.86", "82.5%", "rho=0.79", "rho=0.75", "95.7%"),
    "repetitions": ("rho=0.93", "90.6% within +-1", "rho=0.76", "rho=0.61", "96.2%"),
    "duration": ("MAPE=9.8%", "80.0%", "MAPE=12.6%", "MAPE=14.1%", "94.8%"),
    "symmetry": ("Acc.=86.0%", "86.0%", "--", "--", "93.5%"),
}


def _rho(d: dict[str, Any]) -> str:
    return f"rho={fmt_num(d.get('rho_per_set'))} (pooled {fmt_num(d.get('rho_pooled_all'))})"


def summary_table(summary: dict[str, Any], retention: dict[str, Any]) -> str:
    """The paper's table layout: one row per control (in `ATTRIBUTES` order), from the
    `summary` and `retention` of a run (in memory or as read back from results.json)."""
    ordered = {a: summary[a] for a in ATTRIBUTES if a in summary}
    return markdown_table(*_main_rows(ordered, retention))


def _main_rows(summary: dict[str, Any], retention: dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    has_validator = any(v.get("validator") is not None for v in retention["per_control"].values())
    headers = ["Control", "Motion agreement", "Motion compliance", "Raw-IMU agreement",
               "Grounded-IMU agreement", "Label retention (templates)"]
    if has_validator:
        headers.append("Label retention (validator)")
    rows = []
    for attribute, s in summary.items():
        cp = s["checkpoints"]
        ret = retention["per_control"][attribute]
        if attribute == "symmetry":
            acc = cp["motion"]["accuracy"]
            row = [f"Acc.={fmt_pct(acc)}", fmt_pct(acc), "--", "--"]
        elif attribute == "duration":
            row = [f"MAPE={fmt_pct(cp['motion']['mape'])}", fmt_pct(cp["motion"]["ordering_compliance"]),
                   f"MAPE={fmt_pct(cp['raw_imu']['mape'])}", f"MAPE={fmt_pct(cp['grounded_imu']['mape'])}"]
        elif attribute == "repetitions":
            row = [_rho(cp["motion"]), f"{fmt_pct(cp['motion']['within_one'])} within +-1",
                   _rho(cp["raw_imu"]), _rho(cp["grounded_imu"])]
        else:
            row = [_rho(cp["motion"]), fmt_pct(cp["motion"]["ordering_compliance"]),
                   _rho(cp["raw_imu"]), _rho(cp["grounded_imu"])]
        row = [CONTROL_TITLES[attribute], *row, fmt_pct(ret["template"])]
        if has_validator:
            row.append(fmt_pct(ret.get("validator")))
        rows.append(row)
    return headers, rows


def checkpoint_table(summary: dict[str, Any]) -> str:
    """Every control at every checkpoint: rho three ways, ordering, unmeasured, counts or MAPE."""
    ordered = {a: summary[a] for a in ATTRIBUTES if a in summary}
    return markdown_table(["Control", "Checkpoint", "rho per set", "rho pooled per activity",
                           "rho pooled (all)", "Ordering", "Unmeasured", "Other"],
                          _detail_rows(ordered), align=["l", "l", "r", "r", "r", "r", "r", "l"])


def _detail_rows(summary: dict[str, Any]) -> list[list[str]]:
    rows = []
    for attribute, s in summary.items():
        if attribute == "symmetry":
            continue
        for cp in (c for c in CHECKPOINTS if c in s["checkpoints"]):
            d = s["checkpoints"][cp]
            extra = ""
            if attribute == "repetitions":
                extra = (f"within +-1 {fmt_pct(d['within_one'])}, exact {fmt_pct(d['exact'])}, "
                         f"mean error {d['mean_error']:+.2f}")
            elif attribute == "duration":
                extra = f"MAPE {fmt_pct(d['mape'])}"
            rows.append([CONTROL_TITLES[attribute], CHECKPOINT_TITLES[cp], fmt_num(d["rho_per_set"]),
                         fmt_num(d["rho_pooled_activity"]), fmt_num(d["rho_pooled_all"]),
                         fmt_pct(d["ordering_compliance"]), str(d["unmeasured"]), extra])
    return rows


def target_checks(results: ControlResults) -> list[dict[str, Any]]:
    """Each target of this implementation with its measured value and the activities below it."""
    s = results.summary
    checks = []

    def add(name: str, attribute: str, checkpoint: str, key: str, target: float, higher: bool) -> None:
        if attribute not in s or checkpoint not in s[attribute]["checkpoints"]:
            return
        value = s[attribute]["checkpoints"][checkpoint][key]
        ok = value is not None and np.isfinite(value) and (value >= target if higher else value <= target)
        below = {}
        for activity, per in s[attribute]["per_activity"].items():
            v = per[checkpoint][key]
            if not (np.isfinite(v) and (v >= target if higher else v <= target)):
                below[activity] = v
        checks.append({"check": name, "control": attribute, "checkpoint": checkpoint, "metric": key,
                       "value": value, "target": target, "higher_is_better": higher, "met": bool(ok),
                       "activities_missing_target": below})

    for attribute in ("tempo", "amplitude", "repetitions"):
        add(f"{attribute} motion rho", attribute, "motion", "rho_per_set", TARGETS["motion_rho"], True)
    add("repetitions within +-1 (motion)", "repetitions", "motion", "within_one", TARGETS["within_one"], True)
    add("duration MAPE (motion)", "duration", "motion", "mape", TARGETS["duration_mape"], False)
    add("symmetry accuracy (motion)", "symmetry", "motion", "accuracy", TARGETS["symmetry_accuracy"], True)
    for attribute in ("tempo", "amplitude", "repetitions"):
        add(f"{attribute} grounded-IMU rho", attribute, "grounded_imu", "rho_per_set",
            TARGETS["grounded_rho"], True)
    return checks


def _why(check: dict[str, Any], results: ControlResults) -> str:
    """A short reason for a missed target, from what the study measured."""
    attribute, checkpoint = check["control"], check["checkpoint"]
    parts = []
    below = check["activities_missing_target"]
    if below:
        listed = ", ".join(f"{a} ({fmt_num(v)})" for a, v in sorted(below.items(), key=lambda kv: str(kv[1])))
        parts.append(f"activities below the target: {listed}")
    if checkpoint == "grounded_imu":
        g = results.grounding
        note = g.get("location_note", "")
        parts.append(f"the grounded values pass through a monotone per-channel map to {g.get('target')} "
                     "statistics, which compresses peaks of the channels whose synthetic range differs "
                     f"most from the target's{'; ' + note if note else ''}")
    if attribute == "repetitions":
        d = results.summary[attribute]["checkpoints"][checkpoint]
        parts.append(f"mean count error {d['mean_error']:+.2f} (positive: extra peaks from the lead-in "
                     "or lead-out, negative: merged cycles)")
    return "; ".join(parts)


def _violations_text(results: ControlResults, limit: int = 12) -> list[str]:
    lines = []
    for attribute, s in results.summary.items():
        for cp, d in s["checkpoints"].items():
            bad = d.get("violations") or []
            if not bad:
                continue
            shown = "; ".join(
                f"{v['activity']} seed {v['seed']}: "
                + ", ".join(f"{k} {fmt_num(x, 3)}" for k, x in v["values"].items())
                for v in bad[:limit])
            more = f" (and {len(bad) - limit} more in results.json)" if len(bad) > limit else ""
            lines.append(f"- {CONTROL_TITLES[attribute]}, {CHECKPOINT_TITLES[cp]} "
                         f"({len(bad)} sets): {shown}{more}")
    return lines


def activity_table(summary: dict[str, Any], attribute: str) -> str:
    """One control per activity: rho and ordering (within +-1 for counts, MAPE for duration)
    at each checkpoint, or C_sym ranges for symmetry; activities in the study's order."""
    s = summary[attribute]
    order = [a for a in s.get("activities", []) if a in s["per_activity"]]
    s = {**s, "per_activity": {a: s["per_activity"][a] for a in order + sorted(set(s["per_activity"]) - set(order))}}
    if attribute == "symmetry":
        headers = ["Activity", "Motion accuracy", "C_sym symmetric", "C_sym asymmetric"]
        rows = []
        for activity, per in s["per_activity"].items():
            m = per["motion"]
            rng = m["c_sym_range"]
            rows.append([activity, fmt_pct(m["accuracy"]),
                         "..".join(fmt_num(x) for x in rng["symmetric"]) if rng["symmetric"] else "n/a",
                         "..".join(fmt_num(x) for x in rng["asymmetric"]) if rng["asymmetric"] else "n/a"])
        return markdown_table(headers, rows)
    key = {"repetitions": "within_one", "duration": "mape"}.get(attribute, "ordering_compliance")
    label = {"within_one": "within +-1", "mape": "MAPE", "ordering_compliance": "ordering"}[key]
    headers = ["Activity"] + [f"{CHECKPOINT_TITLES[cp]} rho / {label}" for cp in CHECKPOINTS]
    rows = []
    for activity, per in s["per_activity"].items():
        cells = [activity]
        for cp in CHECKPOINTS:
            d = per[cp]
            cells.append(f"{fmt_num(d['rho_per_set'])} / {fmt_pct(d[key])}")
        rows.append(cells)
    return markdown_table(headers, rows)


def render_markdown(results: ControlResults, figure: str | None) -> str:
    st = results.settings
    g = results.grounding
    lines = [
        "# End-to-end SMP controllability",
        "",
        f"{st['n_motions']} motions: controls {', '.join(st['controls'])} on "
        f"{len(st['activities'])} UTD-MHAD activities, seeds {st['seeds']}, backend `{st['backend']}`; "
        f"virtual IMU at {st['fs_hz']:g} Hz at each activity's UTD-MHAD location "
        f"({'with' if st['noise'] else 'without'} sensor noise; noise seed = {st['noise_seed']}); "
        f"grounding target `{g['target']}`. Run time {results.elapsed_s:.1f} s.",
        "",
        "## Summary (the paper's table layout)",
        "",
        summary_table(results.summary, results.retention),
        "",
        "rho is the Spearman correlation between requested level and measured value, computed in each "
        "matched set (one activity, one seed, every level) and averaged over the sets; *pooled* is "
        "one Spearman correlation over every motion of the control, on values divided by the value "
        "at the medium (1.00) level of their matched set (repetition counts as counted). With several "
        "seeds per level the tied levels cap a pooled rho near 0.94-0.97 even when every set is "
        "perfectly ordered. Compliance: share of matched sets whose values strictly increase with the "
        "level. Duration MAPE: |measured ratio to the 1.00 level - requested factor| / factor.",
        "",
        "## Every checkpoint",
        "",
        checkpoint_table(results.summary),
        "",
        "## Targets",
        "",
    ]
    for check in target_checks(results):
        sign = ">=" if check["higher_is_better"] else "<="
        value = (fmt_pct(check["value"]) if check["metric"] in ("within_one", "mape", "accuracy")
                 else fmt_num(check["value"]))
        target = (fmt_pct(check["target"], 0) if check["metric"] in ("within_one", "mape", "accuracy")
                  else fmt_num(check["target"]))
        status = "met" if check["met"] else "NOT MET"
        line = f"- {check['check']}: {value} (target {sign} {target}): {status}"
        if not check["met"]:
            line += f". Why: {_why(check, results)}."
        lines.append(line)
    sym = results.summary.get("symmetry")
    if sym:
        conf = sym["checkpoints"]["motion"]["confusion"]
        m = conf["matrix"]
        lines += ["", "## Symmetry (motion only)", "",
                  "A single sensor on one side (UTD-MHAD's right wrist or right thigh) cannot observe "
                  "whether the other side follows, so symmetry is measured on the motion only "
                  "(C_sym >= 0.82: symmetric).", "",
                  markdown_table(["requested \\ measured", "symmetric", "asymmetric"],
                                 [["symmetric", m[0][0], m[0][1]], ["asymmetric", m[1][0], m[1][1]]])]
    lines += ["", "## Label retention", "",
              "The paper's blinded annotators are replaced here. *Templates*: a motion retains its label "
              "when its nearest template (default executions of the "
              f"{len(results.retention['template_method']['templates'])} candidate activities with "
              f"held-out seeds {results.retention['template_method']['template_seeds']}; features: "
              "mean joint posture and per-joint-axis movement shares) belongs to its own activity. It "
              "measures whether an intervention moved the motion closer to another activity, not "
              "whether a person would still name it."]
    if "validator_method" in results.retention:
        v = results.retention["validator_method"]
        lines.append("")
        lines.append(f"*Validator*: {v['model']} ({v['windows']} windows of {v['window_s']} s), "
                     f"{v['decision']}; a grounded recording retains its label when the validator "
                     "names its activity.")
    lines.append("")
    for attribute, ret in results.retention["per_control"].items():
        conf = ", ".join(f"{a} -> {b}" for a, b in ret["confusions"]) or "none"
        extra = f", validator {fmt_pct(ret['validator'])}" if ret.get("validator") is not None else ""
        lines.append(f"- {CONTROL_TITLES[attribute]}: templates {fmt_pct(ret['template'])}{extra}; "
                     f"template confusions: {conf}")
    lines += ["", "## Per activity", ""]
    for attribute in results.summary:
        lines += [f"### {CONTROL_TITLES[attribute]}", "", activity_table(results.summary, attribute), ""]
    viol = _violations_text(results)
    lines += ["## Matched sets out of order", ""] + (viol or ["none"]) + [""]
    lines += ["## Grounding", "", f"- target: `{g['target']}`", f"- statistics: {g['statistics']}",
              f"- grounder: {g['grounder']}"]
    if "convention" in g:
        c = g["convention"]
        lines.append(f"- convention (gamma): device axes {', '.join(c['axes'])}, gravity "
                     f"{'included' if c['gravity_included'] else 'removed'}, {c['acc_unit']}, {c['gyr_unit']}")
    for loc, d in g.get("locations", {}).items():
        lines.append(f"- {loc}: {d['real_samples']} real samples ({len(d['real_classes'])} classes), "
                     f"{d['synthetic_samples']} synthetic samples, inferred axes {', '.join(d['inferred_axes'])}")
    if g.get("location_note"):
        lines.append(f"- note: {g['location_note']}")
    lines += ["", "## Paper reference (HY-Motion backend, human annotators)", "",
              markdown_table(["Control", "Motion agreement", "Motion compliance", "Raw-IMU agreement",
                              "Grounded-IMU agreement", "Label retention"],
                             [[CONTROL_TITLES[a], *PAPER_VALUES[a]] for a in results.summary]), ""]
    if figure:
        lines += ["## Figure", "", f"![controllability]({figure})", ""]
    return "\n".join(lines)


def cases_csv(cases: list[CaseResult]) -> str:
    rows = [c.row() for c in cases]
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
    return buf.getvalue()


def _strip(ax: Any, results: list[CaseResult], title: str, ylabel: str, labels: tuple[str, str]) -> None:
    """Box plots per requested level, motion and grounded IMU side by side, with the points."""
    attribute = results[0].case.attribute
    levels = list(LEVELS[attribute])
    rng = np.random.default_rng(0)
    for offset, checkpoint, color, label in ((-0.18, "motion", MOTION_COLOR, labels[0]),
                                             (0.18, "grounded_imu", GROUNDED_COLOR, labels[1])):
        rel = np.array(relative_values(results, checkpoint))
        groups = [rel[[r.case.level == lv for r in results]] for lv in levels]
        groups = [g[np.isfinite(g)] for g in groups]
        pos = np.arange(len(levels)) + offset
        ax.boxplot(groups, positions=pos, widths=0.28, showfliers=False, patch_artist=True,
                   boxprops={"facecolor": color, "alpha": 0.25, "edgecolor": color},
                   medianprops={"color": color, "linewidth": 1.6},
                   whiskerprops={"color": color}, capprops={"color": color})
        for p, g in zip(pos, groups, strict=True):
            ax.scatter(p + rng.uniform(-0.08, 0.08, len(g)), g, s=9, color=color, alpha=0.75,
                       edgecolors="none", label=label if p == pos[0] else None, zorder=3)
    ax.axhline(1.0, color="#999999", lw=0.8, ls=":")
    ax.set_xticks(range(len(levels)), [str(lv) for lv in levels])
    ax.set_xlabel(f"requested {attribute}")
    ax.set_ylabel(ylabel)
    ax.set_title(title, loc="left", fontsize=11)
    ax.legend(frameon=False, fontsize=8, loc="upper left")


def _repetitions(ax: Any, results: list[CaseResult]) -> None:
    rng = np.random.default_rng(1)
    levels = np.array(LEVELS["repetitions"], dtype=float)
    for offset, checkpoint, color, label in ((-0.25, "motion", MOTION_COLOR, "motion"),
                                             (0.25, "grounded_imu", GROUNDED_COLOR, "grounded IMU")):
        x = np.array([float(r.case.level) for r in results])
        y = np.array([r.values.get(checkpoint, np.nan) for r in results])
        ax.scatter(x + offset + rng.uniform(-0.12, 0.12, len(x)), y + rng.uniform(-0.12, 0.12, len(y)),
                   s=10, color=color, alpha=0.7, edgecolors="none", label=label, zorder=3)
    lim = [levels.min() - 1.5, levels.max() + 1.5]
    ax.plot(lim, lim, ls="--", color="#555555", lw=1.0, label="perfect agreement", zorder=2)
    ax.set_xlim(lim)
    ax.set_xticks(levels)
    ax.set_xlabel("requested repetitions")
    ax.set_ylabel("detected repetitions")
    ax.set_title("(b) Repetition count", loc="left", fontsize=11)
    ax.legend(frameon=False, fontsize=8, loc="upper left")


def _confusion(ax: Any, summary: dict[str, Any]) -> None:
    conf = summary["checkpoints"]["motion"]["confusion"]
    m = np.array(conf["matrix"], dtype=float)
    share = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
    ax.imshow(share, cmap="Blues", vmin=0, vmax=1)
    for i in range(2):
        for j in range(2):
            ax.text(j, i, f"{int(m[i, j])}\n({100 * share[i, j]:.0f}%)", ha="center", va="center",
                    color="white" if share[i, j] > 0.6 else "#222222", fontsize=10)
    ax.set_xticks([0, 1], conf["labels"])
    ax.set_yticks([0, 1], conf["labels"])
    ax.set_xlabel("measured (C_sym ≥ 0.82)")
    ax.set_ylabel("requested")
    ax.set_title("(d) Symmetry (motion)", loc="left", fontsize=11)


def _empty(ax: Any, title: str) -> None:
    ax.set_title(title, loc="left", fontsize=11)
    ax.text(0.5, 0.5, "not run", ha="center", va="center", transform=ax.transAxes, color="#777777")
    ax.set_xticks([])
    ax.set_yticks([])


def control_figure(results: ControlResults, path: str | Path) -> Path:
    """The paper's 4-panel controllability figure."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    by = {a: [r for r in results.cases if r.case.attribute == a] for a in ATTRIBUTES}
    fig, axes = plt.subplots(2, 2, figsize=(10.5, 8.2))
    (ax_a, ax_b), (ax_c, ax_d) = axes
    if by["tempo"]:
        _strip(ax_a, by["tempo"], "(a) Tempo", "measured tempo / medium level",
               ("motion tempo", "grounded-IMU tempo"))
    else:
        _empty(ax_a, "(a) Tempo")
    if by["repetitions"]:
        _repetitions(ax_b, by["repetitions"])
    else:
        _empty(ax_b, "(b) Repetition count")
    if by["amplitude"]:
        _strip(ax_c, by["amplitude"], "(c) Amplitude", "measured amplitude / medium level",
               ("motion range of motion", "grounded-IMU energy"))
    else:
        _empty(ax_c, "(c) Amplitude")
    if "symmetry" in results.summary:
        _confusion(ax_d, results.summary["symmetry"])
    else:
        _empty(ax_d, "(d) Symmetry (motion)")
    for ax in (ax_a, ax_b, ax_c):
        ax.spines[["top", "right"]].set_visible(False)
        ax.grid(axis="y", color="#eeeeee", lw=0.6)
        ax.set_axisbelow(True)
    st = results.settings
    fig.suptitle(f"End-to-end SMP controllability ({st['backend']} backend, {st['n_motions']} motions, "
                 f"grounding target {results.grounding['target']})", fontsize=12)
    fig.tight_layout()
    return save_figure(fig, path)


def write_control_outputs(results: ControlResults, out_dir: str | Path) -> dict[str, Path]:
    """report.md, results.json, cases.csv and the figure in `out_dir`."""
    out = Path(out_dir)
    figure = control_figure(results, out / FIGURE_NAME)
    markdown = render_markdown(results, FIGURE_NAME)
    payload = {
        "study": "controllability",
        "settings": results.settings,
        "grounding": results.grounding,
        "summary": results.summary,
        "targets": target_checks(results),
        "retention": results.retention,
        "elapsed_s": results.elapsed_s,
        "cases": [c.row() for c in results.cases],
    }
    md, js = write_report(out, markdown, payload)
    csv_path = write_text(out / "cases.csv", cases_csv(results.cases))
    return {"report": md, "results": js, "cases": csv_path, "figure": figure}
