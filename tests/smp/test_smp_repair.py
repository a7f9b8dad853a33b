"""Deterministic repair of raw model text: hand-made cases and a mutation fuzzer."""

from __future__ import annotations

import json
import random
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from smp_helpers import mutate_response

from vsmp_imu.smp.repair import RepairResult, parse_response
from vsmp_imu.smp.schema import MAX_PRIMITIVES, SMP, UNCERTAINTY_FIELDS


@pytest.fixture
def raw(jj) -> dict:
    return jj.model_dump(mode="json")


def test_valid_json_needs_no_repair(raw, jj):
    result = parse_response(json.dumps(raw))
    assert result.valid and not result.repaired
    assert not result.report.malformed_json and result.report.json_found
    assert result.smp == jj
    assert result.report.to_dict()["valid"] is True


def test_bytes_are_accepted(raw, jj):
    assert parse_response(json.dumps(raw).encode()).smp == jj


def test_json_in_prose_and_fences(raw, jj):
    text = f"Sure! Here is the SMP.\n```json\n{json.dumps(raw, indent=2)}\n```\nLet me know."
    result = parse_response(text)
    assert result.smp == jj
    assert result.report.malformed_json and result.report.json_found
    assert any("fence" in r for r in result.report.repairs)


def test_largest_most_smp_like_object_wins(raw, jj):
    text = 'Example: {"a": 1}. Answer: ' + json.dumps(raw) + ' Note: {"activity_label": "x"}'
    assert parse_response(text).smp == jj


def test_truncated_json_is_repaired(raw):
    text = json.dumps(raw)
    cut = text[: text.index('"uncertainty"') + 40]
    result = parse_response(cut)
    assert result.valid and result.report.malformed_json
    assert any("json_repair" in r for r in result.report.repairs)
    assert result.smp.activity_label == "jumping jacks"


def test_malformed_keys_mapped_at_every_level(raw):
    raw["activty_label"] = raw.pop("activity_label")
    ea = raw.pop("execution_attributes")
    ea["temop"] = ea.pop("tempo")
    raw["execution_atributes"] = ea
    raw["motion_primitives"][0]["descriptoin"] = raw["motion_primitives"][0].pop("description")
    raw["uncertainty"]["Tempo"] = raw["uncertainty"].pop("tempo")
    raw["mood"] = "happy"
    result = parse_response(json.dumps(raw))
    repairs = result.report.repairs
    assert "renamed key 'activty_label' -> 'activity_label'" in repairs
    assert any("'temop' -> 'tempo'" in r for r in repairs)
    assert any("'descriptoin' -> 'description'" in r for r in repairs)
    assert any("dropped unknown key 'mood'" in r for r in repairs)
    smp = result.smp
    assert smp.activity_label == "jumping jacks"
    assert smp.execution_attributes.tempo == "medium"
    assert smp.motion_primitives[0].description.startswith("stand upright")


def test_value_synonyms_and_conservative_defaults():
    text = json.dumps({
        "activity_label": "jumping jacks",
        "primitive_sequence": "stand -> jump open -> jump close",
        "temporal_structure": {"is_repetitive": "yes", "repetition_count": "eight",
                               "periodicity": "periodic", "ordering": "sideways"},
        "execution_attributes": {"tempo": "very quick", "amplitude": "low", "dominant_side": "both",
                                 "symmetry": "Symmetrical", "global_displacement": "in place"},
        "uncertainty": {"tempo": 1.7, "amplitude": -0.2, "symmetry": "high", "dominant_side": "20%"},
    })
    result = parse_response(text)
    smp, report = result.smp, result.report
    assert smp.primitive_sequence == ["stand", "jump open", "jump close"]
    assert [p.name for p in smp.motion_primitives] == smp.primitive_sequence
    assert smp.temporal_structure.is_repetitive is True
    assert smp.temporal_structure.repetition_count == 8
    assert smp.temporal_structure.periodicity == "cyclic"
    assert smp.temporal_structure.ordering == "ordered"  # invalid -> schema default
    ea = smp.execution_attributes
    assert (ea.tempo, ea.amplitude, ea.dominant_side, ea.symmetry, ea.global_displacement) == (
        "fast", "small", "bilateral", "symmetric", "stationary")
    u = smp.uncertainty
    assert (u.tempo, u.amplitude, u.symmetry, u.dominant_side) == (1.0, 0.5, 0.8, 0.2)
    assert u.object_contact == 0.5  # missing -> default
    for path in ("execution_attributes.tempo", "execution_attributes.amplitude",
                 "temporal_structure.ordering", "uncertainty.tempo", "uncertainty.amplitude"):
        assert path in report.invalid_values
    assert "motion_primitives" in report.missing_mandatory
    assert any("rebuilt 'motion_primitives'" in r for r in report.repairs)


