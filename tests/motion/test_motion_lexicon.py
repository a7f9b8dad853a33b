"""The lexicon (words -> anatomical movements) and the normative range-of-motion table."""

from __future__ import annotations

import pytest

from vsmp_imu.motion import lexicon as lex
from vsmp_imu.motion.anatomy import MOVEMENTS, ROM_DEG
from vsmp_imu.motion.lexicon import movements_in, read_primitive
from vsmp_imu.smp.library import ActivityLibrary

# recipe principal joint (side removed) -> the lexicon joints that move it
_JOINTS = {"shoulder": {"shoulder"}, "collar": {"shoulder"}, "elbow": {"elbow", "forearm"},
           "wrist": {"wrist", "forearm"}, "hip": {"hip"}, "knee": {"knee"}, "ankle": {"ankle"},
           "foot": {"ankle"}, "spine1": {"trunk"}, "spine2": {"trunk"}, "spine3": {"trunk"},
           "pelvis": {"hip", "trunk", "body"}, "head": {"neck"}, "neck": {"neck"}}


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


def _joints(moves) -> set[str]:
    return {MOVEMENTS[m].joint for m in moves}


def _activity_movements(entry) -> set[str]:
    out: set[str] = set()
    for p in entry.smp.motion_primitives:
        out |= set(read_primitive(p.name, p.description).all_movements())
    return out


def test_single_joint_movements_stay_within_the_normative_range():
    checked = 0
    for move in MOVEMENTS.values():
        if move.kind != "excursion" or move.joint not in {j for j, _ in ROM_DEG}:
            continue
        stem, value = next(iter(move.pose.items()))
        largest = max(v for (j, _), v in ROM_DEG.items() if j == move.joint)
        assert abs(value) <= largest, (move.name, value, largest)
        checked += 1
    assert checked >= 20


@pytest.mark.parametrize(("name", "description", "expected"), [
    ("curl_up", "bend both elbows to lift the dumbbells to the shoulders, turning the palms up",
     {"elbow_flexion", "forearm_supination"}),
    ("hammer_curl", "curl the kettlebells up with the thumbs up", {"elbow_flexion"}),
    ("raise_arms", "raise both arms out to the sides to shoulder height", {"shoulder_abduction"}),
    ("front_raise", "raise both arms straight forward to shoulder height", {"shoulder_flexion"}),
    ("press_up", "press the dumbbells overhead", {"shoulder_abduction_overhead"}),
    ("bend_left", "bend the trunk sideways to the left", {"trunk_side_bend"}),
    ("twist", "twist the torso to the right", {"trunk_rotation"}),
    ("hinge", "bend the trunk forward at the hips", {"trunk_flexion"}),
    ("squat_down", "bend the hips and knees to squat down", {"squat"}),
    ("walk", "walk forward at a steady pace", {"walk"}),
    ("climb", "walk up the stairs", {"stairs_up"}),
    ("sit_down", "sit down on the chair", {"sit_down"}),
    ("lie_down", "lie down flat on the back", {"lie_down"}),
    ("lean_back", "lean the trunk backward, supporting the body while reclining", {"recline"}),
    ("lie_back", "recline until lying flat", {"lie_down"}),  # a lie down includes its recline
    ("jump", "jump with both feet", {"jump"}),
    ("pronate", "turn the palms down", {"forearm_pronation"}),
    ("circle", "trace a circle with the right hand", {"arm_circumduction"}),
    ("calf_raise", "rise onto the toes", {"ankle_plantarflexion"}),
    ("shrug", "shrug the shoulders", {"shoulder_elevation"}),
])
def test_words_name_movements(name, description, expected):
    assert expected <= set(read_primitive(name, description).movements)


@pytest.mark.parametrize(("words", "expected"), [
    ("draw the knees up", ("hip_flexion",)), ("pull the left knee up", ("hip_flexion",)),
    ("bring the legs up", ("hip_flexion",)), ("draw the hand up", ("shoulder_flexion_overhead",)),
    ("pull the bar up", ("elbow_flexion",))])
