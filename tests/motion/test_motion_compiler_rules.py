"""The compiler's pose rules on their own (`motion.compiler`): the lunge's rear leg, the arm circle, the
hop and the pelvis travel of a change of posture, each checked value by value."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from vsmp_imu.motion import compiler
from vsmp_imu.motion.anatomy import MOVEMENTS, SEAT_SHIFT_M, undoes
from vsmp_imu.motion.dofs import DOF_INDEX, N_DOFS
from vsmp_imu.motion.lexicon import PACE, Reading, read_primitive
from vsmp_imu.motion.selfcheck import MAX_STEP_FRACTION
from vsmp_imu.motion.skeleton import DEFAULT_HEIGHT_M, SMPL22_JOINTS


def _reading(**kw) -> Reading:
    base = dict(movements=(), context=(), returns=False, there_and_back=False, hold=False, arm_side=None,
                leg_side=None, direction=0, counter_clockwise=False, posture=None)
    return Reading(**{**base, **kw})


def _step(parts=(), **kw) -> compiler.Step:
    return compiler.Step("p", _reading(**kw), tuple(parts))


def _col(name: str) -> int:
    return DOF_INDEX[name]


@pytest.mark.parametrize("front,back", [("left", "right"), ("right", "left")])
def test_the_lunge_rear_leg_extends_the_hip_and_bends_the_knee(front, back):
    assert compiler._lunge("hip_flex", 70.0, front) == [(_col(f"{front}_hip_flex"), 70.0),
                                                        (_col(f"{back}_hip_flex"), -15.0)]
    assert compiler._lunge("knee_flex", 90.0, front)[1] == (_col(f"{back}_knee_flex"), 85.0)
    assert compiler._lunge("ankle_flex", 10.0, front)[1] == (_col(f"{back}_ankle_flex"), -20.0)
    assert compiler._lunge("hip_abd", 5.0, front)[1] == (_col(f"{back}_hip_abd"), 0.0)  # other stems: rear at 0


def test_an_arm_circle_goes_up_out_down_and_back_on_the_named_arm():
    before = np.linspace(-1.0, 1.0, N_DOFS)
    keys = compiler._circle(_step(parts=("left_hand",)), before)
    assert [(at, ease) for at, _, ease in keys] == [(0.25, "smooth"), (0.5, "smooth"), (0.75, "smooth"),
                                                      (1.0, "stop")]
    flex, abd = _col("left_shoulder_flex"), _col("left_shoulder_abd")
    r = compiler.CIRCLE_DEG
    for (_, vec, _), (d_flex, d_abd) in zip(keys, [(r, r), (0.0, 2 * r), (-r, r), (0.0, 0.0)], strict=True):
        assert vec[flex] - before[flex] == pytest.approx(d_flex, abs=1e-9)
        assert vec[abd] - before[abd] == pytest.approx(d_abd, abs=1e-9)
        others = np.delete(vec - before, [flex, abd])
        assert not others.any()  # the right arm and everything else stay
    ccw = compiler._circle(_step(parts=("left_hand",), counter_clockwise=True), before)
    assert ccw[0][1][flex] - before[flex] == pytest.approx(-r)
    assert ccw[0][1][abd] - before[abd] == pytest.approx(r)


def test_a_circle_without_a_named_side_uses_the_right_arm_and_words_beat_parts():
    before = np.zeros(N_DOFS)
    plain = compiler._circle(_step(), before)[0][1]
    assert plain[_col("right_shoulder_abd")] == pytest.approx(compiler.CIRCLE_DEG)
    assert plain[_col("left_shoulder_abd")] == 0.0
    both = compiler._circle(_step(parts=("left_hand", "right_hand")), before)[0][1]
    assert both[_col("left_shoulder_abd")] == both[_col("right_shoulder_abd")] == pytest.approx(compiler.CIRCLE_DEG)
    worded = compiler._circle(_step(parts=("right_hand",), arm_side="left"), before)[0][1]
    assert worded[_col("left_shoulder_abd")] == pytest.approx(compiler.CIRCLE_DEG)
    assert worded[_col("right_shoulder_abd")] == 0.0


def test_a_hop_crouches_takes_off_and_lands_on_the_target():
    before = np.linspace(-10.0, 10.0, N_DOFS)
    target = before.copy()
    target[_col("left_shoulder_flex")] += 100.0
    keys = compiler._hop(before, target)
    assert [(at, ease) for at, _, ease in keys] == [(0.3, "stop"), (0.6, "smooth"), (1.0, "stop")]
    crouch, air, land = (vec for _, vec, _ in keys)
    shoulder = _col("left_shoulder_flex")
    assert crouch[shoulder] == pytest.approx(before[shoulder] + 30.0)  # 0.7 before + 0.3 target
    assert air[shoulder] == pytest.approx(before[shoulder] + 60.0)  # 0.4 before + 0.6 target: an even pace
    for side in ("left", "right"):
        for stem, extra in compiler.HOP_CROUCH.items():
            assert crouch[_col(f"{side}_{stem}")] == pytest.approx(before[_col(f"{side}_{stem}")] + extra)
        ankle = _col(f"{side}_ankle_flex")
        assert air[ankle] == pytest.approx(before[ankle] - 25.0)
        assert air[_col(f"{side}_knee_flex")] == pytest.approx(before[_col(f"{side}_knee_flex")])
    dy = _col("root_dy")
    assert air[dy] == pytest.approx(before[dy] + MOVEMENTS["jump"].pose["root_dy"])
    assert crouch[dy] == pytest.approx(before[dy])
    assert land is target
    in_place = compiler._hop(before, before.copy())
    # a hop in place still ends on its own key, just before the primitive's end
    assert [(at, ease) for at, _, ease in in_place] == [(0.3, "stop"), (0.6, "smooth"), (0.99, "stop")]
    assert np.array_equal(in_place[-1][1], before)


@pytest.mark.parametrize("src,dst,shift", [
    ("standing", "sitting", SEAT_SHIFT_M), ("kneeling", "lying", SEAT_SHIFT_M), ("standing", "lying", SEAT_SHIFT_M),
    ("sitting", "standing", -SEAT_SHIFT_M), ("lying", "kneeling", -SEAT_SHIFT_M),
    ("sitting", "lying", 0.0), ("standing", "kneeling", 0.0), ("lying", "sitting", 0.0), ("standing", None, 0.0),
])
def test_the_pelvis_travels_onto_a_seat_behind_the_feet_and_back(src, dst, shift):
    assert compiler._posture_shift(src, dst, 0.25) == pytest.approx(0.25 + shift)
    assert math.isclose(compiler._posture_shift(src, dst, 0.0), shift)


@pytest.mark.parametrize("src,dst,shift", [
    ("sitting", "lying", compiler.LIE_SHIFT_M), ("lying", "sitting", -compiler.LIE_SHIFT_M),
    ("standing", "lying", SEAT_SHIFT_M + compiler.LIE_SHIFT_M), ("lying", "standing", -SEAT_SHIFT_M - compiler.LIE_SHIFT_M),
    ("standing", "sitting", SEAT_SHIFT_M), ("sitting", "sitting_floor", 0.0), ("lying", None, 0.0),
])
def test_lying_down_from_a_beds_edge_slides_the_pelvis_back_along_the_bed(src, dst, shift):
    assert compiler._posture_shift(src, dst, 0.25, bed=True) == pytest.approx(0.25 + shift)
    before = np.zeros(N_DOFS)
    if {src, dst} == {"standing", "lying"}:  # passing the seat on the bed's edge
        via = compiler._via(src, dst, before, before, 0.25 + shift, bed=True)
        assert via[_col("root_dz")] == pytest.approx(0.25 + (SEAT_SHIFT_M if dst == "lying" else -compiler.LIE_SHIFT_M))


def test_a_bed_is_read_from_the_smps_contacts_or_a_primitives():
    smp = _smp(("lie", "lie on the back", []))
    smp.object_contact.environment_contact, smp.object_contact.required_contact = ["floor"], []
    assert not compiler._on_bed(smp)
    smp.motion_primitives[0].contact = ["Sofa"]
    assert compiler._on_bed(smp)
    smp.motion_primitives[0].contact = ["bedside table"]
    assert not compiler._on_bed(smp)  # a word of its own: "bed" in "bedside" is not one
    smp.motion_primitives[0].contact = ["hospital bed"]
    assert compiler._on_bed(smp)


def test_standing_and_lying_pass_through_sitting_and_a_seat_through_a_crouch():
    before, target = np.zeros(N_DOFS), np.full(N_DOFS, 8.0)
    before[_col("left_elbow_flex")] = 40.0
    down = compiler._via("standing", "lying", before, target, -0.3)
    up = compiler._via("lying", "standing", before, target, -0.3)
    for via in (down, up):
        assert via[_col("left_hip_flex")] == via[_col("right_knee_flex")] == 88.0  # the sitting pose
        assert via[_col("left_elbow_flex")] == 55.0  # the sitting pose's arms, not the ones before
    assert down[_col("root_dz")] == pytest.approx(-0.3)  # already on the seat's level
    assert up[_col("root_dz")] == pytest.approx(-0.3 + SEAT_SHIFT_M)
    lean = MOVEMENTS["squat"].pose["trunk_flex"]
    for src, dst in (("standing", "sitting"), ("sitting", "standing")):
        crouch = compiler._via(src, dst, before, target, -0.3)
        half = 0.5 * (before + target)  # legs, arms and pelvis half way: never below the seat
        assert np.delete(crouch, _col("trunk_flex")) == pytest.approx(np.delete(half, _col("trunk_flex")))
        assert crouch[_col("trunk_flex")] == lean  # leaning over the feet
        target[_col("trunk_flex")] = 2 * lean + 10.0
        assert compiler._via(src, dst, before, target, -0.3)[_col("trunk_flex")] == lean + 5.0  # already leaning more
        target[_col("trunk_flex")] = 8.0
    seat, stand = compiler._posture_vector("sitting", -0.3), compiler._posture_vector("standing", 0.0)
    assert seat[_col("pelvis_tilt")] < stand[_col("pelvis_tilt")]  # the seat rolls the pelvis back
    for src, dst, a, b in (("standing", "sitting", stand, seat), ("sitting", "standing", seat, stand)):
        over = compiler._via(src, dst, a, b, -0.3)  # the pelvis tilts forward with the trunk, not back
        assert over[_col("pelvis_tilt")] == stand[_col("pelvis_tilt")]
    for src, dst in (("sitting", "lying"), ("standing", "kneeling"), ("kneeling", "sitting"), ("standing", None)):
        assert compiler._via(src, dst, before, target, -0.3) is None


def test_sitting_down_and_standing_up_move_the_pelvis_one_way_only():
    """No dip below the seat on the way down or up (the crouch is half way, not a full squat)."""
    from vsmp_imu.motion.procedural import ProceduralBackend

    backend = ProceduralBackend(compile_mode="always")
    sit = ("sit", "sit upright on the chair", [])
    crouch = ("crouch", "lean forward over the feet in a crouch", [])  # seated: the seat-off crouch, not below it
    for prims, rising in (((("stand", "stand upright", []), ("sit", "bend the hips and knees to sit down", [])), False),
                          ((sit, ("rise", "stand up from the chair", [])), True),
                          ((sit, crouch, ("rise", "stand up from the chair", [])), True)):
        motion = backend.generate(_smp(*prims), seed=0)
        steps = np.diff(motion.positions[:, 0, 1])  # the pelvis height
        assert (steps >= -1e-3).all() if rising else (steps <= 1e-3).all()
    _, keys = _compiled(_smp(sit, crouch))
    off, seated = keys["crouch"][-1][1], compiler.BUILTIN_POSES["sitting"]
    assert off["left_knee_flex"] == seated["knee_flex"] and off["root_dz"] == 0.0  # seat-off: the legs as seated
    assert off["trunk_flex"] >= MOVEMENTS["squat"].pose["trunk_flex"]  # the trunk over the feet
    assert off["pelvis_tilt"] == compiler.BUILTIN_POSES["standing"].get("pelvis_tilt", 0.0)  # tilted up with it
    before = compiler._posture_vector("sitting", 0.1)
    before[_col("trunk_flex")] = 50.0
    assert compiler._crouch_off_seat(before)[_col("trunk_flex")] == 50.0  # already leaning further


def test_each_return_undoes_the_latest_open_outward_primitive():
    steps = [_step() for _ in range(8)]
    for step, action in zip(steps, ["go", "go", "return", "return", "hold", "return", "go", "return"], strict=True):
        step.action = action
    assert compiler._matches(steps) == {1: 2, 0: 3, 6: 7}  # nested, and a return with nothing open is skipped
    assert compiler._matches(steps[:2]) == {}


def test_a_limb_movement_takes_the_side_its_words_or_its_body_parts_name():
    leg, arm = MOVEMENTS["knee_bend"], MOVEMENTS["elbow_flexion"]
    assert (leg.limb, arm.limb) == ("leg", "arm")
    worded = _step(leg_side="left", arm_side="right")
    assert compiler._limb_sides(leg, worded, None) == ("left",)
    assert compiler._limb_sides(arm, worded, None) == ("right",)
    parts = _step(parts=("left_thigh", "right_forearm"))
    assert compiler._limb_sides(leg, parts, None) == ("left",)
    assert compiler._limb_sides(arm, parts, None) == ("right",)


def test_gait_alternates_its_waves_and_a_compiled_entry_is_named_after_the_label():
    from pathlib import Path

    from vsmp_imu.smp.library import ActivityLibrary

    walking = ActivityLibrary.load().match("walking").smp
    cycle = compiler.compile_recipe_data(walking)["cycle"]
    assert cycle["alternate"] is True
    assert cycle["wave"] == {k: [list(p) for p in v] for k, v in MOVEMENTS["walk"].waves.items()}
    entry = compiler.compiled_entry(walking)
    assert entry.path == Path() and entry.name == compiler._slug(walking.activity_label)
    assert compiler.compiled_entry(walking, "w", Path("a.yaml")).path == Path("a.yaml")
    assert compiler._slug("Hammer curl") == "hammer_curl" and compiler._slug("") == "activity"


def test_without_words_the_sides_come_from_the_parts_then_the_dominant_segments_then_the_dominant_side():
    from vsmp_imu.smp.library import ActivityLibrary

    leg, arm = MOVEMENTS["knee_bend"], MOVEMENTS["elbow_flexion"]
    mixed = _step(parts=("left_lower_leg", "right_upper_arm", "pelvis"))
    assert compiler._limb_sides(leg, mixed, None) == ("left",)
    assert compiler._limb_sides(arm, mixed, None) == ("right",)
    smp = ActivityLibrary.load().match("bicep curls").smp.model_copy(deep=True)
    assert compiler._limb_sides(arm, _step(parts=("left_hand", "right_upper_arm")), smp) == ("left", "right")
    smp.body_parts.dominant_moving_segments = ["left_lower_leg", "right_upper_arm", "pelvis"]
    assert compiler._limb_sides(leg, _step(), smp) == ("left",)
    assert compiler._limb_sides(arm, _step(), smp) == ("right",)
    smp.body_parts.dominant_moving_segments = []
    smp.execution_attributes.dominant_side = "left"
    smp.execution_attributes.symmetry = "asymmetric"
    assert compiler._limb_sides(arm, _step(), smp) == ("left",)
    smp.execution_attributes.dominant_side = "right"
    assert compiler._limb_sides(leg, _step(), smp) == ("right",)
    smp.execution_attributes.symmetry = "symmetric"
    assert compiler._limb_sides(arm, _step(), smp) == ("left", "right")
    smp.execution_attributes.symmetry = "asymmetric"
    smp.body_parts.dominant_moving_segments = ["left_forearm"]  # a named segment beats the dominant side
    assert compiler._limb_sides(arm, _step(), smp) == ("left",)


def _actions(*actions: str) -> list[compiler.Step]:
    steps = [_step() for _ in actions]
    for step, action in zip(steps, actions, strict=True):
        step.action = action
    return steps


def test_the_repeated_cycle_peels_off_the_set_up_and_the_final_return():
    # gait: the cycle runs from the first to the last gait primitive
    assert compiler._cycle_span(_actions("hold", "gait", "hold", "gait", "hold", "hold")) == ([0], [1, 2, 3], [4, 5])
    assert compiler._cycle_span(_actions("gait", "gait")) == ([], [0, 1], [])
    assert compiler._cycle_span(_actions("gait", "hold", "gait", "hold", "gait", "hold")) == (
        [], [0, 1, 2, 3, 4], [5])  # from the first to the last gait primitive, not the second
    assert compiler._cycle_span(_actions("hold", "gait", "gait", "return")) == ([0], [1, 2], [3])
    # raise the guard ... lower the guard: the outer go / return pair and the leading hold are set-up
    assert compiler._cycle_span(_actions("hold", "go", "go", "return", "return")) == ([0, 1], [2, 3], [4])
    assert compiler._cycle_span(_actions("go", "return")) == ([], [0, 1], [])
    assert compiler._cycle_span(_actions("go", "hold", "return")) == ([0], [1], [2])
    assert compiler._cycle_span(_actions("hold", "go")) == ([0], [1], [])
    assert compiler._cycle_span(_actions("go")) == ([], [0], [])
    # a trailing hold is peeled once a set-up was, and never down to a single primitive
    assert compiler._cycle_span(_actions("hold", "go", "go", "hold")) == ([0], [1, 2], [3])
    assert compiler._cycle_span(_actions("go", "go", "hold")) == ([], [0, 1, 2], [])
    assert compiler._cycle_span(_actions("hold", "go", "hold")) == ([0], [1, 2], [])


def _closed(action: str, keys: list, current: np.ndarray, start: np.ndarray) -> list:
    step = _actions(action)[0]
    step.keys = list(keys)
    compiler._close(step, np.zeros(N_DOFS), current, start)
    return step.keys


def test_the_last_primitive_of_a_cycle_ends_where_the_cycle_started():
    start, away = np.full(N_DOFS, 10.0), np.full(N_DOFS, 40.0)
    # already there (within a hundredth of CHANGE_DEG, the bound included): nothing to add
    assert _closed("hold", [], start.copy(), start) == []
    edge = np.where(np.arange(N_DOFS) == 0, 0.01 * compiler.CHANGE_DEG, 0.0)
    assert _closed("hold", [], edge, np.zeros(N_DOFS)) == []
    # half a degree off is not there
    off = start.copy()
    off[3] += 0.5
    [(at, pose, ease)] = _closed("hold", [], off, start)
    assert (at, ease) == (1.0, "stop") and np.array_equal(pose, start)
    # an outward primitive goes out and comes back within its time
    (at1, out, _), (at2, back, ease) = _closed("go", [(1.0, away, "stop")], away, start)
    assert (at1, at2, ease) == (0.5, 1.0, "stop") and out is away and np.array_equal(back, start)
    # keys that end elsewhere end at the start instead, at the same time
    mid = np.full(N_DOFS, 25.0)
    keys = _closed("back", [(0.3, away, "stop"), (0.6, mid, "smooth"), (1.0, away, "smooth")], start.copy(), start)
    assert [(at, ease) for at, _, ease in keys] == [(0.3, "stop"), (0.6, "smooth"), (1.0, "stop")]
    assert keys[0][1] is away and keys[1][1] is mid and np.array_equal(keys[-1][1], start)
    # a hold that ends away from the start gets a key back; gait is left to its waves
    assert len(_closed("hold", [], away, start)) == 1
    assert _closed("gait", [], away, start) == []


def test_a_reset_puts_its_dofs_back_to_the_base_on_both_sides():
    base, current = np.zeros(N_DOFS), np.full(N_DOFS, 30.0)
    out = compiler._reset(current, [MOVEMENTS["leg_straighten"], MOVEMENTS["elbow_flexion"]], base)
    reset = [f"{s}_{stem}" for s in ("left", "right") for stem in ("hip_flex", "knee_flex", "ankle_flex")]
    reset += ["root_dz", "trunk_flex"]
    for name, col in DOF_INDEX.items():
        assert out[col] == (0.0 if name in reset else 30.0), name
    assert current[DOF_INDEX["root_dz"]] == 30.0  # a copy, not the pose itself


def test_the_shape_of_a_primitive_follows_its_kind_and_action():
    before, target = np.zeros(N_DOFS), np.full(N_DOFS, 5.0)
    circle = compiler._shape(_step(), [MOVEMENTS["arm_circumduction"]], before, target)
    assert [at for at, _, _ in circle] == [0.25, 0.5, 0.75, 1.0]
    jump = [MOVEMENTS["jump"]]
    hop = compiler._shape(_actions("go")[0], jump, before, target)
    assert [(at, ease) for at, _, ease in hop] == [(0.3, "stop"), (0.6, "smooth"), (1.0, "stop")]
    hop_back = compiler._shape(_actions("back")[0], jump, before, target)
    assert [(at, ease) for at, _, ease in hop_back][3:] == [(1.0, "stop")] and hop_back[3][1] is before
    excursion = [MOVEMENTS["elbow_flexion"]]
    out_and_back = [(0.5, target, "stop"), (1.0, before, "stop")]
    for action, moves in (("back", excursion), ("back", [MOVEMENTS["arm_pendulum_swing"]]),
                          ("return", [MOVEMENTS["arm_pendulum_swing"]])):
        assert compiler._shape(_actions(action)[0], moves, before, target) == out_and_back, action
    assert compiler._shape(_actions("go")[0], [MOVEMENTS["arm_pendulum_swing"]], before, target) == [
        (1.0, target, "stop")]  # a swing that goes out stays out
    assert compiler._shape(_actions("go")[0], excursion, before, target) == [(1.0, target, "stop")]
    assert compiler._shape(_actions("return")[0], excursion, before, target) == [(1.0, target, "stop")]


def test_paired_joints_list_each_side_with_its_mirror_and_drop_the_centre():
    assert compiler._paired(["right_elbow", "left_elbow", "spine3", "left_knee"]) == [
        "right_elbow", "left_elbow", "left_knee", "right_knee"]
    assert compiler._paired(["pelvis"]) == []
    assert [compiler._joint(d) for d in ("left_wrist_rot", "right_toe_flex", "root_dx", "head_tilt")] == [
        "left_elbow", "right_foot", "pelvis", "head"]


def test_a_turn_without_a_side_goes_back_through_the_middle_or_toward_the_dominant_side():
    from vsmp_imu.smp.library import ActivityLibrary

    smp = ActivityLibrary.load().match("bicep curls").smp.model_copy(deep=True)
    pose = np.zeros(N_DOFS)
    pose[_col("trunk_twist")] = 20.0
    assert compiler._twist_hint(pose, smp) == -1  # twisted left: back to the right
    pose[_col("trunk_twist")] = -20.0
    assert compiler._twist_hint(pose, smp) == 1
    pose[_col("trunk_twist")] = compiler.CHANGE_DEG  # not yet twisted
    smp.execution_attributes.dominant_side = "right"
    assert compiler._twist_hint(pose, smp) == -1
    smp.execution_attributes.dominant_side = "left"
    assert compiler._twist_hint(pose, smp) == 1


def test_turning_targets_take_the_words_side_then_the_hint_and_root_travel_adds_up():
    twist = MOVEMENTS["trunk_rotation"]
    stem, value = next(iter(twist.pose.items()))
    assert stem == "trunk_twist"
    current = np.zeros(N_DOFS)
    current[_col("root_dz")] = 0.5
    col = _col(stem)
    assert compiler._targets(twist, stem, value, _step(direction=-1), None, current, 1) == [(col, -value)]
    assert compiler._targets(twist, stem, value, _step(), None, current, -1) == [(col, -value)]
    assert compiler._targets(twist, stem, value, _step(), None, current, 0) == [(col, value)]
    for turning in ("trunk_lean", "root_yaw", "head_turn"):
        assert compiler._targets(twist, turning, 10.0, _step(direction=-1), None, current, 0) == [
            (_col(turning), -10.0)]
    assert compiler._targets(twist, "trunk_flex", 10.0, _step(direction=-1), None, current, 0) == [
        (_col("trunk_flex"), 10.0)]  # not a turn: the side does not flip it
    # a body already turned: the whole body turns on from where it faces; the trunk, the lean and the
    # head turn to their angle relative to the body, wherever they were
    turned = np.zeros(N_DOFS)
    for name, angle in (("root_yaw", 30.0), ("trunk_twist", 20.0), ("trunk_lean", -15.0), ("head_turn", 25.0)):
        turned[_col(name)] = angle
    assert compiler._targets(twist, "root_yaw", 10.0, _step(direction=-1), None, turned, 0) == [
        (_col("root_yaw"), 20.0)]
    for relative in ("trunk_twist", "trunk_lean", "head_turn"):
        assert compiler._targets(twist, relative, 10.0, _step(direction=-1), None, turned, 0) == [
            (_col(relative), -10.0)]
    lunge = MOVEMENTS["lunge"]
    assert compiler._targets(lunge, "hip_flex", 80.0, _step(leg_side="right"), None, current, 0) == [
        (_col("right_hip_flex"), 80.0), (_col("left_hip_flex"), -15.0)]
    squat = MOVEMENTS["squat"]
    assert compiler._targets(squat, "root_dz", -0.27, _step(), None, current, 0) == [
        (_col("root_dz"), pytest.approx(0.23))]
    assert compiler._targets(squat, "trunk_flex", 32, _step(), None, current, 0) == [(_col("trunk_flex"), 32.0)]
    assert compiler._targets(squat, "knee_flex", 105, _step(), None, current, 0) == [
        (_col("left_knee_flex"), 105.0), (_col("right_knee_flex"), 105.0)]


def _bone(joint: str) -> float:
    return float(np.linalg.norm(compiler._BODY.offsets[SMPL22_JOINTS.index(joint)]))


def _arc(radius: float, degrees: float) -> float:
    """The path PATH_SAMPLES chords make along an arc (what `_joint_paths` measures of a hinge)."""
    n = compiler.PATH_SAMPLES
    return 2 * n * radius * math.sin(math.radians(degrees) / (2 * n))


def test_the_speed_limit_times_the_fastest_joint_along_its_path():
    step = _step()
    step.start = np.zeros(N_DOFS)
    assert compiler._slowest(step) == 0.0  # no keys
    a = np.zeros(N_DOFS)
    a[_col("left_elbow_flex")], a[_col("right_elbow_flex")] = 90.0, 120.0  # the faster arm: 120 degrees
    b = a.copy()
    b[_col("root_dz")] = 1.0  # the whole body a metre forward
    step.keys = [(0.5, a, "stop"), (1.0, b, "stop")]
    hand = _arc(_bone("right_wrist"), 120.0)
    assert compiler._slowest(step) == pytest.approx(max(hand, 1.0) / 0.5 / compiler.MAX_MEAN_SPEED_M_S)
    step.keys = [(0.0, a, "stop")]  # a key at the start: the time step is floored, not zero
    assert compiler._slowest(step) == pytest.approx(hand / 1e-3 / compiler.MAX_MEAN_SPEED_M_S, rel=1e-3)
    step.start = None
    assert compiler._slowest(step) == 0.0


def test_the_speed_limit_is_the_quality_filters_step_limit_at_fast_tempo_and_large_amplitude():
    peak = compiler.MAX_MEAN_SPEED_M_S * 1.875 * 1.5 * 1.4 / compiler.SPEED_SPARE  # minimum-jerk peak, fast, large
    assert peak / 30.0 == pytest.approx(MAX_STEP_FRACTION * DEFAULT_HEIGHT_M)


def test_a_joint_path_follows_the_arc_of_the_bones_a_rotation_carries():
    start = np.zeros(N_DOFS)
    elbow, shoulder = start.copy(), start.copy()
    elbow[_col("left_elbow_flex")] = 90.0
    shoulder[_col("left_shoulder_flex")] = 90.0
    paths = compiler._joint_paths(np.stack([start, start, elbow, start, shoulder]))
    assert paths[0] == paths[2] - paths[1] == 0.0  # no change, no path; back the same way
    assert paths[1] == pytest.approx(_arc(_bone("left_wrist"), 90.0), rel=1e-3)  # the forearm swings
    # the whole arm swings (nearly straight at rest: its reach a little under the two bones)
    assert paths[3] == pytest.approx(_arc(_bone("left_wrist") + _bone("left_elbow"), 90.0), rel=5e-3)


def test_durations_follow_the_action_and_the_movement():
    from vsmp_imu.smp.library import ActivityLibrary

    smp = ActivityLibrary.load().match("bicep curls").smp  # repeated: not static; its 2 shares do not fit 5 steps
    steps = _actions("hold", "back", "back", "go", "go")
    moves = [(), (MOVEMENTS["elbow_flexion"],), (MOVEMENTS["leg_kick"],), (MOVEMENTS["arm_circumduction"],),
             (MOVEMENTS["elbow_flexion"], MOVEMENTS["jump"])]
    for step, m in zip(steps, moves, strict=True):
        step.movements = m
    compiler._durations(steps, smp)
    flex, kick = MOVEMENTS["elbow_flexion"].nominal_s, MOVEMENTS["leg_kick"].nominal_s
    assert kick < 0.6 <= flex
    assert [s.duration_s for s in steps] == pytest.approx([compiler.HOLD_S, 2.0 * flex, 1.6 * kick, 1.6,
                                                           max(flex, MOVEMENTS["jump"].nominal_s)])


def test_a_movements_first_dof_wins_over_another_movements_side_dofs():
    """Curl while pressing overhead: the press's straight elbow (a side DOF) yields to the curl's elbow."""
    curl, press = MOVEMENTS["elbow_flexion"], MOVEMENTS["shoulder_flexion_overhead"]
    assert list(press.pose)[1] == "elbow_flex" and list(curl.pose)[0] == "elbow_flex"
    out = compiler._apply(np.zeros(N_DOFS), [curl, press], _step(arm_side="left"), None, 0)
    assert out[_col("left_elbow_flex")] == curl.pose["elbow_flex"]
    assert out[_col("left_shoulder_flex")] == press.pose["shoulder_flex"]
    assert out[_col("right_elbow_flex")] == 0.0
    alone = compiler._apply(np.zeros(N_DOFS), [press], _step(arm_side="left"), None, 0)
    assert alone[_col("left_elbow_flex")] == press.pose["elbow_flex"]  # its side DOF applies when uncontested


def test_apply_skips_resets_and_passes_the_turn_hint_on():
    current = np.zeros(N_DOFS)
    current[_col("trunk_flex")] = 30.0
    out = compiler._apply(current, [MOVEMENTS["trunk_upright"], MOVEMENTS["elbow_flexion"]],
                          _step(arm_side="right"), None, 0)
    assert out[_col("trunk_flex")] == 30.0  # a reset is _reset's job, not a target
    assert out[_col("right_elbow_flex")] == MOVEMENTS["elbow_flexion"].pose["elbow_flex"]
    twist = MOVEMENTS["trunk_rotation"]
    turned = compiler._apply(current, [twist], _step(), None, -1)
    assert turned[_col("trunk_twist")] == -twist.pose["trunk_twist"]


def test_a_relative_root_travel_is_applied_once():
    # the second pass (a movement's first DOF wins) must not add the travel again
    squat = MOVEMENTS["squat"]
    out = compiler._apply(np.zeros(N_DOFS), [squat], _step(), None, 0)
    assert out[_col("root_dz")] == pytest.approx(squat.pose["root_dz"])
    start = np.zeros(N_DOFS)
    start[_col("root_dz")] = 0.5  # without a neutral pose, travel is relative to where the step starts
    again = compiler._apply(start, [squat], _step(), None, 0)
    assert again[_col("root_dz")] == pytest.approx(0.5 + squat.pose["root_dz"])


def test_a_second_squat_does_not_sink_the_pelvis_further():
    squat = MOVEMENTS["squat"]
    low = compiler._apply(np.zeros(N_DOFS), [squat], _step(), None, 0, neutral=np.zeros(N_DOFS))
    lower = compiler._apply(low, [squat], _step(), None, 0, neutral=np.zeros(N_DOFS))
    assert lower[_col("root_dz")] == low[_col("root_dz")] == pytest.approx(squat.pose["root_dz"])


def test_a_jump_lands_where_it_took_off():
    """The root rises in the air only: a jump's target keeps the take-off height (each jump of
    a sequence of jumps lifted the body 9 cm for good)."""
    start = np.zeros(N_DOFS)
    start[_col("root_dy")] = 0.2
    landed = compiler._apply(start, [MOVEMENTS["jump"]], _step(), None, 0)
    assert landed[_col("root_dy")] == 0.2
    keys = compiler._hop(start, landed)
    assert max(k[1][_col("root_dy")] for k in keys) == pytest.approx(0.2 + MOVEMENTS["jump"].pose["root_dy"])
    assert keys[-1][1][_col("root_dy")] == 0.2


def test_structural_entries_of_the_sequence_are_not_primitives():
    from vsmp_imu.smp.library import ActivityLibrary

    smp = ActivityLibrary.load([Path(__file__).resolve().parents[1] / "fixtures" / "compiled_activities"]).get(
        "hammer_curl_kettlebell").smp
    d = smp.model_dump(mode="json")
    d["primitive_sequence"] = ["curl_up", "Repeat", "lower", "repeat cycle"]
    d["primitive_durations"] = {"type": "unknown", "values": []}
    steps = compiler._steps(type(smp).model_validate(d))
    assert [s.name for s in steps] == ["curl_up", "lower"]
    assert [s.action for s in steps] == ["go", "return"]


def _library_smp(name: str):
    from vsmp_imu.smp.library import ActivityLibrary

    return ActivityLibrary.load().get(name).smp.model_copy(deep=True)


def test_a_motion_is_periodic_when_its_smp_or_its_gait_says_so():
    smp = _library_smp("bicep_curls")
    ts = smp.temporal_structure
    ts.is_repetitive, ts.periodicity, ts.repetition_count = False, "none", "unknown"
    assert smp.repetition_count() is None and not compiler._periodic(smp, [])
    ts.is_repetitive = True
    assert compiler._periodic(smp, [])
    ts.is_repetitive, ts.periodicity = False, "cyclic"
    assert compiler._periodic(smp, [])
    ts.periodicity = "none"
    for count, periodic in ((1, False), (2, True)):
        ts.repetition_count = count
        assert smp.repetition_count() == count and compiler._periodic(smp, []) is periodic
    ts.repetition_count = "unknown"
    assert compiler._periodic(smp, _actions("hold", "gait")) and not compiler._periodic(smp, _actions("go"))


def test_the_start_posture_comes_from_the_first_primitive_then_gait_then_a_seat():
    smp = _library_smp("bicep_curls")
    smp.object_contact.environment_contact, smp.object_contact.objects = [], ["dumbbells"]
    sit = _step()
    sit.movements = (MOVEMENTS["sit_down"],)
    assert compiler._start_posture(smp, [sit]) == MOVEMENTS["sit_down"].posture == "sitting"
    lie = _step(posture="lying")  # a hold that names its posture
    assert compiler._sets_start(lie) and compiler._start_posture(smp, [lie]) == "lying"
    curl = _step(posture="sitting")  # names a posture but moves: it does not set the start
    curl.action, curl.movements = "go", (MOVEMENTS["elbow_flexion"],)
    assert not compiler._sets_start(curl) and compiler._start_posture(smp, [curl]) == "standing"
    smp.object_contact.objects = ["office chair"]
    assert compiler._start_posture(smp, [curl]) == "sitting"  # a seat among the contacts
    assert compiler._start_posture(smp, [curl, *_actions("gait")]) == "standing"  # gait stands
    rise = _step()
    rise.action, rise.movements = "go", (MOVEMENTS["stand_up"],)
    assert compiler._start_posture(smp, [curl, rise]) == "standing"  # a change of support: not seated


def test_a_primitive_sets_the_start_when_it_holds_or_names_a_posture_with_resets_only():
    moving = _actions("go")[0]
    assert not compiler._sets_start(moving)  # no posture named, no movement: not all resets by default
    assert compiler._sets_start(_actions("hold")[0])
    upright = _step(posture="standing")
    upright.action, upright.movements = "go", (MOVEMENTS["trunk_upright"],)
    assert compiler._sets_start(upright)


# -- whole sequences: what each primitive does to the pose, read from the compiled recipe --------------
_TEMPLATE = Path(__file__).resolve().parents[1] / "fixtures" / "compiled_activities" / "front_raise.yaml"


def _smp(*prims, periodic: bool = False, dominant: str = "bilateral", symmetry: str = "symmetric",
         shares: list[float] | None = None):
    """An SMP of `prims` ((name, description, body parts) each) on the front raise's other fields."""
    import yaml

    from vsmp_imu.smp.schema import SMP

    d = yaml.safe_load(_TEMPLATE.read_text())["smp"]
    d["motion_primitives"] = [dict(name=n, order_index=i, description=desc, body_parts=list(parts))
                              for i, (n, desc, parts) in enumerate(prims)]
    d["primitive_sequence"] = [p[0] for p in prims]
    d["primitive_durations"] = ({"type": "relative", "values": shares} if shares
                                else {"type": "unknown", "values": []})
    d["temporal_structure"].update(is_repetitive=periodic, periodicity="cyclic" if periodic else "none",
                                   repetition_count=10 if periodic else "unknown")
    d["execution_attributes"].update(dominant_side=dominant, symmetry=symmetry)
    return SMP.model_validate(d)


