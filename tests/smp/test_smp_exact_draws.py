"""Constrained augmentation drawn exactly from its named streams, and the SMP's scalar views.

Each expected value is computed from the appendix rule and
`rng_for(seed, smp_id, index, field)`, not by the augmenter itself."""

from __future__ import annotations

import json
import math

import pytest
from smp_helpers import make_smp, simple_smp

from vsmp_imu.errors import ValidationError
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import augment as aug
from vsmp_imu.smp.augment import SMPAugmenter, augment_variant
from vsmp_imu.smp.schema import (
    AMPLITUDE_LEVELS,
    SMP,
    TEMPO_LEVELS,
    displacement_word,
    ordinal_level,
    ordinal_word,
    smp_json_schema,
)
from vsmp_imu.validation import SHOWN_INPUT_CHARS

U = 0.2


def _draw(smp: SMP, seed: int, index: int, field: str):
    return rng_for(seed, smp.smp_id, index, field)


def test_perturbation_ranges_are_the_appendix_table():
    assert (aug.TEMPO_MAX_LEVELS, aug.AMPLITUDE_MAX_LEVELS, aug.REPETITION_MAX_CYCLES) == (1.0, 1.0, 5)
    assert (aug.DURATION_MAX_FRACTION, aug.DISPLACEMENT_MAX_FRACTION) == (0.25, 0.25)
    assert (aug.SIDE_SWAP_PROBABILITY, aug.SYMMETRY_CHANGE_PROBABILITY) == (0.5, 0.3)
    assert aug.DECIMALS == 4 and aug.MIN_EXTENT_M == 1e-3


@pytest.mark.parametrize("index", [0, 3])
def test_ordinal_and_count_fields_are_drawn_from_their_streams(index):
    smp = simple_smp()
    out, changed = augment_variant(smp, 9, index)
    radius = (1 - U) * 1.0
    tempo = round(min(2.0, max(0.0, _draw(smp, 9, index, "tempo").uniform(1 - radius, 1 + radius))), 4)
    amp = round(min(2.0, max(0.0, _draw(smp, 9, index, "amplitude").uniform(2 - radius, 2 + radius))), 4)
    assert out.execution_attributes.tempo == tempo and out.execution_attributes.amplitude == amp
    r = (1 - U) * 5
    lo, hi = max(1, math.ceil(6 - r)), max(1, math.floor(6 + r))
    assert (lo, hi) == (2, 10)
    count = int(_draw(smp, 9, index, "repetition_count").integers(lo, hi + 1))
    assert out.temporal_structure.repetition_count == count
    assert changed["execution_attributes.tempo"] == {"before": "medium", "after": tempo}
    if count != 6:
        assert changed["temporal_structure.repetition_count"] == {"before": 6, "after": count}


def test_relative_durations_scale_then_renormalize_to_their_sum():
    smp = simple_smp()
    out, changed = augment_variant(smp, 4, 1)
    radius = (1 - U) * 0.25
    f = _draw(smp, 4, 1, "primitive_duration").uniform(1 - radius, 1 + radius, size=3)
    raw = [v * x for v, x in zip([0.3, 0.5, 0.2], f, strict=True)]
    want = [round(v * 1.0 / sum(raw), 4) for v in raw]
    assert out.primitive_durations.values == want and out.primitive_durations.type == "relative"
    assert changed["primitive_durations"] == {"before": {"type": "relative", "values": [0.3, 0.5, 0.2]},
                                              "after": {"type": "relative", "values": want}}


def test_absolute_durations_are_scaled_without_renormalizing_and_unknowns_stay():
    smp = make_smp(simple_smp(), **{"primitive_durations": {"type": "absolute", "values": [2.0, "unknown", 1.0]}})
    out, _ = augment_variant(smp, 4, 0)
    radius = (1 - U) * 0.25
    f = _draw(smp, 4, 0, "primitive_duration").uniform(1 - radius, 1 + radius, size=3)
    assert out.primitive_durations.values == [round(2.0 * f[0], 4), "unknown", round(1.0 * f[2], 4)]


def test_empty_durations_are_filled_from_the_nominal_primitive_durations():
    smp = make_smp(simple_smp(), **{"primitive_durations": {"type": "unknown", "values": []}})
    out, _ = augment_variant(smp, 4, 0)
    assert out.primitive_durations.type == "relative" and len(out.primitive_durations.values) == 3
    assert sum(out.primitive_durations.values) == pytest.approx(1.0, abs=2e-4)
    unknown = make_smp(smp, **{"motion_primitives.0.relative_duration": "unknown"})
    assert augment_variant(unknown, 4, 0)[0].primitive_durations.values == []


