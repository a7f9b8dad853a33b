"""The HTTP client under the VLM client (`client.VLMClient`), built on `httpx2` (the
`openai` package's own HTTP library, pinned with it).

- No redirects: a 3xx is returned as it is (a followed 302 would turn the POST
  into a GET without the frames).
- No compression: the request asks for `identity`, and a compressed answer is
  refused (its size is unknown until it is decoded).
- A bounded answer: a body over `MAX_RESPONSE_BYTES` is refused, from its
  Content-Length or while it is read, and so is a body still arriving at the
  request's deadline (`total_s` after it was sent, or the request's own read
  timeout when that is shorter: the last attempt of a query running out of time).
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import httpx2

# An SMP answer is a few kB and smp.repair parses at most 2 MB whole; 4 MiB leaves room for the
# response envelope and JSON escapes.
MAX_RESPONSE_BYTES = 4 * 2**20
_DEADLINE = "vsmp_imu.deadline"  # request extension: time.monotonic() by which the answer is read


class AnswerRefused(httpx2.ReadError):
    """An answer too large, or compressed."""


class AnswerTooSlow(httpx2.ReadTimeout):
    """An answer still arriving at the request's deadline."""


def http_client(total_s: float) -> httpx2.Client:
    """An httpx2 client whose requests follow no redirect and whose answers are bounded in
    size and in time (`total_s`, or a request's shorter timeout, from the request's start to
    the body's end)."""

    def start(request: httpx2.Request) -> None:
        read = (request.extensions.get("timeout") or {}).get("read")
        limit = total_s if read is None else min(total_s, read)
        request.extensions[_DEADLINE] = time.monotonic() + limit

    return httpx2.Client(timeout=total_s, follow_redirects=False, headers={"Accept-Encoding": "identity"},
                         event_hooks={"request": [start], "response": [_bound]})


def _bound(response: httpx2.Response) -> None:
    """Refuse a compressed or declared-too-large answer; bound the rest while it is read."""
    request = response.request
    encoding = response.headers.get("content-encoding", "identity").strip().lower()
    if encoding not in ("", "identity"):
        raise AnswerRefused(f"answer compressed ({encoding}) although the request asked for none",
                            request=request)
    declared = response.headers.get("content-length", "").strip()
    if declared.isdigit() and int(declared) > MAX_RESPONSE_BYTES:
        raise AnswerRefused(f"answer too large: Content-Length {declared} bytes, more than "
                            f"{MAX_RESPONSE_BYTES} (not read)", request=request)
    deadline = request.extensions.get(_DEADLINE, float("inf"))
    response.stream = _Bounded(response.stream, deadline, request)


class _Bounded(httpx2.SyncByteStream):
    """The body stream, cut off past MAX_RESPONSE_BYTES or past the deadline."""

    def __init__(self, inner: httpx2.SyncByteStream, deadline: float, request: httpx2.Request) -> None:
        self.inner, self.deadline, self.request = inner, deadline, request

    def __iter__(self) -> Iterator[bytes]:
        size = 0
        for chunk in self.inner:
            size += len(chunk)
            if size > MAX_RESPONSE_BYTES:
                raise AnswerRefused(f"answer too large: more than {MAX_RESPONSE_BYTES} bytes (cut off)",
                                    request=self.request)
            if time.monotonic() > self.deadline:
                raise AnswerTooSlow("the answer was still arriving at the deadline", request=self.request)
            yield chunk

    def close(self) -> None:
        self.inner.close()
