"""`vsmp-imu smp ...` commands, run in-process."""

from __future__ import annotations

import json

import pytest
import yaml

from vsmp_imu.smp import load_smp
from vsmp_imu.smp.library import BUILTIN_DIR
from vsmp_imu.smp.schema import SMP, displacement_word


@pytest.fixture
def jj_file(tmp_path, jj):
    path = tmp_path / "jj.json"
    path.write_text(jj.model_dump_json())
    return path


def test_schema_and_validate(cli, jj_file, tmp_path):
    code, out, _ = cli("smp", "schema")
    assert code == 0 and json.loads(out)["title"] == "Semantic Motion Program"
    code, out, _ = cli("smp", "validate", jj_file)
    assert code == 0 and "valid" in out
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({**json.loads(jj_file.read_text()), "primitive_sequence": []}))
    code, _, err = cli("smp", "validate", bad)
    assert code == 2 and str(bad) in err and "primitive_sequence" in err


def test_library_list_and_show(cli, tmp_path, library):
    code, out, _ = cli("smp", "library", "list")
    assert code == 0
    assert f"({len(library)} activities)" in out
    assert all(name in out for name in library.names())
    code, out, _ = cli("smp", "library", "list", "--json")
    rows = {row["name"]: row for row in json.loads(out)}
    assert rows["jumping_jacks"]["datasets"] == {"mmfit": "jumping_jacks"}
    assert rows["jumping_jacks"]["primitives"] == ["stand", "jump_open", "jump_close"]
    code, out, _ = cli("smp", "library", "show", "Jumping Jacks")
    assert code == 0 and SMP.model_validate_json(out) == library.get("jumping_jacks").smp
    target = tmp_path / "jj.yaml"
    code, _, _ = cli("smp", "library", "show", "jumping_jacks", "-o", target)
    assert code == 0 and load_smp(target) == library.get("jumping_jacks").smp
    code, _, err = cli("smp", "library", "show", "jumpin jack")
    assert code == 2 and "jumping_jacks" in err


def test_library_option_adds_user_folders(cli, tmp_path):
    data = yaml.safe_load((BUILTIN_DIR / "jumping_jacks.yaml").read_text())
    data.update(name="seal_jacks", aliases=[], datasets={"mine": "seal"})
    data["smp"]["activity_label"] = "seal jacks"
    (tmp_path / "seal_jacks.yaml").write_text(yaml.safe_dump(data))
    code, out, _ = cli("smp", "library", "list", "--library", tmp_path)
    assert code == 0 and "seal_jacks" in out
    code, out, _ = cli("smp", "verbalize", "seal_jacks", "--library", tmp_path)
    assert code == 0 and "seal jacks" in out
    code, _, err = cli("smp", "verbalize", "seal_jacks")
    assert code == 2 and "seal_jacks" in err


def test_repair(cli, tmp_path, jj):
    raw = tmp_path / "raw.txt"
    raw.write_text("Here it is:\n```json\n" + jj.model_dump_json().replace("tempo", "temop")[:-30])
    out_file, report_file = tmp_path / "out.json", tmp_path / "report.json"
    code, out, _ = cli("smp", "repair", raw, "-o", out_file, "--report", report_file)
    assert code == 0 and "repaired" in out and "renamed key 'temop' -> 'tempo'" in out
    assert load_smp(out_file).activity_label == "jumping jacks"
    assert json.loads(report_file.read_text())["malformed_json"] is True
    bad = tmp_path / "bad.txt"
    bad.write_text("I could not see anyone in the video.")
    code, out, err = cli("smp", "repair", bad, "-o", out_file)
    assert code == 2 and str(bad) in err and "no JSON object" in err
    code, _, err = cli("smp", "repair", tmp_path / "missing.txt")
    assert code == 2 and "file not found" in err


