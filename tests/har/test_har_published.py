"""`vsmp-imu report`: committed records -> the tables of the docs, and the check that guards them."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import wilcoxon

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.measures import Metric, format_p, paired_test
from vsmp_imu.har.published import Publication
from vsmp_imu.har.records import import_run, load_run

REPO_ROOT = Path(__file__).resolve().parents[2]
LABELS = ("WALKING", "SIT_TO_LIE")
METHODS = {"real": 0.0, "vsmp": 0.05}


def _record(method: str, fold: int, seed: int, budget: float, f1: float) -> dict:
    return {
        "dataset": "hapt12", "protocol": "low-resource", "budget": budget, "backbone": "rf",
        "method": method, "fold": str(fold), "seed": seed, "macro_f1": f1, "accuracy": f1 + 0.1,
        "group_macro_f1": {"transitions": f1 - 0.2}, "head_macro_f1": None, "tail_macro_f1": None,
        "per_class_f1": {"WALKING": f1 + 0.2, "SIT_TO_LIE": f1 - 0.2},
        "confusion": [[3, 1], [0, 2]], "n_synthetic": 0 if method == "real" else 90,
        "n_synthetic_requested": 0 if method == "real" else 100, "n_train_real": 140,
        "settings_digest": "x", "fit_seconds": 0.2,
    }


def _records() -> list[dict]:
    """Two methods x 4 folds x 2 seeds at one budget; vsmp gains 5 points with a fold-dependent
    spread, so every figure of the tables is known in closed form."""
    out = []
    for fold in range(1, 5):
        for seed in range(2):
            base = 0.5 + 0.02 * fold + 0.01 * seed
            for method, gain in METHODS.items():
                out.append(_record(method, fold, seed, 1.0, base + gain * (1 + 0.1 * fold)))
    return out


def _evaluate_dir(tmp_path: Path) -> Path:
    run = tmp_path / "run"
    run.mkdir()
    results = {"config": {"alpha": 2.0}, "label_names": list(LABELS), "records": _records()}
    (run / "results.json").write_text(json.dumps(results))
    return run


CATALOGUE = """
tables:
  - id: demo:main
    records: demo
    kind: groups
    budgets: [1]
    methods: [real, vsmp]
    metrics:
      - {label: all classes, metric: macro_f1}
      - {label: transitions, metric: "group:transitions"}
  - id: demo:paired
    records: demo
    kind: paired
    baseline: real
    budgets: [1]
    methods: [vsmp]
    metrics:
      - {label: all classes, metric: macro_f1}
unbacked:
  - id: big:main
    reason: "needs 90 GPU runs"
"""

DOC = """# Results

<!-- report:demo:main -->
<!-- /report -->

Some prose quoting a mark, `<!-- report:ID -->`, which is not one.

<!-- report:demo:paired -->
<!-- /report -->

