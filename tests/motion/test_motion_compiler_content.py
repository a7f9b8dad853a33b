"""What `compile_recipe_data` writes, checked against the rules in the compiler's docstring: the poses each
primitive reaches (movement targets from `motion.anatomy`), the returns, the timing from the relative
durations and the speed limit, the cycle, the side, the principal joints."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.motion.anatomy import MOVEMENTS, SEAT_SHIFT_M
from vsmp_imu.motion.compiler import (
    MAX_MEAN_SPEED_M_S,
    STATIC_HOLD_S,
    _joint_paths,
    compile_recipe_data,
)
from vsmp_imu.motion.dofs import BUILTIN_POSES, pose_vector
from vsmp_imu.smp.library import ActivityLibrary

FIXTURES = Path(__file__).resolve().parents[1] / "fixtures" / "compiled_activities"


@pytest.fixture(scope="module")
def library() -> ActivityLibrary:
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def fixtures() -> ActivityLibrary:
    return ActivityLibrary.load([FIXTURES])


def _changed(data: dict, key: str) -> dict[str, float]:
    """The DOFs a key pose sets away from the base pose."""
    base = data["base_pose"]
    return {k: v for k, v in data["poses"][key].items() if abs(v - base[k]) > 1e-9}


def _keys(data: dict, primitive: str) -> list:
    return data["primitives"][primitive]["keys"]


def test_a_curl_reaches_the_elbow_flexion_target_and_returns_in_its_share_of_the_time(fixtures):
    data = compile_recipe_data(fixtures.get("hammer_curl_kettlebell").smp)
    elbow = MOVEMENTS["elbow_flexion"].pose["elbow_flex"]
    assert (data["kind"], data["side"], data["rest_s"]) == ("periodic", "bilateral", 0.3)
    assert data["cycle"] == {"primitives": ["curl_up", "lower"], "ramp": 0.25} and "continuous" not in data
    [(at, up, ease)] = _keys(data, "curl_up")
    assert (at, ease) == (1.0, "stop")
    assert _changed(data, up) == {"left_elbow_flex": elbow, "right_elbow_flex": elbow}  # a hammer curl: no turn
    [(at, down, ease)] = _keys(data, "lower")
    assert (at, ease) == (1.0, "stop") and _changed(data, down) == {}  # back to where the curl started
    # relative durations 0.45 / 0.55 of the two nominal excursions, within the speed limit of one arm
    # (the two arms curling together do not speed up either hand)
    nominal = 2 * MOVEMENTS["elbow_flexion"].nominal_s
    assert data["primitives"]["lower"]["duration_s"] == pytest.approx(0.55 * nominal, abs=1e-4)
    up_pose = pose_vector(data["poses"][up])
    hand = _joint_paths(np.stack([pose_vector(data["base_pose"]), up_pose]))[0]
    assert hand / MAX_MEAN_SPEED_M_S < 0.45 * nominal  # the speed limit does not bind a curl
    assert data["primitives"]["curl_up"]["duration_s"] == pytest.approx(0.45 * nominal, abs=1e-4)
    assert data["principal_joints"] == data["symmetry_joints"] == ["left_elbow", "right_elbow"]
    assert data["locomotion"] == "none" and data["amplitude_exempt"] == [] and "asymmetry" not in data


def test_a_jab_goes_out_and_back_on_the_right_arm_only(fixtures):
    data = compile_recipe_data(fixtures.get("right_jab").smp)
    assert (data["kind"], data["side"]) == ("periodic", "right")
    assert data["asymmetry"] == {"lag_s": 0.0, "imbalance": 1.0}
    (at_out, out, _), (at_back, back, _) = _keys(data, "punch")
    assert (at_out, at_back) == (0.5, 1.0)
    assert set(_changed(data, out)) == {"right_shoulder_flex", "right_elbow_flex"} and _changed(data, back) == {}
    assert data["principal_joints"] == ["right_elbow", "right_shoulder"]
    jab = fixtures.get("right_jab").smp
    d = jab.model_dump(mode="json")
    d["motion_primitives"] = json.loads(json.dumps(d["motion_primitives"]).replace("right", "left"))
    d["execution_attributes"]["dominant_side"] = "left"
    left = compile_recipe_data(type(jab).model_validate(d))  # the same jab with the left fist
    assert left["side"] == "left" and left["asymmetry"] == {"lag_s": 0.0, "imbalance": 1.0}
    assert data["symmetry_joints"] == ["right_elbow", "left_elbow", "right_shoulder", "left_shoulder"]


def test_walking_is_a_continuous_wave_cycle_from_the_gait_pose(library):
    data = compile_recipe_data(library.get("walking").smp)
    assert (data["kind"], data["rest_s"], data["continuous"], data["locomotion"]) == ("periodic", 0.0, True,
                                                                                     "forward")
    assert data["cycle"]["primitives"] == ["left_step", "right_step"] and data["cycle"]["ramp"] == 0.0
    assert all(p["keys"] == [] for p in data["primitives"].values())  # the waves move the legs, not keys
    for stem, value in MOVEMENTS["walk"].pose.items():
        for dof in (f"left_{stem}", f"right_{stem}", stem):
            if dof in data["base_pose"]:
                assert data["base_pose"][dof] == pytest.approx(value)
    assert {"left_knee", "right_knee", "left_hip", "right_hip"} <= set(data["principal_joints"][:4])
    assert "stair_swing" not in data
    upstairs = compile_recipe_data(library.get("walking_upstairs").smp)
    assert upstairs["locomotion"] == "stairs_up" and upstairs["stair_swing"] == (0.5, 0.7)


def test_stand_to_sit_crouches_on_the_way_and_lands_on_the_seat(library):
    data = compile_recipe_data(library.get("stand_to_sit").smp)
    assert (data["kind"], data["side"]) == ("discrete", "bilateral") and "cycle" not in data
    assert _keys(data, "stand") == []  # the first primitive sets the start: standing
    (at_via, via, ease_via), (at_seat, seat, ease_seat) = _keys(data, "lean_and_lower")
    # the seat is passed (the trunk settles upright next), the crouch on the way is passed as before
    assert (at_via, ease_via, at_seat, ease_seat) == (0.5, "smooth", 1.0, "pass")
    crouch = _changed(data, via)
    knee = BUILTIN_POSES["sitting"]["knee_flex"]
    assert crouch["root_dz"] == pytest.approx(SEAT_SHIFT_M / 2) and crouch["left_knee_flex"] == knee / 2  # half way
    sitting = _changed(data, seat)
    assert sitting["root_dz"] == pytest.approx(SEAT_SHIFT_M)
    assert sitting["left_knee_flex"] == sitting["right_knee_flex"] == BUILTIN_POSES["sitting"]["knee_flex"]
    assert "root_dz" in data["amplitude_exempt"] and "knee_flex" in data["amplitude_exempt"]
    [(_, settled, _)] = _keys(data, "settle_upright")  # a discrete motion is not closed: it stays seated
    assert _changed(data, settled)["root_dz"] == pytest.approx(SEAT_SHIFT_M)


def test_sitting_still_is_a_static_hold(library):
    data = compile_recipe_data(library.get("sitting").smp)
    assert (data["kind"], data["rest_s"], data["continuous"], data["side"]) == ("static", 0.0, True, "none")
    assert [p["duration_s"] for p in data["primitives"].values()] == [STATIC_HOLD_S]
    assert data["principal_joints"] == ["pelvis"] and data["symmetry_joints"] == []
    for stem, value in BUILTIN_POSES["sitting"].items():  # the start posture is the base pose
        for dof in (f"left_{stem}", f"right_{stem}", stem):
            if dof in data["base_pose"]:
                assert data["base_pose"][dof] == pytest.approx(value), dof


def _sided(pose: dict[str, float], data: dict) -> dict[str, float]:
    """A pose written on both sides (side DOFs) or on its centre DOF, as the base pose holds it."""
    out = {}
    for stem, value in pose.items():
        for dof in (f"left_{stem}", f"right_{stem}", stem):
            if dof in data["base_pose"] and value:
                out[dof] = float(value)
    return out


def test_gait_starts_from_standing_plus_its_own_pose(library):
    walk = compile_recipe_data(library.get("walking").smp)  # walking's gait pose is empty: plain standing
    assert {k: v for k, v in walk["base_pose"].items() if v} == _sided(BUILTIN_POSES["standing"], walk)
    run = compile_recipe_data(library.get("running").smp)
    expected = _sided(BUILTIN_POSES["standing"], run) | _sided(MOVEMENTS["run"].pose, run)
    assert {k: v for k, v in run["base_pose"].items() if v} == expected


def test_the_first_primitive_sets_the_start_with_its_excursions(library):
    """Sit-ups start lying on the back with the arms crossed over the chest."""
    data = compile_recipe_data(library.get("situps").smp)
    assert data["base_pose"]["root_pitch"] == BUILTIN_POSES["lying"]["root_pitch"]
    for stem, value in MOVEMENTS["arms_crossed"].pose.items():
        assert data["base_pose"][f"left_{stem}"] == data["base_pose"][f"right_{stem}"] == value


def test_a_cycle_without_its_set_up_ends_where_it_started(library):
    wave = compile_recipe_data(library.get("right_hand_wave").smp)
    assert list(wave["primitives"]) == ["raise_hand", "sweep_out", "sweep_back", "lower_hand"]
    assert wave["cycle"]["primitives"] == ["sweep_out", "sweep_back"]  # raising and lowering the hand are set-up
    jacks = compile_recipe_data(library.get("jumping_jacks").smp)
    assert jacks["cycle"]["primitives"] == ["jump_open", "jump_close"]
    (_, crouch, _), (_, air, _), (at_end, end, ease) = _keys(jacks, "jump_close")
    assert (at_end, ease) == (1.0, "stop")
    assert _changed(jacks, end) == {}  # closed: back to the standing start, ready for the next jump
    # the legs close in the air: a hop whose peak is the jump's rise, landing on the ground
    assert jacks["poses"][air]["root_dy"] == pytest.approx(0.09) and jacks["poses"][end]["root_dy"] == 0.0


def test_the_first_gait_primitive_sets_the_gait_pose(library):
    """Walk then run: the base is walking's (plain standing), not running's bent elbows."""
    smp = library.get("walking").smp
    d = smp.model_dump(mode="json")
    d["motion_primitives"][1]["description"] = "run forward"
    data = compile_recipe_data(type(smp).model_validate(d))
    assert data["base_pose"]["left_elbow_flex"] == BUILTIN_POSES["standing"]["elbow_flex"]
    assert MOVEMENTS["run"].pose["elbow_flex"] != BUILTIN_POSES["standing"]["elbow_flex"]


def _last(data: dict, primitive: str) -> dict[str, float]:
    return _changed(data, _keys(data, primitive)[-1][1])


def test_a_return_goes_back_to_where_its_own_outward_primitive_started(library):
    """Raise the hands, clap, separate: separating returns to the raised hands, lowering to the start."""
    smp = library.get("two_hand_front_clap").smp.model_copy(deep=True)
    smp.temporal_structure.is_repetitive, smp.temporal_structure.periodicity = False, "single"
    smp.temporal_structure.repetition_count = 1
    data = compile_recipe_data(smp)  # one clap: no cycle to close, each return alone says where it goes
    assert data["kind"] == "discrete"
    assert _last(data, "separate") == _last(data, "raise_hands") != {}
    assert _last(data, "clap") != _last(data, "raise_hands")
    assert _last(data, "lower_hands") == {}


def test_standing_up_from_a_squat_straightens_the_legs_and_the_trunk(library):
    """'stand up' names the posture the squat never left: it becomes a movement back to straight legs."""
    data = compile_recipe_data(library.get("squats").smp)
    down, up = _last(data, "squat_down"), _last(data, "stand_up")
    assert down["left_knee_flex"] == 105.0 and down["trunk_flex"] == 32.0
    assert up == _last(data, "clasp_hands")  # the clasped hands stay, legs and trunk are straight again
    assert [at for at, _, _ in _keys(data, "stand_up")] == [1.0]


@pytest.mark.parametrize("name,primitive,movement", [
    ("sit_to_lie", "lie_down", "lie_down"), ("stand_to_lie", "lie_down", "lie_down"),
    ("stand_to_sit", "lean_and_lower", "sit_down"),
])
def test_a_change_of_posture_takes_as_long_as_the_librarys_reviewed_recipes_take(library, name, primitive, movement):
    """The nominal paces of lying and sitting down come from the library's recipes (reviewed motion):
    an activity compiled from its SMP alone lies down as fast as the library's transitions do."""
    from vsmp_imu.motion.recipe import recipe_for_entry

    recipe = recipe_for_entry(library.get(name))
    assert recipe.primitives[primitive].duration_s == MOVEMENTS[movement].nominal_s