def _category_smp(**ea):
    fields = ["dominant_side", "symmetry", "global_displacement"]
    return make_smp(simple_smp(), **{"constraints.variant_fields": fields,
                                     **{f"execution_attributes.{k}": v for k, v in ea.items()}})


def test_categorical_fields_flip_when_their_stream_falls_below_the_probability():
    flips = {"side": 0, "sym": 0}
    for index in range(40):
        smp = _category_smp(dominant_side="left", symmetry="asymmetric", global_displacement="small")
        out, changed = augment_variant(smp, 1, index)
        side = _draw(smp, 1, index, "dominant_side").random() < (1 - U) * 0.5
        sym = _draw(smp, 1, index, "symmetry").random() < (1 - U) * 0.3
        assert out.execution_attributes.dominant_side == ("right" if side else "left")
        assert out.execution_attributes.symmetry == ("symmetric" if sym else "asymmetric")
        assert ("execution_attributes.dominant_side" in changed) == side
        if side:
            assert changed["execution_attributes.dominant_side"] == {"before": "left", "after": "right"}
        if sym:
            assert changed["execution_attributes.symmetry"] == {"before": "asymmetric", "after": "symmetric"}
        factor = _draw(smp, 1, index, "global_displacement").uniform(1 - (1 - U) * 0.25, 1 + (1 - U) * 0.25)
        extent = round(max(1e-3, 1.0 * factor), 4)
        assert out.execution_attributes.global_displacement == extent
        assert changed["execution_attributes.global_displacement"] == {"before": "small", "after": extent}
        flips["side"] += side
        flips["sym"] += sym
    assert flips["side"] > 0 and flips["sym"] > 0
    right = _category_smp(dominant_side="right")
    swapped = [augment_variant(right, 1, i)[0].execution_attributes.dominant_side for i in range(20)]
    assert "left" in swapped and set(swapped) <= {"left", "right"}


class _Fixed:
    """A stream whose every draw is `value`."""

    def __init__(self, value: float) -> None:
        self.value = value

    def random(self) -> float:
        return self.value


def test_a_draw_equal_to_the_probability_changes_nothing(monkeypatch):
    """The draw is in [0, 1) and a field changes when it is below p: so with p = 0 (u = 1)
    even a draw of 0.0 leaves the field."""
    smp = make_smp(_category_smp(dominant_side="left", symmetry="symmetric"),
                   **{"uncertainty.dominant_side": 0.5, "uncertainty.symmetry": 1.0})
    for draw, side in ((0.25, "left"), (0.2499, "right"), (0.0, "right")):  # side: p = 0.25
        monkeypatch.setattr(aug, "rng_for", lambda *keys, d=draw: _Fixed(d))
        out, _ = augment_variant(smp, 1, 0)
        assert out.execution_attributes.dominant_side == side
        assert out.execution_attributes.symmetry == "symmetric"


def test_unconditioned_augmentation_uses_full_radius():
    smp = make_smp(simple_smp(), **dict.fromkeys([f"uncertainty.{k}" for k in ("tempo",)], 1.0))
    frozen, _ = augment_variant(smp, 2, 0)
    assert frozen.execution_attributes.tempo == "medium"
    free, _ = augment_variant(smp, 2, 0, uncertainty_conditioned=False)
    want = round(min(2.0, max(0.0, _draw(smp, 2, 0, "tempo").uniform(0.0, 2.0))), 4)
    assert free.execution_attributes.tempo == want


def test_augmenter_records_each_variant():
    smp = simple_smp()
    a = SMPAugmenter(uncertainty_conditioned=False)
    variants = a.augment(smp, 2, 5)
    assert len(variants) == len(a.changes_) == 2
    for i, (v, c) in enumerate(zip(variants, a.changes_, strict=True)):
        assert c["index"] == i and c["source_smp_id"] == smp.smp_id and c["seed"] == 5
        assert c["uncertainty_conditioned"] is False and c["smp_id"] == v.smp_id
        assert c["changed"] == augment_variant(smp, 5, i, False)[1]
    assert SMPAugmenter().augment(smp, 0, 5) == []
    with pytest.raises(ValidationError) as err:
        SMPAugmenter().augment(smp, -1, 5)
    assert err.value.field == "k"


