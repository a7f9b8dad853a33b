"""The UTD-MHAD, MM-Fit and PAMAP2 activity files: postures that read as the activity, side-agnostic
mirroring, continuous cycles to the end, the running flight phase."""

from __future__ import annotations

import numpy as np
import pytest
from motion_cases import SYMMETRY_VARIANT

from vsmp_imu.motion import selfcheck
from vsmp_imu.motion.procedural import FLIGHT_RAMP_M, FLIGHT_START_M, _hold_in_flight
from vsmp_imu.smp.schema import SMP


def _at(motion, joint: str) -> np.ndarray:
    return motion.positions[:, motion.joint_names.index(joint)]


def _scale(motion) -> float:
    return motion.body_height_m() / 1.70


def _with_side(smp: SMP, side: str) -> SMP:
    data = smp.model_dump(mode="json")
    data["execution_attributes"]["dominant_side"] = side
    return SMP.model_validate(data)


def test_pushups_are_prone_on_hands_and_toes(backend, library):
    m = backend.generate(library.get("pushups").smp, seed=0)
    s = _scale(m)
    head, pelvis = _at(m, "head"), _at(m, "pelvis")
    body = head - _at(m, "left_ankle")
    assert np.all(np.abs(body[:, 2]) > 2.0 * np.abs(body[:, 1]))  # more horizontal than vertical
    assert np.all(head[:, 2] > pelvis[:, 2])  # face down, head forward
    hands = np.minimum(_at(m, "left_wrist")[:, 1], _at(m, "right_wrist")[:, 1])
    toes = np.minimum(_at(m, "left_foot")[:, 1], _at(m, "right_foot")[:, 1])
    assert hands.max() < 0.12 * s and toes.max() < 0.12 * s  # both on the floor throughout
    assert np.ptp(_at(m, "spine3")[:, 1]) > 0.15 * s  # the chest goes down and up


def test_situps_lie_on_the_floor_and_curl_up(backend, library):
    m = backend.generate(library.get("situps").smp, seed=0)
    s = _scale(m)
    assert _at(m, "pelvis")[:, 1].max() < 0.3 * s
    head = _at(m, "head")[:, 1]
    assert np.percentile(head, 5) < 0.25 * s and head.max() > 0.5 * s  # lying, then nearly sitting


def test_cycling_is_seated_with_pedalling_legs(backend, library):
    m = backend.generate(library.get("cycling").smp, seed=0)
    s = _scale(m)
    pelvis = _at(m, "pelvis")
    assert np.ptp(pelvis, axis=0).max() < 0.02  # on the saddle, in the bicycle's frame
    assert 0.85 * s < pelvis[0, 1] < 1.1 * s
    left, right = _at(m, "left_ankle")[:, 1], _at(m, "right_ankle")[:, 1]
    assert np.ptp(left) > 0.25 * s and np.corrcoef(left, right)[0, 1] < -0.8  # feet in opposition
    assert min(left.min(), right.min(), _at(m, "left_foot")[:, 1].min()) > 0.0


@pytest.mark.parametrize("name", ["watching_tv", "computer_work", "car_driving", "tricep_extensions",
                                  "dumbbell_shoulder_press", "lateral_shoulder_raises"])
def test_seated_activities_sit(backend, library, name):
    m = backend.generate(library.get(name).smp, seed=0)
    s = _scale(m)
    pelvis, knee = _at(m, "pelvis"), _at(m, "left_knee")
    assert np.all(pelvis[:, 1] < 0.65 * s)  # chair height, not standing (about 0.95 m)
    assert np.all(knee[:, 2] - pelvis[:, 2] > 0.25 * s)  # thighs forward


def test_overhead_actions_raise_the_hand_above_the_head(backend, library):
    for name, joint in (("tennis_serve", "right_wrist"), ("dumbbell_shoulder_press", "left_wrist"),
                        ("tricep_extensions", "right_wrist")):
        m = backend.generate(library.get(name).smp, seed=0)
        assert (_at(m, joint)[:, 1] - _at(m, "head")[:, 1]).max() > 0.15, name


