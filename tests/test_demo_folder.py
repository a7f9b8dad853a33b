"""`vsmp-imu demo -o DIR` takes a new or empty folder, or an earlier demo's (the one `make demo`
reruns into, written before demo.json was too); a folder of anything else is refused before any
work, its files untouched. The demo's work is replaced by files of the same names (tests/test_demo.py
runs the real one)."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from vsmp_imu.io import write_bytes, write_text

# what `make demo` leaves in demo_out (an older demo also wrote cache/ there)
DEMO_OUT = ("evaluation/results.json", "synthetic/summary.json", "report.md", "summary.json", "traces.png",
            "filter_stats.png", "skeleton.gif", "skeleton_keyframes.png", "cache/x.parquet")


@pytest.fixture
def quick_demo(monkeypatch):
    """run_demo with each step writing its files' names only; the list of steps run."""
    import vsmp_imu.demo as demo

    steps: list[str] = []

    def evaluation(_cfg, out: Path, _progress=None):
        steps.append("evaluation")
        write_text(out / "evaluation" / "results.json", "{}")
        return {"summary": []}

    def synthetic(_cfg, out: Path):
        write_text(out / "synthetic" / "summary.json", "{}")
        return SimpleNamespace(summary={}), SimpleNamespace(fit=None), None

    def render(_fold_out, out: Path):
        return [write_bytes(out / "skeleton.gif", b"GIF"), write_bytes(out / "skeleton_keyframes.png", b"png")]

    monkeypatch.setattr(demo, "run_evaluation", evaluation)
    monkeypatch.setattr(demo, "first_fold_synthetic", synthetic)
    monkeypatch.setattr(demo, "plot_traces", lambda _f, _r, _i, path: write_bytes(path, b"png"))
    monkeypatch.setattr(demo, "plot_filter_stats", lambda _s, path: write_bytes(path, b"png"))
    monkeypatch.setattr(demo, "render_example", render)
    monkeypatch.setattr(demo, "report_markdown", lambda *_args: "# VSMP-IMU demo\n")
    monkeypatch.setattr(demo, "prune_cache", lambda *_args: None)
    return steps


def _demo(cli, out: Path):
    return cli("demo", "-o", out, "--folds", "2", "--workers", "1")


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_a_folder_of_the_users_files_is_refused_before_any_work(cli, quick_demo, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("my notes\n")
    (mine / "report.md").write_text("my report\n")  # a name the demo writes
    before = _files(mine)
    code, _, err = _demo(cli, mine)
    assert code == 2 and "--output" in err and "notes.txt, report.md" in err, err
    assert "earlier `vsmp-imu demo`" in err and "another -o" in err
    assert _files(mine) == before and quick_demo == []


def test_a_home_like_folder_names_five_of_its_entries(cli, quick_demo, tmp_path):
    home = tmp_path / "home"
    for name in ("Desktop", "Documents", "Downloads", "Music", "Pictures", "Videos", ".bashrc"):
        (home / name).mkdir(parents=True) if name[0] != "." else (home / name).write_text("x")
    code, _, err = _demo(cli, home)
    assert code == 2 and ".bashrc, Desktop, Documents, Downloads, Music and 2 more" in " ".join(err.split()), err
    assert quick_demo == [] and not (home / "demo.json").exists()


def test_an_empty_folder_and_a_rerun_into_it_work(cli, quick_demo, tmp_path):
    out = tmp_path / "demo_out"
    out.mkdir()
    assert _demo(cli, out)[0] == 0
    assert json.loads((out / "demo.json").read_text()) == {"command": "vsmp-imu demo"}
    (out / "notes.txt").write_text("mine")  # beside demo.json: the folder is still the demo's
    code, stdout, err = _demo(cli, out)
    assert code == 0, stdout + err
    assert quick_demo == ["evaluation", "evaluation"] and (out / "notes.txt").read_text() == "mine"
    assert _demo(cli, tmp_path / "new" / "demo_out")[0] == 0


def test_a_demo_out_written_before_demo_json_is_taken(cli, quick_demo, tmp_path):
    out = tmp_path / "demo_out"
    for name in DEMO_OUT:
        write_text(out / name, "old")
    assert _demo(cli, out)[0] == 0
    assert (out / "report.md").read_text() == "# VSMP-IMU demo\n" and (out / "demo.json").exists()
    killed = tmp_path / "killed"  # a demo stopped during its evaluation
    write_text(killed / "evaluation" / "records" / "r.json", "{}")
    assert _demo(cli, killed)[0] == 0


@pytest.mark.parametrize("files", [
    {"generate.json": json.dumps({"command": "vsmp-imu generate", "dataset": "hapt12", "holdout": "1"})},
    {"study_run.json": json.dumps({"command": "vsmp-imu study control"}), "cases.csv": ""},
    {"report.md": "a report", "summary.json": "{}"},  # demo's names, but none only the demo writes
])
def test_another_commands_folder_is_refused(cli, quick_demo, tmp_path, files):
    out = tmp_path / "out"
    for name, text in files.items():
        write_text(out / name, text)
    code, _, err = _demo(cli, out)
    assert code == 2 and "--output" in err, err
    assert {p.name: p.read_text() for p in out.iterdir()} == files and quick_demo == []


def test_run_demo_takes_its_folder_itself(quick_demo, tmp_path):
    from vsmp_imu.demo import DemoConfig, run_demo
    from vsmp_imu.errors import ConfigError

    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(ConfigError, match="notes.txt"):
        run_demo(tmp_path, DemoConfig(folds=("2",), workers=1))
    assert quick_demo == [] and [p.name for p in tmp_path.iterdir()] == ["notes.txt"]