def _compiled(smp) -> tuple[dict, dict[str, list[tuple[float, dict]]]]:
    """The recipe data and, per primitive, its keys as (time, pose by DOF name)."""
    data = compiler.compile_recipe_data(smp)
    keys = {name: [(at, data["poses"][pose]) for at, pose, _ in p["keys"]] for name, p in data["primitives"].items()}
    return data, keys


_WAIT = ("wait", "stand and wait", [])
_ARMS = ["left_upper_arm", "right_upper_arm"]


def test_a_return_goes_back_to_where_its_outward_primitive_started_not_to_the_start_pose():
    _, keys = _compiled(_smp(_WAIT, ("sit", "sit down on the chair", []), ("raise", "raise both arms forward", _ARMS),
                             ("lower", "lower the arms", _ARMS)))
    seated = keys["sit"][-1][1]
    assert seated["left_knee_flex"] > 60.0 and seated["root_dz"] == pytest.approx(SEAT_SHIFT_M)
    assert keys["raise"][-1][1]["left_shoulder_flex"] > 60.0
    assert keys["lower"] == [(1.0, seated)]  # still seated: back to the pose the raise started from


def test_after_sitting_down_standing_up_takes_the_pelvis_back_over_the_feet():
    _, keys = _compiled(_smp(_WAIT, ("sit", "sit down on the chair", []), ("rise", "stand up", [])))
    (_, crouch), (_, up) = keys["rise"]
    assert crouch["root_dz"] == pytest.approx(0.5 * SEAT_SHIFT_M)  # the crouch half way up, from the seat
    assert up["root_dz"] == pytest.approx(0.0) and up["left_knee_flex"] == 0.0