def test_legs_drawn_up_flex_the_hips_and_hands_drawn_up_raise_the_arm(words, expected):
    """'draw the knees up' had read as a hand raised overhead (its object is a leg)."""
    assert movements_in(words) == expected


@pytest.mark.parametrize("words", ["jump while bringing the legs together", "pull the legs apart"])
def test_legs_brought_together_or_apart_do_not_flex_the_hips(words):
    assert "hip_flexion" not in movements_in(words)


def test_a_recline_is_the_whole_body_leaning_back_not_a_trunk_extension_too():
    assert read_primitive("lean_back", "lean the trunk backward, supporting the body while reclining").movements == (
        "recline",)
    assert read_primitive("lie_back", "recline until lying flat").movements == ("lie_down",)
    assert read_primitive("lean_back", "lean the trunk backward").movements == ("trunk_extension",)


@pytest.mark.parametrize(("words", "expected"), [
    ("sit on the bed and lean the trunk back", ("sit_down", "trunk_extension")),  # sitting down leans forward
    ("sit down, leaning the trunk forward", ("sit_down",)),
    ("lie down, leaning the trunk back flat", ("lie_down",)),
    ("stand up and lean back", ("stand_up",))])
def test_a_change_of_support_keeps_only_a_lean_back_after_sitting_down(words, expected):
    assert read_primitive("p", words).movements == expected


def test_hammer_curl_keeps_the_grip_neutral():
    assert "forearm_supination" not in read_primitive("curl_up", "hammer curl the kettlebells up").movements


def test_a_curl_turns_the_palms_up_unless_the_label_names_a_hammer_curl():
    curl = read_primitive("curl_up", "curl the dumbbells up to the shoulders")
    assert curl.movements == ("elbow_flexion", "forearm_supination")
    told = read_primitive("curl_up", "bend the elbows to curl the dumbbells up, turning the palms up")
    assert told.movements.count("forearm_supination") == 1  # named once, read once
    assert read_primitive("curl_up", "curl the kettlebell up", "hammer curl").movements == ("elbow_flexion",)
    assert "forearm_supination" not in read_primitive("bend", "bend both elbows to raise the hands").movements


@pytest.mark.parametrize(("description", "pace"), [
    ("whip the right arm forward and extend the elbow to release the throw", lex.PACE["ballistic"]),
    ("swing the bat forward through the hitting zone", lex.PACE["ballistic"]),
    ("swing the fist forward so that the knuckles strike the door", lex.PACE["ballistic"]),
    ("bring both palms together in a clap", lex.PACE["ballistic"]),
    ("quickly lift the left knee", lex.PACE["quick"]),
    ("slowly lower the dumbbells to the thighs", lex.PACE["slow"]),
    ("raise both arms out to the sides", 1.0),
    ("swing the right arm back behind the body", 1.0),  # a backswing winds up, it is not a strike
])
def test_strikes_and_tempo_words_set_the_pace_of_a_primitive(description, pace):
    assert read_primitive("p", description).pace == pace


@pytest.mark.parametrize(("description", "gait"), [
    ("lift the left knee and put the left foot back down in place while the right arm swings forward", "step_in_place"),
    ("quickly lift the right knee and put the right foot back down in place", "jog_in_place"),
    ("jog on the spot", "jog_in_place"),
    ("march in place", "step_in_place"),
])
def test_knee_lifts_and_steps_in_place_are_a_gait_that_does_not_travel(description, gait):
    reading = read_primitive("step", description)
    assert reading.movements == (gait,)
    assert MOVEMENTS[gait].kind == "gait" and MOVEMENTS[gait].locomotion == "none"
    assert read_primitive("lift", "lift the left knee").movements == ("hip_flexion",)  # not in place: a knee raise