def test_incompatible_values_reset_to_unknown():
    text = json.dumps({"activity_label": "x", "primitive_sequence": ["a"],
                       "execution_attributes": {"tempo": 7, "amplitude": "gigantic-ish zzz",
                                                "dominant_side": ["left"]},
                       "temporal_structure": {"repetition_count": -3},
                       "primitive_durations": {"type": "relative", "values": [0.5, 0.5]}})
    result = parse_response(text)
    ea = result.smp.execution_attributes
    assert (ea.tempo, ea.amplitude, ea.dominant_side) == ("unknown",) * 3
    assert result.smp.temporal_structure.repetition_count == "unknown"
    assert result.smp.primitive_durations.values == []  # 2 values for 1 primitive
    assert "primitive_durations.values" in result.report.invalid_values


def test_numbers_as_strings_and_ordinals():
    text = json.dumps({"activity_label": "x", "primitive_sequence": ["a", "b"],
                       "primitive_durations": {"values": ["40%", "0.6"]},
                       "execution_attributes": {"tempo": "1.5", "amplitude": 0.5,
                                                "global_displacement": "3 m"},
                       "temporal_structure": {"repetition_count": 8.0}})
    smp = parse_response(text).smp
    assert smp.primitive_durations.values == [0.4, 0.6]
    assert smp.primitive_durations.type == "relative"  # inferred: values sum to 1
    assert smp.execution_attributes.tempo == 1.5 and smp.execution_attributes.amplitude == 0.5
    assert smp.execution_attributes.global_displacement == 3.0
    assert smp.temporal_structure.repetition_count == 8


def test_top_level_section_keys_are_moved():
    text = json.dumps({"label": "squats", "primitives": [{"name": "down"}, {"name": "up"}],
                       "tempo": "slow", "reps": 10, "objects": ["none"], "is_repetitive": True})
    result = parse_response(text)
    smp = result.smp
    assert smp.activity_label == "squats"
    assert smp.execution_attributes.tempo == "slow"
    assert smp.temporal_structure.repetition_count == 10
    assert smp.object_contact.objects == []
    assert smp.primitive_sequence == ["down", "up"]
    assert any("moved top-level key 'tempo'" in r for r in result.report.repairs)


def test_sequence_rebuilt_from_primitives_in_order_index_order():
    text = json.dumps({"activity_label": "x", "motion_primitives": [
        {"name": "b", "order_index": 1}, {"name": "a", "order_index": 0}]})
    result = parse_response(text)
    assert result.smp.primitive_sequence == ["a", "b"]
    assert result.report.missing_mandatory == ["primitive_sequence"]


def test_a_sequence_name_no_primitive_has_gets_a_bare_primitive():
    """The schema refuses a sequence name that no primitive has; repair adds the primitive."""
    text = json.dumps({"activity_label": "x", "motion_primitives": [{"name": "a", "order_index": 0},
                                                                   {"name": "b", "order_index": 1}],
                       "primitive_sequence": ["a", "B", "c", "", "repeat"]})
    result = parse_response(text)
    assert result.smp.primitive_sequence == ["a", "B", "c", "repeat"]
    assert [(p.name, p.order_index) for p in result.smp.motion_primitives] == [("a", 0), ("b", 1), ("c", 2)]
    assert "added a primitive for 'c' at 'primitive_sequence[2]': no motion primitive had that name" \
        in result.report.repairs