def test_aggregate(cli, tmp_path, jj):
    raws = []
    for i, tempo in enumerate(["fast", "fast", "slow", "fast"]):
        d = jj.model_dump(mode="json")
        d["execution_attributes"]["tempo"] = tempo
        path = tmp_path / f"r{i}.txt"
        path.write_text(json.dumps(d))
        raws.append(path)
    garbage = tmp_path / "garbage.txt"
    garbage.write_bytes(b"\x00\xff not json")
    out_file, report_file = tmp_path / "agg.json", tmp_path / "agg_report.json"
    code, out, _ = cli("smp", "aggregate", *raws, garbage, "-o", out_file, "--report", report_file)
    assert code == 0 and "aggregated 4/5" in out and "refinement" in out
    smp = load_smp(out_file)
    assert smp.execution_attributes.tempo == "fast"
    assert smp.uncertainty.tempo > jj.uncertainty.tempo
    report = json.loads(report_file.read_text())
    assert report["aggregation"]["n_valid"] == 4 and len(report["responses"]) == 5
    code, _, err = cli("smp", "aggregate", raws[0], garbage, garbage, "-o", out_file)
    assert code == 2 and "discarded" in err and "only 1 of 3" in err


def test_aggregate_discards_responses_of_different_activities(cli, tmp_path, library):
    raws = []
    for i, name in enumerate(["jumping_jacks", "walking", "jumping_jacks", "sitting", "walking"]):
        path = tmp_path / f"r{i}.txt"
        path.write_text(json.dumps(library.get(name).smp.model_dump(mode="json")))
        raws.append(path)
    out_file = tmp_path / "agg.json"
    code, _, err = cli("smp", "aggregate", *raws, "-o", out_file)
    assert code == 2 and "no activity is named by a majority of the 5 valid responses" in err
    assert not out_file.exists()
    # one activity by its label, an alias and a typo (3 spellings, walking 2): a majority
    for path, label in zip(raws[2:4], ["Star-Jumps", "jumpin jacks"], strict=True):
        path.write_text(json.dumps({**library.get("jumping_jacks").smp.model_dump(mode="json"),
                                    "activity_label": label}))
    code, out, err = cli("smp", "aggregate", *raws, "-o", out_file)
    assert code == 0, err
    assert load_smp(out_file).activity_label == "jumping jacks"


def test_aggregate_min_valid_is_checked_first(cli, tmp_path):
    code, _, err = cli("smp", "aggregate", tmp_path / "missing.txt", "--min-valid", "0")
    text = " ".join(err.replace("│", " ").split())
    assert code == 2 and "Invalid value for '--min-valid': must be an integer >= 1, not 0" in text, err
    assert "missing.txt" not in err


def test_refine(cli, tmp_path, jj):
    d = jj.model_dump(mode="json")
    d["temporal_structure"]["is_repetitive"] = False
    path = tmp_path / "in.json"
    path.write_text(json.dumps(d))
    out_file = tmp_path / "refined.json"
    code, out, _ = cli("smp", "refine", path, "-o", out_file)
    assert code == 0 and "[temporal] corrected temporal_structure.is_repetitive" in out
    assert load_smp(out_file).temporal_structure.is_repetitive is True
    code, out, _ = cli("smp", "refine", "jumping_jacks")
    assert code == 0 and "0 correction(s)" in out


