"""Frame sampling: uniform indices, letterbox, padding, presets, lying containers, bad files."""

from __future__ import annotations

import contextlib
import json
import os
import threading

import numpy as np
import pytest
from extract_support import level, real_clip

pytest.importorskip("cv2")

from vsmp_imu.errors import ConfigError, InputFileError  # noqa: E402
from vsmp_imu.extract.frames import (  # noqa: E402
    PRESETS,
    FrameSampler,
    contact_sheet,
    letterbox,
    probe,
    uniform_indices,
)


def grey(frames: np.ndarray) -> list[int]:
    """Mean grey level of the centre of each sampled frame."""
    return [int(round(float(f[200:312, 200:312].mean()))) for f in frames]


def test_uniform_indices_cover_the_clip_and_pad_by_repetition():
    assert uniform_indices(40, 5).tolist() == [0, 10, 20, 29, 39]
    assert uniform_indices(40, 1).tolist() == [0]
    # fewer frames than asked: nearest-neighbour repeats, in order, first and last kept
    short = uniform_indices(3, 7).tolist()
    assert short == [0, 0, 1, 1, 1, 2, 2]
    with pytest.raises(ConfigError):
        uniform_indices(0, 4)


def test_sampled_frames_are_the_uniformly_spaced_source_frames(videos):
    s = FrameSampler(n_frames=5).sample(videos["counter"])
    assert s.frames.shape == (5, 512, 512, 3) and s.frames.dtype == np.uint8
    assert s.indices.tolist() == [0, 10, 20, 29, 39]
    # the pixels are those of the indexed source frames (MJPEG: +-3 grey levels)
    assert np.allclose(grey(s.frames), [level(i) for i in s.indices], atol=3)
    assert s.fps == pytest.approx(20.0)
    assert s.duration_s == pytest.approx(2.0)
    assert s.times_s.tolist() == pytest.approx([0.0, 0.5, 1.0, 1.45, 1.95])
    assert s.original_size == (64, 48)
    assert len(s.clip_hash) == 64 and s.warnings == []


def test_short_clip_is_padded_with_nearest_frames_and_warned(videos):
    s = FrameSampler(n_frames=8).sample(videos["short"])
    assert s.indices.tolist() == [0, 1, 1, 2, 2, 3, 3, 4]
    assert np.allclose(grey(s.frames), [level(i) for i in s.indices], atol=3)
    assert any("nearest-neighbour temporal padding" in w for w in s.warnings)


def test_letterbox_keeps_aspect_and_pads_black():
    frame = np.full((40, 160, 3), 255, np.uint8)  # 4:1
    out = letterbox(frame, 512)
    assert out.shape == (512, 512, 3)
    rows = np.flatnonzero(out[:, 256, 0] > 128)
    assert rows.min() == 192 and rows.max() == 319  # 128 rows of picture, centred
    assert out[:190].max() == 0 and out[322:].max() == 0
    tall = letterbox(np.full((100, 50, 3), 200, np.uint8), 64)
    cols = np.flatnonzero(tall[32, :, 0] > 100)
    assert cols.min() == 16 and cols.max() == 47


def test_wide_video_is_letterboxed(videos):
    s = FrameSampler(n_frames=2, size_px=128).sample(videos["wide"])
    assert s.frames.shape == (2, 128, 128, 3)
    assert s.frames[0, 64, 64, 0] > 200 and s.frames[0, 5, 64, 0] == 0


def test_presets_match_the_appendix_table():
    assert {k: (p.n_frames, p.min_duration_s, p.max_duration_s) for k, p in PRESETS.items()} == {
        "mm_fit": (24, 2.0, 12.0), "utd_mhad": (16, 1.0, 8.0), "mmact": (32, 2.0, 17.0),
        "pamap2": (32, 3.0, 15.0), "had_aw": (32, 3.0, 12.0)}
    assert FrameSampler(preset="UTD-MHAD").settings()["n_frames"] == 16
    assert FrameSampler(n_frames=5, preset="mmact").settings()["n_frames"] == 5
    with pytest.raises(ConfigError, match="unknown frame-sampling preset"):
        FrameSampler(preset="kinetics").settings()


def test_clip_outside_the_preset_duration_rule_is_reported_not_refused(videos):
    s = FrameSampler(preset="pamap2").sample(videos["counter"])  # 2 s clip, rule 3-15 s
    assert s.n_frames == 32 and s.preset == "pamap2"
    assert any("shorter than 3 s (pamap2)" in w for w in s.warnings)
    d = s.to_dict()
    assert d["warnings"] == s.warnings and d["indices"] == s.indices.tolist()
    json.dumps(d)