def test_lowering_the_guard_returns_and_the_bottom_of_a_circle_is_not_a_circle():
    lower = read_primitive("lower_guard", "lower both arms to the sides")
    assert lower.returns and lower.movements == ()
    assert "guard" not in read_primitive("lower_guard", "lower both arms to the sides").context
    raise_ = read_primitive("raise_hand", "raise the right arm forward to the bottom of the circle")
    assert raise_.movements == ("shoulder_flexion",)


def test_return_out_and_back_hold_and_sides():
    lower = read_primitive("lower", "straighten both elbows to lower the dumbbells back to the thighs")
    assert lower.returns and not lower.there_and_back
    punch = read_primitive("punch_left", "extend the left fist straight forward and pull it back to the guard")
    assert punch.there_and_back and not punch.returns and punch.arm_side == "left"
    assert "guard" in punch.context  # punches start from a guard
    hold = read_primitive("stand", "stand still")
    assert hold.hold and hold.posture == "standing"
    assert read_primitive("twist", "twist the trunk to the left").direction == 1
    assert read_primitive("twist", "twist the trunk to the right").direction == -1
    for words, sign in (("turn left", 1), ("turn to the left, swinging the legs down", 1), ("turning to the right", -1)):
        turn = read_primitive("p", words)
        assert "turn" in turn.movements and turn.direction == sign
    assert "turn" not in read_primitive("p", "the trunk turns to the left").movements  # a trunk rotation
    assert read_primitive("circle", "trace a counter-clockwise circle").counter_clockwise
    held = read_primitive("row_up", "pull the dumbbells up while bent forward at the hips")
    assert "trunk_flexion" in held.context and "trunk_flexion" not in held.movements


def test_library_primitives_name_the_recipe_joints(library):
    """Test set 1: every library activity's primitives name a movement of a joint its recipe moves most."""
    misses = []
    for entry in library:
        recipe_joints = set().union(*(_JOINTS[j.replace("left_", "").replace("right_", "")]
                                      for j in entry.extras["procedural"]["principal_joints"]))
        if not _joints(_activity_movements(entry)) & recipe_joints:
            misses.append(entry.name)
    assert len(misses) <= 0.05 * len(library), misses


def test_library_captions_and_aliases_agree_with_the_primitives(library):
    """Test set 2: captions (and aliases) name movements of the joints the primitives name."""
    captions = aliases = n_captions = n_aliases = 0
    for entry in library:
        joints = _joints(_activity_movements(entry))
        for caption in entry.captions:
            n_captions += 1
            captions += bool(_joints(movements_in(caption)) & joints)
        for alias in (*entry.aliases, entry.name.replace("_", " ")):
            n_aliases += 1
            aliases += bool(_joints(movements_in(alias)) & joints)
    # floors below the rates benchmarks/study_compiled_motion.py reports
    assert captions / n_captions >= 0.70
    assert aliases / n_aliases >= 0.45


def test_rom_is_the_fraction_of_the_normative_range_to_a_tenth_of_a_degree():
    from vsmp_imu.motion.anatomy import rom

    assert rom("shoulder", "flexion", 0.5) == 90.0
    assert rom("wrist", "radial_deviation", 0.33) == 6.6  # 6.6 exactly, not 6.60000001
    assert rom("wrist", "radial_deviation", 0.333) == 6.7  # to a tenth of a degree
    assert rom("knee", "flexion") == 135.0
    assert MOVEMENTS["shoulder_flexion"].pose == {"shoulder_flex": 90.0}  # the table is built with it


def test_a_movement_takes_its_limb_from_its_joint_unless_told():
    from vsmp_imu.motion.anatomy import Movement

    assert [Movement("m", joint, "sagittal", {}).limb for joint in ("wrist", "knee", "trunk")] == [
        "arm", "leg", "none"]
    assert Movement("m", "knee", "sagittal", {}, limb="arm").limb == "arm"
    assert MOVEMENTS["squat"].limb == "leg" and MOVEMENTS["elbow_flexion"].limb == "arm"


