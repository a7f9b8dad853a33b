"""Helpers shared by the extract tests (a uniquely named module: `conftest` is ambiguous)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

# the same folder as VIDEO_DIR in tests/conftest.py: ../shared/data/videos next to the repository
VIDEO_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "videos"
REAL_CLIPS = {"vtest": "vtest.avi", "bikes": "bikes.mp4", "carphone": "carphone_pristine.mp4"}


def write_video(path: Path, frames: list[np.ndarray], fps: float, fourcc: str = "MJPG") -> Path:
    cv2 = pytest.importorskip("cv2")
    h, w = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*fourcc), fps, (w, h))
    assert writer.isOpened()
    for f in frames:
        writer.write(f)
    writer.release()
    return path


def level(i: int) -> int:
    """Grey level of frame i of the counter clip."""
    return 10 + 5 * i


def real_clip(name: str) -> Path:
    path = VIDEO_DIR / REAL_CLIPS[name]
    if not path.exists():
        pytest.skip(f"real clip {path} is not present (shared data folder missing)")
    return path
