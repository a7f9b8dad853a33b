"""A local chat-completions server (127.0.0.1, ephemeral port) that replays recorded replies.

It speaks the OpenAI protocol as far as the client uses it: `POST
/v1/chat/completions` with a JSON body, answered by the full response
envelope (`tests/fixtures/vlm/completion_envelope.json`) carrying a recorded
message content, or by an error status with an OpenAI-style error body.
Each request takes the next reply of the script; every request is recorded
(method, body and headers) for the test to inspect. A reply may also be sent
slowly (`trickle_s`), without a Content-Length, or be a redirect; a GET (a
followed redirect) is recorded and answered with a valid SMP.
"""

from __future__ import annotations

import copy
import json
import threading
import time
from dataclasses import dataclass, field
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "vlm"
TRICKLE_BYTES = 64


def fixture_text(name: str) -> str:
    return (FIXTURES / name).read_text(encoding="utf-8")


@dataclass
class Reply:
    """One scripted answer."""

    status: int = 200
    content: str | None = None  # message content for a 200
    headers: dict[str, str] = field(default_factory=dict)
    delay_s: float = 0.0
    raw_body: str | bytes | None = None  # sent as is instead of the envelope
    trickle_s: float = 0.0  # > 0: the whole answer (headers too) in TRICKLE_BYTES pieces this far apart
    length: bool = True  # False: no Content-Length; the connection closes after the body


def ok(name: str, delay_s: float = 0.0) -> Reply:
    """A 200 carrying the recorded content of fixture `name`."""
    return Reply(200, fixture_text(name), delay_s=delay_s)


def redirect(status: int = 302, location: str = "/v1/elsewhere") -> Reply:
    return Reply(status, headers={"Location": location}, raw_body="")


def error(status: int, retry_after: str | None = None, message: str = "") -> Reply:
    headers = {"Retry-After": retry_after} if retry_after is not None else {}
    body = json.dumps({"error": {"message": message or f"status {status}", "type": "server_error",
                                 "param": None, "code": None}})
    return Reply(status, headers=headers, raw_body=body)


class ChatServer:
    """Replay `script` (a list of Reply) one request at a time; `default` once it runs out.

    reject_response_format: answer 400 to any request that carries a
    `response_format` (as servers without structured output do), without
    consuming the script.
    """

    def __init__(self, script: list[Reply], default: Reply | None = None,
                 reject_response_format: bool = False) -> None:
        self.script = list(script)
        self.default = default
        self.reject_response_format = reject_response_format
        self.requests: list[dict[str, Any]] = []
        self.lock = threading.Lock()
        self.envelope = json.loads(fixture_text("completion_envelope.json"))
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), self._handler())
        self.httpd.daemon_threads = True
        self.thread = threading.Thread(target=self.httpd.serve_forever, kwargs={"poll_interval": 0.02},
                                       daemon=True)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}/v1"

    def __enter__(self) -> ChatServer:
        self.thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.httpd.shutdown()
        self.httpd.server_close()

    def next_reply(self, body: dict[str, Any]) -> Reply:
        with self.lock:
            if self.reject_response_format and "response_format" in body:
                return Reply(400, raw_body=json.dumps({"error": {
                    "message": "response_format of type json_schema is not supported by this server",
                    "type": "invalid_request_error", "param": "response_format", "code": None}}))
            if self.script:
                return self.script.pop(0)
            if self.default is not None:
                return self.default
            return error(500, message="script exhausted")

    def answer(self, reply: Reply, body: dict[str, Any]) -> tuple[int, dict[str, str], bytes]:
        if reply.raw_body is not None:
            raw = reply.raw_body
            return reply.status, reply.headers, raw if isinstance(raw, bytes) else raw.encode()
        env = copy.deepcopy(self.envelope)
        env["model"] = body.get("model", env["model"])
        env["id"] = f"chatcmpl-test{len(self.requests):04d}"
        env["choices"][0]["message"]["content"] = reply.content
        return reply.status, reply.headers, json.dumps(env).encode()

    def _handler(self) -> type[BaseHTTPRequestHandler]:
        server = self

        class Handler(BaseHTTPRequestHandler):
            protocol_version = "HTTP/1.1"

            def log_message(self, *args: Any) -> None:  # keep test output quiet
                pass

            def _record(self) -> dict[str, Any]:
                length = int(self.headers.get("Content-Length", "0"))
                raw = self.rfile.read(length)
                try:
                    body = json.loads(raw) if raw else {}
                except json.JSONDecodeError:
                    body = {}
                with server.lock:
                    server.requests.append({"method": self.command, "path": self.path, "body": body,
                                            "headers": {k.lower(): v for k, v in self.headers.items()}})
                return body

            def do_GET(self) -> None:  # noqa: N802 (http.server naming)
                self._record()
                self._send(ok("walking_valid_1.json"), *server.answer(ok("walking_valid_1.json"), {}))

            def do_POST(self) -> None:  # noqa: N802 (http.server naming)
                body = self._record()
                if self.path.rstrip("/") != "/v1/chat/completions":
                    self._send(Reply(), 404, {}, b'{"error": {"message": "not found"}}')
                    return
                reply = server.next_reply(body)
                if reply.delay_s:
                    time.sleep(reply.delay_s)
                self._send(reply, *server.answer(reply, body))

            def _send(self, reply: Reply, status: int, headers: dict[str, str], payload: bytes) -> None:
                head = {"Content-Type": "application/json", **headers}
                if reply.length:
                    head["Content-Length"] = str(len(payload))
                else:
                    head["Connection"] = "close"
                    self.close_connection = True
                lines = [f"HTTP/1.1 {status} {self.responses.get(status, ('',))[0]}"]
                data = ("\r\n".join(lines + [f"{k}: {v}" for k, v in head.items()]) + "\r\n\r\n").encode()
                data += payload
                step = TRICKLE_BYTES if reply.trickle_s else len(data) or 1
                try:
                    for i in range(0, len(data), step):
                        self.wfile.write(data[i:i + step])
                        self.wfile.flush()
                        if reply.trickle_s:
                            time.sleep(reply.trickle_s)
                except (BrokenPipeError, ConnectionResetError):
                    pass  # the client gave up (timeout tests)

        return Handler