def test_two_spellings_of_a_primitive_name_take_the_first_spelling():
    """'curl_up' beside 'Curl Up' was kept as given, two spellings the schema refuses; repair spells
    the later one as the first, the primitive listed again as an exact repeat is."""
    text = json.dumps({"activity_label": "curls", "motion_primitives": [
        {"name": "curl_up", "order_index": 0}, {"name": "lower", "order_index": 1},
        {"name": "Curl Up", "order_index": 2, "description": "again"}],
        "primitive_sequence": ["curl_up", "lower", "Curl Up"]})
    result = parse_response(text)
    assert result.valid
    assert [(p.name, p.order_index, p.description) for p in result.smp.motion_primitives] == [
        ("curl_up", 0, ""), ("lower", 1, ""), ("curl_up", 2, "again")]
    assert result.smp.primitive_sequence == ["curl_up", "lower", "Curl Up"]
    assert "renamed the primitive 'Curl Up' to 'curl_up', the spelling of an earlier one" in result.report.repairs


def test_primitives_rebuilt_from_a_sequence_with_repeats_stay_valid():
    """A sequence that repeats a name in two spellings rebuilds a primitive per position."""
    text = json.dumps({"activity_label": "squats", "primitive_sequence": ["down", "up", "Down", "up"]})
    result = parse_response(text)
    assert result.valid
    assert [p.name for p in result.smp.motion_primitives] == ["down", "up", "down", "up"]


def test_key_value_text_is_read():
    text = "activity_label: walking\nprimitive_sequence: [step left, step right]\ntempo: fast\n"
    smp = parse_response(text).smp
    assert smp.activity_label == "walking" and smp.execution_attributes.tempo == "fast"


def test_key_value_text_whose_aliases_explode_is_not_read():
    """Nine levels of nine aliases once made a 600-byte answer take 40 s and 1.3 GB."""
    levels = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    levels += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 9)]
    text = "\n".join(["primitive_sequence: [step]", *levels, "activity_label: *a8"]) + "\n"
    result = parse_response(text)
    assert result.smp is None and "no JSON object" in result.report.reason


@pytest.mark.parametrize("text,reason", [
    ("", "empty"),
    ("   \n", "empty"),
    ("I cannot see the video.", "no JSON object"),
    ('{"primitive_sequence": ["a"]}', "activity_label"),
    ('{"activity_label": "walking"}', "motion_primitives/primitive_sequence"),
    ('{"activity_label": "walking", "motion_primitives": [], "primitive_sequence": []}',
     "motion_primitives/primitive_sequence"),
    ('{"activity_label": {"x": 1}, "primitive_sequence": ["a"]}', "activity_label"),
    ("[1, 2, 3]", "no JSON object"),
    ("{" * 5000, "no JSON object"),
])
def test_rejections_have_a_reason(text, reason):
    result = parse_response(text)
    assert result.smp is None and result.report.rejected and not result.valid
    assert reason in result.report.reason


def test_report_is_json_serializable(raw):
    raw["execution_attributes"]["tempo"] = "rapid"
    result = parse_response("```" + json.dumps(raw))
    back = json.loads(json.dumps(result.to_dict()))
    assert back["report"]["repaired"] is True
    assert SMP.model_validate(back["smp"]) == result.smp


# ---------------------------------------------------------------------------
# never raises on garbage
# ---------------------------------------------------------------------------
def _check(result: RepairResult) -> None:
    assert isinstance(result, RepairResult)
    assert (result.smp is None) == result.report.rejected
    if result.smp is not None:
        assert SMP.model_validate(result.smp.model_dump(mode="json")) == result.smp
        assert set(UNCERTAINTY_FIELDS) <= set(result.smp.uncertainty.model_dump())
    else:
        assert result.report.reason
        assert not result.report.reason.startswith("internal error"), result.report.reason
    json.dumps(result.to_dict())


def _fuzz(raw: dict, n: int, seed: int) -> tuple[int, int]:
    rng = random.Random(seed)
    text = json.dumps(raw, indent=2)
    valid = 0
    for _ in range(n):
        result = parse_response(mutate_response(rng, text, raw))
        _check(result)
        valid += result.valid
    return valid, n - valid


