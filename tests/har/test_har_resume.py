"""Resuming an evaluation: run-only settings (where and how fast a record is computed) are
recorded but need not match for a record to be reused; every other setting must."""

from __future__ import annotations

import json

import pytest

from vsmp_imu.baselines.classical import ClassicalAugmentation
from vsmp_imu.har.evaluate import EvalConfig, Evaluation
from vsmp_imu.har.synthetic import METHOD_DISPLAY, METHODS, RUN_PARAMS
from vsmp_imu.pipeline.spec import RUN_FIELDS

RUN_A = {"workers": 1, "executor": "local", "address": None, "cache_dir": "/cache/a"}
RUN_B = {"workers": 3, "executor": "ray", "address": "auto", "cache_dir": "/elsewhere/b",
         "gpus_per_task": 0.5}
# The digest the code before run-only settings left the digest gave a `pooled` record of
# `_config()` on the tiny dataset (RUN_A, rf with 10 trees, fold 3).
DIGEST_WITH_RUN_A = "386fbfc032b6ec96"


class PooledSource:
    """Classical Aug taking the run settings a generative method gets (and ignoring them)."""

    name = "pooled"

    def __init__(self, k: int = 2, **run: object) -> None:
        unknown = set(run) - set(RUN_PARAMS)
        assert not unknown, unknown
        self.k = k

    def generate(self, context):
        return ClassicalAugmentation().generate(context)


@pytest.fixture
def pooled(monkeypatch):
    monkeypatch.setitem(METHODS, "pooled", PooledSource)
    monkeypatch.setitem(METHOD_DISPLAY, "pooled", "Pooled")


def _config(run=RUN_A, n_jobs: int = 1, **kw) -> EvalConfig:
    base = dict(dataset="tiny", backbones=("rf",), methods=("real", "pooled"), folds=("3",),
                backbone_params={"rf": {"n_estimators": 10, "n_jobs": n_jobs}},
                method_params={"pooled": {"k": 2, **run}})
    return EvalConfig(**{**base, **kw})


def _run(config, dataset, out) -> list[str]:
    """The run's record lines (a stage line, such as 'synthetic windows', repeats the count)."""
    lines: list[str] = []

    def record(description: str, done: int, total: int) -> None:
        if done > len(lines):
            lines.append(description)

    Evaluation(config, dataset, out).run(record)
    return lines


def _files(out) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "records").glob("*.json"))}


def test_the_spec_run_fields_are_the_harness_run_params():
    assert set(RUN_FIELDS) == set(RUN_PARAMS)


def test_run_only_settings_leave_the_digest_and_the_others_change_it(pooled, tiny_dataset):
    digest = Evaluation(_config(), tiny_dataset)._digest("rf", "pooled")
    assert Evaluation(_config(RUN_B, n_jobs=2), tiny_dataset)._digest("rf", "pooled") == digest
    changed = [_config(alpha=0.6), _config(policy="tail"), _config(window_s=1.0),
               _config(method_params={"pooled": {"k": 3, **RUN_A}}),
               _config(backbone_params={"rf": {"n_estimators": 11, "n_jobs": 1}})]
    others = {Evaluation(c, tiny_dataset)._digest("rf", "pooled") for c in changed}
    assert digest not in others and len(others) == len(changed)


def test_resuming_with_another_cache_and_worker_count_reuses_the_records(pooled, tiny_factory, tmp_path):
    out = tmp_path / "run"
    first = _run(_config(), tiny_factory(), out)
    assert not any("(cached)" in line for line in first) and len(first) == 2
    files = _files(out)
    results = json.loads((out / "results.json").read_text())
    # each record file says its confusion matrix's class order (an unfinished run imports right)
    assert all(json.loads(f)["label_names"] == results["label_names"] for f in files.values())
    again = _run(_config(RUN_B, n_jobs=2), tiny_factory(), out)
    assert all(line.endswith("(cached)") for line in again) and len(again) == 2
    assert _files(out) == files
    resumed = json.loads((out / "results.json").read_text())
    assert resumed["records"] == results["records"]
    # the run settings are still recorded: the last run's, for the reader
    assert resumed["config"]["method_params"]["pooled"] == {"k": 2, **RUN_B}
    assert resumed["config"]["backbone_params"]["rf"]["n_jobs"] == 2


