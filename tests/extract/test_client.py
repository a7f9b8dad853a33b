"""The chat-completions client against a real local HTTP server: retries, fallback, cache."""

from __future__ import annotations

import email.utils
import gzip
import json
import logging
import time

import pytest
from vlm_server import Reply, error, fixture_text, ok, redirect

from vsmp_imu.errors import ServiceError
from vsmp_imu.extract.client import (
    ENDPOINTS_FILE,
    VLMClient,
    abbreviate_images,
    api_key_from_env,
    message_text,
    retry_after,
    retry_after_s,
    scrub,
)
from vsmp_imu.extract.http import MAX_RESPONSE_BYTES

MESSAGES = [{"role": "user", "content": [{"type": "text", "text": "describe"},
                                         {"type": "image_url",
                                          "image_url": {"url": "data:image/jpeg;base64,QUJDRA=="}}]}]
FORMAT = {"type": "json_schema", "json_schema": {"name": "x", "schema": {"type": "object"}}}


class Sleeps:
    """Records the waits instead of sleeping."""

    def __init__(self) -> None:
        self.waits: list[float] = []

    def __call__(self, seconds: float) -> None:
        self.waits.append(seconds)


def client(server, tmp_path=None, **kw) -> VLMClient:
    kw.setdefault("sleep", Sleeps())
    kw.setdefault("base_delay_s", 0.01)
    kw.setdefault("timeout_s", 5.0)
    return VLMClient(server.url, "vlm-test", cache_dir=None if tmp_path is None else tmp_path / "cache", **kw)


def test_helpers():
    assert retry_after_s({"Retry-After": "3"}) == 3.0
    assert retry_after_s({"retry-after-ms": "1500"}) == 1.5
    assert retry_after_s({"Retry-After": "Wed, 21 Oct 2015 07:28:00 GMT"}, now=1445412470.0) == 10.0
    assert retry_after_s({"Retry-After": "soon"}) is None and retry_after_s({}) is None
    assert scrub("Bearer sk-abc and sk-abc", "sk-abc") == "Bearer *** and ***"
    assert scrub("text", None) == "text"
    short = abbreviate_images(MESSAGES)
    assert short[0]["content"][1]["image_url"]["url"] == "data:image/jpeg;base64,<6 bytes>"
    assert MESSAGES[0]["content"][1]["image_url"]["url"].endswith("QUJDRA==")  # not mutated
    assert message_text({"choices": [{"message": {"content": [{"type": "text", "text": "a"},
                                                               {"type": "text", "text": "b"}]}}]}) == "ab"
    assert message_text({"choices": []}) is None
    assert api_key_from_env({"OPENAI_API_KEY": "k2"}) == "k2"
    assert api_key_from_env({"VSMP_VLM_API_KEY": "k1", "OPENAI_API_KEY": "k2"}) == "k1"
    assert api_key_from_env({}) is None


def test_a_valid_reply_is_returned_with_the_full_body(chat_server):
    with chat_server([ok("walking_valid_1.json")]) as server:
        done = client(server).complete(MESSAGES, {"q": 0}, FORMAT)
    assert done.ok and done.attempts == 1 and done.retries == 0
    assert json.loads(done.content)["activity_label"] == "walking"
    assert done.response["object"] == "chat.completion" and "usage" in done.response
    sent = server.requests[0]
    assert sent["path"] == "/v1/chat/completions"
    assert sent["body"]["model"] == "vlm-test" and sent["body"]["response_format"] == FORMAT
    assert sent["body"]["messages"] == MESSAGES


def test_429_with_retry_after_is_honoured_then_succeeds(chat_server):
    sleeps = Sleeps()
    with chat_server([error(429, retry_after="2"), ok("walking_valid_1.json")]) as server:
        done = client(server, sleep=sleeps).complete(MESSAGES, {"q": 0})
    assert done.ok and done.attempts == 2 and done.retries == 1
    assert sleeps.waits == done.waits_s and sleeps.waits[0] >= 2.0
    assert "HTTP 429, Retry-After 2 s" in done.errors[0]


def test_5xx_backoff_grows_exponentially_with_jitter(chat_server):
    sleeps = Sleeps()
    script = [error(500), error(502), error(503), ok("walking_valid_1.json")]
    with chat_server(script) as server:
        done = client(server, sleep=sleeps, base_delay_s=1.0, max_delay_s=100.0).complete(MESSAGES, {})
    assert done.ok and done.retries == 3
    for k, wait in enumerate(sleeps.waits):
        assert 0.5 * 2**k <= wait <= 2**k  # base * 2^k x jitter in [0.5, 1]


