"""The VLM extractor end to end against the replay server: prompt, accounting, cache, CLI."""

from __future__ import annotations

import base64
import json
import logging
import re
from pathlib import Path

import numpy as np
import pytest
from vlm_server import Reply, error, ok

from vsmp_imu.extract.client import VLMClient
from vsmp_imu.extract.frames import FrameSampler
from vsmp_imu.extract.prompt import PROMPT_TEMPLATE, SCHEMA_TEXT, smp_prompt
from vsmp_imu.extract.vlm import VLMExtractor
from vsmp_imu.smp import load_smp
from vsmp_imu.smp.library import ActivityLibrary

cv2 = pytest.importorskip("cv2")

PAPER = Path(__file__).resolve().parents[2].parent / "shared" / "paper" / "vsmp-imu-paper.tex"
SECRET = "sk-live-Zq9SECRETkey0000"


def extractor(server, tmp_path, n_frames=4, max_retries=2, **kw) -> VLMExtractor:
    client = VLMClient(server.url, "vlm-test", cache_dir=tmp_path / "cache", base_delay_s=0.001,
                       max_retries=max_retries, timeout_s=5.0, sleep=lambda s: None)
    return VLMExtractor(client, sampler=FrameSampler(n_frames=n_frames), **kw)


def test_prompt_and_schema_are_the_papers_verbatim():
    if not PAPER.exists():
        pytest.skip(f"paper source {PAPER} not present")
    tex = PAPER.read_text(encoding="utf-8")
    section = tex[tex.index(r"\label{app:vlm_prompt}"):]
    quote = section[section.index(r"\begin{quote}") + len(r"\begin{quote}"):section.index(r"\end{quote}")]
    verbatim = section[section.index(r"\begin{verbatim}") + len(r"\begin{verbatim}"):section.index(r"\end{verbatim}")]
    assert verbatim.strip("\n") == SCHEMA_TEXT
    assert quote.strip().replace("$", "") == PROMPT_TEMPLATE
    json.loads(SCHEMA_TEXT)
    assert smp_prompt().startswith(PROMPT_TEMPLATE) and smp_prompt().endswith(SCHEMA_TEXT)


def test_the_request_carries_prompt_hint_timing_and_frames(chat_server, tmp_path, videos):
    with chat_server([ok("walking_valid_1.json")] * 5) as server:
        extractor(server, tmp_path, n_frames=4).extract(videos["counter"], label="walking")
    assert len(server.requests) == 5
    body = server.requests[0]["body"]
    assert body["response_format"]["type"] == "json_schema"
    assert body["response_format"]["json_schema"]["schema"]["title"] == "Semantic Motion Program"
    (message,) = body["messages"]
    assert message["role"] == "user"
    texts = [p["text"] for p in message["content"] if p["type"] == "text"]
    images = [p["image_url"]["url"] for p in message["content"] if p["type"] == "image_url"]
    assert texts[0] == smp_prompt()
    assert texts[1].startswith('Label hint: the dataset labels this clip "walking"')
    assert texts[2].startswith("The clip lasts 2.00 s. The 4 frames")
    assert len(images) == 4
    jpeg = base64.b64decode(images[0].split(",", 1)[1])
    frame = cv2.imdecode(np.frombuffer(jpeg, np.uint8), cv2.IMREAD_COLOR)
    assert frame.shape == (512, 512, 3)
    # the five queries are the same request (answers differ by the server's sampling)
    assert all(r["body"] == body for r in server.requests)


def test_mixed_responses_are_repaired_aggregated_refined_and_counted(chat_server, tmp_path, videos):
    script = [ok("walking_valid_1.json"), ok("walking_fenced.md"), ok("walking_valid_2.json"),
              ok("walking_wrong_keys.json"), ok("walking_invalid_values.json")]
    with chat_server(script) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    c = result.counts
    assert (c.queries, c.valid, c.rejected, c.request_failures) == (5, 5, 0, 0)
    assert (c.malformed_json, c.missing_mandatory_field, c.invalid_value) == (1, 0, 1)
    assert c.repaired == 3 and c.schema_repair == 1
    assert c.five_response_disagreement == 1  # response 2 says fast and 9 repetitions
    assert not result.discarded and c.discarded == 0
    smp = result.smp
    assert smp.activity_label == "walking"
    assert smp.primitive_sequence == ["left_step", "right_step"]
    assert smp.execution_attributes.tempo == "medium"  # median of medium x3, fast
    assert smp.temporal_structure.repetition_count == 8
    assert result.aggregated_smp is not None and result.refinement["entry"] == "walking"
    assert result.aggregation["n_valid"] == 5
    # fast (response 2) and unknown (response 4, reset) differ from the aggregate: 2 of 5
    assert result.aggregation["disagreement"]["execution_attributes.tempo"] == pytest.approx(0.4)
    assert len(result.raw_responses) == 5 and result.raw_responses[1].startswith("Here is")
    json.dumps(result.to_dict())


