"""An evaluation's results.md pairs every method with Real-only, and the other methods with
Classical Aug, over the runs both have: mean difference, runs won, Wilcoxon p."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import wilcoxon

from vsmp_imu.har.report import results_markdown
from vsmp_imu.methods import register_all


@pytest.fixture(autouse=True)
def _names():
    register_all()  # the methods' display names, as the CLI has them

GAINS = {"real": 0.0, "classical": 0.01, "vsmp": 0.03}


def _record(method: str, fold: int, seed: int, backbone: str = "rf", **extra) -> dict:
    f1 = 0.5 + 0.02 * fold + 0.01 * seed + GAINS[method] * (1 + 0.1 * fold)
    return {"dataset": "hapt12", "protocol": "low-resource", "budget": 1.0, "backbone": backbone,
            "method": method, "fold": str(fold), "seed": seed, "macro_f1": f1,
            "group_macro_f1": {"transitions": f1 - 0.2}, "tail_macro_f1": None, **extra}


def _results(records: list[dict]) -> dict:
    summary = [{"dataset": "hapt12", "protocol": "low-resource", "budget": 1.0, "backbone": "rf",
                "method": m, "macro_f1_mean": 0.5, "macro_f1_std": 0.1} for m in GAINS]
    return {"summary": summary, "config": {"methods": list(GAINS), "backbones": ["rf"]}, "records": records}


def _rows(text: str) -> dict[str, list[str]]:
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) > 3 and " vs. " in cells[2]:
            out[cells[2]] = cells[3:]
    return out


def test_each_method_is_paired_with_real_only_and_classical_aug():
    records = [_record(m, fold, seed) for m in GAINS for fold in range(1, 6) for seed in range(2)]
    rows = _rows(results_markdown(_results(records)))
    assert set(rows) == {"Classical Aug. vs. Real-only", "VSMP-IMU vs. Real-only", "VSMP-IMU vs. Classical Aug."}
    diffs = np.array([_record("vsmp", f, s)["macro_f1"] - _record("real", f, s)["macro_f1"]
                      for f in range(1, 6) for s in range(2)])
    p = wilcoxon(diffs).pvalue
    assert rows["VSMP-IMU vs. Real-only"][0] == f"+{100 * diffs.mean():.2f} (10/10, p = {p:.2g})"
    assert len(rows["VSMP-IMU vs. Real-only"]) == 2  # Macro-F1 and the transitions group


def test_only_the_runs_both_methods_have_are_paired():
    records = [_record(m, fold, 0) for m in ("real", "vsmp") for fold in range(1, 6)]
    records = [r for r in records if not (r["method"] == "vsmp" and r["fold"] == "5")]
    rows = _rows(results_markdown(_results(records)))
    assert rows["VSMP-IMU vs. Real-only"][0].endswith("(4/4, p = 0.12)")


def test_one_run_has_no_test():
    records = [_record(m, 1, 0) for m in ("real", "vsmp")]
    rows = _rows(results_markdown(_results(records)))
    assert rows["VSMP-IMU vs. Real-only"][0].endswith("(1/1, p = n/a)")


def test_nothing_to_pair_leaves_the_section_out():
    records = [_record("vsmp", fold, 0) for fold in range(1, 4)]
    assert "Paired differences" not in results_markdown(_results(records))


def test_unseen_and_tail_figures_are_paired_where_the_protocol_has_them():
    records = [_record(m, fold, 0, unseen_macro_f1=0.3 + GAINS[m] * fold, unseen_classes=["SIT_TO_LIE"])
               for m in ("real", "vsmp") for fold in range(1, 6)]
    text = results_markdown(_results(records))
    assert "| Pair | Macro-F1 | Unseen Macro-F1 | transitions Macro-F1 |" in text
    assert _rows(text)["VSMP-IMU vs. Real-only"][1] == "+9.00 (5/5, p = 0.062)"