def test_never_raises_on_mutated_responses(raw):
    valid, rejected = _fuzz(raw, 3000, seed=0)
    assert valid > 1000 and rejected > 300  # both paths are exercised


@pytest.mark.slow
def test_never_raises_on_mutated_responses_long(raw):
    valid, rejected = _fuzz(raw, 40000, seed=1)
    assert valid > 10000 and rejected > 3000


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(st.text(max_size=2000), st.binary(max_size=2000)))
def test_never_raises_on_arbitrary_text(text):
    _check(parse_response(text))


_json_values = st.recursive(
    st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=20), inner, max_size=4),
    max_leaves=30)
_smp_keys = st.sampled_from(["activity_label", "motion_primitives", "primitive_sequence",
                             "primitive_durations", "body_parts", "temporal_structure",
                             "execution_attributes", "object_contact", "constraints", "uncertainty",
                             "tempo", "reps", "label"])


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(_smp_keys, _json_values, max_size=10))
def test_never_raises_on_wrong_typed_fields(data):
    _check(parse_response(json.dumps(data)))


def test_huge_input_is_cut_not_fatal(raw):
    text = "x" * 3_000_000 + json.dumps(raw)
    result = parse_response(text)
    _check(result)
    assert result.report.rejected  # the object lies beyond the part that is searched
    big_valid = json.dumps(raw) + " " * 3_000_000
    assert parse_response(big_valid).valid


@pytest.mark.parametrize("shape", ["list", "text"])
def test_too_many_primitives_is_an_invalid_value_not_a_stall(shape):
    names = [f"step_{i}" for i in range(1000)]
    seq = names if shape == "list" else ", ".join(names)
    text = json.dumps({"activity_label": "walking", "primitive_sequence": seq})
    start = time.monotonic()
    result = parse_response(text)
    assert time.monotonic() - start < 2
    assert result.smp is None and result.report.rejected
    assert result.report.invalid_values == ["primitive_sequence"]
    assert result.report.reason == f"'primitive_sequence' has 1000 items; at most {MAX_PRIMITIVES} are allowed"


def test_the_primitive_bound_counts_what_repair_builds():
    # 40 primitives and 40 other sequence names: a bare primitive each would make 80
    prims = [{"name": f"a{i}", "order_index": i} for i in range(40)]
    text = json.dumps({"activity_label": "x", "motion_primitives": prims,
                       "primitive_sequence": [f"b{i}" for i in range(40)]})
    result = parse_response(text)
    assert result.smp is None and "motion_primitives" in result.report.invalid_values
    at_bound = json.dumps({"activity_label": "x", "primitive_sequence": [f"p{i}" for i in range(MAX_PRIMITIVES)]})
    assert len(parse_response(at_bound).smp.motion_primitives) == MAX_PRIMITIVES


def test_an_out_of_range_number_resets_only_its_field(raw):
    raw["primitive_durations"] = {"type": "absolute", "values": [-3.0, 1e9, 2.0]}
    raw["motion_primitives"][0]["relative_duration"] = 1e9
    raw["execution_attributes"]["global_displacement"] = 1e308
    result = parse_response(json.dumps(raw))
    smp, report = result.smp, result.report
    assert smp is not None and not [r for r in report.repairs if r.startswith("reset")]
    assert smp.primitive_durations.values == ["unknown", "unknown", 2.0]
    assert smp.motion_primitives[0].relative_duration == "unknown"
    ea = smp.execution_attributes
    assert ea.global_displacement == "unknown"
    # the section's other fields are kept
    assert (ea.tempo, ea.amplitude, ea.symmetry) == (raw["execution_attributes"]["tempo"],
                                                     raw["execution_attributes"]["amplitude"], "symmetric")
    assert {"primitive_durations.values[1]", "motion_primitives[0].relative_duration",
            "execution_attributes.global_displacement"} <= set(report.invalid_values)
    assert any("1e+308" in r and "0..2000 m" in r for r in report.repairs)