def test_a_primitive_naming_the_posture_the_body_is_already_in():
    # standing up out of a squat straightens the legs and the trunk
    _, keys = _compiled(_smp(("squat", "squat down", []), ("rise", "stand up", [])))
    low, up = keys["squat"][-1][1], keys["rise"][-1][1]
    assert low["left_knee_flex"] > 60.0 and low["trunk_flex"] > 10.0 and low["root_dz"] < -0.1
    assert (up["left_knee_flex"], up["right_hip_flex"], up["trunk_flex"], up["root_dz"]) == (0.0, 0.0, 0.0, 0.0)
    # sitting down when seated already, with nothing else to do: a hold
    data, keys = _compiled(_smp(("sit", "sit down on the chair", []), ("lean", "lean the trunk forward", []),
                                ("again", "sit down on the chair", [])))
    assert keys["again"] == [] and keys["sit"] == []
    assert data["primitives"]["again"]["duration_s"] == compiler.HOLD_S
    # lying down when lying already, with the arms overhead: the arms move, the posture does not
    data, keys = _compiled(_smp(("lie", "lie down with the arms overhead", _ARMS), ("hold", "hold still", [])))
    assert len(keys["lie"]) == 1 and keys["lie"][0][1]["left_shoulder_flex"] > 120.0
    assert data["base_pose"]["root_pitch"] == keys["lie"][0][1]["root_pitch"] != 0.0
    assert data["primitives"]["lie"]["duration_s"] == MOVEMENTS["lie_down"].nominal_s


