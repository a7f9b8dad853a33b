"""The demo (what `make demo` runs), on one held-out subject."""

from __future__ import annotations

import json

from vsmp_imu.demo import DemoConfig, run_demo


def test_demo_writes_its_report_and_figures(tmp_path):
    out = tmp_path / "demo"
    result = run_demo(out, DemoConfig(folds=("2",), workers=1))
    pairs = [(r["backbone"], r["method"]) for r in result["rows"]]
    assert pairs == [(b, m) for b in ("rf", "rf-seg") for m in ("real", "classical", "vsmp")]
    for r in result["rows"]:
        assert 0.2 < r["macro_f1"] / 100 < 1.0
        assert {"activities", "transitions"} <= set(r)
    for name in ("report.md", "traces.png", "filter_stats.png", "skeleton.gif", "skeleton_keyframes.png",
                 "synthetic/synthetic.parquet", "synthetic/summary.json", "evaluation/results.json"):
        assert (out / name).stat().st_size > 0, name
    report = (out / "report.md").read_text()
    assert "| RF-SEG (balanced, synthetic 0.5) | VSMP-IMU |" in report and "Quality filter" in report
    config = json.loads((out / "evaluation" / "results.json").read_text())["config"]
    assert config["backbone_params"] == {"rf": {"class_weight": "balanced"}, "rf-seg": {"class_weight": "balanced"}}
    assert config["synthetic_weight"] == 0.5
    # the samples live in the cache directory (conftest: a temporary one), not in the output folder
    from vsmp_imu.har.cache import samples_dir

    assert not (out / "cache").exists() and any(samples_dir().glob("*.parquet"))
    summary = json.loads((out / "synthetic" / "summary.json").read_text())
    assert summary["per_class"]["STAND_TO_SIT"]["budget"] > 0
