"""A chat-completions client for any OpenAI-compatible endpoint (hosted, vLLM, Ollama, ...).

Built on the `openai` package with its own retries switched off
(`max_retries=0`): this module retries, so that every attempt, wait and
failure is counted in the extraction report.

- Limits: `timeout_s` bounds a whole request, however slowly its answer
  arrives; an answer over `http.MAX_RESPONSE_BYTES` or compressed is refused;
  a redirect is not followed (see `extract.http`).
- Retries: HTTP 408/409/425/429 and 5xx, timeouts, connection errors, refused
  answers and unreadable response bodies are retried with exponential backoff
  (`base_delay_s * 2**k`, capped at `max_delay_s`) and jitter (x 0.5..1);
  a `Retry-After` (or `retry-after-ms`) header, in seconds or an HTTP date, is
  honoured (the wait is at least that long; a header that is neither is
  ignored). Waits are bounded: one wait by `timeout_s` and
  `max_retry_after_s`, and a whole query, attempts and waits together, by
  `(1 + max_retries) * timeout_s` (`query_budget_s`); a server that asks for
  a longer wait than that allows fails the query at once, naming the endpoint
  and what it asked. A 3xx fails the query at once (it names where it
  points). Other client errors (401, 403, 404, ...) are configuration
  mistakes: `ServiceError` at once.
- Structured output: the JSON-schema `response_format` is sent unless the
  endpoint is known not to support it. A 400/422 answer to a request that
  carried it is retried at once without it; when that succeeds and the error
  named the format (or it is the second such fallback of this client), the
  endpoint (base URL + model) is remembered as text-only, in memory and in the
  cache folder (`endpoints.json`).
- Cache: successful responses are stored under the request's key fields, the
  endpoint (base URL) and the model (`cache.ResponseCache`); a hit costs no
  request. With an `accept` check, only usable answers are stored, and a
  cached answer it refuses is asked again.
- The API key comes from the constructor or the environment
  (`VSMP_VLM_API_KEY`, else `OPENAI_API_KEY`). It is sent in the
  Authorization header only: never cached, logged or put in a message, and
  every stored text is scrubbed of it.
"""

from __future__ import annotations

import datetime
import email.utils
import json
import logging
import math
import os
import random
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

from vsmp_imu.errors import ConfigError, DependencyError, ServiceError
from vsmp_imu.extract.cache import ResponseCache

log = logging.getLogger(__name__)

API_KEY_ENV_VARS = ("VSMP_VLM_API_KEY", "OPENAI_API_KEY")
NO_KEY_PLACEHOLDER = "no-key"  # sent when no key is set (local servers ignore it)
RETRY_STATUSES = frozenset({408, 409, 425, 429})
FORMAT_REJECT_STATUSES = frozenset({400, 422})
FORMAT_ERROR_WORDS = ("response_format", "response format", "json_schema", "structured output")
FORMAT_FALLBACKS_TO_REMEMBER = 2  # fallbacks after errors that do not name the format
ENDPOINTS_FILE = "endpoints.json"
MAX_ERROR_CHARS = 300
MAX_TIMEOUT_S = 3600.0  # the longest a request may take (--timeout-s)
MAX_RETRIES = 10  # retries per query at most (--max-retries)
Accept = Callable[[str], str | None]  # None: a usable answer; else why it is not


def api_key_from_env(environ: Mapping[str, str] | None = None) -> str | None:
    """The key from VSMP_VLM_API_KEY, else OPENAI_API_KEY; None when neither is set."""
    env = os.environ if environ is None else environ
    for name in API_KEY_ENV_VARS:
        value = env.get(name, "").strip()
        if value:
            return check_api_key(value, name)
    return None