def test_a_change_of_posture_carries_the_arm_movements_it_names():
    _, keys = _compiled(_smp(_WAIT, ("lie", "lie down with the arms overhead", [*_ARMS, "pelvis"])))
    (_, via), (_, lying) = keys["lie"]
    assert via["left_knee_flex"] == 88.0  # through sitting
    assert lying["root_pitch"] != 0.0 and lying["left_shoulder_flex"] == lying["right_shoulder_flex"] > 120.0
    assert lying["left_knee_flex"] < 30.0  # the legs follow the posture, not the sitting pass


@pytest.mark.parametrize("dominant,sign", [("right", -1.0), ("left", 1.0)])
def test_a_twist_without_a_side_turns_toward_the_dominant_side(dominant, sign):
    value = MOVEMENTS["trunk_rotation"].pose["trunk_twist"]
    _, keys = _compiled(_smp(_WAIT, ("twist", "twist the trunk", []), dominant=dominant, symmetry="asymmetric"))
    assert keys["twist"][-1][1]["trunk_twist"] == pytest.approx(sign * value)
    # the same inside a change of posture
    _, keys = _compiled(_smp(_WAIT, ("sit", "sit down and twist the trunk", []), dominant=dominant,
                             symmetry="asymmetric"))
    assert keys["sit"][-1][1]["trunk_twist"] == pytest.approx(sign * value)


def test_a_swing_that_goes_out_stays_out_and_a_jump_back_hops_home():
    _, keys = _compiled(_smp(_WAIT, ("swing", "swing the right arm", ["right_upper_arm"])))
    assert keys["swing"] == [(1.0, pytest.approx(keys["swing"][-1][1]))]
    assert keys["swing"][-1][1]["right_shoulder_flex"] == pytest.approx(MOVEMENTS["arm_pendulum_swing"].pose[
        "shoulder_flex"])
    assert keys["swing"][-1][1]["left_shoulder_flex"] == 0.0
    # a return with a jump in it hops back to where the outward jump started
    _, keys = _compiled(_smp(_WAIT, ("out", "jump the feet apart", []), ("home", "jump back to the start", [])))
    home = keys["home"]
    assert [at for at, _ in home] == [0.3, 0.6, 1.0]
    assert home[1][1]["root_dy"] == pytest.approx(MOVEMENTS["jump"].pose["root_dy"])
    assert home[-1][1]["left_hip_abd"] == pytest.approx(0.0) and home[-1][1]["root_dy"] == 0.0
    assert keys["out"][-1][1]["left_hip_abd"] > 10.0


def test_a_plank_is_the_plank_pose_over_lying_prone_and_an_unknown_posture_stands():
    from vsmp_imu.motion.anatomy import PLANK_POSE
    from vsmp_imu.motion.dofs import BUILTIN_POSES, pose_vector

    plank = compiler._posture_vector("plank", 0.2)
    assert plank[_col("root_pitch")] == PLANK_POSE["root_pitch"] == 72
    assert plank[_col("left_shoulder_flex")] == plank[_col("right_shoulder_flex")] == 72
    assert plank[_col("right_wrist_flex")] == -80 and plank[_col("left_toe_flex")] == 30
    assert plank[_col("root_dz")] == 0.2
    standing = pose_vector(BUILTIN_POSES["standing"])
    assert np.array_equal(compiler._posture_vector("floating", 0.0), standing)
    assert not np.array_equal(standing, np.zeros(N_DOFS))
    sitting = compiler._posture_vector("sitting", -0.1)
    assert sitting[_col("left_hip_flex")] == 88.0 and sitting[_col("root_dz")] == -0.1


def test_left_and_right_versions_of_one_movement_each_go_out_and_back():
    def actions(*prims):
        return [s.action for s in compiler._steps(_smp(*prims))]

    knees = (("left", "lift the left knee", []), ("right", "lift the right knee", []))
    assert actions(*knees) == ["back", "back"]
    assert actions(_WAIT, *knees) == ["hold", "back", "back"]  # a hold before them changes nothing
    arms = (("left", "raise the left arm forward", []), ("right", "raise the right arm forward", []))
    assert actions(*arms) == ["back", "back"]
    assert actions(("left", "lift the left knee", []), ("again", "lift the left knee once more", [])) == ["go", "go"]
    assert actions(("left", "lift the left knee", []), ("right", "kick the right leg forward", [])) == ["go", "go"]
    assert actions(("knee", "lift the knee", []), ("right", "lift the right knee", [])) == ["go", "go"]  # no side: no pair


def test_a_limb_movement_needs_that_limb_among_the_body_parts():
    curl, knee, rise = MOVEMENTS["elbow_flexion"], MOVEMENTS["knee_bend"], MOVEMENTS["stand_up"]
    assert compiler._limb_named(curl, ("left_upper_arm",)) and compiler._limb_named(curl, ("hand",))
    assert compiler._limb_named(knee, ("right_lower_leg",)) and not compiler._limb_named(knee, ("left_forearm",))
    assert not compiler._limb_named(curl, ("pelvis",)) and not compiler._limb_named(curl, ("right_thigh",))
    assert compiler._limb_named(curl, ())  # no parts listed: nothing to check against
    assert rise.kind == "posture" and compiler._limb_named(rise, ("left_hand",))  # only excursions are checked
    steps = compiler._steps(_smp(("curl", "curl the dumbbell up", ["pelvis"])))
    assert steps[0].parts == ("pelvis",) and steps[0].movements == () and steps[0].action == "hold"
    steps = compiler._steps(_smp(("curl", "curl the dumbbell up", ["right_forearm", "right_hand"])))
    assert steps[0].parts == ("right_forearm", "right_hand") and steps[0].movements == (
        curl, MOVEMENTS["forearm_supination"])  # a curl turns the palm up


def test_a_primitive_holds_when_it_names_no_movement_and_goes_there_and_back_when_told():
    steps = compiler._steps(_smp(("still", "stand still", []), ("curl", "curl up and back", [])))
    assert [s.action for s in steps] == ["hold", "back"]


def test_durations_of_a_swing_there_and_back_and_of_gait_ignore_the_shares():
    swing, walk = MOVEMENTS["arm_pendulum_swing"], MOVEMENTS["walk"]
    assert swing.nominal_s == 0.6  # the edge: from 0.6 s on, there and back takes twice the time
    smp = _smp(("a", "walk forward", []), ("b", "stand still", []), periodic=True, shares=[0.9, 0.1])
    steps = _actions("back", "gait")
    steps[0].movements, steps[1].movements = (swing,), (walk,)
    compiler._durations(steps, smp)
    assert [s.duration_s for s in steps] == pytest.approx([1.2, walk.nominal_s])


def test_the_smps_shares_set_the_durations_within_their_bounds():
    holds = [(f"h{i}", "hold still", []) for i in range(21)]
    data = compiler.compile_recipe_data(_smp(*holds, shares=[0.96] + [0.002] * 20))
    assert data["kind"] == "static"
    total = 21 * compiler.STATIC_HOLD_S  # 63 s to share out
    assert 0.96 * total > 60.0 and 0.002 * total < 0.15
    assert data["primitives"]["h0"]["duration_s"] == 60.0
    assert {data["primitives"][f"h{i}"]["duration_s"] for i in range(1, 21)} == {0.15}


def test_shares_are_the_written_durations_normalized_and_only_when_every_primitive_has_one():
    two = (("a", "raise the arms forward", _ARMS), ("b", "lower the arms", _ARMS))
    assert compiler._shares(_smp(*two, shares=[2.0, 6.0]), 2) == pytest.approx([0.25, 0.75])
    assert compiler._shares(_smp(*two, shares=[2.0, 6.0]), 3) is None
    assert compiler._shares(_smp(*two, shares=[0.0, 6.0]), 2) is None
    assert compiler._shares(_smp(*two), 2) is None
    smp = _smp(*two, shares=[2.0, 6.0])
    d = smp.model_dump(mode="json")
    d["primitive_sequence"] = ["a", "repeat", "b"]
    d["primitive_durations"]["values"] = [2.0, 1.0, 6.0]
    assert compiler._shares(type(smp).model_validate(d), 2) == pytest.approx([0.25, 0.75])  # "repeat" left out


def test_a_motion_is_static_only_when_held_unrepeated_and_unchanged():
    smp = _library_smp("bicep_curls")
    ts = smp.temporal_structure
    ts.is_repetitive, ts.periodicity, ts.repetition_count = False, "none", "unknown"
    sit = _step()
    sit.movements = (MOVEMENTS["sit_down"],)
    assert compiler._static(smp, [_step()])
    assert compiler._static(smp, [sit])  # the first primitive sets the start posture: no change
    assert not compiler._static(smp, [_step(), sit])  # a change of posture later
    ts.repetition_count = 1
    assert not compiler._static(smp, [_step()])  # a count, even of one
    ts.repetition_count, ts.periodicity = "unknown", "cyclic"
    assert not compiler._static(smp, [_step()])


def test_pose_values_are_written_to_four_decimals():
    vec = np.full(N_DOFS, 0.123456)
    out = compiler._pose_dict(vec)
    assert list(out) == list(DOF_INDEX) and set(out.values()) == {0.1235}


def test_the_moved_columns_are_those_past_the_threshold():
    base = np.zeros(N_DOFS)
    step = _step()
    pose = base.copy()
    pose[_col("left_elbow_flex")] = compiler.CHANGE_DEG
    pose[_col("right_elbow_flex")] = compiler.CHANGE_DEG + 0.5
    pose[_col("trunk_flex")] = -20.0
    step.keys = [(1.0, pose, "stop")]
    assert compiler._moved_columns([step], base) == {_col("right_elbow_flex"): 1.5, _col("trunk_flex"): 20.0}


