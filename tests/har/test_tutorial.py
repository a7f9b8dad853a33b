"""docs/tutorial.md runs as written: its python blocks, its `file=` blocks and its bash
commands, in order, in an empty folder."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections import Counter
from pathlib import Path

TUTORIAL = Path(__file__).resolve().parents[2] / "docs" / "tutorial.md"
BLOCK = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```$", re.S | re.M)


def blocks(text: str) -> list[tuple[str, str, str]]:
    """(language, info after it, body) of every fenced block, in order."""
    return [(m[1], m[2].strip(), m[3]) for m in BLOCK.finditer(text)]


def run_block(lang: str, info: str, body: str, cwd: Path, env: dict) -> None:
    if info.startswith("file="):
        target = cwd / info.removeprefix("file=")
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(body)
    elif lang == "python":
        # python blocks share their variables, as in one session: each runs after the ones before
        script = cwd / "tutorial_session.py"
        script.write_text((script.read_text() if script.exists() else "") + body + "\n")
        subprocess.run([sys.executable, script.name], cwd=cwd, env=env, check=True, capture_output=True)
    elif lang == "bash":
        done = subprocess.run(["bash", "-euo", "pipefail", "-c", body], cwd=cwd, env=env, capture_output=True,
                              text=True)
        assert done.returncode == 0, f"{body}\n{done.stdout}\n{done.stderr}"


def test_blocks_are_found():
    found = blocks(TUTORIAL.read_text())
    kinds = [(lang, info.split("=")[0]) for lang, info, _ in found]
    assert kinds.count(("python", "")) == 2 and ("yaml", "file") in kinds and kinds.count(("bash", "")) == 3


def test_tutorial_runs_as_written(tmp_path):
    env = {**os.environ, "VSMP_IMU_CACHE": str(tmp_path / "cache"),
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    work = tmp_path / "work"
    work.mkdir()
    for lang, info, body in blocks(TUTORIAL.read_text()):
        run_block(lang, info, body, work, env)
    results = json.loads((work / "my_watch/runs/results.json").read_text())
    assert {r["method"] for r in results["records"]} == {"real", "vsmp"}
    assert all(r["fold"] == "p1" for r in results["records"])
    vsmp = next(r for r in results["records"] if r["method"] == "vsmp")
    assert vsmp["n_synthetic"] > 0
    assert not (work / "my_watch/runs/cache").exists() and any((tmp_path / "cache/samples").iterdir())
    check = json.loads((work / "my_watch/check/check.json").read_text())
    assert [c["label"] for c in check["classes"]] == ["walking", "sitting", "dumbbell curls"]
    assert (work / "my_watch/check/check.png").stat().st_size > 0


def _sample_classes(folder: Path) -> dict[str, str]:
    """Cache file name -> the class of the sample it holds (its key is fold/class/slot)."""
    import pyarrow.parquet as pq

    return {p.name: json.loads(pq.read_schema(p).metadata[b"vsmp_imu.sample"])["key"].split("/")[1]
            for p in folder.glob("*.parquet")}


def test_an_edited_activity_file_remakes_the_samples_that_read_it(tmp_path):
    """The tutorial's promise: after an edit to an activity file the same evaluation makes that
    activity's samples again and recomputes the VSMP-IMU record, keeping Real-only's. An edit that
    leaves the sensor mounting (estimated from the default motions of the classes that hold a
    posture or repeat a rhythm) where it was reuses every other activity's samples; one that
    moves it remakes theirs as well."""
    from vsmp_imu.smp.library import BUILTIN_DIR

    env = {**os.environ, "VSMP_IMU_CACHE": str(tmp_path / "cache"),
           "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
    work = tmp_path / "work"
    work.mkdir()
    found = blocks(TUTORIAL.read_text())
    evaluate = next(body for lang, _, body in found if lang == "bash" and "vsmp-imu evaluate" in body)
    for lang, info, body in found:
        if "data check" not in body:
            run_block(lang, info, body, work, env)
    samples, records = tmp_path / "cache/samples", work / "my_watch/runs/records"
    slots = Counter(_sample_classes(samples).values())  # samples per class in the run
    curls = (BUILTIN_DIR / "bicep_curls.yaml").read_text()
    (work / "mine").mkdir()

    def rerun(text: str) -> tuple[dict[str, str], list[str]]:
        """The classes of the samples made anew, and the records kept byte for byte."""
        before = _sample_classes(samples)
        kept = {p.name: p.read_bytes() for p in records.glob("*.json")}
        (work / "mine/bicep_curls.yaml").write_text(text)
        run_block("bash", "", evaluate.rstrip() + " --library mine\n", work, env)
        made = {n: label for n, label in _sample_classes(samples).items() if n not in before}
        return made, sorted(p.name for p in records.glob("*.json") if p.read_bytes() == kept.get(p.name))

    # a caption: the default motion, hence the mounting, is unchanged
    assert "A person does bicep curls" in curls
    made, kept = rerun(curls.replace("A person does bicep curls", "A person curls"))
    assert set(made.values()) == {"dumbbell curls"} and len(made) == slots["dumbbell curls"]
    assert kept and all("_real_" in name for name in kept)
    # the recipe's timing: the class's default motion moves, and with it the estimated mounting
    assert "curl_up: {duration_s: 0.9," in curls
    made, kept = rerun(curls.replace("curl_up: {duration_s: 0.9,", "curl_up: {duration_s: 1.3,"))
    assert Counter(made.values())["dumbbell curls"] == slots["dumbbell curls"]
    assert kept and all("_real_" in name for name in kept)
