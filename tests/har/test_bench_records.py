"""Benchmark tables: the table a benchmark script writes, rebuilt from its committed JSON."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from vsmp_imu.errors import ConfigError, InputFileError
from vsmp_imu.har.bench_records import BenchTable
from vsmp_imu.har.published import Publication

REPO_ROOT = Path(__file__).resolve().parents[2]
SOURCE = "benchmarks/results/run_all.json"
CATALOGUE = f"tables:\n  - id: bench:stages\n    records: run_all\n    kind: benchmark\n    source: {SOURCE}\n"


def test_the_committed_table_is_what_the_script_writes_from_the_committed_json():
    rendered = BenchTable(REPO_ROOT, "bench:stages", SOURCE).render()
    assert rendered.startswith((REPO_ROOT / "benchmarks/results/run_all.md").read_text() + "\n")
    assert f"Records: `{SOURCE}`" in rendered


def _root(tmp_path: Path, stages: dict) -> Path:
    (tmp_path / "benchmarks/results").mkdir(parents=True)
    shutil.copy(REPO_ROOT / "benchmarks/run_all.py", tmp_path / "benchmarks/run_all.py")
    results = {"command": "python benchmarks/run_all.py --stages cem", "started": "2026-01-01T00:00:00",
               "stages": stages}
    (tmp_path / SOURCE).write_text(json.dumps(results))
    (tmp_path / "results").mkdir()
    (tmp_path / "results/tables.yaml").write_text(CATALOGUE)
    (tmp_path / "BENCHMARKS.md").write_text("<!-- report:bench:stages -->\nold\n<!-- /report -->\n")
    return tmp_path


def test_write_then_check_and_a_changed_figure_differs(tmp_path):
    root = _root(tmp_path, {"smp_augment": {"unit": "SMP variants", "per_s_per_core": 1234.5}})
    Publication(root).check(write=True)
    text = (root / "BENCHMARKS.md").read_text()
    assert "| SMP augmentation [SMP variants/s per core] | 1234.5 |" in text
    assert not Publication(root).check().differing
    (root / "BENCHMARKS.md").write_text(text.replace("1234.5", "2000.0"))
    assert Publication(root).check().differing == ["BENCHMARKS.md: table 'bench:stages'"]


def test_unknown_sources_and_missing_results_are_refused(tmp_path):
    with pytest.raises(ConfigError, match="no benchmark script renders"):
        BenchTable(tmp_path, "b:x", "benchmarks/results/other.json")
    with pytest.raises(InputFileError, match="not committed"):
        BenchTable(tmp_path, "b:x", SOURCE).render()
    (tmp_path / "results").mkdir()
    (tmp_path / "results/tables.yaml").write_text(CATALOGUE.replace(f"    source: {SOURCE}\n", ""))
    with pytest.raises(ConfigError, match="needs the source JSON"):
        Publication(tmp_path)


def _fold_run(workers: int, wall: float, synthesis: float) -> dict:
    return {"workers": workers, "wall_s": wall, "synthesis_map_s": synthesis}


SCALING = {"fold_runs": [_fold_run(1, 10.0, 8.0), _fold_run(2, 5.0, 4.0), _fold_run(2, 7.0, 4.2),
                         _fold_run(1, 12.0, 8.4)],
           "speedup_fold": 22 / 12, "speedup_synthesis": 16.4 / 8.2, "speedup_synthesis_abba": 1.9,
           "replay_tasks": 60, "alpha": 0.05, "worker_niceness": [0], "finished": "2026-01-01T02:00:00"}


def _views_root(tmp_path: Path) -> Path:
    root = _root(tmp_path, {"scaling_local": SCALING})
    results = json.loads((root / SOURCE).read_text())
    results["updates"] = [
        {"command": "python benchmarks/run_all.py --stages scaling_local --update", "started": "2026-01-01T01:00:00"},
        {"command": "python benchmarks/run_all.py --stages cem --update", "started": "2026-01-01T01:30:00"},
        {"command": "python benchmarks/run_all.py --stages scaling_local --update", "started": "2026-01-01T03:00:00"},
    ]
    (root / SOURCE).write_text(json.dumps(results))
    (root / "results/tables.yaml").write_text(
        CATALOGUE + f"  - id: scale:scaling\n    records: run_all\n    kind: benchmark\n    source: {SOURCE}\n"
                    "    view: scaling\n")
    (root / "BENCHMARKS.md").write_text("<!-- report:scale:scaling -->\nold\n<!-- /report -->\n")
    return root


def test_a_view_composes_the_stage_figures_and_names_the_run_that_measured_them(tmp_path):
    root = _views_root(tmp_path)
    rendered = BenchTable(root, "scale:scaling", SOURCE, "scaling").render()
    # means of the two runs per worker count; the ratios as the stage computed them
    assert "| local pool | 11.0 s → 6.0 s | 1.83× | 8.2 s → 4.1 s | 2.00× | 1.90× |" in rendered
    assert "(60 tasks, 1, 2, 2, 1 workers)" in rendered and "α = 0.05" in rendered
    # the update that ran the stage before it finished, not the later one nor one of another stage
    assert ("stage `scaling_local` of `benchmarks/results/run_all.json`, from `python benchmarks/run_all.py "
            "--stages scaling_local --update` (finished: scaling_local 2026-01-01T02:00:00)") in rendered
    Publication(root).check(write=True)
    assert not Publication(root).check().differing
    text = (root / "BENCHMARKS.md").read_text()
    (root / "BENCHMARKS.md").write_text(text.replace("11.0 s", "10.0 s"))
    assert Publication(root).check().differing == ["BENCHMARKS.md: table 'scale:scaling'"]


def test_an_unknown_view_is_refused(tmp_path):
    root = _views_root(tmp_path)
    with pytest.raises(ConfigError, match="has no view 'other'"):
        BenchTable(root, "b:x", SOURCE, "other").render()


def test_the_committed_views_render_from_the_committed_json():
    for source, view, head in ((SOURCE, "targets", "| target | measured | status |"),
                               (SOURCE, "per_sample", "| method | s per sample here |"),
                               (SOURCE, "scaling", "| executor | whole fold, 1 → 2 workers |"),
                               ("benchmarks/results/motion_controls.json", "controls", "| check | result |"),
                               (SOURCE, "scaling_cpu", "| executor | workers | wall |"),
                               (SOURCE, "speed", "| what | measured |"), (SOURCE, "imu", "| what | measured |"),
                               (SOURCE, "run", "| | |"), (SOURCE, "notes", "- **Post-motion stages.**"),
                               ("benchmarks/results/extract_clips.json", "clips", "| clip | person found |")):
        rendered = BenchTable(REPO_ROOT, "b:x", source, view).render()
        assert rendered.startswith(head) and "Records: " in rendered


def test_a_target_missed_in_the_stage_reads_not_met():
    from vsmp_imu.har.bench_records import _script

    run_all = _script(REPO_ROOT / "benchmarks/run_all.py")
    figures, status = run_all._scaling_cells({**SCALING, "met": False, "met_synthesis": True})
    assert status == "whole fold NOT met, synthesis replay met"
    assert figures.startswith("whole fold **1.83×** (1, 2, 2, 1 workers: 10.0, 5.0, 7.0, 12.0 s)")


def _extract_script():
    from vsmp_imu.har.bench_records import _script

    return _script(REPO_ROOT / "benchmarks/bench_extract.py")


def _part(clips: list[dict]) -> dict:
    return {"clips": clips, "command": "python benchmarks/bench_extract.py --parts clips",
            "started": "2026-01-01T00:00:00+00:00", "wall_s": 12.0, "load_avg_at_start": [0.5, 0.4, 0.3],
            "machine": {"cpus": 2, "mediapipe": "0.10.21"}}


def _field(value, uncertainty, raw=None) -> dict:
    return {"value": value, "uncertainty": uncertainty, "raw": raw or {}, "evidence": {}, "note": ""}


def test_the_extract_view_renders_the_record_of_each_clip():
    clip = {"clip": "walk.mp4", "label": "walking", "library_entry": None, "generic_smp": True,
            "n_frames": 200, "fps": 10.0, "frames_with_pose": 150, "wall_s": 4.0, "window": [20, 120],
            "clip_track": {"identity_switches": 3},
            "track": {"quality": 0.25, "body_height_px": 110.4, "visibility": 0.871},
            "fields": {"tempo": _field(2.0, 1.0, {"cycle_frequency_hz": 1.25, "cadence_steps_per_min": 150.0,
                                                  "level_unclipped": 2.7, "ratio_to_reference": 1.3}),
                       "periodicity": _field(True, 0.4), "symmetry": _field(None, 1.0),
                       "global_displacement": _field(11.94, 0.9), "body_parts": _field(["left_foot", "head"], 1.0)}}
    record = {"clips": _part([clip]), "frames": {**_part([]), "runs": [{"decoded": 100, "wall_s": 0.05},
                                                                      {"decoded": 100, "wall_s": 0.1}]}}
    table, source = _extract_script().VIEWS["clips"](record)
    row = table.splitlines()[2]
    assert row == ("| `walk.mp4` (label walking, not in the library) | 150 / 200 frames, 3 identity switches | "
                   "20–119 (10.0 s) | 0.25 (body ~110 px tall, core landmarks 87 % visible, 10 fps) | generic SMP; "
                   "periodic yes (u = 0.40); tempo 2.00 (u = 1.00; 1.25 Hz by peaks = 150 steps/min; clipped from "
                   "2.70, 1.3× the reference); symmetry not measured; displacement 11.9 m (u = 0.90); body parts "
                   "left foot, head (u = 1.00) |")
    assert "MediaPipe 0.10.21, every frame: 50–50 frames/s" in source
    assert "frame sampling 1000–2000 decoded frames/s" in source
    assert "`python benchmarks/bench_extract.py --parts clips` (2026-01-01T00:00:00+00:00" in source


def test_the_extract_record_of_a_real_extraction_renders():
    """A clip record as the benchmark writes it, from the pose extractor on a rendered motion."""
    from vsmp_imu.extract.calibrate import motion_track
    from vsmp_imu.extract.pose import PoseExtractor
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.library import ActivityLibrary

    library = ActivityLibrary.load()
    motion = ProceduralBackend(library).generate(library.get("walking").smp, seed=0, duration_s=6.0)
    track = motion_track(motion)
    script = _extract_script()
    clip = script.clip_record("walk.mp4", "walking", track, PoseExtractor(library=library).extract_track(
        track, "walking"), 2.0)
    clip = json.loads(json.dumps(clip))  # as read back from the committed JSON
    table, _ = script.VIEWS["clips"]({"clips": _part([clip])})
    row = table.splitlines()[2]
    assert row.startswith(f"| `walk.mp4` (label walking) | {track.n_frames} / {track.n_frames} frames, "
                          "0 identity switches | whole clip | ")
    tempo = clip["fields"]["tempo"]
    assert f"tempo {tempo['value']:.2f} (u = {tempo['uncertainty']:.2f}" in row


HISTORY = "benchmarks/results/scaling_history.jsonl"


def _scaling_fig(fold: float, replay: float) -> dict:
    return {**SCALING, "speedup_fold": fold, "speedup_synthesis_abba": replay, "replay_tasks": 240,
            "replay": [{"workers": w, "wall_s": 1.0, "load_avg_after": [0.1, 0.1, 0.1]} for w in (1, 2, 2, 1)],
            "load_avg_at_start": [1.25, 1.0, 1.0], "finished": "2026-01-01T02:00:00"}


def test_each_scaling_run_adds_one_line_and_the_views_read_the_history(tmp_path):
    from vsmp_imu.har.bench_records import _script

    run_all = _script(REPO_ROOT / "benchmarks/run_all.py")
    root = _root(tmp_path, {})
    path = root / HISTORY
    for started, fold, commit in (("2026-01-01T00:00:00", 1.83, None), ("2026-01-02T00:00:00", 1.88, "abcdef123")):
        results = {"stages": {"scaling_local": _scaling_fig(fold, 1.9), "cem": {}}, "machine": {"cpus": "2"}}
        run = {"command": "python benchmarks/run_all.py", "started": started, "commit": commit, "dirty": True}
        run_all.append_history(path, run_all.scaling_entry(results, ["scaling_local"], run))
    lines = path.read_text().splitlines()
    assert len(lines) == 2 and json.loads(lines[0])["executors"]["scaling_local"]["speedup_fold"] == 1.83
    runs = BenchTable(root, "bench:scaling_runs", HISTORY, "scaling_runs").render()
    assert ("| 2026-01-01T00:00:00 (code not recorded) | local pool | 1.83× (1, 2, 2, 1 workers: 10.0, 5.0, 7.0, "
            "12.0 s) | 2.00× | 1.90× (240 tasks) | 1.2 |") in runs
    assert "| 2026-01-02T00:00:00 (`abcdef1` + changes) | local pool | 1.88×" in runs
    assert "`benchmarks/results/scaling_history.jsonl`, 2 runs of `benchmarks/run_all.py`" in runs
    spread = BenchTable(root, "scale:scaling_spread", HISTORY, "scaling_spread").render()
    assert "| local pool | 2 | 1.83–1.88× | 2.00× | 1.90× |" in spread
    with pytest.raises(ConfigError, match="shown through a view"):
        BenchTable(root, "b:x", HISTORY).render()


def test_the_committed_history_ends_with_the_committed_run():
    """Each scaling run adds its line to the history and its figures to run_all.json: the
    committed figures are the last line's (the first line was taken from the first committed run)."""
    history = [json.loads(line) for line in (REPO_ROOT / HISTORY).read_text().splitlines()]
    committed = json.loads((REPO_ROOT / SOURCE).read_text())["stages"]
    assert history[-1]["executors"]
    for stage, fig in history[-1]["executors"].items():
        assert fig["speedup_fold"] == committed[stage]["speedup_fold"]
        assert fig["finished"] == committed[stage]["finished"]
    for view in ("scaling_runs", "scaling_spread"):
        assert "Records: `benchmarks/results/scaling_history.jsonl`" in BenchTable(REPO_ROOT, "b:x", HISTORY,
                                                                                 view).render()


