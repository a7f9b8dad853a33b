"""`study granularity` and `study realism` with `--describer-url/--describer-model`: the imugpt
descriptions come from that endpoint and model (a local server replaying recorded answers),
and the study's results name it, as `evaluate` does."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from study_support import FIXTURES

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "extract"))
from vlm_server import ChatServer, Reply  # noqa: E402

GENERIC = FIXTURES / "datasets" / "generic" / "dataset.yaml"  # two classes: walk, sit
WALK = json.dumps({"descriptions": ["A person walks briskly.", "A person walks slowly with small steps."]})
SIT = json.dumps({"descriptions": ["A person sits down on a chair.", "A person sits still, relaxed."]})


def _ask(cli, *args):
    """Run the study against a describer serving one answer per class: (exit code, stderr,
    the server's requests)."""
    with ChatServer([Reply(200, WALK), Reply(200, SIT)]) as server:
        code, stdout, err = cli(*args, "--describer-url", server.url, "--describer-model", "writer")
    assert code == 0, stdout + err
    return server


def _check_asked(server, settings: dict) -> dict:
    """One request per class, to the named model, and the settings recording it."""
    assert [r["body"]["model"] for r in server.requests] == ["writer", "writer"]
    prompts = [r["body"]["messages"][0]["content"] for r in server.requests]
    assert any("'walk" in p for p in prompts) and any("'sit" in p for p in prompts)
    describer = {"describer_url": server.url, "describer_model": "writer"}
    assert settings["method_options"] == {"imugpt": describer}
    return describer


def test_granularity_asks_the_describer_and_records_it(cli, tmp_path, monkeypatch):
    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "cache"))
    taxonomy = tmp_path / "groups.yaml"
    taxonomy.write_text("Moving: [walk]\nStill: [sit]\n")
    out = tmp_path / "out"
    server = _ask(cli, "study", "granularity", "-o", out, "-d", GENERIC, "--taxonomy", taxonomy,
                  "--methods", "real,imugpt", "--folds", "p1", "--jobs", "1")
    results = json.loads((out / "results.json").read_text())
    describer = _check_asked(server, results["settings"])
    assert "imugpt" in results["settings"]["methods"]
    params = json.loads((out / "runs" / "results.json").read_text())["config"]["method_params"]
    assert describer.items() <= params["imugpt"].items()
    assert any((out / "cache" / "describer").iterdir())  # the study's own cache
    assert "model `writer` of the describer endpoint" in (out / "report.md").read_text()


def test_realism_asks_the_describer_and_records_it(cli, tmp_path, monkeypatch):
    monkeypatch.setenv("VSMP_IMU_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "out"
    server = _ask(cli, "study", "realism", "-o", out, "-d", GENERIC, "--fold", "p1", "--methods", "imugpt",
                  "--epochs", "1", "--filters", "8", "--hidden", "16", "--max-per-class", "10")
    results = json.loads((out / "results.json").read_text())
    _check_asked(server, results["settings"])
    assert results["skipped"] == {} and any(m["method"] == "imugpt" for m in results["methods"])
    assert "model `writer` of the describer endpoint" in (out / "report.md").read_text()