<!-- report:big:main -->
| a | b |
|---|---|
| 1 | 2 |
<!-- /report -->
"""


@pytest.fixture()
def repo(tmp_path: Path, report_repo) -> Path:
    root = report_repo(CATALOGUE, {"docs/results.md": DOC})
    import_run(_evaluate_dir(tmp_path), "demo", "vsmp-imu evaluate --dataset hapt12 -o run",
               root / "results", code_commit="abc1234def")
    return root


def test_import_keeps_the_records_and_the_command(tmp_path):
    folder = import_run(_evaluate_dir(tmp_path), "demo", "vsmp-imu evaluate x", tmp_path / "res")
    lines = (folder / "records.jsonl").read_text().splitlines()
    assert len(lines) == 16
    first = json.loads(lines[0])
    assert "fit_seconds" not in first and "settings_digest" not in first
    assert first["per_class_f1"]["WALKING"] == pytest.approx(first["macro_f1"] + 0.2)
    loaded = load_run(tmp_path / "res", "demo")
    assert loaded.command == "vsmp-imu evaluate x"
    assert loaded.label_names == LABELS
    assert len(loaded.select(method="vsmp", seed=1)) == 4


def _unfinished_run(tmp_path: Path, labels: tuple[str, ...] | None) -> Path:
    run = tmp_path / "run"
    (run / "records").mkdir(parents=True)
    for i, record in enumerate(_records()[:3]):
        if labels is not None:
            record["label_names"] = list(labels)
        (run / "records" / f"r{i}.json").write_text(json.dumps(record))
    return run


def test_import_reads_the_record_files_of_an_unfinished_run(tmp_path):
    run = _unfinished_run(tmp_path, LABELS)
    older = json.loads((run / "records" / "r0.json").read_text())  # written before records said the order
    del older["label_names"]
    (run / "records" / "r0.json").write_text(json.dumps(older))
    folder = import_run(run, "partial", "cmd", tmp_path / "res")
    assert len((folder / "records.jsonl").read_text().splitlines()) == 3
    assert "label_names" not in json.loads((folder / "records.jsonl").read_text().splitlines()[0])
    assert load_run(tmp_path / "res", "partial").label_names == LABELS


def test_record_files_that_do_not_say_their_class_order_need_it_given(tmp_path):
    """The per-class F1 keys are sorted; the confusion matrix follows the dataset's order."""
    run = _unfinished_run(tmp_path, None)
    with pytest.raises(ConfigError, match="order of their confusion"):
        import_run(run, "partial", "cmd", tmp_path / "res")
    with pytest.raises(ConfigError, match=r"3 classes given; .*r0.json has a 2x2 confusion matrix"):
        import_run(run, "partial", "cmd", tmp_path / "res", labels=("WALKING", "SIT_TO_LIE", "LAYING"))
    with pytest.raises(ConfigError, match="--labels"):
        import_run(run, "partial", "cmd", tmp_path / "res", labels=("WALKING", "LAYING"))
    order = tuple(reversed(LABELS))
    import_run(run, "partial", "cmd", tmp_path / "res", labels=order)
    assert load_run(tmp_path / "res", "partial").label_names == order


def test_a_folder_run_into_once_per_seed_imports_every_seed_only_when_asked(tmp_path, cli):
    """results.json holds the last invocation's records (here seed 1); records/ every invocation's."""
    run = tmp_path / "run"
    (run / "records").mkdir(parents=True)
    records = _records()
    for i, record in enumerate(records):
        (run / "records" / f"r{i}.json").write_text(json.dumps(record))
    last = [r for r in records if r["seed"] == 1]
    (run / "results.json").write_text(json.dumps({"config": {}, "label_names": list(LABELS), "records": last}))
    with pytest.raises(ConfigError, match="8 records and .* 8 more") as info:
        import_run(run, "seeds", "cmd", tmp_path / "res")
    assert info.value.field == "--every-record"
    folder = import_run(run, "seeds", "cmd", tmp_path / "res", every_record=True)
    rows = [json.loads(line) for line in (folder / "records.jsonl").read_text().splitlines()]
    assert len(rows) == 16 and {r["seed"] for r in rows} == {0, 1}
    code, _, err = cli("report", "import", run, "--name", "seeds2", "--command", "cmd", "--root", tmp_path)
    assert code == 2 and "--every-record" in err
    code, _, err = cli("report", "import", run, "--name", "seeds2", "--command", "cmd", "--root", tmp_path,
                       "--every-record")
    assert code == 0, err
    assert len((tmp_path / "results" / "seeds2" / "records.jsonl").read_text().splitlines()) == 16


def _seed_dir(tmp_path: Path, seed: int, config: dict) -> Path:
    """An `evaluate` folder of one `--only-seeds SEED` invocation."""
    run = tmp_path / f"run_s{seed}"
    run.mkdir()
    records = [r for r in _records() if r["seed"] == seed]
    (run / "results.json").write_text(json.dumps(
        {"config": {**config, "seeds": [seed]}, "label_names": list(LABELS), "records": records}))
    return run