OUTWARD_LOWERING = ("squat", "knee_bend", "lunge", "elbow_flexion", "trunk_flexion", "sit_down", "sit_down_floor",
                    "lie_down", "lie_prone", "kneel", "jump", "walk", "run", "stairs_down", "stairs_up")


@pytest.mark.parametrize("movement", OUTWARD_LOWERING)
def test_lowering_into_a_movement_goes_out_unless_it_comes_back(movement):
    """'lower the body into a squat' goes out; 'lower back down' and 'return' come back."""
    from vsmp_imu.motion.lexicon import _outward_lowering

    assert _outward_lowering("lower the body", (movement,))
    for words in ("lower back down", "lower again", "returning to the start", "lower back to the start"):
        assert not _outward_lowering(words, (movement,)), words


def test_lowering_the_arms_comes_back():
    from vsmp_imu.motion.lexicon import _outward_lowering

    assert not _outward_lowering("lower the arms", ("shoulder_abduction", "shoulder_flexion"))
    assert read_primitive("lower", "lower the body into a squat").movements == ("squat",)
    assert not read_primitive("lower", "lower the body into a squat").returns
    assert read_primitive("lower", "lower the arms to the sides").returns


def test_text_is_lower_case_with_single_spaces():
    from vsmp_imu.motion.lexicon import normalize_text

    assert normalize_text(" Raise_the-LEFT/arm   now ") == "raise the left arm now"


@pytest.mark.parametrize(("text", "expected"), [
    ("squat down bending the knees", ("squat",)),  # a squat already bends the knees
    ("lunge forward bending the knees", ("lunge", "trunk_flexion")),
    ("jog up the stairs walking", ("run", "stairs_up")),  # running is not also walking
    ("reach overhead raising the arms forward", ("shoulder_flexion_overhead",)),
    ("sit down bending the knees and leaning the trunk forward", ("sit_down",)),  # the posture change has them
])
def test_redundant_movements_are_pruned(text, expected):
    assert movements_in(text) == expected


def test_directions_and_sides_come_from_the_words():
    from vsmp_imu.motion.lexicon import _direction, _sides

    assert [_direction(t) for t in ("turn toward the right", "step leftward", "rightward", "turn to the left",
                                    "twist")] == [-1, 1, -1, 1, 0]
    assert _sides("kick with the left leg and swing the right arm") == ("right", "left")
    assert _sides("raise the right arm and the left arm") == ("right", None)  # the side named first acts
    assert _sides("the left knee then the right knee") == (None, "left")
    kick = read_primitive("kick", "kick the right leg forward while the left arm swings back")
    assert (kick.leg_side, kick.arm_side, kick.movements) == ("right", None, ("leg_kick",))  # the other limb is dropped


@pytest.mark.parametrize(("words", "posture"), [("sit on the chair", "sitting"), ("lie on the back", "lying"),
                                                ("kneel", "kneeling"), ("stand still", "standing"),
                                                ("wave the hand", None)])
def test_the_posture_a_primitive_names(words, posture):
    assert read_primitive("p", words).posture == posture


@pytest.mark.parametrize(("description", "expected"), [
    ("bend the elbows then straighten the arms", ("elbow_flexion",)),
    ("straighten the arms then bend the elbows", ("elbow_extension",)),
])
def test_when_both_elbow_movements_are_named_the_first_one_wins(description, expected):
    """An elbow cannot bend and straighten in one pose: the movement named first is the one read."""
    assert read_primitive("arms", description).movements == expected


@pytest.mark.parametrize(("description", "expected"), [
    ("break into a jog from walking", ("run",)),  # running is not also walking
    ("walk up the stairs", ("stairs_up",)),  # climbing stairs is not also level walking
    ("walk down the stairs", ("stairs_down",)),
])
def test_running_and_stairs_are_not_also_walking(description, expected):
    assert read_primitive("gait", description).movements == expected


