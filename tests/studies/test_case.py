"""The qualitative case study: variants, keyframes, outputs, CLI, and a real clip."""

from __future__ import annotations

import json

import numpy as np
import pytest
from study_support import VIDEO_DIR

from vsmp_imu.smp import load_smp
from vsmp_imu.studies.case import (
    CaseStudy,
    default_variants,
    keyframe_indices,
    natural_location,
    smp_summary,
    write_case_outputs,
)


def test_default_variants_follow_the_smp(library):
    throw = library.get("right_arm_throw")
    titles = [v.title for v in default_variants(throw.smp, throw)]
    assert titles == ["tempo: fast", "amplitude: large", "release x1.25"]
    curl = library.get("two_arm_curl")
    assert [v.title for v in default_variants(curl.smp, curl)] == [
        "tempo: fast", "amplitude: large", "repetitions: 7"]
    standing = library.get("standing")
    assert all(v.attribute in standing.smp.constraints.variant_fields for v in
               default_variants(standing.smp, standing))


def test_natural_locations(library):
    assert natural_location(library.get("jogging_in_place")) == "right_thigh"
    assert natural_location(library.get("right_hand_wave")) == "right_wrist"
    assert natural_location(library.get("walking")) == "waist"
    assert natural_location(library.get("bicep_curls")) == "right_wrist"


def test_keyframes_span_the_motion(library):
    from vsmp_imu.motion.procedural import ProceduralBackend

    motion = ProceduralBackend(library).generate(library.get("two_arm_curl").smp, seed=0)
    frames = keyframe_indices(motion, 5)
    assert frames[0] == 0 and len(set(frames.tolist())) == 5 and (np.diff(frames) > 0).all()
    rel = motion.positions - motion.positions[:, :1]
    spread = [np.linalg.norm(rel[a] - rel[b]) for a in frames for b in frames if a < b]
    # farthest-point frames are farther apart than evenly spaced ones (which catch rest poses)
    even = np.linspace(0, motion.n_frames - 1, 5).round().astype(int)
    spread_even = [np.linalg.norm(rel[a] - rel[b]) for a in even for b in even if a < b]
    assert min(spread) > min(spread_even)


def test_case_study_outputs(tmp_path, library):
    result = CaseStudy("right_arm_throw", seed=2, library=library).run()
    assert result.source == "library" and result.location == "right_wrist"
    assert [v.variant.attribute for v in result.variants] == ["tempo", "amplitude", "duration"]
    fast = result.variants[0]
    assert fast.smp.execution_attributes.tempo == "fast" and "fast pace" in fast.prompt
    assert fast.motion.meta["seed"] == 2 and fast.imu.data.shape[1] == 6
    paths = write_case_outputs(result, tmp_path)
    assert paths["figure"].read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert load_smp(tmp_path / "variant_2.smp.json").execution_attributes.amplitude == "large"
    prompts = (tmp_path / "prompts.txt").read_text()
    assert prompts.count("A person performs") == 4  # base and three variants
    assert (tmp_path / "variant_3_right_wrist.csv").exists() and (tmp_path / "variant_1.npz").exists()
    data = json.loads(paths["results"].read_text())
    assert [v["title"] for v in data["variants"]] == ["tempo: fast", "amplitude: large", "release x1.25"]
    assert "label: right arm throw" in smp_summary(result.smp)


def test_cli(cli, tmp_path):
    code, out, err = cli("study", "case", "--activity", "jogging_in_place", "-o", tmp_path,
                         "--location", "left thigh")
    assert code == 0, err
    assert "variant 3" in out and (tmp_path / "case_study.png").exists()
    assert (tmp_path / "variant_1_left_thigh.csv").exists()
    code, _, err = cli("study", "case", "--activity", "moonwalk", "-o", tmp_path)
    assert code == 2 and "moonwalk" in err
    code, _, err = cli("study", "case", "--activity", "walking", "-o", tmp_path, "--location", "elbow")
    assert code == 2 and "elbow" in err


@pytest.mark.video
def test_case_study_from_a_real_clip(tmp_path, library):
    """carphone: a seated man, head and shoulders only. The pose extractor measures what it can,
    the figure shows the clip's frames."""
    pytest.importorskip("mediapipe")
    pytest.importorskip("cv2")
    if not (VIDEO_DIR / "carphone_pristine.mp4").exists():
        pytest.skip(f"the shared clips are not beside this checkout ({VIDEO_DIR})")
    result = CaseStudy("right_hand_wave", video=VIDEO_DIR / "carphone_pristine.mp4",
                       library=library).run()
    assert result.frames is not None and result.frames.shape[0] == 6
    assert result.source.startswith("pose extractor") and result.extraction["library_entry"] == \
        "right_hand_wave"
    paths = write_case_outputs(result, tmp_path)
    assert paths["figure"].exists()
    assert json.loads(paths["results"].read_text())["extraction"]["track"]
