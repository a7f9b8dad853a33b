"""Every kind of input, made bad: exit code 2 and one message naming the file (or option) and
the problem, through the real entry point (`vsmp_imu.cli.main`, as the console script runs
it), never a traceback and never a partial output file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from reliability_support import leftovers, run_cli

from vsmp_imu.cli import main
from vsmp_imu.smp.library import ActivityLibrary


def run_main(capsys, *argv) -> tuple[int, str]:
    """(exit code, stdout + stderr) of `vsmp-imu ARGV` run in this process."""
    try:
        main([str(a) for a in argv])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    captured = capsys.readouterr()
    return code, " ".join((captured.out + captured.err).split())


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def good_motion(tmp_path_factory, library):
    from vsmp_imu.motion.procedural import ProceduralBackend

    return ProceduralBackend(library).generate(library.get("walking").smp, 0, 3.0)


def _smp_with(library, tmp_path, change) -> Path:
    data = library.get("walking").smp.model_dump(mode="json")
    change(data)
    path = tmp_path / "smp.json"
    path.write_text(json.dumps(data))
    return path


def _csv_dataset(tmp_path, rows: list[str], yaml_extra: str = "") -> Path:
    (tmp_path / "data").mkdir(parents=True)
    (tmp_path / "data" / "p1.csv").write_text("\n".join(["subject,label,ax,ay,az", *rows]) + "\n")
    yaml = tmp_path / "dataset.yaml"
    yaml.write_text("name: mine\ndata: data\nfs_hz: 50\n" + yaml_extra +
                    "locations:\n  - {name: waist, acc: [ax, ay, az], acc_unit: g}\n")
    return yaml


def case_video(tmp_path, library, motion):
    clip = tmp_path / "clip.mp4"
    clip.write_bytes(np.random.default_rng(0).integers(0, 256, 4096, dtype=np.uint8).tobytes())
    return ["video", "info", clip], clip.name, "cannot open the video"


def case_video_extract(tmp_path, library, motion):
    clip = tmp_path / "empty.mp4"
    clip.write_bytes(b"")
    out = tmp_path / "out" / "clip.json"
    return (["smp", "extract", clip, "--label", "walking", "--extractor", "pose", "-o", out],
            clip.name, "empty")


def case_pose_max_fps_nan(tmp_path, library, motion):
    return (["video", "pose", tmp_path / "clip.mp4", "-o", tmp_path / "m.npz", "--max-fps", "nan"],
            "--max-fps", "a finite number > 0")


def case_pool_max_fps_zero(tmp_path, library, motion):
    return ["video", "pool", tmp_path, "-o", tmp_path / "pool.json", "--max-fps", "0"], "--max-fps", "> 0"


def case_extract_max_fps_negative(tmp_path, library, motion):
    return (["smp", "extract", tmp_path / "clip.mp4", "--label", "walking", "--extractor", "pose",
             "-o", tmp_path / "s.json", "--max-fps", "-5"], "--max-fps", "> 0")


def case_smp_value(tmp_path, library, motion):
    path = _smp_with(library, tmp_path, lambda d: d["execution_attributes"].update(tempo="warp"))
    return ["smp", "validate", path], path.name, "execution_attributes.tempo"


def case_smp_missing(tmp_path, library, motion):
    path = _smp_with(library, tmp_path, lambda d: [d.pop("motion_primitives"), d.pop("primitive_sequence")])
    return ["smp", "verbalize", path], path.name, "motion_primitives"


def case_smp_not_json(tmp_path, library, motion):
    path = tmp_path / "smp.json"
    path.write_text('{"activity_label": "walking", ')
    return ["smp", "refine", path, "-o", tmp_path / "out.json"], path.name, "not valid JSON"


def case_vlm_text(tmp_path, library, motion):
    raw = tmp_path / "response.txt"
    raw.write_text("I am sorry, I cannot see a person in these frames.")
    return ["smp", "repair", raw, "-o", tmp_path / "out.json"], raw.name, "no JSON object"


def case_vlm_text_no_label(tmp_path, library, motion):
    raw = tmp_path / "response.txt"
    raw.write_text('```json\n{"tempo": "fast", "amplitude": "large"}\n```')
    return ["smp", "repair", raw, "-o", tmp_path / "out.json"], raw.name, "rejected"


def case_dataset_yaml(tmp_path, library, motion):
    yaml = _csv_dataset(tmp_path, ["p1,walk,1,0,0"] * 200, yaml_extra="window: 3\n")
    return ["dataset", "info", yaml], yaml.name, "'window'"


def case_dataset_nan(tmp_path, library, motion):
    rows = [f"p1,walk,{'nan' if i == 7 else '1.0'},0.1,0.2" for i in range(200)]
    yaml = _csv_dataset(tmp_path, rows)
    return ["dataset", "info", yaml], "p1.csv", "first at data row 8"


def case_dataset_inf_evaluate(tmp_path, library, motion):
    rows = [f"p1,walk,1.0,{'inf' if i == 11 else '0.1'},0.2" for i in range(200)]
    yaml = _csv_dataset(tmp_path, rows)
    return ["evaluate", "--dataset", yaml, "-o", tmp_path / "run"], "p1.csv", "NaN, inf"


def case_dataset_column(tmp_path, library, motion):
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "p1.csv").write_text("subject,label,ax,ay\np1,walk,1,0\n")
    yaml = tmp_path / "dataset.yaml"
    yaml.write_text("name: mine\ndata: data\nfs_hz: 50\n"
                    "locations:\n  - {name: waist, acc: [ax, ay, az], acc_unit: g}\n")
    return ["dataset", "info", yaml], "p1.csv", "az"


def case_library_yaml(tmp_path, library, motion):
    folder = tmp_path / "lib"
    folder.mkdir()
    (folder / "seal_jacks.yaml").write_text("name: seal_jacks\nsmp: {activity_label: seal jacks}\n")
    return ["smp", "library", "list", "--library", folder], "seal_jacks.yaml", "smp.motion_primitives"


def case_config_yaml_syntax(tmp_path, library, motion):
    yaml = tmp_path / "dataset.yaml"
    yaml.write_text("name: mine\ndata: [unclosed\n")
    return ["evaluate", "--dataset", yaml, "-o", tmp_path / "run"], yaml.name, "not valid YAML"


@pytest.mark.parametrize("option,value,allowed", [
    ("--k", "0", "greater than or equal to 1"),
    ("--k-unseen", "0", "greater than or equal to 1"),
    ("--alpha", "5", "0.1..2"),
    ("--alpha", "nan", "0.1..2"),
    ("--workers", "0", "greater than or equal to 1"),
    ("--overlap", "0.99", "0..0.9, not 0.99"),
    ("--overlap", "0.95", "0..0.9, not 0.95"),  # evaluate's bound (it took 0.95)
    ("--holdout", "99", "1, 2, 3"),
    ("--executor", "spark", "local, ray"),
])
def test_generate_numbers_out_of_range(capsys, tmp_path, small_dataset, option, value, allowed):
    args = {"--k": "4", "--k-unseen": "16", "--alpha": "0.5", "--workers": "1", "--overlap": "0.5", "--holdout": "1",
            "--executor": "local", "--source": f"smp:{small_dataset.parent / 'smps'}"}
    args[option] = value
    flat = [x for kv in args.items() for x in kv]
    code, text = run_main(capsys, "generate", "--dataset", small_dataset, *flat, "-o", tmp_path / "out")
    assert code == 2, text
    assert option.lstrip("-") in text and allowed in text and "Traceback" not in text
    assert not (tmp_path / "out" / "synthetic.parquet").exists()


@pytest.mark.parametrize("argv, option, allowed", [
    (["motion", "synth", "walking", "--seed", "0", "--duration-s", "nan"], "--duration-s", "0.1..600, not nan"),
    (["motion", "synth", "walking", "--seed", "0", "--duration-s", "-inf"], "--duration-s", "0.1..600, not -inf"),
    (["motion", "synth", "walking", "--seed", "0", "--fps", "nan"], "--fps", "1..1000, not nan"),
    (["motion", "synth", "walking", "--seed", "0", "--fps", "5000"], "--fps", "1..1000, not 5000"),
    (["motion", "resample", "M", "--fps", "inf"], "--fps", "1..1000, not inf"),
    (["imu", "simulate", "M", "--smoothing-hz", "nan"], "--smoothing-hz", "0..1000, not nan"),
    (["evaluate", "--dataset", "hapt", "--window-s", "nan"], "--window-s", "0.5..30, not nan"),
    (["demo", "--budget", "nan"], "--budget", "0.1..100, not nan"),
    (["generate", "--dataset", "hapt", "--holdout", "1", "--window-s", "nan"], "--window-s", "0.5..30, not nan"),
    (["generate", "--dataset", "hapt", "--holdout", "1", "--overlap", "inf"], "--overlap", "0..0.9, not inf"),
    (["generate", "--dataset", "hapt", "--holdout", "1", "--gpus-per-task", "nan"], "--gpus-per-task",
     "0..8, not nan"),
    (["data", "check", "hapt", "--window-s", "nan"], "--window-s", "0.5..30, not nan"),
    (["data", "check", "hapt", "--overlap", "nan"], "--overlap", "0..0.9, not nan"),
    (["video", "pose", "V", "--height-m", "nan"], "--height-m", "0.5..2.5, not nan"),
    (["video", "pool", "P", "--threshold", "nan"], "--threshold", "0..1, not nan"),
])
def test_a_number_option_that_is_nan_or_inf_is_called_not_finite(capsys, tmp_path, argv, option, allowed):
    code, text = run_main(capsys, *argv, "-o", tmp_path / "out")
    text = " ".join(text.replace("│", " ").split())
    assert code == 2 and f"Invalid value for '{option}': must be a finite number in {allowed}" in text, text


@pytest.mark.parametrize("argv, option, allowed", [
    (["video", "pose", "V", "--height-m", "3"], "--height-m", "0.5..2.5, not 3"),  # a traceback after tracking
    (["video", "pose", "V", "--height-m", "0"], "--height-m", "0.5..2.5, not 0"),
    (["video", "pool", "P", "--threshold", "1.5"], "--threshold", "0..1, not 1.5"),  # named 'threshold'
    (["video", "pool", "P", "--threshold", "-0.1"], "--threshold", "0..1, not -0.1"),
    (["data", "check", "hapt", "--overlap", "0.999"], "--overlap", "0..0.9, not 0.999"),  # minutes of windows
])
def test_a_number_option_out_of_its_range_is_refused_before_any_work(capsys, tmp_path, argv, option, allowed):
    code, text = run_main(capsys, *argv, "-o", tmp_path / "out")
    text = " ".join(text.replace("│", " ").split())
    assert code == 2 and f"Invalid value for '{option}': must be a finite number in {allowed}" in text, text
    assert not (tmp_path / "out").exists()


def case_imu_number(tmp_path, library, motion):
    path = motion.save(tmp_path / "walk.npz")
    return ["imu", "simulate", path, "--fs", "-5", "-o", tmp_path / "x.csv"], "--fs", "1..10000 Hz"


def case_motion_npz(tmp_path, library, motion):
    path = tmp_path / "motion.npz"
    path.write_bytes(b"PK\x03\x04 but not a zip archive")
    return ["imu", "simulate", path, "-o", tmp_path / "x.csv"], path.name, "cannot read motion"


def case_motion_keys(tmp_path, library, motion):
    path = tmp_path / "motion.npz"
    np.savez(path, positions=np.zeros((3, 22, 3)))
    return ["motion", "info", path], path.name, "missing key(s) rotations"


def case_motion_nan(tmp_path, library, motion):
    broken = motion.__class__(motion.positions.copy(), motion.rotations, motion.fps, motion.joint_names,
                              motion.parents, dict(motion.meta))
    broken.positions[10, 3] = np.nan
    path = tmp_path / "motion.npz"
    path.write_bytes(broken.to_npz_bytes())  # save() refuses it
    return ["imu", "simulate", path, "-o", tmp_path / "x.csv"], path.name, "a coordinate of nan at frame 10, joint 3"


def case_imu_csv_text(tmp_path, library, motion):
    path = tmp_path / "imu.csv"
    path.write_text("time_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n0,1,2,3,4,5,6\n0.02,1,abc,3,4,5,6\n")
    return ["imu", "plot", path, "-o", tmp_path / "x.png"], path.name, "non-numeric"


def case_imu_csv_inf(tmp_path, library, motion):
    path = tmp_path / "imu.csv"
    path.write_text("time_s,acc_x,acc_y,acc_z,gyr_x,gyr_y,gyr_z\n0,1,2,3,4,5,6\n0.02,1,inf,3,4,5,6\n"
                    "0.04,1,2,3,4,5,6\n")
    return ["imu", "plot", path, "-o", tmp_path / "x.png"], path.name, "NaN or inf values"


def case_imu_csv_time(tmp_path, library, motion):
    path = tmp_path / "imu.csv"
    path.write_text("acc_x,acc_y,acc_z\n1,2,3\n")
    return ["imu", "plot", path, "-o", tmp_path / "x.png"], path.name, "no 'time_s' column"


def case_imu_csv_many_columns(tmp_path, library, motion):
    path = tmp_path / "imu.csv"  # 3000 columns once meant a figure 3000 panels tall
    columns = [f"c{k}" for k in range(3000)]
    rows = [",".join(["time_s", *columns])] + [",".join([f"{t / 50:.2f}"] + ["0"] * 3000) for t in range(5)]
    path.write_text("\n".join(rows) + "\n")
    return ["imu", "plot", path, "-o", tmp_path / "x.png"], path.name, "3000 panels to draw"


def case_imu_plot_suffix(tmp_path, library, motion):
    path = tmp_path / "imu.csv"
    path.write_text("time_s,acc_x\n0,1\n0.02,2\n")
    return ["imu", "plot", path, "-o", tmp_path / "x.txt"], "--output", "'.txt' is not an image format"


def case_imu_simulate_plot_suffix(tmp_path, library, motion):
    path = motion.save(tmp_path / "walk.npz")  # the CSV was written before the plot failed
    return (["imu", "simulate", path, "-o", tmp_path / "x.csv", "--plot", tmp_path / "x.txt"], "--plot",
            "Allowed: .png, .svg, .pdf")


CASES = {name[5:]: fn for name, fn in dict(globals()).items() if name.startswith("case_")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_exits_2_naming_file_and_problem(name, capsys, tmp_path, library, good_motion):
    argv, names, problem = CASES[name](tmp_path, library, good_motion)
    code, text = run_main(capsys, *argv)
    assert code == 2, text
    assert text.count("error:") == 1 and "Traceback" not in text
    assert names in text, f"message does not name {names}: {text}"
    assert problem in text, f"message does not say '{problem}': {text}"
    written = [p for p in tmp_path.rglob("*") if p.is_file() and p.suffix in (".csv", ".png", ".parquet")
               and p.name not in {"p1.csv", "imu.csv"}]
    assert written == [] and leftovers(tmp_path) == []


SAME_FILE = [  # (argv with M: a motion, S: an SMP, R: a raw answer, C: an IMU CSV, V: a clip; the clash)
    (["imu", "simulate", "M", "-o", "M"], "the input motion and --output"),
    (["imu", "simulate", "M", "-o", "both.png", "--plot", "both.png"], "--output and --plot"),
    (["imu", "plot", "C", "-o", "C"], "an input CSV and --output"),
    (["motion", "render", "M", "-o", "r.gif", "--keyframes", "sub/../r.gif"], "--output and --keyframes"),
    (["motion", "bvh", "M", "-o", "link.npz"], "the input motion and --output"),
    (["motion", "resample", "M", "--fps", "60", "-o", "M"], "the input motion and --output"),
    (["motion", "synth", "S", "--seed", "0", "-o", "S"], "the input SMP and --output"),
    (["smp", "augment", "S", "-k", "3", "-o", "S"], "the input SMP and --output"),
    (["smp", "augment", "walking", "-k", "3", "-o", "v.jsonl", "--provenance", "v.jsonl"], "--output and --provenance"),
    (["smp", "refine", "S", "-o", "S"], "the input SMP and --output"),
    (["smp", "intervene", "S", "--attribute", "tempo", "--level", "fast", "-o", "S"], "the input SMP and --output"),
    (["smp", "repair", "R", "-o", "out.json", "--report", "R"], "the raw response and --report"),
    (["smp", "aggregate", "R", "R", "R", "-o", "R"], "a raw response and --output"),
    (["video", "pose", "V", "-o", "V"], "the video and --output"),
    (["smp", "extract", "V", "--label", "walking", "--extractor", "pose", "-o", "s.json", "--motion-out",
      "s.report.json"], "the report next to --output and --motion-out"),
]


@pytest.mark.parametrize("argv, clash", SAME_FILE, ids=[" ".join(a[:2]) + f" {c}" for a, c in SAME_FILE])
def test_an_output_that_is_an_input_or_another_output_is_refused(capsys, tmp_path, monkeypatch, library,
                                                                  good_motion, argv, clash):
    monkeypatch.chdir(tmp_path)
    good_motion.save(tmp_path / "M")
    Path("link.npz").symlink_to("M")
    (tmp_path / "sub").mkdir()
    Path("S").write_text(json.dumps(library.get("walking").smp.model_dump(mode="json")))
    Path("R").write_text("no JSON here")
    Path("C").write_text("time_s,acc_x\n0,1\n0.02,2\n")
    Path("V").write_bytes(b"\x00" * 64)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    code, text = run_main(capsys, *argv)
    assert code == 2 and f"{clash} name the same file" in text, text
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before  # nothing written


def test_a_pool_manifest_never_replaces_a_clip_of_the_pool(capsys, tmp_path):
    clip = tmp_path / "pool" / "walking" / "a.mp4"
    clip.parent.mkdir(parents=True)
    clip.write_bytes(b"\x00" * 64)
    code, text = run_main(capsys, "video", "pool", tmp_path / "pool", "-o", clip)
    assert code == 2 and "a clip of POOL and --output name the same file" in text, text
    assert clip.read_bytes() == b"\x00" * 64
    code, text = run_main(capsys, "video", "pool", tmp_path / "pool", "-o", tmp_path / "manifest.csv")
    assert code == 2 and "a pool manifest is written as .json, not under '.csv'" in " ".join(text.split()), text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["pool"]


def test_a_clip_longer_than_a_motion_is_refused_before_tracking(capsys, tmp_path):
    """601 frames at 1 fps: `video pose` (and `smp extract --motion-out`) refuse it from the
    header, before MediaPipe sees a frame, instead of writing a motion `Motion.load` refuses."""
    cv2 = pytest.importorskip("cv2")
    clip = tmp_path / "long.avi"
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"MJPG"), 1.0, (16, 16))
    for _ in range(601):
        writer.write(np.zeros((16, 16, 3), np.uint8))
    writer.release()
    code, text = run_main(capsys, "video", "pose", clip, "-o", tmp_path / "m.npz")
    assert code == 2 and "long.avi: the clip lasts 601 s" in text and "at most 600 s" in text, text
    code, text = run_main(capsys, "smp", "extract", clip, "--label", "walking", "--extractor", "pose",
                          "-o", tmp_path / "s.json", "--motion-out", tmp_path / "m.npz")
    assert code == 2 and "the clip lasts 601 s" in text, text
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.avi"]


def test_a_motion_load_would_refuse_is_not_saved(tmp_path, good_motion):
    from dataclasses import replace

    from vsmp_imu.errors import ValidationError

    positions = good_motion.positions.copy()
    positions[3, 2, 0] = np.nan
    with pytest.raises(ValidationError) as err:
        replace(good_motion, positions=positions).save(tmp_path / "bad.npz")
    assert "bad.npz" in str(err.value) and err.value.field == "positions"
    assert not (tmp_path / "bad.npz").exists()


def test_the_console_script_exits_2_with_one_paragraph(tmp_path):
    """The installed `vsmp-imu` script, as a user runs it."""
    bad = tmp_path / "motion.npz"
    bad.write_bytes(b"not a motion")
    done = run_cli("imu", "simulate", bad, "-o", tmp_path / "x.csv", timeout=120)
    assert done.returncode == 2
    assert "motion.npz" in done.stderr and "not a motion file" in " ".join(done.stderr.split())
    assert "Traceback" not in done.stderr + done.stdout
