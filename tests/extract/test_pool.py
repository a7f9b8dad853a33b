"""Source clip pools: the VLM check through the replay server, the pose check, the manifest."""

from __future__ import annotations

import json
import shutil

import pytest
from vlm_server import Reply, error, ok

from vsmp_imu.errors import InputFileError
from vsmp_imu.extract.calibrate import motion_track
from vsmp_imu.extract.client import VLMClient
from vsmp_imu.extract.frames import FrameSampler
from vsmp_imu.extract.pool import (
    MANIFEST_FORMAT,
    PoseClipChecker,
    SourcePoolFilter,
    VLMClipChecker,
    parse_check_answer,
    pool_clips,
    retained_clips,
)
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.library import ActivityLibrary

pytest.importorskip("cv2")


@pytest.fixture
def pool(tmp_path, videos):
    root = tmp_path / "POOL"
    for rel in ("walking/a.avi", "walking/b.avi", "walking/c.avi", "jumping_jacks/d.avi"):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        source = {"walking/b.avi": "short", "walking/c.avi": "wide"}.get(rel, "counter")
        shutil.copy(videos[source], root / rel)  # a and d share bytes, under different activities
    shutil.copy(videos["corrupt"], root / "jumping_jacks" / "e.mp4")
    (root / "walking" / "notes.txt").write_text("not a clip")
    return root


def test_parse_check_answer():
    assert parse_check_answer('{"answer": "yes", "confidence": 0.8, "reason": "r"}') == (True, 0.8, "r")
    assert parse_check_answer('```json\n{"answer": "No", "confidence": 90}\n```')[:2] == (False, 0.9)
    assert parse_check_answer('{"answer": true, "confidence": "0.7"}')[:2] == (True, 0.7)
    assert parse_check_answer("yes!")[0] is None
    assert parse_check_answer('{"answer": "maybe", "confidence": 0.5}')[0] is None
    # a confidence that is neither a fraction nor a percentage is no confidence (it was clamped to 1)
    for text in ('{"answer": "yes", "confidence": 150}', '{"answer": "yes", "confidence": -0.2}'):
        answer, conf, reason = parse_check_answer(text)
        assert (answer, conf) == (True, 0.0) and "neither a fraction 0..1 nor a percentage" in reason
    assert parse_check_answer('{"answer": "yes", "confidence": 100}')[1] == 1.0


def test_pool_listing(pool, tmp_path):
    clips = [(a, p.name) for a, p in pool_clips(pool)]
    assert clips == [("jumping_jacks", "d.avi"), ("jumping_jacks", "e.mp4"), ("walking", "a.avi"),
                     ("walking", "b.avi"), ("walking", "c.avi")]
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputFileError, match="no video clips"):
        pool_clips(tmp_path / "empty")


def test_vlm_checker_manifest(pool, chat_server, tmp_path):
    # clips in sorted order: jumping_jacks/d, (e corrupt: no request), walking/a, walking/b, walking/c
    script = [ok("check_unsure.json"), ok("check_yes.json"), ok("check_no.json")]
    with chat_server(script, default=ok("check_garbage.txt")) as server:
        client = VLMClient(server.url, "vlm-test", cache_dir=tmp_path / "cache", sleep=lambda s: None)
        checker = VLMClipChecker(client, FrameSampler(n_frames=3))
        data = SourcePoolFilter(checker, threshold=0.6).filter(pool)
        assert len(server.requests) == 4
        again = SourcePoolFilter(checker, threshold=0.6).filter(pool)
        assert len(server.requests) == 5  # cached, but the unreadable answer (not cached)
    keys = ("path", "decision", "confidence", "reason")
    assert [[c[k] for k in keys] for c in again["clips"]] == [[c[k] for k in keys] for c in data["clips"]]
    assert [c["details"].get("cached") for c in again["clips"]] == [True, None, True, True, False]
    assert data["format"] == MANIFEST_FORMAT and data["threshold"] == 0.6
    assert data["counts"] == {"clips": 5, "retained": 1, "rejected": 4}
    by = {c["path"]: c for c in data["clips"]}
    assert by["walking/a.avi"]["decision"] == "retained" and by["walking/a.avi"]["confidence"] == 0.9
    assert by["jumping_jacks/d.avi"]["reason"].startswith("confidence 0.45 below 0.6")
    assert by["walking/b.avi"]["shows_activity"] is False and "seated man" in by["walking/b.avi"]["reason"]
    assert by["walking/c.avi"]["reason"].startswith("unreadable answer")
    assert by["jumping_jacks/e.mp4"]["reason"].startswith("unreadable clip")
    assert data["activities"]["walking"] == {"retained": ["walking/a.avi"],
                                             "rejected": ["walking/b.avi", "walking/c.avi"]}
    assert retained_clips(data) == [("walking", pool / "walking" / "a.avi")]
    question = server.requests[0]["body"]["messages"][0]["content"][0]["text"]
    assert 'activity "jumping jacks" as its dominant action' in question
    assert "response_format" not in server.requests[0]["body"]