def _moving(**dofs: float) -> compiler.Step:
    step = _step()
    pose = np.zeros(N_DOFS)
    for name, value in dofs.items():
        pose[_col(name)] = value
    step.keys = [(1.0, pose, "stop")]
    return step


def test_principal_joints_are_those_moved_at_least_fifteen_degrees_else_the_four_most_moved():
    base = np.zeros(N_DOFS)
    step = _moving(left_elbow_flex=15.0, right_knee_flex=14.9, trunk_flex=40.0, head_flex=3.0)
    assert compiler._principal_joints({}, base, [step]) == ["spine3", "left_elbow"]
    weak = _moving(left_elbow_flex=5.0, right_knee_flex=6.0, trunk_flex=7.0, head_flex=3.0, left_hip_flex=2.0)
    assert compiler._principal_joints({}, base, [weak]) == ["spine3", "right_knee", "left_elbow", "head"]
    assert compiler._principal_joints({}, base, [_step()]) == ["pelvis"]  # nothing moves


def test_principal_joints_take_the_larger_of_a_dofs_keys_and_its_wave():
    base = np.zeros(N_DOFS)
    data = {"cycle": {"wave": {"elbow_flex": [[0.0, -5.0], [0.5, 5.0]], "trunk_flex": [[0.0, 0.0], [0.5, 0.5]]}}}
    step = _moving(left_elbow_flex=30.0, head_flex=2.0)
    assert compiler._principal_joints(data, base, [step]) == ["left_elbow"]  # keys 30 > wave 10
    step = _moving(left_elbow_flex=8.0, head_flex=2.0)
    assert compiler._principal_joints(data, base, [step]) == ["left_elbow", "right_elbow", "head", "spine3"]
    # waves alone, under a degree: ranked by their own range
    data["cycle"]["wave"] = {"elbow_flex": [[0.0, 0.0], [0.5, 10.0]], "trunk_flex": [[0.0, 0.0], [0.5, 0.8]],
                             "knee_flex": [[0.0, 0.0], [0.5, 0.5]]}
    assert compiler._principal_joints(data, base, [_step()]) == ["left_elbow", "right_elbow", "spine3", "left_knee"]


def test_a_joint_scores_its_most_moved_dof():
    base = np.zeros(N_DOFS)
    assert _col("left_shoulder_abd") < _col("left_shoulder_flex")  # the larger value comes last here
    step = _moving(left_shoulder_flex=5.0, left_shoulder_abd=30.0, trunk_flex=20.0)
    assert compiler._principal_joints({}, base, [step]) == ["left_shoulder", "spine3"]


def test_root_travel_moves_every_joint_as_far_in_the_speed_limit():
    step = _step()
    step.start = np.zeros(N_DOFS)
    low = np.zeros(N_DOFS)
    low[_col("root_dz")] = -0.5  # 50 cm, nothing else
    step.keys = [(1.0, low, "stop")]
    assert compiler._slowest(step) == pytest.approx(0.5 / compiler.MAX_MEAN_SPEED_M_S)
    up = np.zeros(N_DOFS)
    up[_col("root_dy")] = 0.09  # a hop's rise counts too
    step.keys = [(1.0, up, "stop")]
    assert compiler._slowest(step) == pytest.approx(0.09 / compiler.MAX_MEAN_SPEED_M_S)


def test_a_jump_that_closes_a_cycle_hops_back_to_the_start():
    _, keys = _compiled(_smp(("out", "jump the feet apart", []), ("in", "jump the feet together", []), periodic=True))
    out, back = keys["out"], keys["in"]
    assert out[-1][1]["left_hip_abd"] > 10.0
    assert [at for at, _ in back] == [0.3, 0.6, 1.0]  # crouch, air, landing
    assert back[1][1]["root_dy"] == pytest.approx(MOVEMENTS["jump"].pose["root_dy"])
    assert back[0][1]["left_hip_abd"] == pytest.approx(0.7 * out[-1][1]["left_hip_abd"], abs=1e-3)  # from `out`
    assert back[-1][1]["left_hip_abd"] == 0.0


def test_arm_circles_repeated_move_the_arm_and_end_where_they_began():
    data, keys = _compiled(_smp(("circle", "circle the right arm clockwise", ["right_upper_arm"]), periodic=True))
    base = data["base_pose"]
    circle = keys["circle"]
    assert [at for at, _ in circle] == [0.25, 0.5, 0.75, 1.0]
    top = max(pose["right_shoulder_abd"] - base["right_shoulder_abd"] for _, pose in circle)
    assert top == pytest.approx(2 * compiler.CIRCLE_DEG)
    assert circle[-1][1] == pytest.approx(base)
    assert "right_shoulder" in data["principal_joints"]


def test_a_primitive_after_a_circle_starts_where_the_circle_ended():
    _, keys = _compiled(_smp(_WAIT, ("circle", "circle the right arm clockwise", ["right_upper_arm"]),
                             ("raise", "raise the left arm forward", ["left_upper_arm"])))
    end, raised = keys["circle"][-1][1], keys["raise"][-1][1]
    assert raised["left_shoulder_flex"] > 60.0
    for dof in ("right_shoulder_flex", "right_shoulder_abd", "right_elbow_flex"):
        assert raised[dof] == end[dof], dof  # the right arm stays where the circle left it


def test_pelvis_travel_counts_in_centimetres_among_the_principal_joints():
    base = np.zeros(N_DOFS)
    squat = _moving(root_dz=-0.27, left_knee_flex=20.0)
    assert compiler._moved_columns([squat], base)[_col("root_dz")] == pytest.approx(27.0)
    assert compiler._principal_joints({}, base, [squat]) == ["pelvis", "left_knee"]
    assert compiler._moved_columns([_moving(root_dz=0.005)], base) == {}  # half a centimetre is still
    run = {"cycle": {"wave": {"root_dy": [[0.0, 0.0], [0.5, 0.2]]}}}
    assert compiler._principal_joints(run, base, [_step()]) == ["pelvis"]
    assert compiler._principal_joints(run, base, [_moving(left_knee_flex=16.0)]) == ["pelvis", "left_knee"]


def test_two_leading_holds_are_both_set_up():
    assert compiler._cycle_span(_actions("hold", "hold", "go", "go")) == ([0, 1], [2, 3], [])


def test_a_second_squat_in_a_sequence_keeps_the_first_ones_depth():
    _, keys = _compiled(_smp(("down", "squat down", []), ("again", "squat down again", [])))
    assert keys["again"][-1][1]["root_dz"] == keys["down"][-1][1]["root_dz"] == pytest.approx(
        MOVEMENTS["squat"].pose["root_dz"])


def test_the_speed_limit_times_each_key_from_the_one_before():
    step = _step()
    step.start = np.zeros(N_DOFS)
    small, big = np.zeros(N_DOFS), np.zeros(N_DOFS)
    small[_col("left_elbow_flex")] = 10.0
    big[_col("left_elbow_flex")] = 110.0
    step.keys = [(0.5, small, "stop"), (0.6, big, "stop")]  # 100 degrees in a tenth of the time
    assert compiler._slowest(step) == pytest.approx(
        _arc(_bone("left_wrist"), 100.0) / 0.1 / compiler.MAX_MEAN_SPEED_M_S, rel=1e-3)


@pytest.mark.parametrize("text,pelvis,turns", [
    ("walk forward", {}, None),
    ("walk up the stairs", compiler.STAIRS_PELVIS, {}),
    ("walk down the stairs", compiler.STAIRS_PELVIS, {}),
    ("jog forward", None, None),
])
def test_gait_takes_the_librarys_pelvis_path_and_stairs_their_landings(text, pelvis, turns):
    data = compiler.compile_recipe_data(_smp(("go", text, [])))
    assert data.get("pelvis") == pelvis and data.get("turns") == turns
    assert data["locomotion"] == {"walk forward": "forward", "jog forward": "forward"}.get(text, data["locomotion"])
    assert data["locomotion"] != "none"


def test_a_gait_step_takes_the_gaits_duration_whatever_else_it_names():
    walk = MOVEMENTS["walk"]
    steps = compiler._steps(_smp(("step", "walk forward, swinging the right leg forward", ["right_thigh"]),
                                 periodic=True))
    assert steps[0].action == "gait" and MOVEMENTS["hip_flexion"] in steps[0].movements
    compiler._durations(steps, _smp(_WAIT, periodic=True))
    assert steps[0].duration_s == walk.nominal_s < MOVEMENTS["hip_flexion"].nominal_s


def test_a_return_after_a_circle_undoes_the_primitive_before_the_circle():
    _, keys = _compiled(_smp(_WAIT, ("raise", "raise the left arm forward", ["left_upper_arm"]),
                             ("circle", "circle the right arm clockwise", ["right_upper_arm"]),
                             ("lower", "lower the arms", _ARMS), _WAIT))
    assert keys["raise"][-1][1]["left_shoulder_flex"] > 60.0
    # the circle opened nothing to return to (not the last primitive: its return is not the rest pose)
    assert keys["lower"][-1][1]["left_shoulder_flex"] == 0.0


def test_a_placement_every_primitive_of_a_cycle_names_is_held_from_the_start():
    """Triceps extensions: the arms stay overhead while the elbows bend and straighten; they are not
    raised from the sides and lowered again on every repetition."""
    data, keys = _compiled(_smp(("bend", "lower the dumbbell behind the head by bending the elbows", _ARMS),
                                ("extend", "straighten the elbows to raise the dumbbell back overhead", _ARMS),
                                periodic=True))
    overhead = MOVEMENTS["shoulder_flexion_overhead"].pose["shoulder_flex"]
    assert data["base_pose"]["left_shoulder_flex"] == pytest.approx(overhead)
    assert data["base_pose"]["left_elbow_flex"] < 30.0
    (_, bent), = keys["bend"]
    assert bent["left_shoulder_flex"] == pytest.approx(overhead) and bent["left_elbow_flex"] > 90.0
    assert keys["extend"] == [(1.0, data["base_pose"])]  # back to the straight arms overhead


@pytest.mark.parametrize("prims", [
    # the two sides alternate: each leg and each twist goes out and back
    (("right", "bring the right elbow to the left knee, twisting the trunk to the left and back", []),
     ("left", "bring the left elbow to the right knee, twisting the trunk to the right and back", [])),
    # one primitive: a cycle of one movement goes out and back
    (("curl", "curl the dumbbells up to the shoulders and back", _ARMS),),
])
def test_what_alternates_or_a_single_primitive_names_is_not_held(prims):
    data, _ = _compiled(_smp(*prims, periodic=True))
    standing = compiler._posture_vector("standing", 0.0)
    assert data["base_pose"] == compiler._pose_dict(standing)


def test_a_primitive_whose_only_movement_is_held_holds():
    _, keys = _compiled(_smp(("up", "raise the arms overhead", _ARMS),
                             ("wave", "raise the arms overhead and wave the hands", _ARMS), periodic=True))
    assert keys["up"] == []  # its placement is the start pose: nothing left to move
    assert keys["wave"]


def test_a_press_from_the_shoulders_starts_there_and_comes_back_there():
    data, keys = _compiled(_smp(
        ("press", "extend both arms to press the dumbbells from the shoulders to overhead", _ARMS),
        ("lower", "bend the elbows to lower the dumbbells back to shoulder height", _ARMS), periodic=True))
    base = data["base_pose"]
    for side in ("left", "right"):
        for stem, value in MOVEMENTS["press_rack"].pose.items():
            assert base[f"{side}_{stem}"] == pytest.approx(value)
    (_, pressed), = keys["press"]
    assert pressed["left_shoulder_abd"] == pytest.approx(
        MOVEMENTS["shoulder_abduction_overhead"].pose["shoulder_abd"])
    assert pressed["left_elbow_flex"] < 15.0
    assert keys["lower"] == [(1.0, base)]


def test_in_a_plank_bending_the_elbows_lowers_the_body():
    data, keys = _compiled(_smp(("plank", "hold the body straight, face down, on the hands and toes", []),
                                ("down", "bend the elbows to lower the chest toward the floor", _ARMS),
                                ("up", "extend the elbows to push the body back up", _ARMS), periodic=True))
    (_, low), = keys["down"]
    for stem, value in MOVEMENTS["push_up_lower"].pose.items():
        col = f"left_{stem}" if f"left_{stem}" in low else stem
        expected = data["base_pose"][col] + value if stem == "root_dz" else value
        assert low[col] == pytest.approx(expected)
    assert data["base_pose"]["root_pitch"] == pytest.approx(compiler.PLANK_POSE["root_pitch"])