def test_folders_of_one_experiment_on_other_seeds_import_as_one_set(tmp_path, cli):
    config = {"alpha": 2.0, "folds": ["1", "2", "3", "4"]}
    runs = [_seed_dir(tmp_path, seed, config) for seed in (1, 0)]
    folder = import_run(runs, "both", "cmd", tmp_path / "res")
    rows = [json.loads(line) for line in (folder / "records.jsonl").read_text().splitlines()]
    assert len(rows) == 16 and {r["seed"] for r in rows} == {0, 1}
    meta = json.loads((folder / "run.json").read_text())
    assert meta["config"] == {"alpha": 2.0, "folds": ["1", "2", "3", "4"], "seeds": [0, 1]}
    code, _, err = cli("report", "import", *runs, "--name", "both", "--command", "cmd", "--root", tmp_path)
    assert code == 0, err
    assert (tmp_path / "results" / "both" / "records.jsonl").read_text() == (folder / "records.jsonl").read_text()


def test_folders_that_ran_other_settings_or_the_same_run_do_not_join(tmp_path, cli):
    first = _seed_dir(tmp_path, 0, {"alpha": 2.0})
    other = _seed_dir(tmp_path, 1, {"alpha": 0.5})
    with pytest.raises(ConfigError, match=r"ran with alpha = 2\.0, .*run_s1 with 0\.5"):
        import_run([first, other], "mixed", "cmd", tmp_path / "res")
    again = tmp_path / "again"
    shutil.copytree(first, again)
    with pytest.raises(ConfigError, match=r"again.*and .*run_s0.* hold the same run"):
        import_run([first, again], "twice", "cmd", tmp_path / "res")
    with pytest.raises(ConfigError, match=r"run_s0 is given twice"):
        import_run([first, tmp_path / "." / "run_s0"], "twice", "cmd", tmp_path / "res")
    swapped = tmp_path / "swapped"
    shutil.copytree(other, swapped)
    data = json.loads((swapped / "results.json").read_text())
    data["label_names"] = list(reversed(LABELS))
    (swapped / "results.json").write_text(json.dumps(data))
    with pytest.raises(ConfigError, match="the folders name different classes"):
        import_run([first, swapped], "classes", "cmd", tmp_path / "res")
    assert not (tmp_path / "res").exists()
    code, _, err = cli("report", "import", first, other, "--name", "mixed", "--command", "cmd", "--root", tmp_path)
    assert code == 2 and "alpha" in err
    code, _, err = cli("report", "import", first, other, "--name", "study2", "--command",
                       "vsmp-imu study control -o x", "--root", tmp_path)
    assert code == 2 and "a study is imported from one folder" in err


def test_import_does_not_overwrite_a_record_set_unless_told(tmp_path, cli):
    run = _evaluate_dir(tmp_path)
    code, _, err = cli("report", "import", run, "--name", "kept", "--command", "first", "--root", tmp_path)
    assert code == 0, err
    code, _, err = cli("report", "import", run, "--name", "kept", "--command", "second", "--root", tmp_path)
    assert code == 2 and "record set 'kept' exists" in err and "--replace" in err
    assert json.loads((tmp_path / "results" / "kept" / "run.json").read_text())["command"] == "first"
    code, _, err = cli("report", "import", run, "--name", "kept", "--command", "second", "--root", tmp_path,
                       "--replace")
    assert code == 0, err
    assert json.loads((tmp_path / "results" / "kept" / "run.json").read_text())["command"] == "second"


def test_import_refuses_a_folder_without_records(tmp_path):
    with pytest.raises(InputFileError, match="not an `vsmp-imu evaluate` output folder"):
        import_run(tmp_path, "x", "cmd", tmp_path / "res")
    with pytest.raises(ConfigError, match="--name"):
        import_run(_evaluate_dir(tmp_path), "Bad Name", "cmd", tmp_path / "res")


def test_paired_test_matches_scipy_on_the_same_pairs():
    records = _records()
    real = [r for r in records if r["method"] == "real"]
    vsmp = [r for r in records if r["method"] == "vsmp"]
    vsmp[0]["macro_f1"] = real[0]["macro_f1"] - 0.01  # one run lost
    diffs = np.array([v["macro_f1"] - r["macro_f1"] for v, r in zip(vsmp, real, strict=True)])
    result = paired_test(list(reversed(vsmp)), real, Metric(label="all", metric="macro_f1"))
    assert result.n == 8 and result.won == 7
    assert result.mean_diff == pytest.approx(diffs.mean())
    assert result.p == pytest.approx(wilcoxon(diffs).pvalue)