def test_the_speed_views_take_their_figures_from_the_stages():
    stages = json.loads((REPO_ROOT / SOURCE).read_text())["stages"]
    speed = BenchTable(REPO_ROOT, "b:x", SOURCE, "speed").render()
    assert f"| {stages['chain']['samples_per_s']:.1f} synthetic samples/s |" in speed
    assert f"{stages['scaling_local']['speedup_fold']:.2f}× on the local pool" in speed
    assert f"| {stages['cost']['methods']['vsmp']['s_per_sample']:.3f} s |" in speed
    imu = BenchTable(REPO_ROOT, "b:x", SOURCE, "imu").render()
    assert f"({1e3 / stages['imu_simulation']['per_s_per_core']:.1f} ms per stream;" in imu
    assert f"{stages['cem']['naive_over_vectorized']:.1f}× the vectorized one" in imu
    notes = BenchTable(REPO_ROOT, "b:x", SOURCE, "notes").render()
    post = stages["post_motion"]
    assert f"= {post['per_sample_per_s_per_core']:.1f} samples/s per core" in notes
    assert f"{post['samples']} / {post['post_motion_s'] - post['per_fold_fits_s']:.1f} s" in notes


def test_record_parts_adds_each_part_with_its_run_and_keeps_the_others(tmp_path):
    from vsmp_imu.har.bench_records import record_parts

    path = tmp_path / "bench.json"
    path.write_text(json.dumps({"old": {"x": 1}}))
    seen = []

    def measure(part):
        seen.append(json.loads(path.read_text()).keys() - {"old"})  # earlier parts are on disk already
        return {"value": len(part)}

    record = record_parts(path, "benchmarks/b.py", ["--parts", "ab,c"], ["ab", "c"], measure, {"cpus": 2})
    assert seen == [set(), {"ab"}]
    assert json.loads(path.read_text()) == record
    assert record["old"] == {"x": 1} and record["ab"]["value"] == 2 and record["c"]["value"] == 1
    assert record["c"]["command"] == "python benchmarks/b.py --parts ab,c" and record["c"]["machine"] == {"cpus": 2}
    assert record["c"]["wall_s"] >= 0 and len(record["c"]["load_avg_at_start"]) == 3


def test_the_motion_fit_targets_read_from_their_stage_beside_the_chain_without_it():
    from vsmp_imu.har.bench_records import _script

    run_all = _script(REPO_ROOT / "benchmarks/run_all.py")
    runs = [{"motion_fit": on, "samples": 100, "wall_s": wall} for on, wall in
            ((False, 2.0), (True, 4.0), (True, 4.0), (False, 2.0))]
    fit = {"runs": runs, "samples_per_s": 25.0, "samples_per_s_off": 50.0,
           "fit_s_per_class_per_core": 0.5}
    chain, per_class = run_all._motion_fit_rows(fit)
    assert chain[1].startswith("**25.0 samples/s**; the chain without it in the same stage 50.0: 0.50×")
    assert "(one fold off, on, on, off: 2.0, 4.0, 4.0, 2.0 s)" in chain[1]
    assert chain[2] == "NOT met" and per_class[2] == "met"
    assert run_all._motion_fit_rows({**fit, "fit_s_per_class_per_core": 3.5})[1][2] == "NOT met"
    assert run_all._motion_fit_rows({**fit, "samples_per_s": 40.0})[0][2] == "met"
