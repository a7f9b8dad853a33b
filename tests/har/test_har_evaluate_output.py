"""`vsmp-imu evaluate -o DIR`: which folders it takes, and a rerun into one only with the
settings and data its records were made with (`vsmp_imu.har.output`); its options checked
before the dataset loads."""

from __future__ import annotations

import csv
import json
import os
import shutil
from pathlib import Path

import pytest

from vsmp_imu.errors import ConfigError

RUN_FILE = "evaluate.json"  # vsmp_imu.har.output.RUN_FILE


@pytest.fixture
def generic(fixtures_dir, tmp_path) -> Path:
    """A copy of the generic fixture dataset (its data may be edited); its dataset.yaml."""
    shutil.copytree(fixtures_dir / "generic", tmp_path / "generic")
    return tmp_path / "generic" / "dataset.yaml"


def _evaluate(cli, dataset, out, *args):
    return cli("evaluate", "--dataset", dataset, "--folds", "p1", "--jobs", "1", *args, "-o", out)


def _records(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "records").glob("*.json"))}


def test_a_folder_of_other_files_and_an_empty_path_are_refused(cli, generic, tmp_path):
    stuff = tmp_path / "stuff"
    stuff.mkdir()
    (stuff / "results.md").write_text("my notes\n")
    code, _, err = _evaluate(cli, generic, stuff)
    assert code == 2 and "--output" in err and "results.md" in err and "earlier `vsmp-imu evaluate`" in err
    assert (stuff / "results.md").read_text() == "my notes\n" and sorted(os.listdir(stuff)) == ["results.md"]
    code, _, err = _evaluate(cli, generic, "")
    assert code == 2 and "is empty" in " ".join(err.replace("│", " ").split())


def test_an_earlier_evaluate_folder_is_taken(tmp_path):
    from vsmp_imu.har.output import check_folder

    check_folder(tmp_path / "new")
    (tmp_path / "empty").mkdir()
    check_folder(tmp_path / "empty")
    older = tmp_path / "older"  # written before RUN_FILE: evaluate's own files alone
    (older / "records").mkdir(parents=True)
    for name in ("results.json", "results.md", "confusion_x_lopo_full_rf_real.png"):
        (older / name).write_text("{}")
    check_folder(older)
    (older / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="notes.txt"):
        check_folder(older)
    (older / RUN_FILE).write_text(json.dumps({"command": "vsmp-imu evaluate", "settings": {}, "backbones": {},
                                              "methods": {}, "data": {}}))
    check_folder(older)  # RUN_FILE says whose it is: the user's notes beside it are theirs


def test_a_rerun_with_other_settings_is_refused_and_keeps_the_records(cli, generic, tmp_path):
    out = tmp_path / "run"
    code, stdout, _ = _evaluate(cli, generic, out)
    assert code == 0, stdout
    records = _records(out)
    code, _, err = _evaluate(cli, generic, out, "--window-s", "3")
    assert code == 2 and "--window-s 2 (now 3)" in err and "a new --output folder" in err
    assert _records(out) == records
    code, _, err = _evaluate(cli, generic, out, "--class-weight", "none")
    assert code == 2 and "rf's class_weight balanced (now null)" in err
    # the same settings: resumed, and extended by another method
    code, stdout, _ = _evaluate(cli, generic, out, "--methods", "real,classical")
    assert code == 0 and "(cached)" in stdout
    assert {n: b for n, b in _records(out).items() if n in records} == records and len(_records(out)) == 2
    assert set(json.loads((out / RUN_FILE).read_text())["methods"]) == {"real", "classical"}


def test_a_rerun_after_the_data_changed_is_refused(cli, generic, tmp_path):
    out = tmp_path / "run"
    assert _evaluate(cli, generic, out)[0] == 0
    path = generic.parent / "data" / "p1.csv"  # walk and sit swapped: other true classes
    rows = list(csv.reader(path.open()))
    label = rows[0].index("label")
    for row in rows[1:]:
        row[label] = {"walk": "sit", "sit": "walk"}.get(row[label], row[label])
    with path.open("w", newline="") as f:
        csv.writer(f).writerows(rows)
    code, _, err = _evaluate(cli, generic, out)
    assert code == 2 and "the dataset's recordings (its data files) changed" in err