def _sitting_smp(objects, description):
    smp = _smp(("raise", description, _ARMS), ("lower", "lower both arms back to the sides", _ARMS), periodic=True)
    smp.object_contact.objects = list(objects)
    smp.object_contact.required_contact = []
    smp.object_contact.environment_contact = ["chair", "floor"]
    return smp


def test_seated_dumbbells_hang_at_the_sides_unless_the_forearms_rest_on_the_thighs():
    standing = compiler.BUILTIN_POSES["standing"]
    hang = _compiled(_sitting_smp(["dumbbells"], "raise both arms out to the sides"))[0]["base_pose"]
    for stem in ("elbow_flex", "shoulder_abd", "shoulder_flex", "shoulder_horiz", "wrist_flex"):
        assert hang[f"left_{stem}"] == pytest.approx(standing.get(stem, 0.0))  # as standing, 0 where it sets none
    assert hang["left_knee_flex"] > 60.0  # still seated
    lap = compiler.BUILTIN_POSES["sitting"]["elbow_flex"]
    empty = _compiled(_sitting_smp([], "raise both arms out to the sides"))[0]["base_pose"]
    assert empty["left_elbow_flex"] == pytest.approx(lap)  # no weights: the hands rest in the lap
    resting = _compiled(_sitting_smp(["dumbbells"], "curl the wrists with the forearms resting on the thighs"))
    assert resting[0]["base_pose"]["left_elbow_flex"] == pytest.approx(lap)


def test_arms_placed_at_the_start_stay_placed_through_a_change_of_posture():
    data, keys = _compiled(_smp(("lie", "lie on the back with the arms crossed over the chest", []),
                                ("up", "sit up", []), ("down", "lower the trunk back down to the floor", []),
                                periodic=True))
    (_, seated), = keys["up"][-1:]
    for stem, value in MOVEMENTS["arms_crossed"].pose.items():
        assert data["base_pose"][f"left_{stem}"] == pytest.approx(value)
        assert seated[f"left_{stem}"] == pytest.approx(value)
    assert seated["left_hip_flex"] > 60.0


def test_the_speed_limit_counts_each_limb_with_the_trunk_not_both_arms_together():
    one = _moving(left_shoulder_abd=100.0)
    both = _moving(left_shoulder_abd=100.0, right_shoulder_abd=100.0)
    one.start = both.start = np.zeros(N_DOFS)
    arm = _arc(_bone("left_wrist") + _bone("left_elbow"), 100.0)
    assert compiler._slowest(both) == pytest.approx(compiler._slowest(one), rel=1e-3)
    assert compiler._slowest(one) == pytest.approx(arm / compiler.MAX_MEAN_SPEED_M_S, rel=5e-3)
    raised, twist = _moving(left_shoulder_abd=60.0), _moving(left_shoulder_abd=60.0, trunk_twist=80.0)
    raised.start = twist.start = np.zeros(N_DOFS)
    assert compiler._slowest(twist) > 1.3 * compiler._slowest(raised)  # the trunk carries the arm


def test_arms_that_alternate_are_not_held_and_a_held_arm_keeps_its_side():
    alternating = _compiled(_smp(("left", "raise the left arm overhead", _ARMS),
                                 ("right", "raise the right arm overhead", _ARMS), periodic=True))[0]
    standing = compiler._pose_dict(compiler._posture_vector("standing", 0.0))
    assert alternating["base_pose"] == standing
    held = _compiled(_smp(_WAIT, ("bend", "bend the right elbow with the right arm overhead", _ARMS),
                          ("straighten", "straighten the right elbow with the right arm overhead", _ARMS),
                          periodic=True))[0]["base_pose"]
    overhead = MOVEMENTS["shoulder_flexion_overhead"].pose["shoulder_flex"]
    assert held["right_shoulder_flex"] == pytest.approx(overhead)
    assert held["left_shoulder_flex"] == pytest.approx(standing["left_shoulder_flex"])  # the side its cycle names


def test_arms_not_placed_take_the_new_postures_arms():
    data, keys = _compiled(_smp(_WAIT, ("sit", "sit down on the chair", []), ("rise", "stand up", [])))
    seated, up = keys["sit"][-1][1], keys["rise"][-1][1]
    sitting, standing = (compiler.BUILTIN_POSES[p] for p in ("sitting", "standing"))
    assert seated["left_elbow_flex"] == pytest.approx(sitting["elbow_flex"])  # the hands go to the lap
    assert up["left_elbow_flex"] == pytest.approx(standing["elbow_flex"])  # and back to the sides
    # starting seated: the lap is the posture's own arm pose, not a placement, so standing up leaves it
    seated_start = _smp(("seated", "sit on the chair", []), ("rise", "stand up", []))
    seated_start.object_contact.objects, seated_start.object_contact.required_contact = [], []  # hands free
    data, keys = _compiled(seated_start)
    assert data["base_pose"]["left_elbow_flex"] == pytest.approx(sitting["elbow_flex"])
    (_, up), = keys["rise"][-1:]
    assert up["left_elbow_flex"] == pytest.approx(standing["elbow_flex"])


def test_in_a_plank_only_elbow_flexion_becomes_the_push_up():
    _, keys = _compiled(_smp(("plank", "hold a plank on the hands and toes", []),
                             ("reach", "raise the right arm forward", _ARMS),
                             ("back", "lower the right arm", _ARMS), periodic=True))
    (_, reached), = keys["reach"]
    assert reached["right_shoulder_flex"] == pytest.approx(MOVEMENTS["shoulder_flexion"].pose["shoulder_flex"])
    assert reached["root_pitch"] == pytest.approx(compiler.PLANK_POSE["root_pitch"])  # the body stays up


def test_an_out_and_back_primitive_starts_where_its_words_say():
    data, _ = _compiled(_smp(("press", "press the dumbbells from the shoulders to overhead and back", _ARMS),
                             periodic=True))
    for stem, value in MOVEMENTS["press_rack"].pose.items():
        assert data["base_pose"][f"left_{stem}"] == pytest.approx(value)


def test_compiled_durations_are_kept_to_four_decimals(library):
    for name in ("basketball_shoot", "lie_to_stand", "bicep_curls", "walking", "pushups"):
        for p in compiler.compile_recipe_data(library.get(name).smp)["primitives"].values():
            assert p["duration_s"] == round(p["duration_s"], 4)
    data = compiler.compile_recipe_data(library.get("basketball_shoot").smp)
    assert any(p["duration_s"] != round(p["duration_s"], 3) for p in data["primitives"].values())  # 4 in use


def test_a_placement_named_on_other_limbs_by_the_body_parts_is_not_held():
    """No side in the words, but each primitive's body parts name another arm: they alternate."""
    data, _ = _compiled(_smp(("one", "raise the arm overhead", ["left_upper_arm"]),
                             ("other", "raise the arm overhead", ["right_upper_arm"]), periodic=True))
    assert data["base_pose"] == compiler._pose_dict(compiler._posture_vector("standing", 0.0))
    held = _compiled(_smp(("bend", "bend the elbow with the arm overhead", ["right_upper_arm", "right_forearm"]),
                          ("straighten", "straighten the elbow with the arm overhead",
                           ["right_upper_arm", "right_forearm"]), periodic=True))[0]["base_pose"]
    assert held["right_shoulder_flex"] == pytest.approx(MOVEMENTS["shoulder_flexion_overhead"].pose["shoulder_flex"])
    assert held["left_shoulder_flex"] == pytest.approx(0.0)


def test_a_primitive_of_antagonist_movements_undoes_the_one_before_and_the_set_up_leaves_the_cycle():
    smp = _smp(("raise", "raise the right fist in front of the face with the elbow bent", []),
               ("knock", "swing the fist forward so that the knuckles strike the door", []),
               ("pull_back", "draw the fist back a little from the door", []),
               ("lower", "lower the right arm to the side", []), periodic=True)
    steps = compiler._steps(smp)
    assert [s.action for s in steps] == ["go", "go", "go", "return"]
    assert compiler._matches(steps) == {1: 2, 0: 3}
    assert compiler._cycle_span(steps) == ([0], [1, 2], [3])
    assert compiler.compile_recipe_data(smp)["cycle"]["primitives"] == ["knock", "pull_back"]
    squat = _smp(("raise", "raise both arms straight forward", _ARMS), ("down", "squat down", []),
                 ("up", "stand back up", []), ("lower", "lower the arms", _ARMS), periodic=True)
    assert compiler.compile_recipe_data(squat)["cycle"]["primitives"] == ["down", "up"]
    assert undoes(("squat",), ("stand_up",)) and undoes(("shoulder_extension",), ("shoulder_flexion",))
    assert not undoes(("shoulder_flexion",), ("shoulder_flexion",)) and not undoes((), ("stand_up",))
    assert not undoes(("squat",), ())  # nothing undoes nothing
    assert not undoes(("elbow_flexion", "shoulder_flexion"), ("elbow_extension", "trunk_flexion"))


def test_a_strike_is_as_fast_as_the_speed_limit_lets_it_and_quick_words_shorten_a_primitive():
    smps = {k: _smp(("up", f"{k} the right arm straight forward", []), ("down", "lower the right arm", []))
            for k in ("raise", "quickly raise", "slowly raise", "whip")}
    d = {k: compiler.compile_recipe_data(s)["primitives"]["up"]["duration_s"] for k, s in smps.items()}
    nominal = MOVEMENTS["shoulder_flexion"].nominal_s
    assert d["raise"] == pytest.approx(nominal)
    assert d["quickly raise"] == pytest.approx(nominal * PACE["quick"])
    assert d["slowly raise"] == pytest.approx(nominal * PACE["slow"])
    whip = compiler._steps(smps["whip"])
    compiler._keyframes(whip, compiler._posture_vector("standing", 0.0), "standing", smps["whip"], [])
    floor = compiler._slowest(whip[0])  # the whole arm a quarter turn: the limit binds the strike
    assert nominal * PACE["ballistic"] < floor < nominal * PACE["quick"]
    assert d["whip"] == pytest.approx(floor, abs=1e-4)  # durations are written to 4 decimals


def test_stepping_in_place_compiles_to_a_gait_that_swings_the_arms_and_does_not_travel():
    smp = _smp(("left_step", "lift the left knee and put the left foot back down in place while the right arm "
                "swings forward", ["left_thigh"]),
               ("right_step", "lift the right knee and put the right foot back down in place while the left arm "
                "swings forward", ["right_thigh"]), periodic=True)
    data = compiler.compile_recipe_data(smp)
    assert data["locomotion"] == "none" and data["cycle"]["alternate"] is True
    assert data["cycle"]["wave"]["shoulder_flex"] == [[0.25, -15], [0.75, 20]]  # the opposite arm forward
    assert data["primitives"]["left_step"]["duration_s"] == MOVEMENTS["step_in_place"].nominal_s
    assert "pelvis" not in data


def test_an_arm_sent_in_a_direction_points_there_and_the_last_return_ends_at_the_start():
    data, keys = _compiled(_smp(("out", "raise the right arm out to the side", []),
                                ("up", "move the hand straight up", []),
                                ("lower", "lower the right arm", [])))
    (_, out), = keys["out"]
    (_, up), = keys["up"]
    (_, end), = keys["lower"]
    assert out["right_shoulder_abd"] == pytest.approx(MOVEMENTS["shoulder_abduction"].pose["shoulder_abd"])
    assert up["right_shoulder_flex"] == pytest.approx(MOVEMENTS["shoulder_flexion_overhead"].pose["shoulder_flex"])
    assert up["right_shoulder_abd"] == pytest.approx(data["base_pose"]["right_shoulder_abd"])  # no longer out
    assert end == pytest.approx(data["base_pose"])  # the stack would have returned to the raised arm
    _, keys = _compiled(_smp(("out", "raise the left arm out to the side", []),
                             ("up", "raise the right arm straight up", []), ("lower", "lower the right arm", [])))
    (_, up), = keys["up"]
    (_, end), = keys["lower"]
    assert end["left_shoulder_abd"] == pytest.approx(up["left_shoulder_abd"])  # the arm not named stays
    assert up["left_shoulder_abd"] > 45.0
    assert end["right_shoulder_flex"] == pytest.approx(data["base_pose"]["right_shoulder_flex"])


def test_seated_with_dumbbells_an_arm_sent_out_keeps_the_hanging_arms_other_angles():
    data, keys = _compiled(_sitting_smp(["dumbbells"], "raise both arms out to the sides"))
    (_, out), = next(iter(keys.values()))
    assert out["left_shoulder_flex"] == pytest.approx(data["base_pose"]["left_shoulder_flex"])  # not the lap's