def test_the_way_back_of_a_there_and_back_primitive_adds_no_movement():
    """Only the outward part ('extend the fist forward') is read; 'pull it back' is the way back."""
    punch = read_primitive("punch_left", "extend the left fist straight forward and pull it back to the guard")
    assert punch.movements == ("elbow_extension", "shoulder_flexion")
    assert punch.there_and_back and punch.returns is False  # a bool, not a mere falsy value


@pytest.mark.parametrize(("description", "context"), [
    # dumbbell_rows: 'driving the elbows back' is the action's shoulder extension ('toward the waist') again;
    # only the bent-forward trunk is held
    ("pull both dumbbells up toward the waist while bent forward at the hips, driving the elbows back",
     ("trunk_flexion",)),
    # sitting is a posture, not a movement held meanwhile
    ("raise both arms overhead while sitting on a chair", ()),
])
def test_held_movements_are_excursions_not_already_in_the_action(description, context):
    assert read_primitive("p", description).context == context


@pytest.mark.parametrize(("description", "returns"), [
    ("raise both arms overhead", False),  # moves out
    ("lower the arms to the sides", True),  # only comes back
])
def test_a_primitive_that_moves_or_returns_is_not_a_hold(description, returns):
    reading = read_primitive("p", description)
    assert reading.returns is returns and not reading.hold


def test_the_side_comes_from_the_action_not_the_held_part():
    row = read_primitive("row_up", "pull the dumbbell up to the waist with the right hand"
                                   " while kneeling on the bench with the left knee")
    assert (row.arm_side, row.leg_side) == ("right", None)  # the left knee only rests on the bench
    # no action part before the held part: the sides come from the whole text
    balance = read_primitive("keeping_balance", "keeping the right knee raised")
    assert balance.hold and (balance.arm_side, balance.leg_side) == (None, "right")


@pytest.mark.parametrize("text,moves", [
    ("raise the arms", ("shoulder_flexion",)),
    ("lift the left arm", ("shoulder_flexion",)),
    ("jump the feet apart and raise the arms", ("jump", "hip_abduction", "shoulder_flexion")),
    ("raise the arms to the sides", ("shoulder_abduction",)),
    ("raise the arms overhead", ("shoulder_flexion_overhead",)),
    ("raise the shoulders", ("shoulder_elevation",)),
    ("lift the legs", ("hip_flexion",)),
])
def test_an_arm_raised_with_no_direction_goes_forward(text, moves):
    assert read_primitive("p", text).movements == moves


def test_a_name_that_starts_with_a_held_phrase_leaves_the_description_its_action():
    bar = read_primitive("holding_the_bar", "pull the bar up to the chest")
    assert bar.movements == ("elbow_flexion",) and not bar.hold
    balance = read_primitive("keeping_balance", "lift the left knee to hip height")
    assert balance.movements == ("hip_flexion",) and balance.leg_side == "left"
    # a held phrase in the description still holds the rest of it
    row = read_primitive("row", "pull the dumbbell to the waist while bent forward at the hips")
    assert "trunk_flexion" in row.context and "trunk_flexion" not in row.movements
    assert read_primitive("holding_the_left_arm_up").arm_side == "left"  # all held: sides from the whole text


@pytest.mark.parametrize("text,moves", [
    ("raise the arms forward and overhead", ("shoulder_flexion_overhead",)),  # overhead is the forward raise, higher
    ("stand up straight", ("stand_up",)),  # a change of support brings its own trunk
    ("lean back and lie down", ("lie_down",)),
    ("sit down and lie down", ("lie_down",)),  # of two postures, the last
    ("sit down and stand up tall", ("stand_up",)),
])
def test_a_primitives_reading_prunes_redundant_movements(text, moves):
    assert read_primitive("p", text).movements == moves