def test_the_fingerprint_follows_the_recordings_of_hapt(tmp_path):
    from vsmp_imu.har.datasets.hapt import HAPT
    from vsmp_imu.har.output import data_fingerprint

    first, second = HAPT().get_subset(["1"]), HAPT().get_subset(["1"])
    assert data_fingerprint(first) == data_fingerprint(second)
    second.recordings()[0].data[5, 2] += 0.01
    assert data_fingerprint(first) != data_fingerprint(second)
    assert data_fingerprint(first) != data_fingerprint(HAPT().get_subset(["2"]))


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs /proc")
@pytest.mark.parametrize("option", ["--output", "--cache-dir"])
def test_a_folder_that_cannot_be_written_is_refused_before_any_work(cli, generic, tmp_path, option):
    """/proc looks writable to root (`os.access`), yet nothing can be made there."""
    out, cache = (Path("/proc/vsmp-imu-test"), None) if option == "--output" else (tmp_path / "run", "/proc/cache")
    code, stdout, err = _evaluate(cli, generic, out, *(("--cache-dir", cache) if cache else ()))
    assert code == 2 and f"field '{option}'" in err and "cannot write in '/proc'" in err, stdout
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("args,option", [
    (("--methods", "real,classical,real"), "--methods"),
    (("--backbones", "rf,rf"), "--backbones"),
    (("--folds", "p1,p1"), "--folds"),
    (("--protocol", "low-resource", "--budgets", "5,5%"), "--budgets"),
    (("--protocol", "unseen", "--unseen", "walk,walk"), "--unseen"),
])
def test_a_value_named_twice_is_refused(cli, generic, tmp_path, args, option):
    code, stdout, err = cli("evaluate", "--dataset", generic, "--jobs", "1", *args, "-o", tmp_path / "run")
    assert code == 2 and f"field '{option}'" in err and "named more than once" in err, stdout
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("args,option,allowed", [
    (("--backend", "foo"), "--backend", "procedural, compiled, hymotion"),
    (("--device", "foo"), "--device", "cpu, cuda, cuda:N, mps, auto"),
])
def test_options_no_chosen_part_uses_are_still_checked(cli, generic, tmp_path, args, option, allowed):
    code, stdout, err = _evaluate(cli, generic, tmp_path / "run", *args)
    assert code == 2 and f"field '{option}'" in err and allowed in err, stdout
    assert not (tmp_path / "run").exists()


def test_a_device_no_backbone_uses_is_said_to_be_unused(monkeypatch, capsys):
    from vsmp_imu.cli.har import _backbone_params

    assert _backbone_params(("rf",), None, None, 1, "cuda:1") == {"rf": {"n_jobs": 1}}
    assert "--device is unused" in capsys.readouterr().out


def test_a_cache_dir_of_the_user_keeps_the_size_cap_on_its_sample_files_alone(tiny_dataset, tmp_path,
                                                                               monkeypatch):
    from vsmp_imu.app import evaluate
    from vsmp_imu.har.evaluate import EvalConfig, Evaluation

    cache = tmp_path / "mine"
    cache.mkdir()
    samples = [cache / f"{i:024x}.parquet" for i in range(4)]
    for age, path in enumerate(samples):
        path.write_bytes(b"x" * 100)
        os.utime(path, (1000 + age, 1000 + age))
    (cache / "notes.parquet").write_bytes(b"y" * 1000)  # not a sample: the user's
    monkeypatch.setenv("VSMP_IMU_CACHE_MAX_GB", str(250 / 1e9))
    config = EvalConfig(dataset="tiny", folds=("1",), backbone_params={"rf": {"n_estimators": 5, "n_jobs": 1}},
                        method_params={"real": {"cache_dir": str(cache)}})
    evaluate(Evaluation(config, tiny_dataset, tmp_path / "run"))
    assert sorted(p.name for p in cache.iterdir()) == sorted([samples[2].name, samples[3].name, "notes.parquet"])


def test_an_empty_cache_dir_is_refused(cli, generic, tmp_path):
    code, _, err = _evaluate(cli, generic, tmp_path / "run", "--cache-dir", "")
    assert code == 2 and "--cache-dir" in err and "is empty" in " ".join(err.replace("│", " ").split())
    assert not (tmp_path / "run").exists()