class Clock:
    """A monotonic clock that the recorded waits advance (a Sleeps that costs no time)."""

    def __init__(self) -> None:
        self.slept = 0.0
        self.waits: list[float] = []
        self.start = time.monotonic()

    def __call__(self) -> float:
        return time.monotonic() + self.slept

    def sleep(self, seconds: float) -> None:
        self.waits.append(seconds)
        self.slept += seconds

    def elapsed(self) -> float:
        return self() - self.start


def test_retry_after_in_seconds_as_an_http_date_or_junk():
    now = 1445412470.0
    assert retry_after_s({"Retry-After": "Wed, 21 Oct 2015 07:28:00 -0000"}, now=now) == 10.0  # no zone: GMT
    assert retry_after_s({"Retry-After": "Wed, 21 Oct 2015 07:27:00 GMT"}, now=now) == 0.0  # past: now
    assert retry_after_s({"Retry-After": "Fri, 31 Dec 9999 23:59:59 GMT"}, now=now) > 1e11
    for junk in ("soon", "", "-5", "inf", "nan", "1e999", "Wed, 99 Foo 2015 07:28:00 GMT", "Mon, 1 Jan 99999 0:0:0 GMT"):
        assert retry_after_s({"Retry-After": junk}, now=now) is None, junk
    assert retry_after_s({"retry-after-ms": "junk", "Retry-After": "4"}) == 4.0
    assert retry_after({"Retry-After": " 86400 "}) == (86400.0, "retry-after: 86400")
    assert retry_after({"Retry-After": "soon"}) == (None, "retry-after: soon")
    assert retry_after({}) == (None, None)


@pytest.mark.parametrize("asked", ["86400", "121", "Fri, 31 Dec 9999 23:59:59 GMT"])
def test_a_retry_after_longer_than_a_wait_may_take_fails_the_query_at_once(chat_server, asked):
    """A hostile or overloaded server asking for a day's wait must not hold the run: the query
    fails without waiting, naming the endpoint and what it asked."""
    sleeps = Sleeps()
    with chat_server([error(429, retry_after=asked), ok("walking_valid_1.json")]) as server:
        c = client(server, sleep=sleeps, timeout_s=200.0)  # a wait may take min(200, 120) s
        done = c.complete(MESSAGES, {})
    assert not done.ok and done.attempts == 1 and done.retries == 0 and sleeps.waits == []
    assert len(server.requests) == 1
    assert f"the endpoint {server.url} vlm-test asked to wait" in done.error
    assert f"(retry-after: {asked})" in done.error and "more than the 120 s a wait may take" in done.error
    assert "not retried" in done.error


def test_a_wait_is_bounded_by_the_timeout_too(chat_server):
    sleeps = Sleeps()
    with chat_server([error(503, retry_after="3"), ok("walking_valid_1.json")]) as server:
        done = client(server, sleep=sleeps, timeout_s=2.0).complete(MESSAGES, {})
    assert not done.ok and sleeps.waits == [] and "more than the 2 s a wait may take (--timeout-s 2" in done.error


def test_a_retry_after_longer_than_what_is_left_of_the_query_fails_it(chat_server):
    """timeout 0.3 s, 2 retries: the query has 0.9 s. After 0.2 s + a 0.25 s wait + 0.2 s, a
    second Retry-After of 0.28 s fits one wait (0.3 s) but not the 0.25 s left."""
    clock = Clock()
    script = [Reply(503, headers={"Retry-After": "0.25"}, raw_body="{}", delay_s=0.2),
              Reply(503, headers={"Retry-After": "0.28"}, raw_body="{}", delay_s=0.2), ok("walking_valid_1.json")]
    with chat_server(script) as server:
        c = client(server, sleep=clock.sleep, clock=clock, timeout_s=0.3, max_retries=2)
        c._client()  # imports done before the clock starts
        done = c.complete(MESSAGES, {})
    assert not done.ok and done.attempts == 2 and clock.waits == [0.25] and len(server.requests) == 2
    assert "asked to wait 0.28 s before a retry (retry-after: 0.28)" in done.error
    assert "s left of the query's 0.9 s ((1 + --max-retries 2) x --timeout-s 0.3)" in done.error


