"""Prompts back into SMPs: the verbalizer's phrases, library captions, free text."""

from __future__ import annotations

import pytest
from motion_cases import AUTHORED

from vsmp_imu.errors import ValidationError
from vsmp_imu.motion import measure
from vsmp_imu.motion.prompt import parse_attributes, smp_from_prompt
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.verbalize import verbalize


@pytest.mark.parametrize("name", AUTHORED)
def test_verbalized_interventions_round_trip(library, name):
    smp = library.get(name).smp
    for attribute, level in (("tempo", "slow"), ("tempo", "fast"), ("amplitude", "small"),
                             ("amplitude", "large"), ("symmetry", "asymmetric")):
        parsed, entry = smp_from_prompt(verbalize(intervene(smp, attribute, level)), library)
        assert entry.name == name
        assert getattr(parsed.execution_attributes, attribute) == level
    if smp.temporal_structure.is_repetitive:
        parsed, _ = smp_from_prompt(verbalize(intervene(smp, "repetitions", 9)), library)
        assert parsed.repetition_count() == 9


@pytest.mark.parametrize("name", AUTHORED)
def test_library_captions_resolve_to_their_activity(library, name):
    for caption in library.get(name).captions:
        assert smp_from_prompt(caption, library)[1].name == name, caption


@pytest.mark.parametrize("name", AUTHORED)
def test_captions_with_attribute_phrases_keep_their_activity(library, name):
    # a caption followed by attribute phrases (IMUGPT-style and C1 prompts) must not
    # lose to a shorter activity name it contains ("walking upstairs" -> "walking")
    for caption in library.get(name).captions:
        for text in (f"{caption} They do this at a fast pace, with a large range of motion.",
                     f"{caption.rstrip('.')} slowly, with large, energetic movements."):
            assert smp_from_prompt(text, library)[1].name == name, text


@pytest.mark.parametrize(("text", "expected"), [
    ("a person waves quickly 3 times", {"tempo": 2.0, "repetitions": 3}),
    ("do the exercise twice, slowly, with a small range of motion", {"tempo": 0.0, "repetitions": 2,
                                                                    "amplitude": 0.0}),
    ("at a somewhat fast pace, using an enlarged range of motion", {"tempo": 1.5, "amplitude": 1.5}),
    ("moving both sides asymmetrically, leading with the left arm", {"symmetry": "asymmetric",
                                                                    "dominant_side": "left"}),
    ("walking, covering about 3.5 meters", {"global_displacement": 3.5}),
    ("walking upstairs, turning left at each landing", {"dominant_side": "left"}),
    ("going down the stairs turning to the right at the landings", {"dominant_side": "right"}),
    ("repeating the complete movement eleven times", {"repetitions": 11}),
])
def test_attribute_phrases(text, expected):
    assert parse_attributes(text) == expected


def test_prompt_drives_the_procedural_backend(backend, library):
    m = backend.generate("A person performs two arm curl. They curl at a deliberately fast pace, "
                         "repeating the complete movement six times.", seed=2)
    assert m.meta["activity"] == "two_arm_curl" and m.meta["prompt"].startswith("A person performs")
    assert measure.count_repetitions(m, m.meta["principal_joints"]).count == 6
    assert m.meta["controls"]["tempo_level"] == 2.0


def test_unparseable_prompt_is_a_clear_error(library):
    with pytest.raises(ValidationError) as info:
        smp_from_prompt("the cat sleeps on the warm piano", library)
    assert info.value.field == "prompt" and "jumping_jacks" in info.value.allowed
    with pytest.raises(ValidationError, match="empty"):
        smp_from_prompt("   ", library)