def test_fewer_than_three_valid_responses_discard_the_clip(chat_server, tmp_path, videos):
    script = [error(429, retry_after="0"), ok("walking_valid_1.json"),  # query 0: retried, valid
              ok("walking_missing_label.json"),  # query 1: missing mandatory field
              ok("walking_truncated_early.txt"),  # query 2: malformed and missing primitives
              ok("prose_refusal.txt"),  # query 3: no JSON
              error(500), error(500), error(500)]  # query 4: fails after 2 retries
    with chat_server(script) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    c = result.counts
    assert result.discarded and result.smp is None and c.discarded == 1
    assert "only 1 of 5 responses are valid" in result.reason and "1 request(s) failed" in result.reason
    assert (c.valid, c.rejected, c.request_failures, c.retries) == (1, 3, 1, 3)
    assert (c.malformed_json, c.missing_mandatory_field, c.invalid_value) == (2, 2, 0)
    assert result.queries[4]["error"].startswith("gave up after 3 attempt(s)")
    assert result.repairs[4]["request_failed"] is True
    assert len(server.requests) == 8


def test_exactly_three_valid_responses_are_enough(chat_server, tmp_path, videos):
    script = [ok("walking_valid_1.json"), ok("prose_refusal.txt"), ok("walking_valid_3.json"),
              ok("walking_missing_label.json"), ok("walking_truncated_recoverable.txt")]
    with chat_server(script) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    assert not result.discarded and result.counts.valid == 3 and result.counts.rejected == 2
    assert result.smp.activity_label == "walking"


def test_server_without_structured_output(chat_server, tmp_path, videos):
    script = [ok(f"walking_valid_{k}.json") for k in (1, 2, 3, 1, 2)]
    with chat_server(script, reject_response_format=True) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    assert result.counts.valid == 5 and result.counts.format_fallbacks == 1
    assert [("response_format" in r["body"]) for r in server.requests] == [True] + [False] * 5
    assert {q["response_format"] for q in result.queries} == {"text"}


def test_rerun_is_free_and_a_killed_run_resumes(chat_server, tmp_path, videos):
    script = [ok(f"walking_valid_{k}.json") for k in (1, 2, 3, 1, 2)]

    class Killed(Exception):
        pass

    def kill_after_two(done: int, total: int) -> None:
        if done == 2:
            raise Killed

    with chat_server(list(script), default=ok("walking_valid_3.json")) as server:
        ex = extractor(server, tmp_path)
        with pytest.raises(Killed):
            ex.extract(videos["counter"], label="walking", progress=kill_after_two)
        assert len(server.requests) == 2
        resumed = ex.extract(videos["counter"], label="walking")
        assert len(server.requests) == 5  # only the three missing queries
        assert resumed.counts.cached == 2
        again = ex.extract(videos["counter"], label="walking")
        assert len(server.requests) == 5 and again.counts.cached == 5
    assert again.smp == resumed.smp
    # another label hint is another prompt: not a cache hit
    with chat_server([], default=ok("walking_valid_1.json")) as server2:
        ex2 = extractor(server2, tmp_path)
        ex2.extract(videos["counter"], label="walking in place")
        assert len(server2.requests) == 5


def test_unusable_answers_are_not_cached_and_asked_again(chat_server, tmp_path, videos):
    """A refusal, prose or an empty answer is not cached as if good: the next run asks again."""
    bad = [ok("prose_refusal.txt"), ok("walking_missing_label.json"), Reply(200, ""),
           ok("walking_valid_1.json"), ok("walking_valid_2.json")]
    with chat_server(bad, default=ok("walking_valid_3.json")) as server:
        first = extractor(server, tmp_path).extract(videos["counter"], label="walking")
        again = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    assert first.counts.valid == 2 and first.discarded
    assert len(server.requests) == 8 and again.counts.cached == 2 and again.counts.valid == 5
    assert [q["cache_note"] is not None for q in first.queries] == [True, True, True, False, False]
    assert first.queries[0]["cache_note"].startswith("not cached: no JSON object found")