# -- scalar views of the schema ---------------------------------------------------------------------
def test_ordinal_levels_and_words():
    assert [ordinal_level(w, TEMPO_LEVELS) for w in ("slow", "medium", "fast", "unknown")] == [0.0, 1.0, 2.0, None]
    assert ordinal_level(1.25, AMPLITUDE_LEVELS) == 1.25
    assert [ordinal_word(v, TEMPO_LEVELS) for v in (-1.0, 0.4, 0.6, 1.5, 2.6, "slow")] == [
        "slow", "slow", "medium", "fast", "fast", "slow"]
    assert [displacement_word(v) for v in (0.0, -1.0, 0.5, 2.5, 2.49, "large")] == [
        "stationary", "stationary", "small", "large", "small", "large"]


def test_smp_scalar_views():
    smp = simple_smp()
    assert smp.tempo_level() == 1.0 and smp.amplitude_level() == 2.0 and smp.repetition_count() == 6
    assert smp.displacement_extent_m() == 0.0
    assert make_smp(smp, **{"execution_attributes.global_displacement": "large"}).displacement_extent_m() == 4.0
    assert make_smp(smp, **{"execution_attributes.global_displacement": 1.5}).displacement_extent_m() == 1.5
    assert make_smp(smp, **{"execution_attributes.global_displacement": "unknown"}).displacement_extent_m() is None
    assert make_smp(smp, **{"temporal_structure.repetition_count": "unknown"}).repetition_count() is None
    assert make_smp(smp, **{"execution_attributes.tempo": 0.5}).tempo_level() == 0.5


def test_relative_durations_fill_unknowns_with_the_known_mean():
    smp = simple_smp()
    assert smp.relative_durations() == pytest.approx([0.3, 0.5, 0.2])
    part = make_smp(smp, **{"primitive_durations.values": [2.0, "unknown", 0.0]})
    assert part.relative_durations() == pytest.approx([0.3333333, 0.3333333, 0.3333333])
    part = make_smp(smp, **{"primitive_durations.values": [3.0, "unknown", 1.0]})
    assert part.relative_durations() == pytest.approx([3 / 6, 2 / 6, 1 / 6])
    none = make_smp(smp, **{"primitive_durations.values": []})
    assert none.relative_durations() == pytest.approx([0.3, 0.5, 0.2])  # from the primitives
    blank = make_smp(none, **{f"motion_primitives.{i}.relative_duration": "unknown" for i in range(3)})
    assert blank.relative_durations() == pytest.approx([1 / 3] * 3)
    # a structural word names no primitive: it takes the mean of the known durations
    looped = make_smp(none, primitive_sequence=["raise_arms", "circle_arms", "lower_arms", "repeat"])
    assert looped.relative_durations() == pytest.approx([0.3 / 4 * 3, 0.5 / 4 * 3, 0.2 / 4 * 3, 1 / 4])


def test_a_sequence_name_finds_its_primitive_whatever_its_case_and_separators():
    """Validation takes 'Raise Arms' for the primitive raise_arms; the durations looked it up by
    its exact name and filled its known 0.3 with the mean."""
    none = make_smp(simple_smp(), **{"primitive_durations.values": []})
    spelled = make_smp(none, primitive_sequence=["Raise Arms", "circle-arms", "LOWER_ARMS", "repeat"])
    assert spelled.relative_durations() == pytest.approx([0.3 / 4 * 3, 0.5 / 4 * 3, 0.2 / 4 * 3, 1 / 4])
    assert spelled.primitive("Raise Arms").name == "raise_arms"
    assert spelled.primitive_duration("circle-arms") == 0.5
    assert spelled.primitive("repeat") is None and spelled.primitive_duration("repeat") is None


def test_identity_and_schema():
    smp = simple_smp()
    assert smp.canonical_json() == smp.canonical_json() and '"activity_label":"arm circles"' in smp.canonical_json()
    assert len(smp.smp_id) == 16 and smp.smp_id != make_smp(smp, activity_label="x").smp_id
    schema = smp_json_schema()
    assert schema["title"] == "Semantic Motion Program"
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    with pytest.raises(ValueError, match="primitive_durations.values has 2 entries but primitive_sequence has 3"):
        make_smp(smp, **{"primitive_durations.values": [0.5, 0.5]})
    with pytest.raises(ValueError, match="must not be empty"):
        make_smp(smp, activity_label="   ")
    assert make_smp(smp, activity_label="  walk ").activity_label == "walk"


