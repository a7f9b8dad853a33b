"""Fixtures of the extract room: small videos written with OpenCV, the real clips, the VLM server."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from extract_support import level, write_video  # noqa: E402
from vlm_server import ChatServer  # noqa: E402


@pytest.fixture(scope="session")
def videos(tmp_path_factory) -> dict[str, Path]:
    """counter.avi: 40 frames of 64x48 at 20 fps, frame i uniformly grey `level(i)`;
    short.avi: 5 such frames; wide.avi: 160x40 white; truncated.avi: the counter clip cut to
    60 % (its header still says 40 frames); corrupt.mp4: random bytes; empty.avi: 0 bytes."""
    root = tmp_path_factory.mktemp("videos")
    counter = [np.full((48, 64, 3), level(i), np.uint8) for i in range(40)]
    out = {
        "counter": write_video(root / "counter.avi", counter, 20.0),
        "short": write_video(root / "short.avi", counter[:5], 10.0),
        "wide": write_video(root / "wide.avi", [np.full((40, 160, 3), 255, np.uint8)] * 6, 10.0),
    }
    data = out["counter"].read_bytes()
    (root / "truncated.avi").write_bytes(data[: int(len(data) * 0.6)])
    out["truncated"] = root / "truncated.avi"
    rng = np.random.default_rng(0)
    (root / "corrupt.mp4").write_bytes(rng.integers(0, 256, 4096, dtype=np.uint8).tobytes())
    out["corrupt"] = root / "corrupt.mp4"
    (root / "empty.avi").write_bytes(b"")
    out["empty"] = root / "empty.avi"
    return out


@pytest.fixture
def chat_server():
    """Factory: `with chat_server(script, ...) as server:` starts a replay server."""
    started: list[ChatServer] = []

    def make(script, **kwargs) -> ChatServer:
        server = ChatServer(script, **kwargs)
        started.append(server)
        return server

    yield make
    for server in started:
        if server.thread.is_alive():
            server.__exit__(None, None, None)


@pytest.fixture(autouse=True)
def _no_ambient_key(monkeypatch):
    """Tests set the key they need; an ambient key must never reach the local server."""
    monkeypatch.delenv("VSMP_VLM_API_KEY", raising=False)
    monkeypatch.delenv("OPENAI_API_KEY", raising=False)