def test_resuming_with_another_alpha_recomputes(pooled, tiny_factory, tmp_path):
    out = tmp_path / "run"
    _run(_config(), tiny_factory(), out)
    again = _run(_config(RUN_B, alpha=0.6), tiny_factory(), out)
    assert not any("(cached)" in line for line in again) and len(again) == 2


def test_a_record_whose_digest_has_the_run_settings_still_resumes(pooled, tiny_factory, tmp_path):
    out = tmp_path / "run"
    _run(_config(), tiny_factory(), out)
    files = _files(out)
    (name,) = [n for n in files if "_pooled_" in n]
    record = json.loads(files[name])
    digest = record["settings_digest"]
    assert digest != DIGEST_WITH_RUN_A
    path = out / "records" / name
    path.write_text(json.dumps({**record, "settings_digest": DIGEST_WITH_RUN_A}), encoding="utf-8")
    # the same run settings as the record was written with: reused, and its digest brought up to date
    lines = _run(_config(), tiny_factory(), out)
    assert all(line.endswith("(cached)") for line in lines)
    assert json.loads(path.read_text())["settings_digest"] == digest
    assert _files(out) == files
    # other run settings cannot be told from an older digest: recomputed
    path.write_text(json.dumps({**record, "settings_digest": DIGEST_WITH_RUN_A}), encoding="utf-8")
    lines = _run(_config(RUN_B), tiny_factory(), out)
    assert [line.endswith("(cached)") for line in lines] == [True, False]


def test_a_method_that_makes_windows_from_motion_reruns_after_a_code_change(pooled, tiny_dataset, monkeypatch):
    """Its records hold the synthesis code's fingerprint; Real-only's and the others' do not."""
    from vsmp_imu.har import synthetic
    from vsmp_imu.pipeline import sample

    monkeypatch.setattr(synthetic, "UNSEEN_CAPABLE", {*synthetic.UNSEEN_CAPABLE, "pooled"})
    monkeypatch.setattr("vsmp_imu.har.evaluate.UNSEEN_CAPABLE", synthetic.UNSEEN_CAPABLE)
    evaluation = Evaluation(_config(), tiny_dataset)
    before = {m: evaluation._digest("rf", m) for m in ("real", "pooled")}
    monkeypatch.setattr(sample, "code_fingerprint", lambda: "another code")
    after = {m: evaluation._digest("rf", m) for m in ("real", "pooled")}
    assert after["real"] == before["real"] and after["pooled"] != before["pooled"]


def test_a_method_that_makes_windows_from_motion_reruns_after_its_activity_files_change(
        pooled, tiny_dataset, monkeypatch, tmp_path):
    """Its records hold a digest of the activity library it animates (built-in and --library
    folders); Real-only's do not."""
    import shutil
    from pathlib import Path

    from vsmp_imu.har import synthetic
    from vsmp_imu.pipeline import sample

    monkeypatch.setattr(sample, "LIBRARY_RECHECK_S", 0.0)  # every use looks at the files
    monkeypatch.setattr(synthetic, "UNSEEN_CAPABLE", {*synthetic.UNSEEN_CAPABLE, "pooled"})
    monkeypatch.setattr("vsmp_imu.har.evaluate.UNSEEN_CAPABLE", synthetic.UNSEEN_CAPABLE)
    example = Path(__file__).resolve().parents[2] / "examples" / "hapt12_timed"
    folder = tmp_path / "lib"
    shutil.copytree(example, folder)

    def digests(library: Path) -> dict[str, str]:
        config = _config(method_params={"pooled": {"k": 2, **RUN_A, "library_dirs": (str(library),)}})
        return {m: Evaluation(config, tiny_dataset)._digest("rf", m) for m in ("real", "pooled")}

    before = digests(folder)
    path = folder / "sit_to_lie.yaml"
    text = path.read_text()
    path.write_text(text.replace("lean_back: {duration_s: 2.0", "lean_back: {duration_s: 2.5"))
    after = digests(folder)
    assert after["real"] == before["real"] and after["pooled"] != before["pooled"]
    path.write_text(text)
    assert digests(folder) == before
    sample.forget_libraries()
