"""Pose-measured SMP fields on tracks of known motions, their uncertainties, and fusion."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vsmp_imu.extract.calibrate import motion_track
from vsmp_imu.extract.fuse import DISAGREE_U, agree, apply_measurements
from vsmp_imu.extract.pose import PoseExtractor, generic_smp
from vsmp_imu.extract.posemeasure import FIELDS, Measurement, PoseMeasurements
from vsmp_imu.motion.procedural import ProceduralBackend
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import SMP


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def backend(library):
    return ProceduralBackend(library)


@pytest.fixture(scope="module")
def extractor(library):
    return PoseExtractor(library=library)


def measured(backend, extractor, library, name, attribute=None, level=None, seed=7, **track_kw):
    smp = library.get(name).smp
    if attribute is not None:
        smp = intervene(smp, attribute, level)
    motion = backend.generate(smp, seed=seed)
    track_kw.setdefault("px_per_m", 250.0)
    return extractor.extract_track(motion_track(motion, **track_kw), name)


def value(result, field):
    return result.measurements.fields[field].value


def unc(result, field):
    return result.measurements.fields[field].uncertainty


def test_tempo_levels_follow_the_execution(backend, extractor, library):
    levels = [value(measured(backend, extractor, library, "walking", "tempo", t), "tempo")
              for t in ("slow", "medium", "fast")]
    assert levels[0] < 0.5 and 0.5 <= levels[1] <= 1.5 and levels[2] > 1.5
    r = measured(backend, extractor, library, "walking")
    raw = r.measurements.fields["tempo"].raw
    assert 90 <= raw["cadence_steps_per_min"] <= 135  # a normal walking cadence
    assert unc(r, "tempo") < 0.25


def test_amplitude_and_repetitions_follow_the_execution(backend, extractor, library):
    small = measured(backend, extractor, library, "jumping_jacks", "amplitude", "small")
    large = measured(backend, extractor, library, "jumping_jacks", "amplitude", "large")
    assert value(small, "amplitude") < 0.6 and value(large, "amplitude") > 1.4
    for n in (4, 9):
        r = measured(backend, extractor, library, "jumping_jacks", "repetitions", n)
        assert abs(value(r, "repetition_count") - n) <= 1
        assert unc(r, "repetition_count") < 0.35


def test_symmetry_side_and_body_parts(backend, extractor, library):
    walk = measured(backend, extractor, library, "walking")
    assert value(walk, "symmetry") == "symmetric"  # alternating: symmetric half a cycle apart
    raw = walk.measurements.fields["symmetry"].raw
    assert raw["c_sym_half_cycle"] > 0.82 > raw["c_sym_lag0"]
    curl = measured(backend, extractor, library, "two_arm_curl", "symmetry", "asymmetric")
    assert value(curl, "symmetry") == "asymmetric"
    assert value(measured(backend, extractor, library, "two_arm_curl"), "symmetry") == "symmetric"
    wave = measured(backend, extractor, library, "right_hand_wave")
    assert value(wave, "dominant_side") == "right" and unc(wave, "dominant_side") < 0.2
    assert set(value(wave, "body_parts")) <= {"right_upper_arm", "right_forearm", "right_hand"}
    data = library.get("right_hand_wave").smp.model_dump(mode="json")
    data["execution_attributes"]["dominant_side"] = "left"  # the backend mirrors the motion
    motion = backend.generate(SMP.model_validate(data), seed=7)
    left = extractor.extract_track(motion_track(motion, px_per_m=250.0), "right_hand_wave")
    assert value(left, "dominant_side") == "left"
    jj = measured(backend, extractor, library, "jumping_jacks")
    assert value(jj, "dominant_side") == "bilateral"


def test_displacement_from_the_image_path(backend, extractor, library):
    motion = backend.generate(library.get("walking").smp, seed=1)
    t = np.arange(motion.n_frames)
    # the person crosses 500 px at 250 px/m in a 640 px frame: 2 m at 1.70 m height
    hip = np.stack([70 + 500 * t / t[-1], np.full(len(t), 240.0)], axis=1)
    moving = extractor.extract_track(motion_track(motion, px_per_m=250, hip_px=hip), "walking")
    m = moving.measurements.fields["global_displacement"]
    assert m.raw["lateral_m"] == pytest.approx(500 / 250, rel=0.15)  # 2 m across the image
    assert m.value == pytest.approx(m.raw["extent_m"], abs=0.01) and m.value > 1.0
    still = measured(backend, extractor, library, "jumping_jacks")
    assert value(still, "global_displacement") == 0.0


def test_weak_evidence_gives_high_uncertainty(backend, extractor, library):
    motion = backend.generate(library.get("walking").smp, seed=2)
    det = np.ones(motion.n_frames, bool)
    det[::3] = False
    det[100:200] = False
    weak = extractor.extract_track(motion_track(motion, px_per_m=40.0, visibility=0.4, detected=det),
                                   "walking")
    for name, m in weak.measurements.fields.items():
        assert m.uncertainty >= 0.8, name
    assert any("weak pose evidence" in w for w in weak.warnings)


def test_jitter_alone_is_never_a_confident_measurement(backend, extractor, library):
    """A still body seen through landmark jitter: no field may come out confident
    (except "not periodic", which is right)."""
    from vsmp_imu.motion.motion import Motion

    motion = backend.generate(library.get("standing").smp, seed=0)
    still = Motion(np.repeat(motion.positions[:1], 150, 0), np.repeat(motion.rotations[:1], 150, 0), 30.0)
    track = motion_track(still, px_per_m=250)
    rng = np.random.default_rng(0)
    track.world = track.world + rng.normal(0, 0.02, track.world.shape)
    for label in ("walking", "right_hand_wave", "jumping_jacks"):
        result = extractor.extract_track(track, label)
        confident = {k: m.value for k, m in result.measurements.fields.items()
                     if m.measured and m.uncertainty < 0.5 and k != "global_displacement"
                     and (k, m.value) != ("periodicity", False)}
        assert confident == {}, label


def test_no_person_keeps_the_base_and_says_so(backend, extractor, library):
    motion = backend.generate(library.get("walking").smp, seed=0)
    empty = motion_track(motion, detected=np.zeros(motion.n_frames, bool))
    result = extractor.extract_track(empty, "walking")
    assert result.motion is None and result.smp == library.get("walking").smp
    assert all(not m.measured for m in result.measurements.fields.values())
    assert any("no person detected" in w for w in result.warnings)
    assert {c.action for c in result.changes} == {"not_measured"}


def test_unknown_label_gets_a_flagged_generic_smp(backend, extractor, library):
    motion = backend.generate(library.get("jumping_jacks").smp, seed=0)
    result = extractor.extract_track(motion_track(motion), "tai chi cloud hands")
    assert result.generic and result.entry is None
    assert result.smp.activity_label == "tai chi cloud hands"
    assert result.smp.primitive_sequence == ["perform_tai_chi_cloud_hands"]
    assert result.smp.uncertainty.motion_primitives >= 0.8
    assert result.smp.temporal_structure.is_repetitive  # measured periodic
    assert result.measurements.fields["tempo"].value is None  # no reference: no level
    assert any("not in the activity library" in w for w in result.warnings)
    report = result.report()
    assert report["generic_smp"] and report["library_entry"] is None
    import json

    json.dumps(result.to_dict())


def test_pose_mode_writes_measured_values_into_the_library_smp(backend, extractor, library):
    r = measured(backend, extractor, library, "jumping_jacks", "tempo", "fast")
    ea = r.smp.execution_attributes
    assert ea.tempo == value(r, "tempo") and r.smp.uncertainty.tempo == unc(r, "tempo")
    assert r.smp.body_parts.mandatory == library.get("jumping_jacks").smp.body_parts.mandatory
    assert r.smp.primitive_sequence == library.get("jumping_jacks").smp.primitive_sequence
    actions = {c.field: c.action for c in r.changes}
    assert actions["tempo"] == "replaced"
    # walking on the spot reads stationary; walking is mobile: an invariant, so kept
    assert actions["global_displacement"] == "conflict_uncertain" or r.entry != "walking"
    w = measured(backend, extractor, library, "walking")
    gd = next(c for c in w.changes if c.field == "global_displacement")
    assert gd.action == "conflict_uncertain" and w.smp.execution_attributes.global_displacement == "large"
    assert w.smp.uncertainty.global_displacement >= DISAGREE_U


# -- fusion rules ------------------------------------------------------------------------------
def _measurements(**fields) -> PoseMeasurements:
    out = {name: Measurement(name, None, 1.0) for name in FIELDS}
    for name, (val, u) in fields.items():
        out[name] = Measurement(name, val, u)
    return PoseMeasurements(out, None, None, True, (), ())


def test_fuse_rules(library):
    base = library.get("jumping_jacks").smp.model_copy(deep=True)
    data = base.model_dump(mode="json")
    data["execution_attributes"]["tempo"] = "medium"
    data["uncertainty"]["tempo"] = 0.2
    data["execution_attributes"]["amplitude"] = "medium"
    data["uncertainty"]["amplitude"] = 0.6
    data["temporal_structure"]["repetition_count"] = 8
    data["uncertainty"]["repetition_count"] = 0.1
    data["execution_attributes"]["symmetry"] = "symmetric"
    data["uncertainty"]["symmetry"] = 0.1
    base = SMP.model_validate(data)
    m = _measurements(tempo=(1.9, 0.1), amplitude=(1.8, 0.2), repetition_count=(9, 0.2),
                      symmetry=("asymmetric", 0.5), global_displacement=(3.0, 0.1))
    fused, changes = apply_measurements(base, m, mode="fuse", threshold=0.35)
    act = {c.field: c for c in changes}
    assert act["tempo"].action == "conflict_replaced"  # both confident, they disagree
    assert fused.execution_attributes.tempo == 1.9 and fused.uncertainty.tempo == DISAGREE_U
    assert act["amplitude"].action == "replaced" and fused.uncertainty.amplitude == 0.2
    assert act["repetition_count"].action == "confirmed"  # 9 vs 8: within one
    assert fused.temporal_structure.repetition_count == 8 and fused.uncertainty.repetition_count == 0.1
    assert act["symmetry"].action == "kept" and fused.execution_attributes.symmetry == "symmetric"
    assert act["global_displacement"].action == "conflict_uncertain"  # stationary -> mobile refused
    assert fused.execution_attributes.global_displacement == base.execution_attributes.global_displacement
    assert act["dominant_side"].action == "not_measured"
    replaced, _ = apply_measurements(base, m, mode="replace")
    assert replaced.execution_attributes.symmetry == "asymmetric"
    assert replaced.uncertainty.symmetry == 0.5


@pytest.mark.parametrize("threshold", [float("nan"), -0.1, 1.5, float("inf")])
def test_fuse_threshold_must_lie_in_0_1(library, threshold):
    from vsmp_imu.errors import ConfigError

    base = library.get("jumping_jacks").smp
    with pytest.raises(ConfigError, match="field 'threshold'.*Allowed: a number in 0..1"):
        apply_measurements(base, _measurements(tempo=(1.9, 0.9)), mode="fuse", threshold=threshold)


def test_agreement():
    assert agree("tempo", "fast", 1.7) and not agree("tempo", "slow", 1.2)
    assert agree("repetition_count", 8, 9) and not agree("repetition_count", 8, 10)
    assert agree("global_displacement", "large", 5.0) and not agree("global_displacement", "small", 0.0)
    assert agree("body_parts", ["left_hand", "right_hand"], ["left_hand", "right_hand", "head"])
    assert not agree("dominant_side", "unknown", "left")


@settings(max_examples=30, deadline=None)
@given(tempo=st.floats(0, 2), u=st.floats(0, 1), reps=st.integers(0, 50),
       side=st.sampled_from(["left", "right", "bilateral", "none"]),
       disp=st.floats(0, 20), mode=st.sampled_from(["fuse", "replace"]))
def test_fused_smp_is_valid_and_keeps_its_invariants(library, tempo, u, reps, side, disp, mode):
    base = library.get("two_arm_curl").smp
    m = _measurements(tempo=(round(tempo, 3), u), repetition_count=(reps, u), dominant_side=(side, u),
                      global_displacement=(round(disp, 2), u),
                      body_parts=(["left_hand"], u))
    fused, changes = apply_measurements(base, m, mode=mode)
    assert fused.activity_label == base.activity_label
    assert fused.primitive_sequence == base.primitive_sequence
    assert fused.body_parts.mandatory == base.body_parts.mandatory
    assert fused.object_contact.required_contact == base.object_contact.required_contact
    # the stationary / mobile class never changes
    from vsmp_imu.smp.schema import displacement_word

    was = displacement_word(base.execution_attributes.global_displacement) == "stationary"
    now = displacement_word(fused.execution_attributes.global_displacement) == "stationary"
    assert was == now
    assert len(changes) == 7


def test_generic_smp_is_minimal():
    smp = generic_smp("Tai Chi")
    assert smp.activity_label == "Tai Chi" and len(smp.motion_primitives) == 1
    assert smp.uncertainty.activity_label == 0.2 and smp.uncertainty.tempo == 0.8


def test_missing_video_extra_is_a_dependency_error(monkeypatch, tmp_path):
    import sys

    from vsmp_imu.errors import DependencyError
    from vsmp_imu.extract.frames import FrameSampler
    from vsmp_imu.extract.landmarks import MediaPipePoseEstimator

    monkeypatch.setitem(sys.modules, "mediapipe", None)  # import mediapipe -> ImportError
    with pytest.raises(DependencyError, match=r"pip install -e \.\[video\]"):
        MediaPipePoseEstimator().estimate(tmp_path / "clip.mp4")
    monkeypatch.setitem(sys.modules, "cv2", None)
    with pytest.raises(DependencyError, match=r"pip install -e \.\[video\]"):
        FrameSampler().sample(tmp_path / "clip.mp4")