def test_p_values_are_written_as_the_docs_write_them():
    assert format_p(3.2e-6) == "3e-6"
    assert format_p(0.0134) == "0.013"
    assert format_p(0.54) == "0.54"


def test_write_then_check_passes(repo, cli):
    code, out, _ = cli("report", "--write", "--root", repo)
    assert code == 0, out
    text = (repo / "docs" / "results.md").read_text()
    real = [r["macro_f1"] for r in _records() if r["method"] == "real"]
    mean, std = 100 * np.mean(real), 100 * np.std(real, ddof=1)
    assert f"| 1 % | all classes | {mean:.2f} ± {std:.2f} |" in text
    assert "(8/8, p = " in text
    assert "`vsmp-imu evaluate --dataset hapt12 -o run` at commit abc1234" in text
    assert "| 1 | 2 |" in text  # the unbacked block is left as written
    code, out, err = cli("report", "--check", "--root", repo)
    assert code == 0, out
    assert "big:main" in err and "needs 90 GPU runs" in err


def test_a_table_edited_by_one_digit_fails_the_check(repo, cli):
    cli("report", "--write", "--root", repo)
    path = repo / "docs" / "results.md"
    text = path.read_text()
    start = text.index("| 1 % | all classes | ") + len("| 1 % | all classes | ")
    digit = text[start]
    path.write_text(text[:start] + str((int(digit) + 1) % 10) + text[start + 1:])
    code, out, err = cli("report", "--check", "--root", repo)
    assert code == 1
    assert "docs/results.md: table 'demo:main'" in err
    assert "(from the records)" in out


def test_a_missing_record_file_is_an_input_error(repo, cli):
    shutil.rmtree(repo / "results" / "demo")
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 2
    assert "record set 'demo' has no run.json" in err and "vsmp-imu report import" in err


def test_an_undeclared_or_unclosed_block_is_an_input_error(repo, cli):
    path = repo / "docs" / "results.md"
    path.write_text(DOC + "\n<!-- report:other:main -->\n<!-- /report -->\n")
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 2 and "'other:main' is not declared" in err
    path.write_text(DOC + "\n<!-- report:demo:main -->\n")
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 2 and "has no '<!-- /report -->'" in err


def _tamper(text: str) -> str:
    """The text with one digit of the demo table's first row changed."""
    start = text.index("| 1 % | all classes | ") + len("| 1 % | all classes | ")
    return text[:start] + str((int(text[start]) + 1) % 10) + text[start + 1:]


def test_a_crlf_document_is_checked_and_keeps_its_line_ends(repo, cli):
    cli("report", "--write", "--root", repo)
    path = repo / "docs" / "results.md"
    crlf = path.read_bytes().replace(b"\n", b"\r\n")
    path.write_bytes(crlf)
    code, out, _ = cli("report", "--check", "--root", repo)
    assert code == 0 and "2 tables from records, 0 differ" in out, out
    path.write_bytes(_tamper(crlf.decode()).encode())
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 1 and "table 'demo:main'" in err
    code, out, _ = cli("report", "--write", "--root", repo)
    assert code == 0, out
    assert path.read_bytes() == crlf  # rebuilt, every line still ending in CRLF


def test_a_mark_with_trailing_whitespace_is_a_mark(repo, cli):
    cli("report", "--write", "--root", repo)
    path = repo / "docs" / "results.md"
    text = path.read_text().replace("<!-- report:demo:main -->\n", "<!-- report:demo:main --> \t\n")
    path.write_text(_tamper(text))
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 1 and "table 'demo:main'" in err
    cli("report", "--write", "--root", repo)
    assert "<!-- report:demo:main --> \t\n" in path.read_text()


@pytest.mark.parametrize("line, why", [
    (" <!-- report:demo:main -->", "looks like a report mark but is not one"),
    ("<!--report:demo:main-->", "looks like a report mark but is not one"),
    ("<!-- report: demo:main -->", "looks like a report mark but is not one"),
    ("<!-- /report -->", "has no '<!-- report:ID -->' before it"),
])
def test_a_line_that_looks_like_a_mark_but_is_none_is_an_input_error(repo, cli, line, why):
    (repo / "docs" / "results.md").write_text(DOC + "\n" + line + "\n")
    code, _, err = cli("report", "--check", "--root", repo)
    assert code == 2 and why in err and "line 17" in err, err