def test_cached_unusable_answers_of_an_older_run_are_asked_again(chat_server, tmp_path, videos):
    with chat_server([ok("prose_refusal.txt")], default=ok("walking_valid_1.json")) as server:
        ex = extractor(server, tmp_path)
        sampled = FrameSampler(n_frames=4).sample(videos["counter"])
        messages, texts = ex._request(sampled, "walking")
        ex.client.complete(messages, ex._key_fields(sampled, texts, 0))  # no check: cached
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    assert result.counts.cached == 0 and result.counts.valid == 5 and len(server.requests) == 6
    assert "the cached answer is unusable (no JSON object found" in result.queries[0]["cache_note"]


def test_cli_extract_writes_smp_raw_and_report_and_never_the_key(chat_server, tmp_path, videos, cli,
                                                                monkeypatch, caplog, capfd):
    monkeypatch.setenv("VSMP_VLM_API_KEY", SECRET)
    caplog.set_level(logging.DEBUG)
    script = [ok("walking_valid_1.json"), ok("walking_fenced.md"), error(500), ok("walking_valid_2.json"),
              ok("walking_invalid_values.json"), ok("walking_valid_3.json")]
    out = tmp_path / "out" / "clip.json"
    with chat_server(script) as server:
        code, stdout, stderr = cli("smp", "extract", videos["counter"], "--label", "walking",
                                   "--extractor", "vlm", "--n-frames", "4",
                                   "--vlm-base-url", server.url, "--vlm-model", "vlm-test",
                                   "--cache-dir", tmp_path / "cache", "-o", out)
    assert code == 0, stderr
    assert all(r["headers"]["authorization"] == f"Bearer {SECRET}" for r in server.requests)
    smp = load_smp(out)
    assert smp.activity_label == "walking"
    raw = sorted(p.name for p in (tmp_path / "out" / "clip.raw").iterdir())
    assert raw == [f"response_{k}.{ext}" for k in range(5) for ext in ("json", "txt")]
    assert (tmp_path / "out" / "clip.raw" / "response_1.txt").read_text().startswith("Here is")
    report = json.loads((tmp_path / "out" / "clip.report.json").read_text())
    assert report["counts"]["valid"] == 5 and report["counts"]["retries"] == 1
    assert report["smp"] == smp.model_dump(mode="json")
    assert "5/5 valid responses" in stdout
    captured = capfd.readouterr()
    texts = [stdout, stderr, caplog.text, captured.out, captured.err]
    for path in list(tmp_path.rglob("*")):
        if path.is_file():
            texts.append(path.read_bytes().decode("utf-8", "replace"))
    assert len(texts) > 10 and "Sending HTTP Request" in caplog.text  # the client's debug log was captured
    assert not [t for t in texts if SECRET in t]


def test_cli_dry_run_sends_nothing_and_redacts(chat_server, tmp_path, videos, cli, monkeypatch):
    monkeypatch.setenv("OPENAI_API_KEY", SECRET)
    with chat_server([]) as server:
        code, stdout, stderr = cli("smp", "extract", videos["counter"], "--label", "walking",
                                   "--extractor", "vlm", "--preset", "utd_mhad", "--dry-run",
                                   "--vlm-base-url", server.url, "--vlm-model", "vlm-test",
                                   "--cache-dir", tmp_path / "cache")
    assert code == 0, stderr
    assert server.requests == []
    shown = json.loads(stdout)
    req = shown["request"]
    assert req["url"] == server.url + "/chat/completions" and req["method"] == "POST"
    assert req["headers"]["Authorization"] == "Bearer ***" and SECRET not in stdout
    content = req["body"]["messages"][0]["content"]
    urls = [p["image_url"]["url"] for p in content if p["type"] == "image_url"]
    assert len(urls) == 16 and all(re.fullmatch(r"data:image/jpeg;base64,<\d+ bytes>", u) for u in urls)
    assert req["body"]["response_format"]["type"] == "json_schema"
    assert shown["requests_per_clip"] == 5 and shown["clip"]["preset"] == "utd_mhad"


def test_cli_discarded_clip_exits_2_and_keeps_the_evidence(chat_server, tmp_path, videos, cli):
    out = tmp_path / "smp.json"
    with chat_server([], default=ok("prose_refusal.txt")) as server:
        code, stdout, stderr = cli("smp", "extract", videos["counter"], "--label", "walking",
                                   "--n-frames", "2", "--vlm-base-url", server.url,
                                   "--vlm-model", "vlm-test", "--cache-dir", tmp_path / "c", "-o", out)
    assert code == 2 and "clip discarded" in stderr and "0 of 5" in stderr
    assert not out.exists()
    report = json.loads((tmp_path / "smp.report.json").read_text())
    assert report["discarded"] and report["counts"]["malformed_json"] == 5
    assert len(list((tmp_path / "smp.raw").glob("*.txt"))) == 5