def check_api_key(key: str, source: str = "api_key") -> str:
    """The key, when an HTTP header can carry it: printable ASCII without spaces. The message
    names where the key came from and never shows it."""
    bad = [i for i, ch in enumerate(key) if not "!" <= ch <= "~"]
    if bad:
        raise ConfigError(f"the API key has a character an HTTP header cannot carry (position {bad[0] + 1} "
                          f"of {len(key)}: a letter with an accent, a space, a control character or a "
                          "typographic quote pasted with it)", field=source,
                          allowed="printable ASCII characters only")
    return key


def check_timeout_s(value: float) -> float:
    """`value` when it is a finite number of seconds in (0, MAX_TIMEOUT_S]."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not (
            math.isfinite(value) and 0 < value <= MAX_TIMEOUT_S):
        raise ConfigError(f"'{value}' is not a time limit for a request", field="timeout_s",
                          allowed=f"a number of seconds > 0, at most {MAX_TIMEOUT_S:g}")
    return float(value)


def check_max_retries(value: int) -> int:
    """`value` when it is a whole number in 0..MAX_RETRIES."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_RETRIES:
        raise ConfigError(f"'{value}' is not a number of retries", field="max_retries",
                          allowed=f"a whole number from 0 to {MAX_RETRIES}")
    return value


def check_base_url(url: str) -> str:
    """`url` when it can name an endpoint: http:// or https:// with a host, no space or control
    character (anything else failed only at the first request, after its retries)."""
    try:
        parts = urlsplit(url)
        parts.port  # noqa: B018 - a port that is not a number raises ValueError
    except (TypeError, ValueError):
        parts = None
    if parts is None or parts.scheme not in ("http", "https") or not parts.hostname or any(
            ch.isspace() or not ch.isprintable() for ch in url):
        raise ConfigError(f"'{url}' is not the URL of an endpoint", field="base_url",
                          allowed="a URL with http:// or https:// and a host, e.g. http://localhost:8000/v1")
    return url


def scrub(text: str, secret: str | None) -> str:
    """`text` with every occurrence of `secret` replaced by ***."""
    if not secret or not text:
        return text
    return text.replace(secret, "***")


def _scrub_obj(obj: Any, secret: str | None) -> Any:
    if not secret:
        return obj
    if isinstance(obj, str):
        return scrub(obj, secret)
    if isinstance(obj, dict):
        return {scrub(str(k), secret): _scrub_obj(v, secret) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_scrub_obj(v, secret) for v in obj]
    return obj


def retry_after_s(headers: Mapping[str, str] | None, now: float | None = None) -> float | None:
    """Seconds asked for by `retry-after-ms` or `Retry-After` (seconds or an HTTP date; a date
    already past asks for 0); None when neither header holds a time (absent, or junk)."""
    return retry_after(headers, now)[0]


def retry_after(headers: Mapping[str, str] | None, now: float | None = None) -> tuple[float | None, str | None]:
    """(seconds asked for, or None; the header as sent, or None when there is none): see
    `retry_after_s`. A negative, infinite or unreadable value asks for nothing."""
    lower = {str(k).lower(): str(v).strip() for k, v in (headers or {}).items()}
    sent = [f"{name}: {_short(lower[name])}" for name in ("retry-after-ms", "retry-after") if name in lower]
    if "retry-after-ms" in lower:
        ms = _seconds(lower["retry-after-ms"])
        if ms is not None:
            return ms / 1000.0, sent[0]
    value = lower.get("retry-after")
    if value is None:
        return None, "; ".join(sent) or None
    seconds = _seconds(value)
    if seconds is None:
        try:
            when = email.utils.parsedate_to_datetime(value)
            if when.tzinfo is None:  # "-0000" or no zone: HTTP dates are in GMT
                when = when.replace(tzinfo=datetime.UTC)
            seconds = max(0.0, when.timestamp() - (time.time() if now is None else now))
        except (TypeError, ValueError, OverflowError, IndexError):
            seconds = None
    return seconds, "; ".join(sent)


def _seconds(text: str) -> float | None:
    """A finite number >= 0 of seconds (or ms) in `text`; None otherwise."""
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) and value >= 0 else None