def test_waits_and_attempts_together_stay_within_the_query_budget(chat_server):
    """A server that never answers in time: attempts (0.2 s each) and backoff waits together
    stop within (1 + 2) x 0.2 s, before the retries run out."""
    clock = Clock()
    with chat_server([], default=ok("walking_valid_1.json", delay_s=0.6)) as server:
        c = client(server, sleep=clock.sleep, clock=clock, timeout_s=0.2, max_retries=2, base_delay_s=0.15)
        c._client()
        clock.start = clock()
        done = c.complete(MESSAGES, {})
    assert not done.ok and done.retries < 2 and "no time left for a retry" in done.error
    assert all(e.startswith("timeout") for e in done.errors)
    # what the client chose: every attempt runs into its 0.2 s timeout, so its waits fit the
    # 0.6 s budget only if it counted the attempts (wall time on a busy machine overshoots each
    # timeout a little, so the wall clock is held to the budget only loosely)
    assert len(done.errors) * 0.2 + sum(clock.waits) <= 0.6 + 1e-9
    assert clock.elapsed() <= 0.6 + 1.0


def test_the_last_attempt_gets_only_what_is_left_of_the_query(chat_server):
    """timeout 0.4 s, 1 retry: 0.8 s in all. After ~0.1 s and a 0.35 s wait, the retry may
    take 0.35 s, not 0.4 s."""
    clock = Clock()
    script = [Reply(503, headers={"Retry-After": "0.35"}, raw_body="{}", delay_s=0.1),
              ok("walking_valid_1.json", delay_s=1.0)]
    with chat_server(script) as server:
        c = client(server, sleep=clock.sleep, clock=clock, timeout_s=0.4, max_retries=1)
        c._client()
        clock.start = clock()
        done = c.complete(MESSAGES, {})
    assert not done.ok and done.attempts == 2 and clock.waits == [0.35]
    assert done.errors[1].startswith("timeout") and "(what was left of the query's time)" in done.errors[1]
    assert clock.elapsed() <= 0.8 + 0.15


def test_retry_after_as_an_http_date_is_honoured_and_junk_is_ignored(chat_server):
    sleeps = Sleeps()
    soon = email.utils.formatdate(time.time() + 3, usegmt=True)
    script = [error(503, retry_after=soon), error(503, retry_after="soon"), ok("walking_valid_1.json")]
    with chat_server(script) as server:
        done = client(server, sleep=sleeps, timeout_s=5.0).complete(MESSAGES, {})
    assert done.ok and done.retries == 2
    assert 1.0 <= sleeps.waits[0] <= 3.0 and sleeps.waits[1] <= 0.02  # the date; then plain backoff
    assert "HTTP 503 (retry-after: soon: not a time, ignored)" in done.errors[1]


def test_slow_server_times_out_and_is_retried(chat_server):
    with chat_server([ok("walking_valid_1.json", delay_s=1.5), ok("walking_valid_2.json")]) as server:
        done = client(server, timeout_s=0.3).complete(MESSAGES, {})
    assert done.ok and done.attempts == 2 and "timeout" in done.errors[0]
    assert json.loads(done.content)["temporal_structure"]["repetition_count"] == 9


def test_a_trickled_answer_is_cut_off_at_the_deadline_and_retried(chat_server):
    """--timeout-s bounds the whole request: a server that sends a piece every 0.2 s (never
    idle for the 0.5 s a single read may wait) is cut off after 0.5 s, not read for 10 s."""
    slow = Reply(200, fixture_text("walking_valid_1.json"), trickle_s=0.2)
    with chat_server([slow, ok("walking_valid_2.json")]) as server:
        c = client(server, timeout_s=0.5)
        c._client()  # imports done before the clock starts
        start = time.monotonic()
        done = c.complete(MESSAGES, {})
        took = time.monotonic() - start
    assert done.ok and done.attempts == 2 and done.errors[0].startswith("timeout")
    assert json.loads(done.content)["temporal_structure"]["repetition_count"] == 9
    assert took < 3.0


@pytest.mark.parametrize("length", [True, False])
def test_an_answer_over_the_size_cap_is_refused_and_not_cached(chat_server, tmp_path, length):
    big = Reply(200, "x" * (MAX_RESPONSE_BYTES + 10), length=length)
    with chat_server([big, ok("walking_valid_1.json")]) as server:
        done = client(server, tmp_path).complete(MESSAGES, {})
    assert done.ok and done.attempts == 2 and len(done.content) < 10_000
    assert done.errors[0].startswith("answer too large") and ("Content-Length" in done.errors[0]) == length
    (entry,) = (tmp_path / "cache").rglob("*.json")
    assert entry.stat().st_size < 20_000