@pytest.mark.parametrize("text,leg", [
    ("standing on the left leg, lift the right leg out to the side", "right"),
    ("stand on the right leg and lift the left knee", "left"),
    ("balance on the right foot and kick the other leg forward", "left"),
    ("balance on the left foot and kick the other leg forward", "right"),
    ("lift the left leg out to the side", "left"),
    ("hop on the right foot", "right"),  # hopping moves the leg it is on
])
def test_the_leg_stood_on_is_not_the_leg_that_moves(text, leg):
    assert read_primitive("p", text).leg_side == leg


@pytest.mark.parametrize("text,moves", [
    ("swing the right leg forward", ("hip_flexion",)),
    ("swing the other leg forward", ("hip_flexion",)),
    ("raise the leg forward", ("hip_flexion",)),  # not the arms as well
    ("swing the left leg out to the side", ("hip_abduction",)),
    ("step out to the side", ("hip_abduction",)),
    ("swing the arms forward", ("shoulder_flexion", "arm_pendulum_swing")),
    ("step forward and punch", ("elbow_extension", "shoulder_flexion")),  # a punch is an arm's
    ("jump the feet apart and raise the arms", ("jump", "hip_abduction", "shoulder_flexion")),
])
def test_direction_words_move_the_arms_only_when_the_words_name_no_leg_or_an_arm_too(text, moves):
    assert read_primitive("p", text).movements == moves


@pytest.mark.parametrize("text,moves,back", [
    ("raise the right arm and then lower it", ("shoulder_flexion",), True),  # not a return: it goes out first
    ("raise the arms and lower them", ("shoulder_flexion",), True),
    ("wall slide raising the arms", ("shoulder_flexion",), False),  # 'raising', not only 'raise'
    ("raising the arms to the sides", ("shoulder_abduction",), False),
    ("raising the knee", ("hip_flexion",), False),
    ("pull the band apart", ("shoulder_horizontal_abduction",), False),
    ("band pull-apart", ("shoulder_horizontal_abduction",), False),
])
def test_more_ways_of_saying_it(text, moves, back):
    reading = read_primitive("p", text)
    assert (reading.movements, reading.there_and_back, reading.returns) == (moves, back, False)


def test_the_held_parts_of_name_and_description_are_read_as_two_phrases():
    both = read_primitive("keeping_balance", "lift the left knee holding the arms in front")
    assert both.movements == ("hip_flexion",) and both.context == ("shoulder_flexion",)
    # a rule does not reach from the name's held words into the description's
    apart = read_primitive("holding_the_arms", "lift the knee keeping them in front")
    assert "shoulder_flexion" not in apart.context


@pytest.mark.parametrize("text,moves", [
    ("bring the cup to the mouth and drink", ("elbow_flexion",)),
    ("eating soup with a spoon", ("elbow_flexion",)),
    ("brush the teeth with the right hand", ("elbow_flexion",)),
    ("comb the hair with the right hand", ("elbow_flexion", "shoulder_abduction")),
    ("write on paper with a pen", ("wrist_flexion",)),
    ("dribble the basketball with the right hand", ("elbow_extension",)),
    ("bounce the ball on the floor", ("elbow_extension",)),  # the ball bounces, not the body
    ("bounce up and down", ("jump",)),
    ("catch the tennis ball", ("shoulder_flexion",)),
    ("catch the object and pull it in to the chest", ("elbow_flexion",)),
])
def test_activities_of_daily_living_and_ball_games(text, moves):
    """What a smartwatch dataset records (drinking, eating, brushing teeth, writing, dribbling)."""
    assert read_primitive("p", text).movements == moves


@pytest.mark.parametrize("text,moves", [
    ("raise both arms overhead", ("shoulder_flexion_overhead",)),
    ("raise the arms out to the sides and overhead", ("shoulder_abduction_overhead",)),
    ("raise the arms overhead out to the sides", ("shoulder_abduction_overhead",)),
    ("press the dumbbells overhead", ("shoulder_abduction_overhead",)),
    ("shoulder press", ("shoulder_abduction_overhead",)),
    ("press the bar forward and up overhead", ("shoulder_flexion_overhead",)),  # the words name the plane
    ("jump while spreading the legs apart and raising both arms overhead",
     ("jump", "shoulder_abduction_overhead", "hip_abduction")),
    ("jumping jacks", ("jump", "shoulder_abduction_overhead")),
    ("star jumps", ("jump", "shoulder_abduction_overhead")),
])
def test_arms_raised_overhead_go_up_the_sides_when_the_words_say_so(text, moves):
    assert movements_in(text) == moves
    assert read_primitive("x", text).movements == moves