def message_text(body: dict[str, Any]) -> str | None:
    """`choices[0].message.content` as text (content parts joined); None if absent."""
    choices = body.get("choices")
    if not isinstance(choices, list) or not choices or not isinstance(choices[0], dict):
        return None
    message = choices[0].get("message")
    if not isinstance(message, dict):
        return None
    content = message.get("content")
    if isinstance(content, list):
        parts = [p.get("text", "") for p in content if isinstance(p, dict)]
        content = "".join(str(p) for p in parts)
    if content is None:
        refusal = message.get("refusal")
        return "" if refusal is None else str(refusal)
    return str(content)


@dataclass
class Completion:
    """The outcome of one logical request (after retries, or from the cache)."""

    content: str | None
    response: dict[str, Any] | None = None  # the full response body
    cached: bool = False
    attempts: int = 0
    retries: int = 0
    response_format: str = "text"  # "json_schema" or "text": what the answered request carried
    format_fallback: bool = False
    waits_s: list[float] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)  # one line per failed attempt
    error: str | None = None  # set when every attempt failed
    cache_note: str | None = None  # why a cache entry was not used or the answer not stored

    @property
    def ok(self) -> bool:
        return self.error is None and self.content is not None

    def to_dict(self) -> dict[str, Any]:
        return {"content": self.content, "response": self.response, "cached": self.cached,
                "attempts": self.attempts, "retries": self.retries,
                "response_format": self.response_format, "format_fallback": self.format_fallback,
                "waits_s": [round(w, 3) for w in self.waits_s], "errors": list(self.errors),
                "error": self.error, "cache_note": self.cache_note}


class _Failed(Exception):
    """A failed attempt: retried (after `wait_hint_s` at least) unless `retry` is False;
    `asked`: the Retry-After header as sent."""

    def __init__(self, message: str, wait_hint_s: float | None = None, retry: bool = True,
                 asked: str | None = None) -> None:
        super().__init__(message)
        self.wait_hint_s = wait_hint_s
        self.retry = retry
        self.asked = asked