def test_a_container_that_lies_about_its_frame_count_is_sampled_over_decoded_frames(videos):
    info = probe(videos["truncated"])
    assert info.header_n_frames == 40 and info.n_frames < 40
    assert info.frame_count_source == "decoded"
    s = FrameSampler(n_frames=4).sample(videos["truncated"])
    n = info.n_frames
    assert s.indices.tolist() == uniform_indices(n, 4).tolist()
    assert np.allclose(grey(s.frames), [level(i) for i in s.indices], atol=3)
    assert any("container says 40 frames" in w for w in s.warnings)


@pytest.mark.parametrize("name", ["corrupt", "empty"])
def test_unreadable_files_raise_input_file_error_naming_the_file(videos, name):
    with pytest.raises(InputFileError) as err:
        FrameSampler(n_frames=4).sample(videos[name])
    assert str(videos[name]) in err.value.render()


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(InputFileError, match="not found"):
        FrameSampler().sample(tmp_path / "nope.mp4")
    with pytest.raises(InputFileError, match="directory"):
        FrameSampler().sample(tmp_path)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_is_refused_before_opencv_opens_it(tmp_path):
    """OpenCV would block for ever opening a FIFO that no one writes to (and ignore SIGTERM)."""
    fifo = tmp_path / "clip.avi"
    os.mkfifo(fifo)
    link = tmp_path / "link.avi"
    link.symlink_to(fifo)
    done = threading.Event()
    threading.Thread(target=_unblock_readers, args=(fifo, done), daemon=True).start()
    try:
        for path in (fifo, link):
            with pytest.raises(InputFileError, match="found a FIFO") as err:
                probe(path)
            assert str(path) in err.value.render()
    finally:
        done.set()


def _unblock_readers(fifo, done: threading.Event) -> None:
    """After 10 s, keep opening the FIFO's write end: a regression fails instead of hanging."""
    done.wait(10.0)
    while not done.wait(0.2):
        with contextlib.suppress(OSError):  # no reader waiting
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))


def test_content_hash_follows_the_bytes(videos, tmp_path):
    a = FrameSampler(n_frames=2).sample(videos["counter"]).clip_hash
    copy = tmp_path / "copy.avi"
    copy.write_bytes(videos["counter"].read_bytes())
    assert FrameSampler(n_frames=2).sample(copy).clip_hash == a
    assert FrameSampler(n_frames=2).sample(videos["short"]).clip_hash != a


def test_contact_sheet_grid():
    frames = np.stack([np.full((32, 32, 3), 20 * k, np.uint8) for k in range(5)])
    sheet = contact_sheet(frames, tile_px=16)
    assert sheet.shape == (32, 48, 3)  # 3 columns x 2 rows of 16 px
    assert sheet[8, 24, 0] == 20 and sheet[24, 8, 0] == 60
    assert sheet[24, 40, 0] == 32  # empty cell: background


@pytest.mark.parametrize("name,fps,n,size", [("vtest", 10.0, 795, (768, 576)),
                                             ("bikes", 25.0, 250, (640, 272)),
                                             ("carphone", 29.97, 120, (176, 144))])
def test_real_clips_decode_and_sample(name, fps, n, size):
    s = FrameSampler(n_frames=16).sample(real_clip(name))
    assert s.info.n_frames == n and s.info.frame_count_source == "header"
    assert s.fps == pytest.approx(fps, abs=0.01)
    assert s.original_size == size
    assert s.indices[0] == 0 and s.indices[-1] == n - 1
    assert s.frames.shape == (16, 512, 512, 3)
    # letterbox: wide clips have black bars above and below the picture
    if size[0] > size[1]:
        assert s.frames[:, :10].max() == 0


def test_cli_video_frames_and_info(cli, videos, tmp_path):
    code, out, err = cli("video", "frames", videos["counter"], "--n", "6", "-o", tmp_path / "f")
    assert code == 0, err
    pngs = sorted(p.name for p in (tmp_path / "f").glob("frame_*.png"))
    assert pngs == [f"frame_{k:03d}.png" for k in range(6)]
    import cv2

    sheet = cv2.imread(str(tmp_path / "f" / "contact_sheet.png"))
    assert sheet.shape == (2 * 192, 3 * 192, 3)
    meta = json.loads((tmp_path / "f" / "frames.json").read_text())
    assert meta["indices"] == uniform_indices(40, 6).tolist()
    code, out, err = cli("video", "frames", videos["counter"], "--n", "2", "-o", tmp_path / "f")
    assert code == 0, err  # a rerun into the folder: no frame of the earlier run is left over
    assert sorted(p.name for p in (tmp_path / "f").glob("frame_*.png")) == ["frame_000.png", "frame_001.png"]
    code, out, err = cli("video", "info", videos["truncated"])
    assert code == 0 and "decoded" in out
    code, out, err = cli("video", "frames", tmp_path / "missing.mp4", "-o", tmp_path / "g")
    assert code == 2 and "missing.mp4" in err
    code, out, err = cli("video", "frames", videos["counter"], "--preset", "nope", "-o", tmp_path / "g")
    assert code == 2 and "mm_fit" in err
