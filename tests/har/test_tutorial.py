"""docs/tutorial.md runs as written: its python blocks, its `file=` blocks and its bash
commands, in order, in an empty folder."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
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