class VLMClient:
    """One OpenAI-compatible chat-completions endpoint and model.

    base_url: e.g. `https://api.openai.com/v1`, `http://localhost:8000/v1`
        (vLLM), `http://localhost:11434/v1` (Ollama).
    model: the model name the endpoint serves.
    api_key: None reads the environment (see module docs).
    timeout_s: the most one request may take, whole answer included (0 < t <= 3600);
    max_retries: retries after the first attempt (0..10); a query, attempts and waits
        together, takes at most `query_budget_s` = (1 + max_retries) * timeout_s.
    base_delay_s, max_delay_s: backoff settings; max_retry_after_s: the longest one wait may
        take (and at most timeout_s), whatever a server's Retry-After asks.
    cache_dir: response cache folder (None: no cache).
    use_response_format: send the JSON-schema response_format when the
        endpoint supports it.
    temperature, max_tokens: sent only when set.
    sleep: the wait function (tests pass a recorder); clock: the monotonic clock the query's
        time is measured on (tests pass one that the recorder advances); seed: jitter seed.
    """

    def __init__(self, base_url: str, model: str, api_key: str | None = None,
                 timeout_s: float = 120.0, max_retries: int = 4, base_delay_s: float = 1.0,
                 max_delay_s: float = 30.0, max_retry_after_s: float = 120.0,
                 cache_dir: str | os.PathLike[str] | None = None, use_response_format: bool = True,
                 temperature: float | None = None, max_tokens: int | None = None,
                 sleep: Callable[[float], None] | None = None, seed: int = 0,
                 clock: Callable[[], float] | None = None) -> None:
        self.base_url = check_base_url(base_url)
        self.model = model
        self.api_key = check_api_key(api_key) if api_key else api_key
        if not api_key:
            api_key_from_env()  # a key the request could not carry fails now, before any work
        self.timeout_s = check_timeout_s(timeout_s)
        self.max_retries = check_max_retries(max_retries)
        self.base_delay_s = base_delay_s
        self.max_delay_s = max_delay_s
        self.max_retry_after_s = max_retry_after_s
        self.cache_dir = cache_dir
        self.use_response_format = use_response_format
        self.temperature = temperature
        self.max_tokens = max_tokens
        self.sleep = sleep
        self.clock = clock
        self.seed = seed
        self._openai: Any = None
        self._rng = random.Random(seed)
        self._text_only: set[str] = set()
        self._fallbacks = 0

    def __repr__(self) -> str:
        return f"VLMClient(base_url={self.base_url!r}, model={self.model!r})"

    # -- settings -------------------------------------------------------------
    @property
    def cache(self) -> ResponseCache:
        return ResponseCache(self.cache_dir)

    @property
    def endpoint_id(self) -> str:
        return f"{self.base_url.rstrip('/')} {self.model}"

    @property
    def query_budget_s(self) -> float:
        """The longest one query may take, attempts and waits together."""
        return (1 + self.max_retries) * self.timeout_s

    @property
    def max_wait_s(self) -> float:
        """The longest one wait before a retry may take."""
        return min(self.timeout_s, self.max_retry_after_s)

    @property
    def url(self) -> str:
        return self.base_url.rstrip("/") + "/chat/completions"

    def _key(self) -> str | None:
        return self.api_key if self.api_key else api_key_from_env()

    def supports_response_format(self) -> bool:
        """False once the endpoint rejected it (this run or a cached earlier one)."""
        if not self.use_response_format or self.endpoint_id in self._text_only:
            return False
        known = self.cache.read_json(ENDPOINTS_FILE).get(self.endpoint_id)
        return not (isinstance(known, dict) and known.get("response_format") == "unsupported")

    def _fell_back(self, named_format: bool) -> None:
        """A request worked as plain text after a 400/422: remember the endpoint as text-only
        when the error named the format, or after repeated fallbacks (a lone other 400 may be
        transient)."""
        self._fallbacks += 1
        if named_format or self._fallbacks >= FORMAT_FALLBACKS_TO_REMEMBER:
            self._remember_text_only()

    def _remember_text_only(self) -> None:
        self._text_only.add(self.endpoint_id)
        data = self.cache.read_json(ENDPOINTS_FILE)
        data[self.endpoint_id] = {"response_format": "unsupported"}
        self.cache.write_json(ENDPOINTS_FILE, data)

    def _client(self) -> Any:
        if self._openai is None:
            try:
                from openai import OpenAI

                from vsmp_imu.extract.http import http_client
            except ImportError as exc:  # pragma: no cover - a pinned dependency
                raise DependencyError("the VLM client needs the `openai` package "
                                      "(pip install -e .)") from exc
            self._openai = OpenAI(base_url=self.base_url, api_key=self._key() or NO_KEY_PLACEHOLDER,
                                  timeout=self.timeout_s, max_retries=0,
                                  http_client=http_client(self.timeout_s))
        return self._openai

    def _body(self, messages: list[dict[str, Any]], response_format: dict[str, Any] | None) -> dict[str, Any]:
        body: dict[str, Any] = {"model": self.model, "messages": messages}
        if response_format is not None:
            body["response_format"] = response_format
        if self.temperature is not None:
            body["temperature"] = self.temperature
        if self.max_tokens is not None:
            body["max_tokens"] = self.max_tokens
        return body

    # -- the request ------------------------------------------------------------
    def preview(self, messages: list[dict[str, Any]],
                response_format: dict[str, Any] | None = None) -> dict[str, Any]:
        """The request that `complete` would send (key redacted, images abbreviated)."""
        fmt = response_format if response_format is not None and self.supports_response_format() else None
        key = self._key()
        auth = "Bearer ***" if key else (f"Bearer {NO_KEY_PLACEHOLDER} (no key in "
                                         + " or ".join(API_KEY_ENV_VARS) + ")")
        headers = {"Content-Type": "application/json", "Authorization": auth}
        return {"method": "POST", "url": self.url, "headers": headers,
                "body": abbreviate_images(self._body(messages, fmt))}

    def complete(self, messages: list[dict[str, Any]], key_fields: dict[str, Any],
                 response_format: dict[str, Any] | None = None,
                 accept: Accept | None = None) -> Completion:
        """One logical request: cache, then attempts with retries. Never raises for
        retryable failures (the Completion carries the error); raises ServiceError for
        configuration errors (401, 403, 404, a 400 that is not about response_format).

        accept: None for an answer the caller can use, else why not. An unusable answer
        is returned but not cached, and a cached one is asked again."""
        fields = {"endpoint": self.base_url.rstrip("/"), "model": self.model, **key_fields}
        hit, problem = self._cached(fields, accept)
        if hit is not None:
            return Completion(hit["content"], hit.get("response"), cached=True, attempts=0,
                              response_format=hit.get("response_format", "text"))
        fmt = response_format if response_format is not None and self.supports_response_format() else None
        out = Completion(None, response_format="json_schema" if fmt is not None else "text")
        if problem is not None:
            out.cache_note = f"cache entry not used, asked again: {problem}"
            log.warning("VLM %s", out.cache_note)
        body = self._attempts(messages, fmt, out)
        if body is not None:
            self._keep(fields, body, out, accept)
        return out

    def _attempts(self, messages: list[dict[str, Any]], fmt: dict[str, Any] | None,
                  out: Completion) -> dict[str, Any] | None:
        """Send until an answer comes (its body), or until the retries or the query's time
        (`query_budget_s`) run out (None; out.error)."""
        secret = self._key()
        named_format = False
        clock = self.clock or time.monotonic
        deadline = clock() + self.query_budget_s
        while True:
            left = deadline - clock()
            if left <= 0:  # a format fallback after an attempt that used the last of the time
                out.error = (f"gave up after {out.attempts} attempt(s): the query's "
                             f"{self.query_budget_s:g} s ({self._budget_text()}) are used up")
                return None
            out.attempts += 1
            try:
                body = self._send(messages, fmt, min(self.timeout_s, left))
            except _FormatRejected as exc:
                named_format, fmt = exc.named_format, None
                out.errors.append(scrub(str(exc), secret))
                out.format_fallback, out.response_format = True, "text"
                continue
            except _Failed as exc:
                out.errors.append(scrub(str(exc), secret))
                if out.retries >= self.max_retries or not exc.retry:
                    out.error = f"gave up after {out.attempts} attempt(s): {out.errors[-1]}"
                    return None
                stop = self._wait(out, exc, deadline - clock())
                if stop is not None:
                    out.error = scrub(f"gave up after {out.attempts} attempt(s): {out.errors[-1]}; {stop}", secret)
                    return None
                continue
            if out.format_fallback:
                self._fell_back(named_format)
            return body

    def _wait(self, out: Completion, failed: _Failed, left_s: float) -> str | None:
        """Wait before the next retry; or, when the wait the server asks for (or the backoff)
        does not fit, why not (the query stops without waiting)."""
        hint_s = failed.wait_hint_s
        if hint_s is not None and hint_s > min(self.max_wait_s, left_s):
            if hint_s > self.max_wait_s:
                room = (f"more than the {self.max_wait_s:g} s a wait may take (--timeout-s "
                        f"{self.timeout_s:g}, at most {self.max_retry_after_s:g} s)")
            else:
                room = f"more than the {max(left_s, 0.0):.3g} s left of the query's {self._budget_text()}"
            return (f"the endpoint {self.endpoint_id} asked to wait {hint_s:g} s before a retry "
                    f"({failed.asked}), {room}; not retried")
        wait = min(self._backoff(out.retries, hint_s), self.max_wait_s)
        if wait >= left_s:
            return (f"no time left for a retry: the next would wait {wait:.3g} s, and "
                    f"{max(left_s, 0.0):.3g} s are left of the query's {self._budget_text()}")
        out.waits_s.append(wait)
        out.retries += 1
        log.info("VLM request failed (%s); retry %d of %d in %.2f s",
                 out.errors[-1], out.retries, self.max_retries, wait)
        (self.sleep or time.sleep)(wait)
        return None

    def _budget_text(self) -> str:
        return (f"{self.query_budget_s:g} s ((1 + --max-retries {self.max_retries}) x "
                f"--timeout-s {self.timeout_s:g})")

    def _keep(self, fields: dict[str, Any], body: dict[str, Any], out: Completion,
              accept: Accept | None) -> None:
        """Fill `out` from the answer's body; cache it unless `accept` finds it unusable."""
        secret = self._key()
        out.response = _scrub_obj(body, secret)
        out.content = scrub(message_text(body) or "", secret)
        unusable = accept(out.content) if accept is not None else None
        if unusable is None:
            self.cache.put(fields, {"content": out.content, "response": out.response,
                                    "response_format": out.response_format})
        else:
            out.cache_note = "; ".join(filter(None, [out.cache_note, f"not cached: {unusable}"]))

    def _cached(self, fields: dict[str, Any], accept: Accept | None) -> tuple[dict[str, Any] | None, str | None]:
        """(the usable cache entry, None), or (None, why an existing entry is not used)."""
        hit, problem = self.cache.lookup(fields)
        if hit is not None and not isinstance(hit.get("content"), str):
            return None, "the cached entry holds no answer text"
        unusable = accept(hit["content"]) if hit is not None and accept is not None else None
        if unusable is not None:
            return None, f"the cached answer is unusable ({unusable})"
        return hit, problem

    def _backoff(self, retry: int, hint_s: float | None) -> float:
        delay = min(self.max_delay_s, self.base_delay_s * (2.0 ** retry))
        delay *= 0.5 + 0.5 * self._rng.random()
        return delay if hint_s is None else max(delay, hint_s)

    def _send(self, messages: list[dict[str, Any]], fmt: dict[str, Any] | None,
              limit_s: float | None = None) -> dict[str, Any]:
        """One attempt, given `limit_s` (timeout_s, or less when the query's time runs out):
        the response body, or _Failed / _FormatRejected / ServiceError."""
        limit = self.timeout_s if limit_s is None else min(limit_s, self.timeout_s)
        client = self._client()
        text = self._in_time(lambda: self._post(client, messages, fmt, limit), limit)
        try:
            body_json = json.loads(text)
        except (json.JSONDecodeError, RecursionError) as exc:  # RecursionError: nested too deeply
            raise _Failed(f"response body is not JSON: {_short(text)}") from exc
        if not isinstance(body_json, dict) or message_text(body_json) is None:
            raise _Failed(f"response has no choices[0].message: {_short(text)}")
        return body_json

    def _in_time(self, call: Callable[[], str], limit_s: float | None = None) -> str:
        """call() in a worker thread, given up after limit_s (timeout_s) however slowly the answer
        arrives (a blocked read is not interrupted: the worker ends on its own, see extract.http)."""
        limit = self.timeout_s if limit_s is None else limit_s
        box: dict[str, Any] = {}

        def run() -> None:
            try:
                box["text"] = call()
            except BaseException as exc:  # noqa: BLE001 - handed to the caller
                box["error"] = exc

        worker = threading.Thread(target=run, name="vlm-request", daemon=True)
        worker.start()
        worker.join(limit)
        if worker.is_alive():
            self._openai = None  # its connection is still busy: the next attempt opens another
            raise _Failed(f"timeout: no complete answer within {_limit_text(limit, self.timeout_s)}")
        if "error" in box:
            raise box["error"]
        return box["text"]

    def _post(self, client: Any, messages: list[dict[str, Any]], fmt: dict[str, Any] | None,
              limit_s: float | None = None) -> str:
        """The request through `openai`, answered within limit_s (timeout_s); the body text of
        a 2xx answer."""
        import openai

        from vsmp_imu.extract.http import AnswerRefused, AnswerTooSlow

        limit = self.timeout_s if limit_s is None else limit_s
        body = self._body(messages, fmt)
        kwargs = {k: v for k, v in body.items() if k not in ("model", "messages")}
        if limit < self.timeout_s:
            kwargs["timeout"] = limit  # the request's deadline in extract.http too
        try:
            raw = client.chat.completions.with_raw_response.create(
                model=body["model"], messages=body["messages"], **kwargs)
            return raw.text
        except openai.APITimeoutError as exc:
            slow = isinstance(exc.__cause__, AnswerTooSlow)
            within = _limit_text(limit, self.timeout_s)
            raise _Failed(f"timeout: the answer was still arriving after {within}" if slow
                          else f"timeout after {within}") from exc
        except openai.APIConnectionError as exc:
            if isinstance(exc.__cause__, AnswerRefused):
                raise _Failed(str(exc.__cause__)) from exc
            raise _Failed(f"connection error ({type(exc.__cause__ or exc).__name__})") from exc
        except openai.APIStatusError as exc:
            error = self._status_error(exc, fmt)
            raise error from (None if isinstance(error, ServiceError) else exc)

    def _status_error(self, exc: Any, fmt: dict[str, Any] | None) -> Exception:
        """The exception for an HTTP error status (`exc`: openai.APIStatusError)."""
        status = exc.status_code
        detail = _short(exc.response.text if exc.response is not None else str(exc))
        headers = dict(exc.response.headers) if exc.response is not None else {}
        if 300 <= status < 400:
            where = headers.get("location", "no Location given")
            return _Failed(f"HTTP {status}: the endpoint redirects to {where} (not followed, so that a POST "
                           "never becomes a GET; check --vlm-base-url)", retry=False)
        if fmt is not None and status in FORMAT_REJECT_STATUSES:
            named = any(word in detail.lower() for word in FORMAT_ERROR_WORDS)
            return _FormatRejected(f"HTTP {status} with response_format ({detail}); "
                                   "retrying as plain text", named)
        if status in RETRY_STATUSES or status >= 500:
            hint, sent = retry_after(headers)
            extra = (f", Retry-After {hint:g} s" if hint is not None
                     else f" ({sent}: not a time, ignored)" if sent else "")
            return _Failed(f"HTTP {status}{extra}: {detail}", hint, asked=sent)
        return ServiceError(f"the endpoint answered HTTP {status}: {scrub(detail, self._key())}"
                            + _status_hint(status), allowed="check --vlm-base-url, --vlm-model and the key in "
                            + " or ".join(API_KEY_ENV_VARS))