def test_augment_jumping_jacks_200_is_deterministic(cli, tmp_path, jj):
    a, b, prov = tmp_path / "a.jsonl", tmp_path / "b.jsonl", tmp_path / "prov.jsonl"
    assert cli("smp", "augment", "jumping_jacks", "-k", 200, "--seed", 0, "-o", a,
               "--provenance", prov)[0] == 0
    assert cli("smp", "augment", "jumping_jacks", "-k", 200, "--seed", 0, "-o", b)[0] == 0
    assert a.read_bytes() == b.read_bytes()
    lines = a.read_text().splitlines()
    assert len(lines) == 200 and len(prov.read_text().splitlines()) == 200
    for line in lines:
        v = SMP.model_validate_json(line)
        assert line == v.canonical_json()
        assert v.activity_label == jj.activity_label
        assert v.primitive_sequence == jj.primitive_sequence
        assert v.motion_primitives == jj.motion_primitives
        assert v.body_parts == jj.body_parts
        assert v.object_contact == jj.object_contact
        assert displacement_word(v.execution_attributes.global_displacement) == "stationary"
        assert 0 <= v.tempo_level() <= 2 and 0 <= v.amplitude_level() <= 2
        assert abs(v.repetition_count() - 8) <= 5
    c = tmp_path / "c.jsonl"
    assert cli("smp", "augment", "jumping_jacks", "-k", 5, "--seed", 0, "-o", c,
               "--no-uncertainty")[0] == 0
    assert c.read_text().splitlines() != lines[:5]
    code, _, err = cli("smp", "augment", tmp_path / "nope.json", "-k", 2, "-o", c)
    assert code == 2 and "file not found" in err


def test_augment_refuses_an_output_over_the_limit_before_drawing(cli, tmp_path, jj_file, monkeypatch):
    import vsmp_imu.smp.augment as augment

    size = len(load_smp(jj_file).canonical_json()) + 1
    monkeypatch.setattr(augment, "MAX_OUTPUT_BYTES", 10 * size)
    monkeypatch.setattr(augment, "augment_variant", lambda *a, **kw: pytest.fail("drew a variant"))
    out = tmp_path / "v.jsonl"
    code, _, err = cli("smp", "augment", jj_file, "-k", 11, "-o", out)
    assert code == 2 and "field '-k'" in err and f"11 variants of this {size:,}-byte SMP" in err
    assert "at most 10 variants" in err and not out.exists()


def test_augment_streams_its_variants(cli, tmp_path, jj_file):
    """Memory does not grow with k (it grew by about 20 KB a variant): each line is written as
    it is drawn."""
    import tracemalloc

    out, prov = tmp_path / "v.jsonl", tmp_path / "p.jsonl"
    assert cli("smp", "augment", jj_file, "-k", 1, "-o", out)[0] == 0  # imports and caches first
    peaks = {}
    for k in (50, 350):
        tracemalloc.start()
        try:
            assert cli("smp", "augment", jj_file, "-k", k, "-o", out, "--provenance", prov)[0] == 0
            peaks[k] = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
    assert len(out.read_text().splitlines()) == len(prov.read_text().splitlines()) == 350
    assert peaks[350] < peaks[50] + 500_000, peaks


def test_augment_that_fails_midway_leaves_no_file(cli, tmp_path, jj_file, monkeypatch):
    import vsmp_imu.smp.augment as augment
    from vsmp_imu.errors import ValidationError

    draw = augment.augment_variant

    def third_fails(smp, seed, index, *args):
        if index == 2:
            raise ValidationError("a variant out of range", field="tempo")
        return draw(smp, seed, index, *args)

    monkeypatch.setattr(augment, "augment_variant", third_fails)
    out, prov = tmp_path / "v.jsonl", tmp_path / "p.jsonl"
    code, _, err = cli("smp", "augment", jj_file, "-k", 5, "-o", out, "--provenance", prov)
    assert code == 2 and "a variant out of range" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jj.json"]


def test_intervene_and_verbalize(cli, tmp_path, jj_file):
    out_file = tmp_path / "fast.json"
    code, _, _ = cli("smp", "intervene", jj_file, "--attribute", "tempo", "--level", "fast",
                     "-o", out_file)
    assert code == 0 and load_smp(out_file).execution_attributes.tempo == "fast"
    code, out, _ = cli("smp", "verbalize", out_file)
    assert code == 0 and "at a deliberately fast pace" in out
    code, out, _ = cli("smp", "verbalize", "jumping_jacks", "--attributes")
    assert code == 0 and out.startswith("at a moderate pace")
    code, _, err = cli("smp", "intervene", jj_file, "--attribute", "tempo", "--level", "zoom")
    assert code == 2 and "field 'level'" in err and "slow, medium, fast" in err
    code, _, err = cli("smp", "intervene", jj_file, "--attribute", "speed", "--level", "fast")
    assert code == 2 and "field 'attribute'" in err
    code, _, err = cli("smp", "verbalize", "not_an_activity")
    assert code == 2 and "neither an existing SMP file nor a library activity" in err