def test_pick_up_reaches_the_floor_and_bowling_releases_low(backend, library):
    m = backend.generate(library.get("pick_up_and_throw").smp, seed=0)
    assert _at(m, "right_wrist")[:, 1].min() < 0.3 * _scale(m)
    m = backend.generate(library.get("bowling").smp, seed=0)
    assert _at(m, "right_wrist")[:, 1].min() < 0.8 * _scale(m)


@pytest.mark.parametrize(("name", "expected"), [("running", (1.0, 2.5)), ("nordic_walking", (0.5, 1.6)),
                                                ("playing_soccer", (0.6, 2.0))])
def test_locomotion_travels_forward(backend, library, name, expected):
    m = backend.generate(library.get(name).smp, seed=1)
    root = _at(m, "pelvis")
    speed = (root[-1, 2] - root[0, 2]) / m.duration_s
    assert expected[0] < speed < expected[1]
    assert abs(root[-1, 0] - root[0, 0]) < 0.3


def _heading(m, joint="pelvis"):
    """Unwrapped heading (rad) of a joint's forward axis on the floor, per frame."""
    from vsmp_imu.motion.quat import rotate

    forward = rotate(m.rotations[:, m.joint_names.index(joint)], np.array([0.0, 0.0, 1.0]))
    return np.unwrap(np.arctan2(forward[:, 0], forward[:, 2]))


@pytest.mark.parametrize("name", ["walking_upstairs", "walking_downstairs"])
@pytest.mark.parametrize("seed", [0, 3])
def test_stairs_turn_at_the_landings(backend, library, name, seed):
    m = backend.generate(library.get(name).smp, seed=seed, duration_s=30.0)
    heading = _heading(m)
    side = np.sign(heading[-1] - heading[0])
    # 30 s of stairs hold two or more half turns, all to one side; only the pelvis's own
    # rotation with each stride (a few degrees) ever turns back
    assert abs(heading[-1] - heading[0]) > 1.8 * np.pi
    turns = m.meta["controls"]["turns"]  # in the provenance: positive headings turn left
    assert turns["side"] == ("left" if side > 0 else "right")
    assert turns["turned_deg"] == pytest.approx(np.degrees(abs(heading[-1] - heading[0])), abs=20)
    assert (side * heading - np.maximum.accumulate(side * heading)).min() > -np.radians(15)
    # the body travels the way it faces
    root = _at(m, "pelvis")
    stride = int(round(m.meta["controls"]["cycle_s"] * m.fps))
    travel = root[stride:, [0, 2]] - root[:-stride, [0, 2]]
    faced = 0.5 * (heading[stride:] + heading[:-stride])
    along = travel[:, 0] * np.sin(faced) + travel[:, 1] * np.cos(faced)
    assert np.median(along / np.linalg.norm(travel, axis=1)) > 0.95


@pytest.mark.parametrize("side", ["left", "right"])
def test_stairs_turn_to_the_smps_dominant_side(backend, library, side):
    """The SMP's dominant side is the way the stairwell turns (the side from evidence sets it)."""
    smp = _with_side(library.get("walking_upstairs").smp, side)
    for seed in range(3):
        m = backend.generate(smp, seed=seed, duration_s=20.0)
        heading = _heading(m)
        assert np.sign(heading[-1] - heading[0]) == (1 if side == "left" else -1)
        assert m.meta["controls"]["turns"]["side"] == side


def test_stairs_without_a_side_turn_either_way(backend, library):
    smp = _with_side(library.get("walking_downstairs").smp, "none")
    sides = {backend.generate(smp, seed=seed, duration_s=8.0).meta["controls"]["turns"]["side"] for seed in range(8)}
    assert sides == {"left", "right"}