def test_primitive_sequence_names_a_primitive_or_a_structural_word():
    """An empty or unknown name was accepted, and synthesis then made some other motion."""
    from vsmp_imu.errors import ValidationError
    from vsmp_imu.smp.io import smp_from_dict

    data = simple_smp().model_dump(mode="json")
    with pytest.raises(ValidationError) as err:
        smp_from_dict({**data, "primitive_sequence": ["raise_arms", " ", "lower_arms"]}, "s.json")
    assert err.value.field == "primitive_sequence[1]" and err.value.message == "must not be empty (got ' ')"
    assert err.value.__cause__.errors()[0]["type"] == "blank_name"
    with pytest.raises(ValidationError) as err:
        smp_from_dict({**data, "primitive_sequence": ["raise_arms", "fly", "lower_arms"]}, "s.json")
    assert err.value.field == "primitive_sequence" and "item 1 'fly' is the name of no motion primitive" \
        in err.value.message
    assert err.value.allowed == ("a name from motion_primitives (raise_arms, circle_arms, lower_arms) or a "
                                 "structural word (repeat, repetition, repeat cycle, loop, repeat sequence)")
    loose = ["Raise Arms", "circle-arms", "lower_arms", "Repeat"]  # case, '-', '_' aside; a structural word
    smp = smp_from_dict({**data, "primitive_sequence": loose, "primitive_durations": {"values": []}})
    assert smp.primitive_sequence == loose


def test_two_spellings_of_one_primitive_name_are_refused():
    """'curl_up' and 'Curl Up' were both accepted, and every sequence name then read the first,
    whichever spelling it had; a name repeated exactly (a primitive per position) still passes."""
    from vsmp_imu.smp.io import smp_from_dict

    data = simple_smp().model_dump(mode="json")
    prims = data["motion_primitives"]
    spelled = [*prims, {**prims[0], "name": "Raise-Arms", "order_index": 3, "relative_duration": 0.9}]
    with pytest.raises(ValidationError) as err:
        smp_from_dict({**data, "motion_primitives": spelled}, "s.json")
    assert err.value.field == "motion_primitives"
    assert err.value.message == ("motion_primitives[0] 'raise_arms' and motion_primitives[3] 'Raise-Arms' differ "
                                 "only in case, spaces, '_' or '-', so a primitive_sequence name cannot tell "
                                 "them apart")
    assert err.value.allowed == "one spelling of each primitive name"
    for n, shown in ((SHOWN_INPUT_CHARS, "'" + "a" * SHOWN_INPUT_CHARS + "'"),
                     (SHOWN_INPUT_CHARS + 1, "'" + "a" * SHOWN_INPUT_CHARS + f"...' ({SHOWN_INPUT_CHARS + 1} characters)")):
        long = [*prims, {**prims[0], "name": "a" * n, "order_index": 3}, {**prims[0], "name": "A" * n, "order_index": 4}]
        with pytest.raises(ValidationError) as err:
            smp_from_dict({**data, "motion_primitives": long}, "s.json")
        assert err.value.message.startswith(f"motion_primitives[3] {shown} and motion_primitives[4] ")  # whole up to 60
    repeated = [*prims, {**prims[0], "order_index": 3}]
    smp = smp_from_dict({**data, "motion_primitives": repeated, "primitive_sequence": [
        "raise_arms", "circle_arms", "lower_arms", "raise_arms"], "primitive_durations": {"values": []}})
    assert smp.primitive("Raise Arms") is smp.motion_primitives[0]


def test_canonical_json_is_key_sorted_and_compact():
    text = simple_smp().canonical_json()
    assert text.startswith('{"activity_label":"arm circles","body_parts":{"dominant_moving_segments":[')
    assert text == json.dumps(json.loads(text), sort_keys=True, separators=(",", ":"))
    assert SMP.model_validate_json(text) == simple_smp()


@pytest.mark.parametrize(("value", "message", "allowed"), [
    (-0.1, "Input should be greater than or equal to 0 (got -0.1)", ">= 0.0"),
    (1.5, "Input should be less than or equal to 1 (got 1.5)", "<= 1.0"),
    ("0.5", "Input should be a valid number (got '0.5')", None),
    (True, "Input should be a valid number (got True)", None),
    (float("nan"), "Input should be a finite number (got nan)", "finite"),
])
def test_an_uncertainty_is_a_finite_number_in_0_to_1(value, message, allowed):
    from vsmp_imu.smp.io import smp_from_dict

    data = simple_smp().model_dump(mode="json")
    data["uncertainty"]["tempo"] = value
    with pytest.raises(ValidationError) as err:
        smp_from_dict(data)
    assert (err.value.field, err.value.message, err.value.allowed) == ("uncertainty.tempo", message, allowed)