def test_a_compressed_answer_is_refused(chat_server):
    packed = gzip.compress(json.dumps({"choices": [{"message": {"content": "x" * 10**6}}]}).encode())
    bomb = Reply(200, headers={"Content-Encoding": "gzip"}, raw_body=packed)
    with chat_server([bomb, ok("walking_valid_1.json")]) as server:
        done = client(server).complete(MESSAGES, {})
    assert server.requests[0]["headers"]["accept-encoding"] == "identity"
    assert done.ok and done.attempts == 2 and done.errors[0].startswith("answer compressed (gzip)")


@pytest.mark.parametrize("status", [301, 302, 307, 308])
def test_a_redirect_is_not_followed(chat_server, status):
    """A followed 302 turns the POST into a GET without the frames (and 307/308 re-send them
    elsewhere): a 3xx is a request failure naming where it points, not retried."""
    with chat_server([redirect(status, "/v1/elsewhere")], default=ok("walking_valid_1.json")) as server:
        done = client(server, max_retries=3).complete(MESSAGES, {})
    assert not done.ok and done.attempts == 1 and len(server.requests) == 1
    assert f"HTTP {status}: the endpoint redirects to /v1/elsewhere" in done.error
    assert [r["method"] for r in server.requests] == ["POST"]


def test_giving_up_returns_the_error_without_raising(chat_server):
    with chat_server([], default=error(503)) as server:
        done = client(server, max_retries=2).complete(MESSAGES, {})
    assert not done.ok and done.attempts == 3 and done.retries == 2
    assert done.error.startswith("gave up after 3 attempt(s)") and len(server.requests) == 3


@pytest.mark.parametrize("status,hint", [(401, "key was refused"), (404, "wrong base URL")])
def test_configuration_errors_raise_at_once(chat_server, status, hint):
    with chat_server([error(status)]) as server, pytest.raises(ServiceError, match=hint):
        client(server).complete(MESSAGES, {}, FORMAT if status == 401 else None)
    assert len(server.requests) == 1


def test_a_server_rejecting_response_format_falls_back_and_is_remembered(chat_server, tmp_path):
    script = [ok("walking_valid_1.json"), ok("walking_valid_2.json")]
    with chat_server(script, reject_response_format=True) as server:
        c = client(server, tmp_path)
        first = c.complete(MESSAGES, {"q": 0}, FORMAT)
        second = c.complete(MESSAGES, {"q": 1}, FORMAT)
    assert first.ok and first.format_fallback and first.response_format == "text"
    assert second.ok and not second.format_fallback
    bodies = [r["body"] for r in server.requests]
    assert ["response_format" in b for b in bodies] == [True, False, False]
    saved = json.loads((tmp_path / "cache" / ENDPOINTS_FILE).read_text())
    assert saved == {f"{server.url} vlm-test": {"response_format": "unsupported"}}
    # a new client for the same endpoint reads it from the cache folder
    assert not client(server, tmp_path).supports_response_format()


def test_a_400_that_does_not_name_the_format_marks_the_endpoint_only_when_repeated(chat_server, tmp_path):
    """One 400 about something else (transient, or the prompt) is no proof that the endpoint lacks
    structured output: the request falls back, but only a second such fallback is remembered."""
    other = error(400, message="upstream busy, try again")
    script = [other, ok("walking_valid_1.json"), other, ok("walking_valid_2.json"), ok("walking_valid_3.json")]
    with chat_server(script) as server:
        c = client(server, tmp_path)
        first = c.complete(MESSAGES, {"q": 0}, FORMAT)
        assert first.ok and first.format_fallback and c.supports_response_format()
        assert not (tmp_path / "cache" / ENDPOINTS_FILE).exists()
        second = c.complete(MESSAGES, {"q": 1}, FORMAT)
        third = c.complete(MESSAGES, {"q": 2}, FORMAT)
    assert second.ok and second.format_fallback and third.ok and not third.format_fallback
    assert ["response_format" in r["body"] for r in server.requests] == [True, False, True, False, False]
    saved = json.loads((tmp_path / "cache" / ENDPOINTS_FILE).read_text())
    assert saved == {c.endpoint_id: {"response_format": "unsupported"}}


def test_cache_hit_costs_no_request_and_keys_differ_by_fields(chat_server, tmp_path):
    with chat_server([ok("walking_valid_1.json"), ok("walking_valid_2.json")]) as server:
        c = client(server, tmp_path)
        a = c.complete(MESSAGES, {"clip": "h", "query_index": 0})
        again = client(server, tmp_path).complete(MESSAGES, {"clip": "h", "query_index": 0})
        other = c.complete(MESSAGES, {"clip": "h", "query_index": 1})
    assert len(server.requests) == 2
    assert again.cached and again.content == a.content and again.attempts == 0
    assert not other.cached and other.content != a.content
    entries = list((tmp_path / "cache").rglob("*.json"))
    assert len(entries) == 2
    stored = json.loads(entries[0].read_text())
    assert stored["key"]["model"] == "vlm-test" and "content" in stored and "response" in stored