def test_level_walking_keeps_its_heading(backend, library):
    m = backend.generate(library.get("walking").smp, seed=0, duration_s=30.0)
    assert np.ptp(_heading(m)) < np.radians(20)
    assert "turns" not in m.meta["controls"]


def test_running_has_a_flight_phase_and_keeps_its_speed(backend, library):
    m = backend.generate(library.get("running").smp, seed=2)
    lowest = np.minimum(_at(m, "left_foot")[:, 1], _at(m, "right_foot")[:, 1])
    assert (lowest > 0.024 * _scale(m) + 0.02).mean() > 0.1  # both feet off the floor in places
    speed = np.diff(_at(m, "pelvis")[:, 2]) * m.fps
    assert speed.min() > 0.5 * speed.mean()  # no stop in the air


def test_flight_hold_keeps_the_last_contact_speed():
    speed = np.array([1.0, 1.2, 1.4, 9.0, 9.0, 1.5])
    on_floor = np.zeros(6)
    assert np.array_equal(_hold_in_flight(speed, on_floor), speed)  # walking: unchanged
    air = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 0.0])
    held = _hold_in_flight(speed, air)
    assert held.tolist() == [1.0, 1.2, 1.4, 1.4, 1.4, 1.5]
    half = _hold_in_flight(speed, np.array([0, 0, 0, FLIGHT_START_M + FLIGHT_RAMP_M / 2, 0, 0]))
    assert half[3] == pytest.approx(0.5 * 9.0 + 0.5 * 1.4)


def test_flight_is_detected_in_running_only(backend, library, monkeypatch):
    from vsmp_imu.motion import procedural

    lowest: list[np.ndarray] = []
    real = procedural._hold_in_flight
    monkeypatch.setattr(procedural, "_hold_in_flight", lambda v, h: lowest.append(h) or real(v, h))
    for name in ("walking", "walking_upstairs", "nordic_walking"):
        backend.generate(library.get(name).smp, seed=0)
        assert lowest[-1].max() < FLIGHT_START_M, name  # always a foot on the floor: the hold is off
    backend.generate(library.get("running").smp, seed=0)
    assert (lowest[-1] > FLIGHT_START_M + FLIGHT_RAMP_M).mean() > 0.1


@pytest.mark.parametrize("name", ["walking", "running", "cycling", "rope_jumping", "playing_soccer"])
def test_continuous_cycles_reach_the_end(backend, library, name):
    for seed in range(8):
        for duration in (None, 7.3):
            plan = backend.plan(library.get(name).smp, seed, duration)
            assert plan.block[1] >= plan.duration_s - 1e-9, (seed, duration)


@pytest.mark.parametrize(("name", "joint"), [("vacuum_cleaning", "wrist"), ("ironing", "wrist"),
                                             ("house_cleaning", "wrist"), ("playing_soccer", "ankle")])
def test_side_agnostic_one_sided_activities_mirror(backend, library, name, joint):
    smp = library.get(name).smp
    assert smp.execution_attributes.dominant_side == "right"
    assert "dominant_side" in smp.constraints.variant_fields
    right = backend.generate(smp, seed=4)
    left = backend.generate(_with_side(smp, "left"), seed=4)
    assert left.meta["controls"]["mirrored"] and not right.meta["controls"]["mirrored"]

    def spread(m, side):
        rel = _at(m, f"{side}_{joint}") - _at(m, "pelvis")
        return float(np.ptp(rel, axis=0).max())

    assert spread(left, "left") == pytest.approx(spread(right, "right"), rel=0.05)
    assert spread(left, "right") == pytest.approx(spread(right, "left"), rel=0.05)


@pytest.mark.parametrize("name", [n for n in SYMMETRY_VARIANT if n not in
                                  ("two_hand_front_clap", "two_arm_curl", "two_hand_push", "squat_arms_extended")])
def test_symmetry_variant_activities_realize_asymmetry(backend, library, name):
    cases = selfcheck.run_cases(backend, library, [name], "symmetry", (0,))
    assert selfcheck.symmetry_accuracy(cases) == 1.0