def test_a_return_that_stands_up_straightens_the_legs_it_comes_back_through():
    data, keys = _compiled(_smp(("lunge", "step forward with the left leg and bend the knees", []),
                                ("reach", "raise both arms forward", _ARMS),
                                ("recover", "stand up and lower the arms", []), ("wait", "stand and wait", [])))
    (_, lunged), = keys["reach"]
    (_, back), = keys["recover"]
    base = data["base_pose"]
    assert lunged["left_knee_flex"] > 45.0 and lunged["left_shoulder_flex"] > 45.0
    for dof in ("left_knee_flex", "right_knee_flex", "left_hip_flex", "left_shoulder_flex"):
        assert back[dof] == pytest.approx(base[dof])  # the arms down where the reach began, the legs straight


def test_the_body_keeps_its_heading_through_a_change_of_posture():
    _, keys = _compiled(_smp(("lie", "lie on the back", []),
                             ("up", "raise the trunk and turn, swinging the legs down to sit on the edge of the bed", []),
                             ("stand", "extend the hips and knees to stand upright", [])))
    (_, seated), = keys["up"][-1:]
    assert abs(seated["root_yaw"]) == pytest.approx(MOVEMENTS["turn"].pose["root_yaw"])
    assert all(pose["root_yaw"] == seated["root_yaw"] for _, pose in keys["stand"])  # standing up does not turn back


def test_an_arm_sent_out_after_another_movement_of_its_primitive_still_points_there():
    data, keys = _compiled(_smp(("fwd", "raise the right arm straight forward", []),
                                ("side", "bend the right elbow and raise the right arm out to the side", [])))
    (_, side), = keys["side"]
    assert [m.name for m in compiler._steps(_smp(("side", "bend the right elbow and raise the right arm out to "
                                                  "the side", [])))[0].movements] == ["elbow_flexion",
                                                                                      "shoulder_abduction"]
    assert side["right_shoulder_flex"] == pytest.approx(data["base_pose"]["right_shoulder_flex"])  # not forward
    assert side["right_shoulder_abd"] == pytest.approx(MOVEMENTS["shoulder_abduction"].pose["shoulder_abd"])


def test_seated_a_recline_leans_the_whole_body_back_before_lying_down_along_the_bed():
    smp = _smp(("sit", "sit upright", []), ("lean_back", "lean the trunk backward, supporting the body while "
                                                          "reclining", []),
               ("lie_down", "turn to lie along the bed, lowering the back flat", []))
    smp.object_contact.environment_contact = ["bed"]
    data, keys = _compiled(smp)
    (_, reclined), = keys["lean_back"]
    recline = MOVEMENTS["recline"].pose
    assert data["base_pose"]["left_knee_flex"] > 60.0  # seated
    assert reclined["root_pitch"] == recline["root_pitch"] and reclined["trunk_flex"] == 0.0  # not a trunk bend
    assert reclined["left_hip_flex"] == reclined["right_hip_flex"] == recline["hip_flex"]
    assert reclined["root_dz"] == pytest.approx(data["base_pose"]["root_dz"] + recline["root_dz"])
    (_, lying), = keys["lie_down"]
    assert lying["root_pitch"] == -90.0 and lying["root_dz"] == pytest.approx(compiler.LIE_SHIFT_M)
    assert "root_pitch" in data["amplitude_exempt"]  # the posture's depth does not scale with amplitude


def test_standing_a_recline_lies_down():
    data, keys = _compiled(_smp(_WAIT, ("recline", "recline on the bed", [])))
    (_, seat), (_, lying) = keys["recline"]
    assert seat["left_hip_flex"] == compiler.BUILTIN_POSES["sitting"]["hip_flex"]  # via the seat
    assert lying["root_pitch"] == -90.0  # lying, not a 45 degree lean back on straight legs
    assert [m.name for m in compiler._steps(_smp(_WAIT, ("recline", "recline on the bed", [])))[1].movements] == [
        "recline"]  # read as a recline; the compiler lies down from standing


def test_a_first_primitive_that_reclines_starts_seated():
    data, _ = _compiled(_smp(("recline", "recline on the sofa", []), _WAIT))
    assert data["base_pose"]["left_knee_flex"] > 60.0


def test_a_recline_sends_both_arms_back_to_the_bed_from_where_they_reached():
    data, keys = _compiled(_smp(("sit", "sit upright", []), ("reach", "raise both arms forward", _ARMS),
                                ("lean", "recline", [])))
    (_, reached), = keys["reach"]
    (_, reclined), = keys["lean"]
    for side in ("left", "right"):  # the recline names no side: both hands reach back
        assert reached[f"{side}_shoulder_flex"] > 60.0
        assert reclined[f"{side}_shoulder_flex"] == pytest.approx(data["base_pose"][f"{side}_shoulder_flex"])
        assert reclined[f"{side}_shoulder_abd"] == MOVEMENTS["recline"].pose["shoulder_abd"]


def test_seated_leaning_back_before_lying_down_reclines_and_otherwise_leans_the_trunk():
    def smp(*lie):
        out = _smp(("stand", "stand upright", []), ("sit", "sit down on the edge of the bed", []),
                   ("lean", "sit on the bed and lean the trunk back", []), *lie)
        out.object_contact.environment_contact = ["bed"]
        return out

    _, keys = _compiled(smp(("lie", "lie down flat on the back", [])))
    (_, leaned), = keys["lean"]
    assert leaned["root_pitch"] == MOVEMENTS["recline"].pose["root_pitch"] and leaned["trunk_flex"] == 0.0
    _, keys = _compiled(smp())  # no lying down follows: the trunk leans back on the seat
    (_, leaned), = keys["lean"]
    assert leaned["root_pitch"] == 0.0
    assert leaned["trunk_flex"] == MOVEMENTS["trunk_extension"].pose["trunk_flex"]


@pytest.mark.parametrize("posture,lies_later,names", [
    ("sitting", True, ["recline", "recline", "elbow_flexion"]),
    ("sitting", False, ["trunk_extension", "recline", "elbow_flexion"]),
    ("standing", True, ["trunk_extension", "lie_down", "elbow_flexion"]),
    ("lying", False, ["trunk_extension", "lie_down", "elbow_flexion"]),
])
def test_a_recline_needs_a_seat_and_a_seated_lean_back_before_lying_is_one(posture, lies_later, names):
    moves = tuple(MOVEMENTS[n] for n in ("trunk_extension", "recline", "elbow_flexion"))
    assert [m.name for m in compiler._seated(moves, posture, lies_later)] == names


def test_sitting_up_from_lying_in_two_primitives_rises_halfway_on_the_hands_first():
    def smp(*more):
        out = _smp(("lie", "lie on the back", []), ("raise_trunk", "lift the trunk and head up from lying", []), *more)
        out.object_contact.environment_contact = ["bed"]
        return out

    data, keys = _compiled(smp(("legs", "turn to the edge of the bed, swinging the legs down to sit", [])))
    (_, half), = keys["raise_trunk"]
    (_, seated), = keys["legs"]
    recline = MOVEMENTS["recline"].pose
    assert half["root_pitch"] == recline["root_pitch"] and half["left_hip_flex"] == recline["hip_flex"]
    assert half["root_dz"] == pytest.approx(-compiler.LIE_SHIFT_M + recline["root_dz"])
    sitting = compiler.BUILTIN_POSES["sitting"]
    assert seated["root_pitch"] == 0.0 and seated["left_knee_flex"] == sitting["knee_flex"]  # upright on the seat
    assert abs(seated["root_yaw"]) == MOVEMENTS["turn"].pose["root_yaw"]
    assert seated["root_dz"] == pytest.approx(-compiler.LIE_SHIFT_M)
    _, keys = _compiled(smp(("stand", "extend the hips and knees to stand upright", [])))
    (_, passed), (_, sat) = keys["raise_trunk"]
    assert sat["root_pitch"] == 0.0  # no second sitting primitive: all the way up, passing the recline
    assert passed["root_pitch"] == recline["root_pitch"]


def test_the_body_is_tipped_out_of_a_posture_when_its_pitch_differs():
    vec = compiler._posture_vector("sitting", 0.2)
    assert not compiler._tipped(vec, "sitting")
    vec[_col("root_pitch")] -= 1.5
    assert compiler._tipped(vec, "sitting")
    vec[_col("root_pitch")] += 0.6  # within a degree of the posture's pitch
    assert not compiler._tipped(vec, "sitting")
    vec[_col("root_pitch")] = -compiler.CHANGE_DEG  # exactly a degree is still in the posture
    assert not compiler._tipped(vec, "sitting")


def test_a_return_with_nothing_to_return_to_goes_to_the_start_pose():
    data, keys = _compiled(_smp(("lower", "lower the arms", _ARMS), _WAIT))
    (_, end), = keys["lower"]
    assert end == pytest.approx(data["base_pose"])


def test_lying_down_on_a_bed_in_one_primitive_passes_its_edge():
    smp = _smp(_WAIT, ("lie", "lie down on the bed", []))
    smp.object_contact.environment_contact = ["bed"]
    _, keys = _compiled(smp)
    (_, edge), (_, lying) = keys["lie"]
    assert edge["root_dz"] == pytest.approx(SEAT_SHIFT_M)  # seated on the edge, feet in place
    assert lying["root_dz"] == pytest.approx(SEAT_SHIFT_M + compiler.LIE_SHIFT_M)


def test_a_seated_lean_back_before_standing_up_is_no_recline():
    _, keys = _compiled(_smp(("sit", "sit down on the chair", []), ("lean", "lean the trunk back", []),
                             ("stand", "stand up", [])))
    (_, leaned), = keys["lean"]
    assert leaned["root_pitch"] == 0.0
    assert leaned["trunk_flex"] == MOVEMENTS["trunk_extension"].pose["trunk_flex"]


def test_a_recline_aims_both_arms_even_when_one_side_dominates():
    smp = _smp(("sit", "sit upright", []), ("reach", "raise both arms forward", _ARMS), ("lean", "recline", []),
               dominant="right", symmetry="asymmetric")
    smp.body_parts.dominant_moving_segments = ["torso"]
    data, keys = _compiled(smp)
    (_, reclined), = keys["lean"]
    for side in ("left", "right"):
        assert reclined[f"{side}_shoulder_flex"] == pytest.approx(data["base_pose"][f"{side}_shoulder_flex"])


def test_a_trunk_turn_every_primitive_of_the_cycle_names_is_held_whichever_arm_moves():
    data, keys = _compiled(_smp(("left", "twist the trunk to the left and raise the left arm forward", ["left_upper_arm"]),
                                ("right", "twist the trunk to the left and raise the right arm forward",
                                 ["right_upper_arm"]), periodic=True))
    twist = MOVEMENTS["trunk_rotation"].pose["trunk_twist"]
    assert data["base_pose"]["trunk_twist"] == pytest.approx(twist)  # held from the start, to the left
    assert all(pose["trunk_twist"] == pytest.approx(twist) for ks in keys.values() for _, pose in ks)


def test_only_a_lying_down_after_a_seated_lean_back_makes_it_a_recline():
    """A lying down before it (here one that only returns, so the body is still seated) does not."""
    _, keys = _compiled(_smp(("sit", "sit down on the chair", []), ("fwd", "lean the trunk forward", []),
                             ("back_down", "lie back down", []), ("lean", "lean the trunk back", []), _WAIT))
    assert [m.name for m in compiler._steps(_smp(("x", "lie back down", [])))[0].movements] == ["lie_down"]
    (_, leaned), = keys["lean"]
    assert leaned["root_pitch"] == 0.0 and leaned["left_knee_flex"] > 60.0  # still seated
    assert leaned["trunk_flex"] == MOVEMENTS["trunk_extension"].pose["trunk_flex"]