@pytest.mark.parametrize("text,moves", [
    ("raise the right hand beside the head with the elbow bent", ("elbow_flexion", "shoulder_abduction")),
    ("hold the bat beside the right shoulder", ("elbow_flexion",)),
])
def test_a_hand_beside_the_head_or_shoulder(text, moves):
    assert read_primitive("x", text).movements == moves


@pytest.mark.parametrize("text,moves", [
    ("raise the knee to the chest", ("hip_flexion",)),  # the knee goes to the chest, not a hand
    ("pull the knees to the chest", ("hip_flexion",)),
    ("leg curl", ()),  # a curl of the leg bends no elbow
    ("hug the knees to the chest", ("elbow_flexion", "shoulder_horizontal_adduction", "hip_flexion")),
    ("sit with the legs crossed and drink from the cup", ("elbow_flexion",)),
    ("bring the hands to the chest", ("hands_at_chest",)),
])
def test_words_that_place_a_leg_bend_no_elbow(text, moves):
    assert read_primitive("x", text).movements == moves


@pytest.mark.parametrize("text,moves,leg", [
    ("bring the right elbow to the left knee while twisting the trunk", ("trunk_rotation", "hip_flexion"), "left"),
    ("elbow to the opposite knee", ("trunk_rotation", "hip_flexion"), None),
    ("extend the right leg forward", ("hip_flexion",), "right"),
    ("extend the leg straight out in front", ("hip_flexion",), None),
    ("extend the legs", ("leg_straighten",), None),
])
def test_an_elbow_to_the_knee_and_a_leg_extended_forward(text, moves, leg):
    reading = read_primitive("x", text)
    assert reading.movements == moves and reading.leg_side == leg


@pytest.mark.parametrize("text,moves,start", [
    ("extend both arms to press the dumbbells from the shoulders to overhead",
     ("elbow_extension", "shoulder_abduction_overhead"), ("press_rack",)),  # elbows out, forearms up
    ("raise the arms forward from the shoulders to overhead", ("shoulder_flexion_overhead",),
     ("shoulder_flexion", "elbow_flexion")),
    ("lower the bar from overhead to the chest", ("elbow_flexion",), ("shoulder_flexion_overhead",)),
    ("lower the bar from above the head", (), ("shoulder_flexion_overhead",)),
    # behind the neck: from where the words say, not the rack of a press from the shoulders
    ("press the barbell from behind the head to overhead", ("shoulder_abduction_overhead",),
     ("elbow_flexion", "shoulder_flexion_overhead")),
    ("press the bar from the chest", (), ("hands_at_chest",)),
    ("lower the dumbbells from the shoulders", (), ("elbow_flexion",)),  # no press: the hands at the shoulders
    ("raise the arms from the sides to overhead", ("shoulder_flexion_overhead",), ()),  # not a place it names
    ("raise both arms overhead", ("shoulder_flexion_overhead",), ()),
])
def test_the_place_a_movement_starts_from(text, moves, start):
    reading = read_primitive("x", text)
    assert reading.movements == moves and reading.start == start


@pytest.mark.parametrize("text,moves", [
    ("slide the iron forward across the board", ("elbow_extension", "shoulder_flexion",
                                                 "shoulder_horizontal_adduction")),
    ("draw the iron back toward the body", ("elbow_flexion", "shoulder_extension")),
    ("grasp the garment with both hands and lift it", ("elbow_flexion",)),
    ("slide the foot forward", ()),  # a leg slid forward moves no arm
    ("lift the leg", ("hip_flexion",)),
])
def test_objects_pushed_slid_pulled_and_lifted_by_the_hands(text, moves):
    assert read_primitive("x", text).movements == moves