def test_write_leaves_a_read_only_document_as_it_is(repo, cli):
    cli("report", "--write", "--root", repo)
    path = repo / "docs" / "results.md"
    tampered = _tamper(path.read_text())
    path.write_text(tampered)
    path.chmod(0o444)
    code, _, err = cli("report", "--write", "--root", repo)
    assert code == 2 and "read-only" in err and "results.md" in err, err
    assert path.read_text() == tampered and path.stat().st_mode & 0o777 == 0o444


def test_write_keeps_a_documents_mode_and_its_link(repo, cli):
    cli("report", "--write", "--root", repo)
    real = repo / "shared.md"
    (repo / "docs" / "results.md").rename(real)
    (repo / "docs" / "results.md").symlink_to(real)
    real.write_text(_tamper(real.read_text()))
    real.chmod(0o640)
    code, out, _ = cli("report", "--write", "--root", repo)
    assert code == 0 and "1 files rewritten" in out, out
    assert (repo / "docs" / "results.md").is_symlink() and real.stat().st_mode & 0o777 == 0o640
    assert cli("report", "--check", "--root", repo)[0] == 0


def test_a_table_asking_for_records_the_set_lacks_is_an_error(repo):
    catalogue = repo / "results" / "tables.yaml"
    catalogue.write_text(CATALOGUE.replace("budgets: [1]\n    methods: [real, vsmp]",
                                           "budgets: [5]\n    methods: [real, vsmp]"))
    with pytest.raises(ConfigError, match="no record of method 'real', budget 5"):
        Publication(repo).check()


def test_the_repository_documents_match_their_records():
    outcome = Publication(REPO_ROOT).check()
    assert outcome.differing == [], "\n".join(outcome.diffs)


def test_a_table_whose_columns_cover_different_runs_is_an_error(tmp_path, repo):
    records = [r for r in _records() if not (r["method"] == "vsmp" and r["seed"] == 1)]
    run = tmp_path / "uneven"
    run.mkdir()
    (run / "results.json").write_text(json.dumps({"label_names": list(LABELS), "records": records}))
    import_run(run, "demo", "cmd", repo / "results")
    with pytest.raises(ConfigError, match=r"do not have the same runs at budget 1 \(real 8, vsmp 4\)"):
        Publication(repo).check()


def test_the_shares_table_counts_the_classes_that_got_no_synthetic_windows():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    def share(share, offered, n_val):
        return {"share": share, "offered": offered, "kept": round(share * offered), "n_val": n_val,
                "mean_change": None, "reason": "r"}

    records = []
    for fold in range(1, 5):
        r = _record("vsmp", fold, 0, 1.0, 0.6)
        r["synthetic_shares"] = {"WALKING": share(0.0 if fold <= 3 else 1.0, 10, 2),
                                 "SIT_TO_LIE": share(1.0, 30, 0)}
        records.append(r)
    spec = TableSpec(id="x:shares", records="x", kind="shares", budgets=[1], methods=["vsmp"])
    table = TableBuilder(spec, RecordSet("x", "cmd", None, None, {}, LABELS, tuple(records))).render()
    # kept: 4 x 30 (SIT_TO_LIE) + 10 (WALKING, once) of 160 offered
    assert "| 1 % | VSMP-IMU | 81 % | WALKING 3/4 | SIT_TO_LIE 4/4 |" in table


