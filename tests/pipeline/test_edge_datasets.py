"""`generate`, `evaluate` and `data check` on datasets at the edge of what a fold can use: one
subject, one class, a subject whose recording is shorter than a window, no window at all, and
sampling rates too low for some stages. Each either works, with the skipped stages saying why,
or exits 2 naming the option or file; none ends in a traceback."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import yaml

FIXTURE = Path(__file__).resolve().parents[1] / "fixtures" / "datasets" / "generic"
FAST = ("--k", "1", "--alpha", "0.2")


def _dataset(root: Path, subjects=("p1", "p2", "p3"), labels=("walk", "sit"), fs_hz: float = 50.0,
             short: str | None = None) -> Path:
    """The generic fixture's recordings of `subjects` (rows of `labels` only, no time column),
    declared at `fs_hz`; `short` adds a subject with a one-row recording."""
    (root / "data").mkdir(parents=True)
    for subject in subjects:
        table = pd.read_csv(FIXTURE / "data" / f"{subject}.csv").drop(columns="t")
        table[table.label.isin(labels)].to_csv(root / "data" / f"{subject}.csv", index=False)
    if short:
        table.head(1).assign(subject=short).to_csv(root / "data" / f"{short}.csv", index=False)
    spec = yaml.safe_load((FIXTURE / "dataset.yaml").read_text())
    del spec["time_column"]
    spec.update(fs_hz=fs_hz, labels=list(labels))
    (root / "dataset.yaml").write_text(yaml.safe_dump(spec, sort_keys=False))
    return root / "dataset.yaml"


def _generate(cli, path: Path, holdout: str, out: Path, *extra: str):
    return cli("generate", "--dataset", path, "--holdout", holdout, "-o", out, "--cache-dir", out.parent / "cache",
               *FAST, *extra)


def test_holding_out_the_only_subject_is_refused(cli, tmp_path):
    path = _dataset(tmp_path / "ds", subjects=("p1",))
    code, _, err = _generate(cli, path, "p1", tmp_path / "gen")
    assert code == 2 and "'--holdout'" in err and "leaves no real training windows" in err
    assert "only subject" in err and not (tmp_path / "gen").exists()
    code, _, err = cli("evaluate", "--dataset", path, "--methods", "real", "-o", tmp_path / "ev")
    assert code == 2 and "at least 2 subjects" in err


def test_a_subject_without_a_window_is_in_the_dataset_and_says_so(cli, tmp_path):
    path = _dataset(tmp_path / "ds", short="p5")
    code, _, err = _generate(cli, path, "p5", tmp_path / "gen")
    assert code == 2 and "'--holdout'" in err and "is in my_waist_phone but has no labelled window of 2 s" in err
    assert "0.02 s (1 sample at 50 Hz)" in err and "Allowed: p1, p2, p3." in err
    code, _, err = _generate(cli, path, "p9", tmp_path / "gen")
    assert code == 2 and "'p9' is not in my_waist_phone" in err


def test_a_dataset_without_a_window_is_refused_with_its_longest_recording(cli, tmp_path):
    path = _dataset(tmp_path / "ds", fs_hz=5000)  # 400 rows: 0.08 s at the declared rate
    runs = {"generate": ["generate", "--dataset", path, "--holdout", "p1", "-o", tmp_path / "gen"],
            "evaluate": ["evaluate", "--dataset", path, "--methods", "real", "-o", tmp_path / "ev"],
            "data check": ["data", "check", path, "-o", tmp_path / "chk"]}
    for name, argv in runs.items():
        code, _, err = cli(*argv)
        assert code == 2 and str(path) in err and "gives no labelled window of 2 s" in err, name
        assert "0.08 s (400 samples at 5000 Hz)" in err and "fs_hz" in err, name


def test_one_class_generates_and_evaluate_asks_for_two(cli, tmp_path):
    path = _dataset(tmp_path / "ds", labels=("walk",))
    code, out, err = _generate(cli, path, "p1", tmp_path / "gen")
    assert code == 0, err
    summary = json.loads((tmp_path / "gen" / "summary.json").read_text())
    assert list(summary["per_class"]) == ["walk"] and summary["per_class"]["walk"]["selected"] > 0
    code, _, err = cli("evaluate", "--dataset", path, "--methods", "real", "-o", tmp_path / "ev")
    assert code == 2 and "field 'labels'" in err and "1 class(es) (walk)" in err and "at least 2 classes" in err


def test_at_one_hz_the_stages_that_need_more_are_skipped_with_the_reason(cli, tmp_path):
    """2 s at 1 Hz: windows of 2 samples, the fewest a window may have. Cadence (6 Hz), texture
    (8 Hz) and the check's pairs of classes (4 samples a window) are skipped and say why."""
    path = _dataset(tmp_path / "ds", fs_hz=1)
    code, out, err = _generate(cli, path, "p1", tmp_path / "gen")
    assert code == 0, err
    summary = json.loads((tmp_path / "gen" / "summary.json").read_text())
    assert "needs 6 Hz" in summary["cadence"]["walk"]["reason"] and "cadence walk: the SMP's tempo" in out
    assert "needs 8 Hz" in summary["texture"]["waist"]["reason"]
    code, out, err = cli("data", "check", path, "--samples", "1", "-o", tmp_path / "chk")
    assert code == 0, err
    check = json.loads((tmp_path / "chk" / "check.json").read_text())
    assert check["pairs"] == [] and "needs 4 samples" in check["pairs_skipped"] and "not compared" in out
    # window levels per part need a sample in each part
    code, _, err = _generate(cli, path, "p1", tmp_path / "parts", "--level-parts", "4")
    assert code == 2 and "'--level-parts'" in err and "(2 samples)" in err and "Allowed: 1..2." in err
    code, _, err = cli("evaluate", "--dataset", path, "--methods", "real,vsmp", "--level-parts", "4", "-o",
                       tmp_path / "ev")
    assert code == 2 and "'--level-parts'" in err and not (tmp_path / "ev").exists()
    # below 2 samples a window the rate is refused, by the dataset's own check of fs_hz
    code, _, err = _generate(cli, _dataset(tmp_path / "half", fs_hz=0.5), "p1", tmp_path / "half_gen")
    assert code == 2 and "field 'fs_hz'" in err and "(got 0.5)" in err