def test_the_cache_key_holds_the_endpoint(chat_server, tmp_path):
    """Two servers with the same model name do not share answers."""
    with chat_server([ok("walking_valid_1.json")]) as one, chat_server([ok("walking_valid_2.json")]) as two:
        first = client(one, tmp_path).complete(MESSAGES, {"q": 0})
        second = client(two, tmp_path).complete(MESSAGES, {"q": 0})
    assert not second.cached and len(two.requests) == 1 and second.content != first.content
    keys = [json.loads(p.read_text())["key"] for p in (tmp_path / "cache").rglob("*.json")]
    assert sorted(k["endpoint"] for k in keys) == sorted([one.url, two.url])


def test_a_200_with_an_unreadable_body_is_retried(chat_server):
    with chat_server([Reply(200, raw_body="<html>gateway</html>"), ok("walking_valid_1.json")]) as server:
        done = client(server).complete(MESSAGES, {})
    assert done.ok and "not JSON" in done.errors[0]


def test_a_deeply_nested_body_is_a_retried_failure(chat_server):
    deep = Reply(200, raw_body="[" * 100_000 + "]" * 100_000)
    with chat_server([deep, ok("walking_valid_1.json")]) as server:
        done = client(server).complete(MESSAGES, {})
    assert done.ok and done.attempts == 2 and "not JSON" in done.errors[0]


@pytest.mark.parametrize("damage", [b"\xff\xfe\x00garbage", b"[" * 100_000, b'{"format": 1}', b"{trunc"])
def test_a_damaged_cache_entry_is_a_miss_that_is_replaced_and_reported(chat_server, tmp_path, caplog, damage):
    with chat_server([ok("walking_valid_1.json"), ok("walking_valid_2.json")]) as server:
        client(server, tmp_path).complete(MESSAGES, {"q": 0})
        (entry,) = (tmp_path / "cache").rglob("*.json")
        entry.write_bytes(damage)
        with caplog.at_level(logging.WARNING):
            again = client(server, tmp_path).complete(MESSAGES, {"q": 0})
        third = client(server, tmp_path).complete(MESSAGES, {"q": 0})
    assert again.ok and not again.cached and len(server.requests) == 2
    assert str(entry) in again.cache_note and again.to_dict()["cache_note"] == again.cache_note
    assert again.cache_note in caplog.text
    assert third.cached and third.content == again.content and third.cache_note is None


@pytest.mark.parametrize("text", [b"\xff", b"[" * 100_000, b"[1, 2]", b'{"ID": "unsupported"}', b'{"ID": null}'])
def test_a_damaged_endpoints_file_is_ignored_then_rewritten(chat_server, tmp_path, text):
    with chat_server([ok("walking_valid_1.json")], reject_response_format=True) as server:
        c = client(server, tmp_path)
        (tmp_path / "cache").mkdir()
        (tmp_path / "cache" / ENDPOINTS_FILE).write_bytes(text.replace(b"ID", c.endpoint_id.encode()))
        assert c.supports_response_format()
        done = c.complete(MESSAGES, {}, FORMAT)
    assert done.ok and done.format_fallback
    saved = json.loads((tmp_path / "cache" / ENDPOINTS_FILE).read_text())
    assert saved[c.endpoint_id] == {"response_format": "unsupported"}


def test_key_goes_only_into_the_authorization_header(chat_server, monkeypatch, tmp_path):
    monkeypatch.setenv("VSMP_VLM_API_KEY", "sk-test-SECRET-123")
    echo = Reply(200, "echo: Bearer sk-test-SECRET-123")  # a server that echoes the key back
    with chat_server([echo]) as server:
        c = client(server, tmp_path)
        done = c.complete(MESSAGES, {})
        preview = c.preview(MESSAGES, FORMAT)
    assert server.requests[0]["headers"]["authorization"] == "Bearer sk-test-SECRET-123"
    assert done.content == "echo: Bearer ***"
    assert "SECRET" not in json.dumps(done.to_dict()) and "SECRET" not in repr(c)
    assert preview["headers"]["Authorization"] == "Bearer ***"
    assert preview["body"]["messages"][0]["content"][1]["image_url"]["url"].endswith("<6 bytes>")
    for path in (tmp_path / "cache").rglob("*"):
        if path.is_file():
            assert "SECRET" not in path.read_text()
    assert fixture_text("check_yes.json")  # fixtures readable