@pytest.mark.parametrize("text,moves", [
    ("stand upright and place the hands on the hips", ("trunk_upright", "hands_on_hips")),
    ("bring the hands together in front of the chest", ("hands_at_chest",)),
    ("bring both hands up to the chest", ("hands_at_chest",)),
    ("clasp the hands", ("hands_at_chest",)),
    ("bring both palms together in front of the chest", ("elbow_flexion", "shoulder_flexion",
                                                         "shoulder_horizontal_adduction")),  # a clap
    ("lie on the back with the arms crossed over the chest", ("lie_down", "arms_crossed")),
    ("raise both forearms and cross them over the chest", ("arms_crossed",)),
    ("face down on the hands and toes", ("plank",)),  # a plank, not lying prone
])
def test_hand_placements_and_the_plank(text, moves):
    assert read_primitive("x", text).movements == moves


def test_a_press_from_the_shoulders_up_the_sides_starts_from_the_rack():
    reading = read_primitive("x", "press the dumbbells from the shoulders to overhead")
    assert reading.movements == ("shoulder_abduction_overhead",) and reading.start == ("press_rack",)


def test_a_swing_goes_the_way_its_words_name_first_and_a_release_is_no_return():
    back = read_primitive("backswing", "swing the right arm back while stepping forward and bending the knees")
    assert back.movements == ("lunge", "shoulder_extension") and back.pace == 1.0  # not a strike, no pendulum
    forward = read_primitive("swing", "swing the right arm forward low and release the ball")
    assert "shoulder_flexion" in forward.movements
    assert not forward.there_and_back and forward.pace == lex.PACE["ballistic"]
    assert read_primitive("grip", "squeeze the ball and release it").there_and_back  # a grip let go comes back
    assert read_primitive("swing", "swing both arms").movements == ("arm_pendulum_swing",)


@pytest.mark.parametrize(("description", "turns"), [
    ("turn to lie along the bed, leaning the trunk back flat", True),
    ("raise the trunk and turn, swinging the legs down to sit on the edge of the bed", True),
    ("turn to the edge of the bed", True),
    ("brings each elbow to the opposite knee in turn.", False),
    ("turn the palms down", False),
])
def test_turning_to_lie_or_to_the_edge_of_the_bed_turns_the_body(description, turns):
    assert ("turn" in movements_in(description)) == turns


def test_legs_swung_down_are_no_strike():
    assert read_primitive("down", "swinging the legs down to sit").pace == 1.0
    assert read_primitive("step", "swing the right leg forward").pace == 1.0


def test_words_after_and_back_are_not_the_outward_movement():
    """'raise the arm forward and back, then bend the elbows': the movement goes out up to 'and back'."""
    reading = read_primitive("raise", "raise the arm forward and back, then bend the elbows")
    assert reading.movements == ("shoulder_flexion",) and reading.there_and_back


def test_in_place_words_without_a_step_leave_the_movements_alone():
    assert read_primitive("hold", "raise both arms forward and hold them in place").movements == ("shoulder_flexion",)
    assert read_primitive("march", "march in place").movements == ("step_in_place",)


def test_shoulder_flexion_wins_when_its_words_end_first():
    """'swing the arm forward, then take it back': forward ends first (the mirror of 'swing the arm
    back while stepping forward')."""
    moves = read_primitive("swing", "swing the arm forward, then take it back").movements
    assert "shoulder_flexion" in moves and "shoulder_extension" not in moves
    back = read_primitive("swing", "take the arm back, then swing it forward").movements
    assert "shoulder_extension" in back and "shoulder_flexion" not in back


def test_a_recline_owns_the_trunks_sagittal_movement():
    assert read_primitive("lean", "bend forward then recline").movements == ("recline",)
