"""`vsmp-imu generate -o DIR` takes a new or empty folder, or one of an earlier run of the same
dataset and held-out subject (to resume or redo it, its earlier outputs removed first); it
refuses a folder of anything else, so it never overwrites a user's files nor mixes two folds."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from vsmp_imu.errors import ConfigError
from vsmp_imu.pipeline.output import RUN_FILE, claim_output

GENERIC = Path(__file__).resolve().parents[1] / "fixtures" / "datasets" / "generic" / "dataset.yaml"


def _generate(cli, out: Path, holdout: str):
    return cli("generate", "--dataset", GENERIC, "--holdout", holdout, "-o", out, "--k", "1", "--alpha", "0.2")


def _run_files(out: Path) -> tuple[set[str], set[str], set[str]]:
    """The samples of synthetic.parquet, and the stems of smps/ and motions/."""
    samples = {s.replace("/", "__") for s in pq.read_table(out / "synthetic.parquet")["sample"].to_pylist()}
    return samples, {p.stem for p in (out / "smps").iterdir()}, {p.stem for p in (out / "motions").iterdir()}


def test_generate_refuses_a_folder_of_the_users_files(cli, tmp_path):
    out = tmp_path / "out"
    (out / "smps").mkdir(parents=True)
    (out / "summary.json").write_text("my notes")
    code, _, err = _generate(cli, out, "p1")
    assert code == 2 and str(out) in err and "--output" in err
    assert "holds no earlier `vsmp-imu generate` run (smps, summary.json)" in err and "another -o" in err
    assert (out / "summary.json").read_text() == "my notes" and sorted(p.name for p in out.iterdir()) == [
        "smps", "summary.json"]


@pytest.mark.parametrize(("args", "says"), [
    (("--backend", "mocap"), "field '--backend': unknown motion backend 'mocap'. "
                             "Allowed: procedural, compiled, hymotion."),
    (("--source", "youtube"), "field '--source': unknown source 'youtube'. Allowed: library, smp:DIR, video:DIR."),
    (("--source", "smp:MISSING"), "MISSING: field '--source': SMP source folder not found."),
])
def test_generate_names_backend_and_source_and_refuses_them_before_the_dataset_loads(cli, tmp_path, args, says):
    missing = str(tmp_path / "nowhere")
    args = tuple(a.replace("MISSING", missing) for a in args)
    code, _, err = cli("generate", "--dataset", tmp_path / "missing.yaml", "--holdout", "1", *args,
                       "-o", tmp_path / "out")
    assert code == 2 and says.replace("MISSING", missing) in err, err
    assert "missing.yaml" not in err and not (tmp_path / "out").exists()


def test_generate_refuses_the_folder_of_another_fold_and_redoes_its_own(cli, tmp_path):
    out = tmp_path / "out"
    assert _generate(cli, out, "p1")[0] == 0
    samples, smps, motions = _run_files(out)
    assert samples and smps == samples and motions == samples
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}

    code, _, err = _generate(cli, out, "p2")
    assert code == 2 and str(out) in err
    assert "holds the output of `vsmp-imu generate` for my_waist_phone with held-out subject p1" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before

    (out / "smps/holdout-p1__walk__0099.json").write_text("{}")  # an earlier run's samples this run does not make
    (out / "motions/holdout-p1__walk__0099.npz").write_bytes(b"x")
    (out / "notes.txt").write_text("mine")
    assert _generate(cli, out, "p1")[0] == 0
    assert _run_files(out) == (samples, smps, motions)
    assert (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / RUN_FILE).read_text())["holdout"] == "p1"


def test_claim_takes_a_new_folder_or_one_of_the_same_fold(tmp_path):
    claim_output(tmp_path / "new", "d", "p1")
    assert json.loads((tmp_path / "new" / RUN_FILE).read_text()) == {
        "command": "vsmp-imu generate", "dataset": "d", "holdout": "p1"}
    killed = tmp_path / "killed"  # a run killed while writing its first file: only a temporary
    killed.mkdir()
    (killed / ".generate.json.host~123.abc.json.tmp").write_text("")
    claim_output(killed, "d", "p1")
    older = tmp_path / "older"  # a finished run written before RUN_FILE existed
    (older / "cache").mkdir(parents=True)
    (older / "cache" / "abc.parquet").write_text("kept")
    (older / "summary.json").write_text(json.dumps({"dataset": "d", "holdout": "p1", "tau_cls": 0.5}))
    (older / "synthetic.parquet").write_text("old")
    claim_output(older, "d", "p1")
    assert sorted(p.name for p in older.iterdir()) == ["cache", RUN_FILE]
    assert (older / "cache" / "abc.parquet").read_text() == "kept"


@pytest.mark.parametrize("other", [("d", "p2"), ("e", "p1")])
def test_claim_refuses_another_fold(tmp_path, other):
    claim_output(tmp_path, "d", "p1")
    with pytest.raises(ConfigError) as err:
        claim_output(tmp_path, *other)
    assert err.value.field == "--output" and err.value.file == str(tmp_path)
    assert "for d with held-out subject p1" in err.value.message


def test_a_class_name_with_separators_stays_one_file_name_inside_the_output(cli, tmp_path):
    """The class is the user's text and goes into the names of smps/ and motions/: a '/' or '..'
    never leaves the folder, and a backslash (a separator on Windows) is made '-' as in the
    confusion figures' names (it was kept: 'holdout-p1__walk__..__x\\y__0000.json')."""
    import shutil

    from vsmp_imu.smp.library import ActivityLibrary

    root = tmp_path / "g"
    shutil.copytree(GENERIC.parent, root)
    label = "walk/../x\\y"
    yaml_path = root / "dataset.yaml"
    yaml_path.write_text(yaml_path.read_text().replace("labels: [walk, sit]", 'labels: ["walk/../x\\\\y", sit]'))
    for csv in (root / "data").glob("*.csv"):
        csv.write_text(csv.read_text().replace(",walk,", f",{label},"))
    (root / "smps").mkdir()
    library = ActivityLibrary.load()
    for activity, name in (("walking", label), ("sitting", "sit")):
        smp = library.get(activity).smp.model_dump(mode="json")
        (root / "smps" / f"{activity}.json").write_text(json.dumps({**smp, "activity_label": name}))
    out = tmp_path / "out"
    code, _, err = cli("generate", "--dataset", yaml_path, "--holdout", "p1", "-o", out, "--k", "1", "--alpha", "0.2",
                       "--source", f"smp:{root / 'smps'}")
    assert code == 0, err
    for folder, suffix in (("smps", ".json"), ("motions", ".npz")):
        names = sorted(p.name for p in (out / folder).iterdir())
        assert f"holdout-p1__walk__..__x-y__0000{suffix}" in names, names
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g", "out"]  # nothing beside the output folder


def test_a_sample_file_stem_is_one_name_whatever_the_class():
    from vsmp_imu.pipeline.sample import sample_stem

    assert sample_stem("holdout-1/WALKING/0003") == "holdout-1__WALKING__0003"  # the names as they were
    assert sample_stem("1/../../x\\y\n\x1b[31m/0000") == "1__..__..__x-y--[31m__0000"