def test_a_paired_table_can_take_its_baseline_from_another_record_set():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    before = [_record("vsmp", fold, 0, 1.0, 0.5) for fold in range(1, 7)]
    after = [_record("vsmp", fold, 0, 1.0, 0.5 + 0.01 * fold) for fold in range(1, 7)]
    spec = TableSpec(id="x:before", records="after", kind="paired", baseline="vsmp", baseline_records="before",
                     budgets=[1], methods=["vsmp"], metrics=[{"label": "all", "metric": "macro_f1"}])
    table = TableBuilder(spec, RecordSet("after", "cmd a", "abcdef1", None, {}, LABELS, tuple(after)),
                         RecordSet("before", "cmd b", "1234567", None, {}, LABELS, tuple(before))).render()
    assert "| 1 % | VSMP-IMU vs. VSMP-IMU of `before` | +3.50 (6/6, p = 0.031) |" in table
    assert "against `results/before/`, from `cmd b` at commit 1234567" in table
    # `same`: each method against itself in the other set
    before += [{**r, "method": "real", "macro_f1": 0.4} for r in before]
    after += [{**r, "method": "real", "macro_f1": 0.4 + 0.02 * int(r["fold"])} for r in after]
    spec = spec.model_copy(update={"baseline": "same", "methods": ["real", "vsmp"]})
    table = TableBuilder(spec, RecordSet("after", "cmd a", None, None, {}, LABELS, tuple(after)),
                         RecordSet("before", "cmd b", None, None, {}, LABELS, tuple(before))).render()
    assert "| 1 % | Real-only vs. Real-only of `before` | +7.00 (6/6, p = 0.031) |" in table
    assert "| 1 % | VSMP-IMU vs. VSMP-IMU of `before` | +3.50 (6/6, p = 0.031) |" in table
    with pytest.raises(ValueError, match="same"):
        TableSpec(id="x:bad", records="after", kind="paired", baseline="same", methods=["vsmp"],
                  metrics=[{"label": "all", "metric": "macro_f1"}])


def test_a_paired_table_can_take_its_baseline_from_another_backbone():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    forest = [_record("vsmp", fold, 0, 1.0, 0.5) for fold in range(1, 7)]
    segments = [{**r, "backbone": "rf-seg", "macro_f1": r["macro_f1"] + 0.01 * int(r["fold"])} for r in forest]
    spec = TableSpec(id="x:seg", records="both", kind="paired", baseline="vsmp", backbone="rf-seg",
                     baseline_backbone="rf", budgets=[1], methods=["vsmp"],
                     metrics=[{"label": "all", "metric": "macro_f1"}])
    table = TableBuilder(spec, RecordSet("both", "cmd", None, None, {}, LABELS, tuple(forest + segments))).render()
    assert "| 1 % | VSMP-IMU with `rf-seg` vs. VSMP-IMU with `rf` | +3.50 (6/6, p = 0.031) |" in table
    with pytest.raises(ValueError, match="baseline_backbone"):
        TableSpec(id="x:bad", records="both", kind="paired", baseline="vsmp", baseline_backbone="rf",
                  methods=["vsmp"], metrics=[{"label": "all", "metric": "macro_f1"}])


def test_a_paired_table_can_take_its_baseline_from_another_budget():
    """A learning curve's step: each method at the table's budgets against itself at one budget."""
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    half = [_record("real", fold, 0, 50.0, 0.5) for fold in range(1, 7)]
    full = [{**r, "budget": 100.0, "macro_f1": r["macro_f1"] + 0.01 * int(r["fold"])} for r in half]
    spec = TableSpec(id="x:curve", records="curve", kind="paired", baseline="real", baseline_budget=50,
                     budgets=[100], methods=["real"], metrics=[{"label": "all", "metric": "macro_f1"}])
    table = TableBuilder(spec, RecordSet("curve", "cmd", None, None, {}, LABELS, tuple(half + full))).render()
    assert "| 100 % | Real-only vs. Real-only at 50 % | +3.50 (6/6, p = 0.031) |" in table
    # and from another record set: a method at one budget against the baseline with more labels
    mixed = [{**r, "method": "vsmp", "macro_f1": 0.5 + 0.02 * int(r["fold"])} for r in half]
    spec = spec.model_copy(update={"baseline_records": "curve", "budgets": [50], "methods": ["vsmp"],
                                   "baseline_budget": 100})
    table = TableBuilder(spec, RecordSet("mix", "cmd m", None, None, {}, LABELS, tuple(mixed)),
                         RecordSet("curve", "cmd", None, None, {}, LABELS, tuple(half + full))).render()
    assert "| 50 % | VSMP-IMU vs. Real-only of `curve` at 100 % | +3.50 (6/6, p = 0.031) |" in table
    with pytest.raises(ValueError, match="baseline_budget"):
        TableSpec(id="x:bad", records="curve", kind="paired", baseline="real", baseline_budget=50,
                  methods=["real"], metrics=[{"label": "all", "metric": "macro_f1"}])