def test_cli_option_errors(cli, videos, tmp_path):
    code, _, err = cli("smp", "extract", videos["counter"], "--label", "walking", "-o", tmp_path / "a.json")
    assert code == 2 and "--vlm-base-url" in err
    code, _, err = cli("smp", "extract", videos["counter"], "--label", "walking", "--extractor", "clip")
    assert code == 2 and "vlm, pose, fused" in err
    code, _, err = cli("smp", "extract", videos["counter"], "--label", "walking", "--n-frames", "4",
                       "--preset", "mm_fit", "-o", tmp_path / "a.json")
    assert code == 2 and "not both" in err


def _vlm_command(command: str, videos, tmp_path, vlm: tuple) -> tuple:
    """`smp extract` of one clip into a.json, or `video pool` of a one-clip pool into m.json, with `vlm`."""
    if command == "extract":
        return ("smp", "extract", videos["counter"], "--label", "walking", "-o", tmp_path / "a.json", *vlm)
    (tmp_path / "pool" / "walking").mkdir(parents=True)
    (tmp_path / "pool" / "walking" / "a.avi").write_bytes(videos["counter"].read_bytes())
    return ("video", "pool", tmp_path / "pool", "--checker", "vlm", "-o", tmp_path / "m.json", *vlm)


@pytest.mark.parametrize("option,value", [("--timeout-s", v) for v in ("-1", "nan", "inf", "0", "3601")]
                         + [("--max-retries", v) for v in ("-1", "11")]
                         + [("--vlm-base-url", v) for v in ("localhost:8000/v1", "ftp://h/v1", "http://h /v1")])
@pytest.mark.parametrize("command", ["extract", "pool"])
def test_cli_base_url_timeout_and_retries_are_checked_before_any_work(cli, videos, tmp_path, option, value, command):
    vlm = ("--vlm-base-url", "http://127.0.0.1:9/v1", "--vlm-model", "m", option, value)
    code, _, err = cli(*_vlm_command(command, videos, tmp_path, vlm))
    assert code == 2 and f"field '{option}': '" in err and "Allowed: a " in err
    assert not (tmp_path / "a.raw").exists() and not (tmp_path / "m.json").exists()


@pytest.mark.parametrize("command", ["extract", "pool"])
def test_cli_a_cache_dir_that_cannot_be_written_is_refused_before_any_request(chat_server, cli, videos, tmp_path,
                                                                             command):
    """A file where the VLM cache folder should be: `smp extract` failed after the first paid answer."""
    (tmp_path / "notes.txt").write_text("mine")
    with chat_server([], default=ok("walking_valid_1.json")) as server:
        vlm = ("--vlm-base-url", server.url, "--vlm-model", "m", "--cache-dir", tmp_path / "notes.txt")
        code, _, err = cli(*_vlm_command(command, videos, tmp_path, vlm))
    assert code == 2 and err.startswith(f"{tmp_path / 'notes.txt'}: field '--cache-dir': exists and is a file")
    assert server.requests == [] and (tmp_path / "notes.txt").read_text() == "mine"
    assert not (tmp_path / "a.raw").exists() and not (tmp_path / "m.json").exists()


def test_client_limits_for_api_users():
    from vsmp_imu.errors import ConfigError

    for bad in (0, -1.0, float("nan"), float("inf"), 3601, True, "5"):
        with pytest.raises(ConfigError, match="Allowed: a number of seconds > 0, at most 3600"):
            VLMClient("http://127.0.0.1:9/v1", "m", timeout_s=bad)
    for bad in (-1, 11, 1.5, True):
        with pytest.raises(ConfigError, match="max_retries"):
            VLMClient("http://127.0.0.1:9/v1", "m", max_retries=bad)
    assert VLMClient("http://127.0.0.1:9/v1", "m", timeout_s=3600, max_retries=0).timeout_s == 3600.0


def _library_answer(name: str) -> Reply:
    return Reply(200, ActivityLibrary.load().get(name).smp.model_dump_json())


