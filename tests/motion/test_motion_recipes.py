"""Recipe validation (errors name file and field) and the activity-library files of this room."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import yaml
from motion_cases import AUTHORED, CONTROLLABILITY, HAPT, MMFIT, SYMMETRY_VARIANT, UTD_MHAD_OTHERS

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion.procedural import match_primitives
from vsmp_imu.motion.recipe import parse_recipe, recipe_for_entry
from vsmp_imu.smp.bodyparts import BODY_PARTS
from vsmp_imu.smp.library import ActivityLibrary

PAMAP2 = {"lying": "lying", "sitting": "sitting", "standing": "standing", "walking": "walking",
          "walking_upstairs": "ascending stairs", "walking_downstairs": "descending stairs",
          "running": "running", "cycling": "cycling", "nordic_walking": "Nordic walking",
          "watching_tv": "watching TV", "computer_work": "computer work", "car_driving": "car driving",
          "vacuum_cleaning": "vacuum cleaning", "ironing": "ironing", "folding_laundry": "folding laundry",
          "house_cleaning": "house cleaning", "playing_soccer": "playing soccer", "rope_jumping": "rope jumping"}
HAPT_LABELS = {"walking": "WALKING", "walking_upstairs": "WALKING_UPSTAIRS",
               "walking_downstairs": "WALKING_DOWNSTAIRS", "sitting": "SITTING", "standing": "STANDING",
               "lying": "LAYING", "stand_to_sit": "STAND_TO_SIT", "sit_to_stand": "SIT_TO_STAND",
               "sit_to_lie": "SIT_TO_LIE", "lie_to_sit": "LIE_TO_SIT", "stand_to_lie": "STAND_TO_LIE",
               "lie_to_stand": "LIE_TO_STAND"}


def _jj_recipe(library):
    return copy.deepcopy(library.get("jumping_jacks").extras["procedural"])


@pytest.mark.parametrize("name", AUTHORED)
def test_library_recipe_is_valid_and_matches_its_smp(library, name):
    entry = library.get(name)
    recipe = recipe_for_entry(entry)
    matched = match_primitives(entry.smp, recipe)
    # every SMP primitive is a recipe primitive under its own name, in the recipe's order
    assert [m[2] for m in matched] == list(entry.smp.primitive_sequence)
    assert list(recipe.primitives) == list(entry.smp.primitive_sequence)
    if entry.central_primitive is not None:
        assert entry.central_primitive in entry.smp.primitive_sequence


@pytest.mark.parametrize("name", AUTHORED)
def test_library_file_content(library, name):
    entry = library.get(name)
    smp = entry.smp
    assert len(entry.captions) >= 5 and len(set(entry.captions)) == len(entry.captions)
    assert len(entry.aliases) >= 3
    for prim in smp.motion_primitives:
        assert prim.description and set(prim.body_parts) <= set(BODY_PARTS), prim.name
        assert isinstance(prim.relative_duration, float) and prim.relative_duration > 0
    parts = smp.body_parts
    assert set(parts.mandatory + parts.optional + parts.dominant_moving_segments) <= set(BODY_PARTS)
    variants = smp.constraints.variant_fields
    side = smp.execution_attributes.dominant_side
    if "dominant_side" in variants:
        # side-agnostic activities only: never a "right-hand ..." (UTD-MHAD) activity; a swap needs a side
        assert side in ("left", "right") and not name.startswith(("right_", "left_"))
        assert "utd_mhad" not in entry.datasets
    if "repetition_count" in variants:
        assert smp.temporal_structure.is_repetitive
    if "symmetry" in variants:
        assert name in SYMMETRY_VARIANT
    if smp.temporal_structure.is_repetitive:
        assert smp.temporal_structure.periodicity == "cyclic"
    assert all(0.0 <= v <= 1.0 for v in smp.uncertainty.model_dump().values())


def test_dataset_labels(library):
    for name in HAPT:
        assert library.get(name).datasets["hapt"] == HAPT_LABELS[name]
    for name, label in PAMAP2.items():
        assert library.get(name).datasets["pamap2"] == label
    for name in CONTROLLABILITY + UTD_MHAD_OTHERS:
        assert library.get(name).datasets.get("utd_mhad"), name
    for name in MMFIT:
        assert library.get(name).datasets["mmfit"] == name
    assert library.get("sit_to_stand").datasets["utd_mhad"] == "sit to stand"
    assert library.get("stand_to_sit").datasets["utd_mhad"] == "stand to sit"
    # dataset spellings resolve to the activity
    assert library.resolve("WALKING_UPSTAIRS").name == "walking_upstairs"
    assert library.resolve("ascending stairs").name == "walking_upstairs"
    assert library.resolve("LAYING").name == "lying"
    assert library.resolve("Nordic walking").name == "nordic_walking"
    assert library.resolve("bowling (right hand)").name == "bowling"
    assert library.resolve("right hand draw circle (counter clockwise)").name == "right_hand_draw_circle_counter_clockwise"


def test_jumping_jacks_keeps_its_smp(library):
    entry = library.get("jumping_jacks")
    assert entry.smp.primitive_sequence == ["stand", "jump_open", "jump_close"]
    assert entry.smp.repetition_count() == 8
    assert "procedural" in entry.extras


@pytest.mark.parametrize(("edit", "field", "words"), [
    (lambda r: r["poses"].__setitem__("open", {"shoulder_abduction": 150}), "procedural.poses",
     "unknown DOF 'shoulder_abduction'"),
    (lambda r: r["primitives"]["jump_open"].__setitem__("keys", [[1.0, "nowhere"]]), "procedural",
     "unknown pose 'nowhere'"),
    (lambda r: r["cycle"].__setitem__("primitives", ["jump_open", "hop"]), "procedural",
     "unknown primitive(s) hop"),
    (lambda r: r.__setitem__("principal_joints", ["left_wirst"]), "procedural.principal_joints",
     "unknown joint(s) left_wirst"),
    (lambda r: r["primitives"]["stand"].__setitem__("duration_s", -1), "procedural.primitives.stand.duration_s",
     "greater than 0"),
    (lambda r: r.__setitem__("kind", "weird"), "procedural.kind", "periodic"),
    (lambda r: r["primitives"]["jump_open"].__setitem__("keys", [[0.8, "open"], [0.5, "base"]]),
     "procedural.primitives.jump_open.keys", "increase"),
    (lambda r: r["cycle"]["wave"].__setitem__("root_dy", [[0.5, 0.0]]), "procedural.cycle.wave",
     "at least 2"),
    (lambda r: r.__setitem__("turns", {"turn_steps": [8, 4]}), "procedural.turns", "fewest steps first"),
    # every number is finite and within its bound, and the field named is the number's own
    (lambda r: r["cycle"]["wave"]["knee_flex"].__setitem__(0, [float("nan"), 22]),
     "procedural.cycle.wave.knee_flex[0][0]", "finite"),
    (lambda r: r["cycle"]["wave"]["knee_flex"].__setitem__(0, [0.0, float("inf")]),
     "procedural.cycle.wave.knee_flex[0][1]", "within ±360 degrees"),
    (lambda r: r["primitives"]["jump_open"].__setitem__("keys", [[1.0, {"elbow_flex": -400}]]),
     "procedural.primitives.jump_open.keys[0].pose.elbow_flex", "within ±360 degrees"),
    (lambda r: r.__setitem__("base_pose", {"like": "standing", "root_dz": 11}),
     "procedural.base_pose.root_dz", "within ±10 m"),
    (lambda r: r["cycle"].__setitem__("count", 10**9), "procedural.cycle.count", "<= 1000"),
    (lambda r: r["primitives"]["jump_open"].__setitem__("keys", [[1.0, "open", "glide"]]),
     "procedural.primitives.jump_open.keys[0].ease", "'stop', 'smooth' or 'pass'"),
])
def test_recipe_errors_name_file_and_field(library, edit, field, words):
    data = _jj_recipe(library)
    edit(data)
    with pytest.raises(ValidationError) as info:
        parse_recipe(data, file="activities/jumping_jacks.yaml")
    err = info.value
    assert err.file == "activities/jumping_jacks.yaml"
    assert err.field.startswith(field), err.field
    assert words in err.render(), err.render()


def test_a_key_may_be_passed_without_overshoot(library):
    data = _jj_recipe(library)
    data["primitives"]["jump_open"]["keys"] = [[0.5, "open", "pass"], [1.0, "open"]]
    assert [k.ease for k in parse_recipe(data).primitives["jump_open"].keys] == ["pass", "stop"]


def test_pose_like_loops_are_reported(library):
    data = _jj_recipe(library)
    data["poses"].update({"a": {"like": "b", "elbow_flex": 1}, "b": {"like": "a"}})
    with pytest.raises(ValidationError, match="refers to itself"):
        parse_recipe(data, file="x.yaml")


def test_activity_without_recipe_is_a_clear_error(tmp_path, library):
    text = (library.get("jumping_jacks").path.read_text()).split("# Procedural recipe")[0]
    data = yaml.safe_load(text)
    data["name"] = "hopscotch"
    data["aliases"] = ["hop scotch"]
    data["smp"]["activity_label"] = "hopscotch"
    (tmp_path / "hopscotch.yaml").write_text(yaml.safe_dump(data))
    lib = ActivityLibrary.load(extra_dirs=[tmp_path])
    with pytest.raises(ValidationError, match="no procedural recipe") as info:
        recipe_for_entry(lib.get("hopscotch"))
    assert "hopscotch.yaml" in info.value.render()


LIBRARY_RECIPES = [e.name for e in ActivityLibrary.load() if "procedural" in e.extras]


@pytest.mark.parametrize("name", LIBRARY_RECIPES)
def test_every_library_recipe_animates_its_smp(backend, library, name):
    """Recipes added to the library later are checked too."""
    from vsmp_imu.motion.selfcheck import is_plausible
    from vsmp_imu.smp.intervene import intervene

    entry = library.get(name)
    recipe = recipe_for_entry(entry)
    assert [m[2] for m in match_primitives(entry.smp, recipe)] == list(entry.smp.primitive_sequence)
    assert is_plausible(backend.generate(entry.smp, seed=0))
    fast = intervene(intervene(entry.smp, "tempo", "fast"), "amplitude", "large")
    assert is_plausible(backend.generate(fast, seed=1))


def _turn_and_pitch(backend, smp, side: str) -> tuple[np.ndarray, float]:
    """Net rotation (rad) of a waist sensor's segment: about the turn's two body axes, and pitch."""
    from vsmp_imu.imu.kinematics import simulate_kinematics

    smp = smp.model_copy(deep=True)
    smp.execution_attributes.dominant_side = side
    net = simulate_kinematics(backend.generate(smp, seed=0), "waist", 50.0).gyr_seg.sum(axis=0) / 50.0
    return net[1:], float(net[0])


@pytest.mark.parametrize("name", ["sit_to_lie", "stand_to_lie", "lie_to_sit", "lie_to_stand"])
def test_lying_transitions_turn_either_way(backend, library, name):
    """Lying along a bed from its edge takes a quarter turn: the waist turns by more than 1 rad
    about the body's long and front axes, the other way when the SMP's side is swapped, and the
    trunk's pitch is the same either way (docs/motion.md, lying transitions)."""
    smp = library.get(name).smp
    assert "dominant_side" in smp.constraints.variant_fields
    right, pitch_r = _turn_and_pitch(backend, smp, "right")
    left, pitch_l = _turn_and_pitch(backend, smp, "left")
    assert np.linalg.norm(right) > 1.0
    np.testing.assert_allclose(left, -right, atol=1e-6)
    assert pitch_l == pytest.approx(pitch_r, abs=1e-6) and abs(pitch_r) > 0.8


def test_sit_stand_transitions_do_not_turn(backend, library):
    for name in ("stand_to_sit", "sit_to_stand"):
        turn, _ = _turn_and_pitch(backend, library.get(name).smp, "none")
        assert np.linalg.norm(turn) < 0.1, name


def test_keyed_travel_is_the_farthest_horizontal_way_of_a_key_from_the_start_pose():
    data = {"kind": "discrete", "principal_joints": ["pelvis"], "start_pose": {"root_dx": 0.1},
            "poses": {"a": {"root_dz": -0.4, "root_dx": 0.1}, "b": {"root_dx": 0.4, "root_dz": 0.4, "root_dy": -0.9}},
            "primitives": {"p": {"duration_s": 1.0, "keys": [[0.5, "a"], [1.0, "b"]]}, "q": {"duration_s": 1.0}}}
    assert parse_recipe(data).keyed_travel_m() == pytest.approx(0.5)  # (0.3, 0.4) from the start; height not counted
    data["start_pose"] = None
    assert parse_recipe(data).keyed_travel_m() == pytest.approx(0.4 * 2 ** 0.5)  # from the base pose
    del data["primitives"]["p"]["keys"]
    assert parse_recipe(data).keyed_travel_m() == 0.0