class _FormatRejected(Exception):
    def __init__(self, message: str, named_format: bool) -> None:
        super().__init__(message)
        self.named_format = named_format  # the error names the response format


def _limit_text(limit_s: float, timeout_s: float) -> str:
    """'120 s', or '3.5 s (what was left of the query's time)' for a shortened attempt."""
    if limit_s >= timeout_s:
        return f"{timeout_s:g} s"
    return f"{limit_s:.3g} s (what was left of the query's time)"


def _short(text: str) -> str:
    text = " ".join(str(text).split())
    return text if len(text) <= MAX_ERROR_CHARS else text[:MAX_ERROR_CHARS] + "..."


def _status_hint(status: int) -> str:
    return {401: " (the key was refused)", 403: " (the key may not use this model)",
            404: " (wrong base URL or unknown model)"}.get(status, "")


def abbreviate_images(obj: Any) -> Any:
    """A copy with every `data:` URL shortened to its media type and size."""
    if isinstance(obj, dict):
        return {k: abbreviate_images(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [abbreviate_images(v) for v in obj]
    if isinstance(obj, str) and obj.startswith("data:") and ";base64," in obj:
        head, data = obj.split(";base64,", 1)
        return f"{head};base64,<{len(data) * 3 // 4} bytes>"
    return obj