def test_library_list_fits_an_80_column_terminal(library):
    """Every line fits 80 columns and no primitive (nor any name up to 20 characters) is cut."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "COLUMNS": "80", "TERM": "dumb"}
    out = subprocess.run([sys.executable, "-c", "from vsmp_imu.cli import main; main()", "smp", "library",
                          "list"], env=env, capture_output=True, text=True, check=True).stdout
    assert max(len(line) for line in out.splitlines()) <= 80
    words = set(out.split())
    assert "repetitive;" in words and "…" not in out
    for entry in library:
        assert set(entry.smp.primitive_sequence) <= words, entry.name
        assert len(entry.name) > 20 or entry.name in words, entry.name


SMP_WORDS = "an SMP is written as .json, .yaml or .yml"


@pytest.mark.parametrize(("args", "says"), [
    (("library", "show", "walking", "-o", "w.txt"), f"w.txt: field '--output': {SMP_WORDS}, not under '.txt'"),
    (("repair", "raw.txt", "-o", "s"), f"s: field '--output': {SMP_WORDS}, not under a name without one"),
    (("aggregate", "raw.txt", "raw.txt", "raw.txt", "-o", "s.npz"), f"{SMP_WORDS}, not under '.npz'"),
    (("refine", "jj.json", "-o", "s.csv"), f"{SMP_WORDS}, not under '.csv'"),
    (("intervene", "jj.json", "--attribute", "tempo", "--level", "fast", "-o", "s.jsonl"),
     f"{SMP_WORDS}, not under '.jsonl'"),
    (("extract", "clip.mp4", "--label", "walking", "--extractor", "pose", "-o", "s.txt"),
     f"{SMP_WORDS}, not under '.txt'"),
    (("augment", "jj.json", "-k", "2", "-o", "v.json"),
     "v.json: field '--output': a file of SMP variants (one a line) is written as .jsonl, not under '.json'"),
    (("augment", "jj.json", "-k", "2", "-o", "v.jsonl", "--provenance", "p.json"),
     "p.json: field '--provenance': the variants' provenance (one a line) is written as .jsonl, not under '.json'"),
    (("repair", "raw.txt", "-o", "s.json", "--report", "r.txt"),
     "r.txt: field '--report': a report is written as .json, not under '.txt'"),
    (("aggregate", "raw.txt", "raw.txt", "raw.txt", "--report", "r"),
     "r: field '--report': a report is written as .json, not under a name without one"),
    (("extract", "clip.mp4", "--label", "walking", "--extractor", "pose", "-o", "s.json", "--motion-out", "m.bvh"),
     "m.bvh: field '--motion-out': a motion is written as .npz, not under '.bvh'"),
])
def test_an_smp_output_named_for_another_format_is_refused(cli, tmp_path, jj, monkeypatch, args, says):
    """Every smp command took any -o name: an SMP went into 's.csv' as JSON (and variants into
    'v.json' as JSON lines), under a name that said another format."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "jj.json").write_text(jj.model_dump_json())
    (tmp_path / "raw.txt").write_text(jj.model_dump_json())
    code, _, err = cli("smp", *args)
    assert code == 2 and says in " ".join(err.split()), err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["jj.json", "raw.txt"]


@pytest.mark.parametrize("name", ["s.json", "s.yaml", "s.YML"])
def test_an_smp_output_takes_each_format_save_smp_writes(cli, tmp_path, jj_file, name):
    code, _, err = cli("smp", "refine", jj_file, "-o", tmp_path / name)
    assert code == 0, err
    assert load_smp(tmp_path / name).activity_label == "jumping jacks"