def test_responses_of_another_activity_than_the_label_discard_the_clip(chat_server, tmp_path, videos):
    with chat_server([], default=_library_answer("jumping_jacks")) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="Walking")
        assert result.discarded and result.smp is None and result.counts.discarded == 1
        assert result.reason == ("the responses name 'jumping jacks' (activity jumping_jacks), not the "
                                 "clip's label 'Walking' (activity walking)")
        assert result.aggregated_smp is not None and result.refinement is None  # kept as evidence
        # a label that names no library activity cannot be checked
        kept = extractor(server, tmp_path).extract(videos["counter"], label="star exercise")
        assert not kept.discarded and kept.smp.activity_label == "jumping jacks"


def test_responses_naming_different_activities_discard_the_clip(chat_server, tmp_path, videos):
    script = [_library_answer(n) for n in ("jumping_jacks", "walking", "sitting", "jumping_jacks", "walking")]
    with chat_server(script) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    assert result.discarded and result.counts.valid == 5
    assert result.reason.startswith("no activity is named by a majority of the 5 valid responses")


def test_an_answer_with_thousands_of_primitives_is_an_invalid_value(chat_server, tmp_path, videos):
    huge = json.dumps({"activity_label": "walking", "primitive_sequence": [f"p{i}" for i in range(5000)]})
    script = [Reply(200, huge)] + [ok("walking_valid_1.json")] * 4
    with chat_server(script) as server:
        result = extractor(server, tmp_path).extract(videos["counter"], label="walking")
    c = result.counts
    assert (c.valid, c.rejected, c.invalid_value) == (4, 1, 1) and not result.discarded


def _extract(cli, server, video, out, *extra):
    return cli("smp", "extract", video, "--label", "walking", "--n-frames", "2",
               "--vlm-base-url", server.url, "--vlm-model", "vlm-test", "--no-cache", "-o", out, *extra)


def test_cli_rerun_leaves_no_file_of_the_earlier_run(chat_server, tmp_path, videos, cli):
    out = tmp_path / "clip.json"
    raw = tmp_path / "clip.raw"
    with chat_server([], default=ok("walking_valid_1.json")) as server:
        code, _, err = _extract(cli, server, videos["counter"], out)
    assert code == 0, err
    (raw / "notes.txt").write_text("mine")
    with chat_server([], default=_library_answer("jumping_jacks")) as server:
        code, _, err = _extract(cli, server, videos["counter"], out, "--n-queries", "3")
    assert code == 2 and "clip discarded: the responses name 'jumping jacks'" in err
    assert f"removed the SMP of an earlier run, {out}" in err
    assert not out.exists()
    assert sorted(p.name for p in raw.iterdir()) == ["notes.txt"] + [
        f"response_{k}.{ext}" for k in range(3) for ext in ("json", "txt")]
    assert all("jumping" in (raw / f"response_{k}.txt").read_text() for k in range(3))
    report = json.loads((tmp_path / "clip.report.json").read_text())
    assert report["discarded"] and len(report["queries"]) == 3


@pytest.mark.parametrize(("args", "field", "allowed"), [
    (["--n-queries", "2"], "--n-queries", "3..20"), (["--n-queries", "100000"], "--n-queries", "3..20"),
    (["--n-frames", "0"], "--n-frames", "1..256"),
])
def test_cli_query_options_are_checked_before_any_request(chat_server, tmp_path, videos, cli, args, field,
                                                          allowed):
    with chat_server([], default=ok("walking_valid_1.json")) as server:
        code, _, err = _extract(cli, server, videos["counter"], tmp_path / "a.json", *args)
    assert code == 2 and f"field '{field}'" in err and allowed in err
    assert server.requests == []


def test_cli_a_file_where_the_raw_folder_goes_is_refused_before_any_request(chat_server, tmp_path, videos,
                                                                           cli):
    (tmp_path / "a.raw").write_text("a file")
    with chat_server([], default=ok("walking_valid_1.json")) as server:
        code, _, err = _extract(cli, server, videos["counter"], tmp_path / "a.json")
    assert code == 2 and "a.raw" in err and "not a folder" in err
    assert server.requests == []


@pytest.mark.parametrize("value", ["nan", "-0.1", "1.5", "inf"])
def test_cli_fuse_threshold_is_a_finite_number_in_0_1(cli, videos, tmp_path, value):
    code, _, err = cli("smp", "extract", videos["counter"], "--label", "walking", "--extractor", "fused",
                       "--fuse-threshold", value, "-o", tmp_path / "a.json")
    assert code == 2 and "--fuse-threshold" in err and "0..1" in err