def test_getting_up_from_lying_turns_back_the_way_lying_down_turned():
    """Lying down from a bed's edge swings the legs onto the bed, turning the body; getting up on the
    same side swings them off, turning back: the opposite sign, in one primitive or in the second of two."""
    def smp(*prims):
        out = _smp(*prims, dominant="right")
        out.object_contact.environment_contact = ["bed"]
        return out

    turn = MOVEMENTS["turn"].pose["root_yaw"]
    _, down = _compiled(smp(("sit", "sit on the edge of the bed", []),
                            ("lie_down", "turn to lie along the bed, swinging the legs up", [])))
    _, up = _compiled(smp(("lie", "lie on the back", []),
                          ("sit", "turn to the edge of the bed, swinging the legs down to sit", [])))
    _, two = _compiled(smp(("lie", "lie on the back", []), ("raise_trunk", "lift the trunk up from lying", []),
                           ("legs", "turn to the edge of the bed, swinging the legs down to sit", [])))
    lying_yaw = down["lie_down"][-1][1]["root_yaw"]
    assert abs(lying_yaw) == turn
    assert up["sit"][-1][1]["root_yaw"] == -lying_yaw
    assert two["raise_trunk"][-1][1]["root_yaw"] == -lying_yaw / 2 and two["legs"][-1][1]["root_yaw"] == -lying_yaw
    _, named = _compiled(smp(("lie", "lie on the back", []),
                             ("sit", "turn left to the edge of the bed, swinging the legs down to sit", [])))
    _, named_down = _compiled(smp(("sit", "sit on the edge of the bed", []),
                                  ("lie_down", "turn left to lie along the bed, swinging the legs up", [])))
    assert named["sit"][-1][1]["root_yaw"] == named_down["lie_down"][-1][1]["root_yaw"] == turn  # words win


def test_between_a_seat_and_lying_in_one_primitive_the_body_passes_the_recline_half_turned():
    recline = MOVEMENTS["recline"].pose
    lying, seat = compiler._posture_vector("lying", 0.3), compiler._posture_vector("sitting", 0.6)
    seat[_col("root_yaw")] = 90.0
    for src, dst, before, target in (("lying", "sitting", lying, seat), ("sitting", "lying", seat, lying)):
        half = compiler._via(src, dst, before, target, 0.0)
        assert half[_col("root_pitch")] == recline["root_pitch"] and half[_col("right_knee_flex")] == recline["knee_flex"]
        assert half[_col("root_dz")] == pytest.approx(0.6 + recline["root_dz"])  # from the seat
        assert half[_col("root_yaw")] == 45.0
    reclined = compiler._apply(seat, [MOVEMENTS["recline"]], None, None, 0)
    assert compiler._via("sitting", "lying", reclined, lying, 0.0) is None  # already on the hands
    assert compiler._via("lying", "sitting", lying, reclined, 0.0) is None  # the rise stops there
    _, keys = _compiled(_smp(("lie", "lie on the back", []), ("sit", "sit up on the edge of the bed", [])))
    (at, half), (_, sat) = keys["sit"]
    assert at == 0.5 and half["root_pitch"] == recline["root_pitch"] and sat["root_pitch"] == 0.0


def test_a_change_of_posture_is_shared_out_with_no_change_of_posture_slower_than_alone():
    prims = (("sit", "sit upright on the chair", []), ("lean", "lean the trunk forward", []),
             ("rise", "stand up", []), ("upright", "straighten the trunk", []))
    shares = [0.15, 0.25, 0.45, 0.15]

    def durations(smp):
        return [p["duration_s"] for p in compiler.compile_recipe_data(smp)["primitives"].values()]

    alone = durations(_smp(*prims))  # no shares: each phase at its own pace
    flowing = durations(_smp(*prims, shares=shares))
    assert flowing == pytest.approx([sum(flowing) * s for s in shares], abs=1e-3)  # as the SMP shares them
    assert all(f <= a + 1e-3 for f, a in zip(flowing, alone, strict=True))
    assert any(f == pytest.approx(a, abs=1e-3) for f, a in zip(flowing, alone, strict=True))
    assert sum(flowing) < sum(alone)
    arms = (("raise", "raise both arms forward", _ARMS), ("lower", "lower the arms", _ARMS))  # no posture change
    apart = durations(_smp(*arms))
    assert sum(durations(_smp(*arms, shares=[0.45, 0.55]))) == pytest.approx(sum(apart), abs=1e-3)


def test_the_phases_between_two_changes_of_posture_take_their_share_and_do_not_set_the_pace():
    prims = (("lie", "lie on the back", []), ("sit_up", "sit up on the edge of the bed", []),
             ("crouch", "lean forward and shift the weight over the feet", []),
             ("stand_up", "extend the hips and knees to stand upright", []))
    shares = [0.1, 0.3, 0.3, 0.3]
    data = compiler.compile_recipe_data(_smp(*prims, shares=shares))
    flowing = [p["duration_s"] for p in data["primitives"].values()]
    assert flowing == pytest.approx([sum(flowing) * s for s in shares], abs=1e-3)
    paces = {"sit_up": MOVEMENTS["sit_down"].nominal_s, "stand_up": MOVEMENTS["stand_up"].nominal_s}
    # the changes of posture run no slower than alone, the quicker one at its own pace
    assert all(data["primitives"][n]["duration_s"] <= pace + 1e-3 for n, pace in paces.items())
    assert max(data["primitives"][n]["duration_s"] - pace for n, pace in paces.items()) == pytest.approx(0.0, abs=1e-3)
    assert data["primitives"]["crouch"]["duration_s"] > MOVEMENTS["squat"].nominal_s  # slower than alone


def test_a_floor_sit_up_passes_the_recline_with_its_arms_crossed_and_no_lower_than_lying():
    crossed = "lie on the back with the knees bent and the arms crossed over the chest"
    _, keys = _compiled(_smp(("lie_back", crossed, []), ("sit_up", "curl the trunk up off the floor toward the knees", []),
                             ("lower_back", "lower the trunk back down to the floor", []), periodic=True))
    (_, half), (_, sat) = keys["sit_up"]
    lying = keys["lower_back"][-1][1]
    assert half["root_pitch"] == MOVEMENTS["recline"].pose["root_pitch"]  # half way up
    for side in ("left", "right"):  # the hands stay on the chest, they do not reach back for a bed
        for stem in ("shoulder_horiz", "elbow_flex"):
            assert half[f"{side}_{stem}"] == sat[f"{side}_{stem}"] == lying[f"{side}_{stem}"] > 50.0
    assert half["root_dz"] >= min(lying["root_dz"], sat["root_dz"])  # never through the floor


def test_a_recline_of_its_own_before_the_body_turns_is_half_turned():
    recline = MOVEMENTS["recline"].pose["root_pitch"]
    _, down = _compiled(_smp(("sit", "sit on the edge of the bed", []),
                             ("lean_back", "lean the trunk backward, supporting the body while reclining", []),
                             ("lie_down", "turn to lie along the bed, swinging the legs up", [])))
    (_, reclined), = down["lean_back"]
    lying = down["lie_down"][-1][1]
    assert reclined["root_pitch"] == recline and abs(lying["root_yaw"]) == 90.0
    assert reclined["root_yaw"] == lying["root_yaw"] / 2  # half of the turn before lying down
    _, up = _compiled(_smp(("lie", "lie on the back", []), ("raise_trunk", "lift the trunk and head up from lying, bending the hips", []),
                           ("legs", "turn to the edge of the bed, swinging the legs down to sit", [])))
    (_, half_up), = up["raise_trunk"]
    sat = up["legs"][-1][1]
    assert half_up["root_pitch"] == recline and abs(sat["root_yaw"]) == 90.0
    assert half_up["root_yaw"] == sat["root_yaw"] / 2
    _, still = _compiled(_smp(("sit", "sit on the edge of the bed", []),
                              ("lean_back", "lean the trunk backward, supporting the body while reclining", []),
                              ("sit_up", "sit upright", [])))
    assert still["lean_back"][-1][1]["root_yaw"] == 0.0  # no turn follows: none taken


def test_only_a_reclined_end_just_before_a_turn_of_more_than_a_degree_takes_half_of_it():
    def step(name, end_yaw, pitch):
        pose = compiler._posture_vector("sitting", 0.0)
        pose[_col("root_yaw")], pose[_col("root_pitch")] = end_yaw, pitch
        return compiler.Step(name, read_primitive(name), (), action="go", keys=[(1.0, pose, "stop")],
                             start=pose.copy())

    recline = MOVEMENTS["recline"].pose["root_pitch"]
    # a seated step with keys, then a recline at 45°, then a turn to -45°: only the recline takes half
    seated, reclined, turned = step("sit", 0.0, 0.0), step("lean", 45.0, recline), step("lie", -45.0, -90.0)
    compiler._turn_through_recline([seated, reclined, turned])
    assert seated.keys[-1][1][_col("root_yaw")] == 0.0  # not reclined: kept, though a turn follows
    assert reclined.keys[-1][1][_col("root_yaw")] == 0.0 == turned.start[_col("root_yaw")]
    upright_first = [step("raise", 0.0, 0.0), step("turn", 90.0, 0.0)]
    compiler._turn_through_recline(upright_first)
    assert upright_first[0].keys[-1][1][_col("root_yaw")] == 0.0
    barely = [step("lean", 0.0, recline), step("lie", compiler.CHANGE_DEG, -90.0)]  # a degree is no turn
    compiler._turn_through_recline(barely)
    assert barely[0].keys[-1][1][_col("root_yaw")] == 0.0


def test_seated_arm_movements_leave_the_trunk_as_seated():
    _, keys = _compiled(_smp(_WAIT, ("sit", "sit down on the chair", []), ("raise", "raise both arms forward", _ARMS)))
    sat, raised = keys["sit"][-1][1], keys["raise"][-1][1]
    assert raised["trunk_flex"] == sat["trunk_flex"] and raised["right_shoulder_flex"] > 60.0


def test_getting_up_on_the_left_side_turns_back_as_lying_down_turned_and_lying_again_turns_back():
    def smp(*prims):
        out = _smp(*prims, dominant="left")
        out.object_contact.environment_contact = ["bed"]
        return out

    legs_up = ("lie_down", "turn to lie along the bed, swinging the legs up", [])
    legs_down = ("sit", "turn to the edge of the bed, swinging the legs down to sit", [])
    _, down = _compiled(smp(("sit", "sit on the edge of the bed", []), legs_up))
    _, up = _compiled(smp(("lie", "lie on the back", []), legs_down))
    assert up["sit"][-1][1]["root_yaw"] == -down["lie_down"][-1][1]["root_yaw"] != 0.0
    _, again = _compiled(smp(("lie", "lie on the back", []), legs_down, legs_up))
    rise = again["sit"][-1][1]["root_yaw"]
    lie_again = again["lie_down"][-1][1]["root_yaw"] - rise
    assert np.sign(lie_again) == -np.sign(rise) != 0  # lying along the bed again turns the other way
    assert again["lie_down"][-1][1]["root_yaw"] == 0.0  # back along the bed: a turn turns from the heading


def _eases(smp) -> dict[str, list[str]]:
    return {name: [ease for _, _, ease in p["keys"]] for name, p in compiler.compile_recipe_data(smp)["primitives"].items()}


def test_a_flowing_change_of_posture_passes_the_ends_of_its_primitives_without_stopping():
    sit, lie = ("sit", "sit on the edge of the bed", []), ("lie_down", "turn to lie along the bed, swinging the legs up", [])
    lean = ("lean_back", "lean the trunk backward, supporting the body while reclining", [])
    assert _eases(_smp(sit, lean, lie)) == {"sit": [], "lean_back": ["pass"], "lie_down": ["stop"]}
    held = _eases(_smp(sit, lean, ("pause", "hold the position", []), lie))  # a hold between: at rest there
    assert held["lean_back"] == ["stop"] and held["lie_down"] == ["stop"]
    arms = _eases(_smp(("raise", "raise both arms forward", _ARMS), ("lower", "lower the arms", _ARMS)))
    assert arms == {"raise": ["stop"], "lower": ["stop"]}  # no change of posture: each excursion stops
    lying = ("lie_back", "lie on the back with the knees bent and the arms crossed over the chest", [])
    sit_ups = _eases(_smp(lying, ("sit_up", "curl the trunk up off the floor toward the knees", []),
                          ("lower_back", "lower the trunk back down to the floor", []), periodic=True))
    assert sit_ups["sit_up"][-1] == "stop"  # repetitions turn back at each end


@pytest.mark.parametrize("name", ["sit_to_lie", "lie_to_sit"])
def test_the_library_lying_transitions_turn_the_pelvis_without_a_halt_between_their_primitives(name):
    from vsmp_imu.motion.procedural import ProceduralBackend
    from vsmp_imu.smp.library import ActivityLibrary

    motion = ProceduralBackend(compile_mode="always").generate(ActivityLibrary.load().get(name).smp, seed=0)
    q = motion.rotations[:, 0]  # the pelvis
    rate = 2.0 * np.arccos(np.clip(np.abs((q[1:] * q[:-1]).sum(axis=-1)), 0.0, 1.0)) * motion.fps
    moving = np.flatnonzero(rate > 0.1 * rate.max())
    # with a stop at each primitive's end the pelvis halts (about 1.5 % of its peak rate) between them
    assert rate[moving[0]:moving[-1] + 1].min() > 0.05 * rate.max()