def test_the_same_clip_twice_counts_once_and_an_out_of_range_confidence_is_rejected(
        tmp_path, videos, chat_server, cli):
    root = tmp_path / "POOL"
    for rel, source in (("jumping_jacks/j.avi", "short"), ("sitting/s.avi", "counter"),
                        ("walking/a.avi", "counter"), ("walking/b.avi", "counter")):
        (root / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(videos[source], root / rel)
    yes_150 = Reply(200, '{"answer": "yes", "confidence": 150, "reason": "sure"}')
    out = tmp_path / "manifest.json"
    with chat_server([yes_150, ok("check_yes.json"), ok("check_yes.json")]) as server:
        code, stdout, err = cli("video", "pool", root, "--checker", "vlm", "--vlm-base-url", server.url,
                                "--vlm-model", "m", "--n-frames", "2", "--no-cache", "-o", out)
        assert code == 0, err
        assert len(server.requests) == 3  # walking/b, a copy of walking/a, is not asked about
    data = json.loads(out.read_text())
    assert data["counts"] == {"clips": 4, "retained": 0, "rejected": 4} and "0 of 4 retained" in stdout
    by = {c["path"]: c for c in data["clips"]}
    assert by["jumping_jacks/j.avi"]["confidence"] == 0.0
    assert "confidence 150 is neither a fraction" in by["jumping_jacks/j.avi"]["reason"]
    assert by["walking/b.avi"]["reason"] == "duplicate of walking/a.avi (the same bytes)"
    assert by["walking/b.avi"]["details"] == {"duplicate_of": "walking/a.avi"}
    assert by["walking/a.avi"]["reason"].startswith("the same clip is also retained as sitting (sitting/s.avi)")
    assert by["sitting/s.avi"]["details"]["also_retained_as"] == ["walking/a.avi"]
    assert retained_clips(data) == []


def test_vlm_checker_caches_only_readable_answers(pool, chat_server, tmp_path):
    clip = pool / "walking" / "a.avi"
    with chat_server([ok("check_garbage.txt"), ok("check_yes.json")]) as server:
        client = VLMClient(server.url, "m", cache_dir=tmp_path / "c", sleep=lambda s: None)
        first = VLMClipChecker(client, FrameSampler(n_frames=2)).check(clip, "walking")
        second = VLMClipChecker(client, FrameSampler(n_frames=2)).check(clip, "walking")
        third = VLMClipChecker(client, FrameSampler(n_frames=2)).check(clip, "walking")
    assert second.shows_activity is True and not second.details["cached"] and third.details["cached"]
    assert len(server.requests) == 2
    assert first.shows_activity is None and first.details["cache_note"] == "not cached: no yes/no answer"


def test_vlm_checker_request_failure_is_a_rejection(pool, chat_server, tmp_path):
    with chat_server([], default=error(503)) as server:
        client = VLMClient(server.url, "m", max_retries=1, base_delay_s=0.0, sleep=lambda s: None)
        result = VLMClipChecker(client, FrameSampler(n_frames=2)).check(pool / "walking" / "a.avi", "walking")
    assert result.shows_activity is None and result.reason.startswith("request failed")


@pytest.fixture(scope="module")
def tracks():
    library = ActivityLibrary.load()
    backend = ProceduralBackend(library)
    out = {}
    for name in ("jumping_jacks", "right_hand_wave", "standing"):
        out[name] = motion_track(backend.generate(library.get(name).smp, seed=4), px_per_m=250)
    return library, out


def test_pose_checker_accepts_matching_motion_and_rejects_others(tracks):
    library, t = tracks
    from vsmp_imu.extract.pose import PoseExtractor

    checker = PoseClipChecker(PoseExtractor(library=library))
    good = checker.check_track(t["jumping_jacks"], "jumping_jacks")
    assert good.shows_activity and good.confidence >= 0.8, good.reason
    wave = checker.check_track(t["right_hand_wave"], "right_hand_wave")
    assert wave.confidence >= 0.6, wave.reason
    # jumping jacks moves parts a right-hand wave never involves; standing moves too little
    assert checker.check_track(t["jumping_jacks"], "right_hand_wave").confidence < 0.6
    assert checker.check_track(t["standing"], "jumping_jacks").confidence < 0.6
    assert checker.check_track(t["jumping_jacks"], "standing").confidence < 0.6
    assert checker.check_track(t["standing"], "standing").confidence >= 0.6


def test_pose_checker_on_a_clip_without_a_person(videos):
    pytest.importorskip("mediapipe")
    from vsmp_imu.extract.landmarks import MediaPipePoseEstimator
    from vsmp_imu.extract.pose import PoseExtractor

    checker = PoseClipChecker(PoseExtractor(MediaPipePoseEstimator(max_frames=10)))
    result = checker.check(videos["counter"], "walking")
    assert result.shows_activity is False and "found in only 0%" in result.reason


def test_cli_video_pool_vlm(pool, chat_server, tmp_path, cli):
    script = [ok("check_yes.json")] * 4
    out = tmp_path / "manifest.json"
    with chat_server(script) as server:
        code, stdout, stderr = cli("video", "pool", pool, "--checker", "vlm", "--threshold", "0.5",
                                   "--vlm-base-url", server.url, "--vlm-model", "m", "--n-frames", "2",
                                   "--cache-dir", tmp_path / "c", "-o", out)
    assert code == 0, stderr
    data = json.loads(out.read_text())
    # walking/a and jumping_jacks/d, the same bytes, are both "yes": ambiguous, neither is retained
    assert data["counts"] == {"clips": 5, "retained": 2, "rejected": 3}
    assert "2 of 5 retained" in stdout
    assert data["activities"]["walking"]["retained"] == ["walking/b.avi", "walking/c.avi"]
    code, _, err = cli("video", "pool", pool, "--checker", "clip", "-o", out)
    assert code == 2 and "pose, vlm" in err