def test_a_per_seed_paired_table_tests_each_seed_over_its_own_folds():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    records = _records()
    spec = TableSpec(id="x:seeds", records="demo", kind="paired", baseline="real", per_seed=True,
                     budgets=[1], methods=["vsmp"], metrics=[{"label": "all", "metric": "macro_f1"}])
    table = TableBuilder(spec, RecordSet("demo", "cmd", None, None, {}, LABELS, tuple(records))).render()
    rows = [line for line in table.splitlines() if line.startswith("| 1 %")]
    assert [row.split(" | ")[1] for row in rows] == ["VSMP-IMU", "VSMP-IMU, seed 0", "VSMP-IMU, seed 1"]
    for row, seed in zip(rows[1:], (0, 1), strict=True):
        mine = [r for r in records if r["method"] == "vsmp" and r["seed"] == seed]
        base = [r for r in records if r["method"] == "real" and r["seed"] == seed]
        expected = paired_test(mine, base, Metric(label="all", metric="macro_f1"))
        assert expected.n == 4 and f"({expected.won}/4, p = {format_p(expected.p)})" in row
    assert "(8/8," in rows[0]


def test_per_seed_belongs_to_paired_tables():
    from vsmp_imu.har.published import TableSpec

    with pytest.raises(ValueError, match="per_seed"):
        TableSpec(id="x:g", records="demo", kind="groups", per_seed=True, methods=["vsmp"],
                  metrics=[{"label": "all", "metric": "macro_f1"}])


def test_the_leave_one_class_out_table_has_a_row_per_class_left_out_and_their_mean():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    records = []
    for cls, f1 in (("SIT_TO_LIE", 0.4), ("WALKING", 0.1)):  # one run per class and method
        for method, capable in (("real", False), ("vsmp", True)):
            r = _record(method, 1, 0, None, 0.7)
            r.update(unseen_classes=[cls], unseen_capable=capable, unseen_macro_f1=f1 if capable else 0.0,
                     seen_macro_f1=0.8 if capable else 0.75)
            records.append(r)
    spec = TableSpec(id="x:each", records="x", kind="unseen_each", methods=["real", "vsmp"],
                     metrics=[{"label": "unseen F1", "metric": "unseen"}, {"label": "seen F1", "metric": "seen"}])
    table = TableBuilder(spec, RecordSet("x", "cmd", None, None, {}, LABELS, tuple(records))).render()
    lines = table.splitlines()
    assert lines[0] == ("| Class left out | Real-only: unseen F1 | Real-only: seen F1 | VSMP-IMU: unseen F1 "
                        "| VSMP-IMU: seen F1 |")
    assert lines[2:5] == ["| WALKING | 0.00 | 75.00 | 10.00 | 80.00 |", "| SIT_TO_LIE | 0.00 | 75.00 | 40.00 | 80.00 |",
                          "| mean over the 2 classes | 0.00 | 75.00 | 25.00 | 80.00 |"]
    assert "Real-only cannot make windows of a class without real windows" in table


def test_leave_one_class_out_runs_pair_by_the_class_left_out():
    """Under `--unseen each` one fold and seed hold a run per class left out: a paired test
    (within a record set or against another) pairs each with the same class's run, never another's."""
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    def runs(method: str, gains: dict[str, float]) -> list[dict]:
        out = []
        for fold in (1, 2, 3):
            for cls, base in (("WALKING", 0.1), ("SIT_TO_LIE", 0.6)):
                r = _record(method, fold, 0, None, 0.7)
                r.update(unseen_classes=[cls], unseen_capable=True, unseen_macro_f1=base + 0.01 * fold + gains[cls])
                out.append(r)
        return out

    before, after = runs("vsmp", {"WALKING": 0.0, "SIT_TO_LIE": 0.0}), runs("vsmp", {"WALKING": 0.2, "SIT_TO_LIE": 0.1})
    unseen = Metric(label="unseen", metric="unseen")
    result = paired_test(list(reversed(after)), before, unseen)
    assert (result.n, result.won) == (6, 6) and result.mean_diff == pytest.approx(0.15)
    spec = TableSpec(id="x:vs", records="x", kind="paired", baseline="vsmp", baseline_records="y",
                     methods=["vsmp"], metrics=[{"label": "unseen", "metric": "unseen"}])
    table = TableBuilder(spec, RecordSet("x", "cmd", None, None, {}, LABELS, tuple(after)),
                         RecordSet("y", "cmd", None, None, {}, LABELS, tuple(before[:4]))).render()
    row = table.splitlines()[2]
    assert "+15.00" in row and "(4/4," in row  # the runs both sets hold: folds 1 and 2, both classes


