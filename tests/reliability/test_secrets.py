"""The VLM API key never leaves the Authorization header.

With the key in the environment, each path that talks to an OpenAI-compatible
endpoint runs against a local replay server: `smp extract --extractor vlm`
(successful queries, a server error that echoes the key back, an
authentication failure), `smp extract --dry-run`, and the IMUGPT 2.0-style
describer. The server must receive the key (so the test would see it if it
leaked); afterwards no file under the test's folders (outputs, raw responses,
reports, caches), no log record at DEBUG level and no console output may
contain it.
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np
import pytest

EXTRACT_TESTS = Path(__file__).resolve().parents[1] / "extract"
sys.path.insert(0, str(EXTRACT_TESTS))

from extract_support import write_video  # noqa: E402
from vlm_server import ChatServer, Reply, error, ok  # noqa: E402

from vsmp_imu.cli import main  # noqa: E402

SECRET = "sk-proj-RELIABILITY0secret0Key0123456789"


def run_main(capsys, *argv) -> tuple[int, str]:
    try:
        main([str(a) for a in argv])
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else 1
    captured = capsys.readouterr()
    return code, captured.out + captured.err


def assert_nowhere(folder: Path, *texts: str) -> int:
    """The key is in none of the texts nor any file under `folder`; returns how many files were read."""
    files = [p for p in folder.rglob("*") if p.is_file()]
    for path in files:
        assert SECRET.encode() not in path.read_bytes(), f"the key is in {path}"
    for text in texts:
        assert SECRET not in text
    return len(files)


@pytest.fixture
def key(monkeypatch, caplog):
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
    monkeypatch.setenv("VSMP_VLM_API_KEY", SECRET)
    caplog.set_level(logging.DEBUG)
    return SECRET


@pytest.fixture(scope="module")
def clip(tmp_path_factory) -> Path:
    pytest.importorskip("cv2")
    frames = [np.full((48, 64, 3), 10 + 5 * i, np.uint8) for i in range(20)]
    return write_video(tmp_path_factory.mktemp("clip") / "walk.avi", frames, 10.0)


def _extract(server, clip, out, cache, *extra):
    return ("smp", "extract", clip, "--label", "walking", "--extractor", "vlm", "--n-frames", "4",
            "--vlm-base-url", server.url, "--vlm-model", "vlm-test", "--cache-dir", cache,
            "--max-retries", "1", "-o", out, *extra)


def test_smp_extract_keeps_the_key_out_of_files_logs_and_output(key, clip, tmp_path, capsys, caplog):
    # one answer is a server error whose body echoes the key, as a misconfigured proxy might
    script = [ok("walking_valid_1.json"), error(500, message=f"upstream rejected Bearer {SECRET}"),
              ok("walking_valid_2.json"), ok("walking_valid_3.json"), ok("walking_fenced.md"),
              ok("walking_valid_1.json")]
    with ChatServer(script) as server:
        code, text = run_main(capsys, *_extract(server, clip, tmp_path / "out" / "clip.json",
                                                tmp_path / "cache"))
    assert code == 0, text
    assert {r["headers"]["authorization"] for r in server.requests} == {f"Bearer {SECRET}"}
    assert (tmp_path / "out" / "clip.report.json").exists()
    assert "Sending HTTP Request" in caplog.text  # the HTTP client's debug log was captured
    assert assert_nowhere(tmp_path, text, caplog.text) >= 12  # SMP, report, raw responses, cache


def test_an_authentication_failure_does_not_print_the_key(key, clip, tmp_path, capsys, caplog):
    with ChatServer([], default=error(401, message=f"Incorrect API key provided: {SECRET}")) as server:
        code, text = run_main(capsys, *_extract(server, clip, tmp_path / "out.json", tmp_path / "cache"))
    assert code == 2 and "401" in text, text
    assert server.requests and server.requests[0]["headers"]["authorization"] == f"Bearer {SECRET}"
    assert_nowhere(tmp_path, text, caplog.text)


def test_dry_run_shows_the_request_with_the_key_masked(key, clip, tmp_path, capsys, caplog):
    with ChatServer([]) as server:
        code, text = run_main(capsys, *_extract(server, clip, tmp_path / "out.json", tmp_path / "cache",
                                                "--dry-run"))
    assert code == 0, text
    assert server.requests == [] and "Bearer ***" in text
    assert_nowhere(tmp_path, text, caplog.text)


def test_imugpt_describer_keeps_the_key_out_of_cache_and_provenance(key, tmp_path, capsys, caplog):
    from vsmp_imu.baselines.generative import ImuGptMethod
    from vsmp_imu.har.datasets import load_dataset
    from vsmp_imu.har.synthetic import FoldContext, synthetic_budget

    ds = load_dataset("hapt")
    train = ds.windows().where_subjects(["2", "3"])[::3]  # a third of the windows keeps it quick
    budget = synthetic_budget(train.class_counts(), 0.02)
    context = FoldContext(dataset=ds.info, fold="1", held_out_subject="1", train=train,
                          train_subjects=("2", "3"), seed=0,
                          budget={n: int(b) for n, b in zip(train.label_names, budget, strict=True) if b},
                          alpha=0.02, protocol="lopo")
    answer = '{"descriptions": ["A person walks at an easy pace.", "A person walks briskly."]}'
    with ChatServer([], default=Reply(200, answer)) as server:
        method = ImuGptMethod(n_descriptions=2, describer_url=server.url, describer_model="describer",
                              cache_dir=str(tmp_path / "cache"))
        windows = method.generate(context)
    assert len(windows) > 0
    assert len(server.requests) == 6  # one description request per class
    assert {r["headers"]["authorization"] for r in server.requests} == {f"Bearer {SECRET}"}
    provenance = " ".join(str(r.provenance.as_dict()) for r in method.last_output_.records)
    assert "walks at an easy pace" in provenance
    captured = capsys.readouterr()
    n_files = assert_nowhere(tmp_path, provenance, caplog.text, captured.out, captured.err)
    assert n_files >= 4  # description cache entries and per-sample results
