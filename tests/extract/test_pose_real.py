"""MediaPipe on the three real clips: decoding, small or absent people, low confidence, no crash.

Fast tests look at a few frames; the full clips run under `slow`.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from extract_support import real_clip

pytest.importorskip("mediapipe")
pytest.importorskip("cv2")

from vsmp_imu.extract.landmarks import LM, MediaPipePoseEstimator, world_to_yup  # noqa: E402
from vsmp_imu.extract.pose import PoseExtractor  # noqa: E402
from vsmp_imu.smp import load_smp  # noqa: E402

pytestmark = pytest.mark.video


def test_mediapipe_axes_on_a_person_facing_the_camera():
    """carphone: a man facing the camera. Checks the documented MediaPipe conventions."""
    track = MediaPipePoseEstimator(max_frames=6).estimate(real_clip("carphone"))
    assert track.detected.all() and track.fps == pytest.approx(29.97, abs=0.01)
    w = track.world
    assert (w[:, LM["left_shoulder"], 0] > w[:, LM["right_shoulder"], 0]).all()  # x: image right
    assert (w[:, LM["nose"], 1] < w[:, LM["left_shoulder"], 1]).all()  # y: down
    assert (w[:, LM["nose"], 2] < 0).all()  # z: the face is nearer the camera than the hips
    img = track.image
    assert (img[:, LM["left_shoulder"], 0] > img[:, LM["right_shoulder"], 0]).all()
    p = world_to_yup(w)
    assert (p[:, LM["nose"], 2] > 0).all() and (p[:, LM["left_shoulder"], 0] > 0).all()


def test_few_frames_of_each_clip():
    est = MediaPipePoseEstimator(max_frames=8)
    vtest = est.estimate(real_clip("vtest"))  # the first 16 s show nobody MediaPipe finds
    assert vtest.n_frames == 8 and not vtest.detected.any()
    bikes = est.estimate(real_clip("bikes"))  # the cyclist is found at the start
    assert bikes.detected.sum() >= 6
    assert bikes.frame_size == (640, 272)
    strided = MediaPipePoseEstimator(max_frames=4, max_fps=10).estimate(real_clip("carphone"))
    assert strided.frame_indices.tolist() == [0, 3, 6, 9] and strided.fps == pytest.approx(29.97 / 3, abs=0.01)


def test_a_clip_with_nobody_found_is_reported_not_crashed():
    ex = PoseExtractor(MediaPipePoseEstimator(max_frames=8))
    result = ex.extract(real_clip("vtest"), "walking")
    assert result.motion is None
    assert all(not m.measured for m in result.measurements.fields.values())
    assert any("no person detected" in w for w in result.warnings)
    json.dumps(result.to_dict())


def test_head_and_shoulders_clip_gives_high_uncertainty():
    """carphone at 10 fps: a seated man, legs and hands out of the frame."""
    ex = PoseExtractor(MediaPipePoseEstimator(max_fps=10))
    result = ex.extract(real_clip("carphone"), "sitting")
    m = result.measurements
    assert m.evidence.detected_fraction == 1.0 and m.evidence.visibility < 0.5
    for name, field in m.fields.items():
        assert field.uncertainty >= 0.8, name
    not_visible = m.fields["body_parts"].raw["not_visible"]
    assert "left_foot" in not_visible and "right_hand" in not_visible
    assert result.motion.meta["detected_fraction"] == 1.0


@pytest.mark.slow
def test_cli_pose_extract_vtest_walking(cli, tmp_path):
    out = tmp_path / "SMP.json"
    code, stdout, stderr = cli("smp", "extract", real_clip("vtest"), "--label", "walking",
                               "--extractor", "pose", "-o", out)
    assert code == 0, stderr
    smp = load_smp(out)
    report = json.loads((tmp_path / "SMP.report.json").read_text())
    tempo = report["measurements"]["fields"]["tempo"]
    cadence = tempo["raw"]["cadence_steps_per_min"]
    # a walking cadence, or a tempo nobody should trust
    assert 70 <= cadence <= 140 or smp.uncertainty.tempo >= 0.8
    assert report["track"]["frames_with_pose"] > 300
    assert report["measurements"]["window"][1] - report["measurements"]["window"][0] > 100


@pytest.mark.slow
@pytest.mark.parametrize("clip,label", [("bikes", "cycling"), ("carphone", "sitting")])
def test_cli_pose_extract_other_clips(cli, tmp_path, clip, label):
    out = tmp_path / "SMP.json"
    code, stdout, stderr = cli("smp", "extract", real_clip(clip), "--label", label,
                               "--extractor", "pose", "-o", out, "--motion-out", tmp_path / "m.npz")
    assert code == 0, stderr
    report = json.loads((tmp_path / "SMP.report.json").read_text())
    assert report["measurements"]["track"]["quality"] < 0.3
    smp = load_smp(out)
    assert max(smp.uncertainty.tempo, smp.uncertainty.amplitude) >= 0.8
    from vsmp_imu.motion.motion import Motion

    motion = Motion.load(tmp_path / "m.npz")
    assert motion.is_finite() and motion.meta["source"] == "video_pose"


@pytest.mark.slow
def test_cli_video_pose_and_fused(cli, tmp_path):
    code, _, err = cli("video", "pose", real_clip("bikes"), "--window", "longest", "-o", tmp_path / "b.npz")
    assert code == 0, err
    from vsmp_imu.motion.motion import Motion

    m = Motion.load(tmp_path / "b.npz")
    # the longest run bridges gaps up to 0.5 s: MediaPipe 0.10.21 finds the rider in 80 % of its frames
    assert m.meta["detected_fraction"] > 0.75 and np.isfinite(m.positions).all()
    # fused without a VLM: the library SMP checked by the measurements (weak here: kept)
    out = tmp_path / "f.json"
    code, _, err = cli("smp", "extract", real_clip("carphone"), "--label", "sitting",
                       "--extractor", "fused", "-o", out)
    assert code == 0, err
    report = json.loads((tmp_path / "f.report.json").read_text())
    actions = {c["field"]: c["action"] for c in report["pose"]["changes"]}
    assert set(actions.values()) <= {"kept", "not_measured", "conflict_uncertain"}


def test_cli_fused_vlm_then_pose(cli, chat_server, tmp_path):
    """fused with a VLM: the VLM SMP is checked by weak pose evidence and therefore kept."""
    from vlm_server import ok

    out = tmp_path / "fused.json"
    script = [ok(f"walking_valid_{k}.json") for k in (1, 2, 3, 1, 3)]
    with chat_server(script) as server:
        code, stdout, stderr = cli("smp", "extract", real_clip("carphone"), "--label", "walking",
                                   "--extractor", "fused", "--n-frames", "4", "--max-fps", "10",
                                   "--vlm-base-url", server.url, "--vlm-model", "vlm-test",
                                   "--cache-dir", tmp_path / "cache", "-o", out)
    assert code == 0, stderr
    report = json.loads((tmp_path / "fused.report.json").read_text())
    assert report["extractor"] == "fused" and report["counts"]["valid"] == 5
    vlm_smp = report["aggregated_smp"]
    fused = load_smp(out)
    actions = {c["field"]: c["action"] for c in report["pose"]["changes"]}
    assert "replaced" not in actions.values() and "conflict_replaced" not in actions.values()
    assert fused.execution_attributes.tempo == vlm_smp["execution_attributes"]["tempo"]
    assert len(list((tmp_path / "fused.raw").glob("response_*.txt"))) == 5