def test_every_committed_record_set_names_its_confusion_matrices_classes_in_their_order():
    """Per committed record: the F1 of class i read off the confusion matrix (row i, column i,
    in the set's `label_names` order) is the F1 the record gives that class by name."""
    checked = 0
    for folder in sorted((REPO_ROOT / "results").iterdir()):
        if not (folder / "records.jsonl").is_file():
            continue
        names = load_run(REPO_ROOT / "results", folder.name).label_names
        for record in load_run(REPO_ROOT / "results", folder.name).records:
            if not record.get("confusion") or not record.get("per_class_f1"):
                continue
            c = np.asarray(record["confusion"], dtype=float)
            f1 = 2 * np.diag(c) / np.maximum(c.sum(axis=0) + c.sum(axis=1), 1e-12)
            given = [record["per_class_f1"].get(name) for name in names]
            assert all(g is None or g == pytest.approx(f, abs=1e-6) for g, f in zip(given, f1, strict=True)), \
                f"{folder.name}: label_names do not follow the confusion matrices' order"
            checked += 1
    assert checked > 1000


def test_a_table_can_show_a_subset_of_the_runs_and_says_which():
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    records = _records()
    spec = TableSpec(id="x:sub", records="demo", kind="groups", budgets=[1], methods=["real", "vsmp"],
                     folds=["1", "2"], seeds=[0], metrics=[{"label": "all", "metric": "macro_f1"}])
    table = TableBuilder(spec, RecordSet("demo", "cmd", None, None, {}, LABELS, tuple(records))).render()
    kept = [r for r in records if r["method"] == "vsmp" and r["fold"] in ("1", "2") and r["seed"] == 0]
    mean = 100 * np.mean([r["macro_f1"] for r in kept])
    row = next(line for line in table.splitlines() if line.startswith("| 1 % | all"))
    assert row.split(" | ")[3].startswith(f"{mean:.2f} ±")
    assert "(2 runs: held-out subjects 1, 2 and seed 0 of its runs)" in table
    with pytest.raises(ConfigError, match="no run of the folds and seeds"):
        TableBuilder(spec.model_copy(update={"seeds": [7]}),
                     RecordSet("demo", "cmd", None, None, {}, LABELS, tuple(records))).render()


def test_a_table_over_records_of_several_budgets_must_name_them():
    """Records of two budgets, a table naming none: each (fold, seed) has two records, which a
    paired test would pair across budgets; the table is refused, naming the budgets."""
    from vsmp_imu.har.published import TableBuilder, TableSpec
    from vsmp_imu.har.records import RecordSet

    records = [_record(m, fold, 0, budget, 0.5 + budget / 100 + (0.01 * fold if m == "vsmp" else 0.0))
               for m in ("real", "vsmp") for fold in range(1, 7) for budget in (1.0, 5.0)]
    spec = TableSpec(id="x:mixed", records="x", kind="paired", baseline="real", methods=["vsmp"],
                     metrics=[{"label": "all", "metric": "macro_f1"}])
    with pytest.raises(ConfigError, match=r"several records per fold and seed in record set 'x' \(budgets 1.0, 5.0\)"):
        TableBuilder(spec, RecordSet("x", "cmd", None, None, {}, LABELS, tuple(records))).render()
    table = TableBuilder(spec.model_copy(update={"budgets": [1, 5]}),
                         RecordSet("x", "cmd", None, None, {}, LABELS, tuple(records))).render()
    assert "| 1 % | VSMP-IMU | +3.50 (6/6, p = 0.031) |" in table  # each budget paired with itself
    assert "| 5 % | VSMP-IMU | +3.50 (6/6, p = 0.031) |" in table
