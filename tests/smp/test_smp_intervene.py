"""One-factor-at-a-time interventions: only the tested attribute changes."""

from __future__ import annotations

import pytest
from smp_helpers import make_smp, simple_smp

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp.intervene import (
    INTERVENTION_LEVELS,
    central_primitive_index,
    intervene,
    is_rest,
)


def _without(smp, *paths):
    d = smp.model_dump(mode="json")
    for path in paths:
        *head, last = path.split(".")
        target = d
        for key in head:
            target = target[key]
        target.pop(last)
    return d


@pytest.mark.parametrize("attribute,path", [
    ("tempo", "execution_attributes.tempo"),
    ("amplitude", "execution_attributes.amplitude"),
    ("symmetry", "execution_attributes.symmetry"),
    ("repetitions", "temporal_structure.repetition_count"),
])
def test_only_the_attribute_changes(jj, attribute, path):
    for level in INTERVENTION_LEVELS[attribute]:
        out = intervene(jj, attribute, level)
        section, name = path.split(".")
        assert getattr(getattr(out, section), name) == level
        assert _without(out, path) == _without(jj, path)


def test_duration_scales_only_the_central_phase(jj):
    c = central_primitive_index(jj)
    assert c == 1  # stand (rest) is skipped; jump_open and jump_close tie -> the earlier middle
    for factor in INTERVENTION_LEVELS["duration"]:
        out = intervene(jj, "duration", factor)
        values = out.primitive_durations.values
        for i, (a, b) in enumerate(zip(jj.primitive_durations.values, values, strict=True)):
            assert b == pytest.approx(a * factor if i == c else a)
        assert _without(out, "primitive_durations") == _without(jj, "primitive_durations")
        assert central_primitive_index(out) == c  # stable under the intervention
    assert intervene(jj, "duration", 1.0) == jj


def test_duration_fills_unknown_durations_the_same_way_for_every_factor():
    s = simple_smp(**{"primitive_durations.values": [], "primitive_durations.type": "unknown"})
    outs = [intervene(s, "duration", f) for f in (0.75, 1.0, 1.25)]
    base = outs[1].primitive_durations.values
    assert outs[1].primitive_durations.type == "relative"
    assert base == pytest.approx([0.3, 0.5, 0.2])
    for out, f in zip(outs, (0.75, 1.0, 1.25), strict=True):
        v = out.primitive_durations.values
        assert v[1] == pytest.approx(base[1] * f) and v[0] == base[0] and v[2] == base[2]


def test_central_primitive_rules():
    assert is_rest("stand") and is_rest("return_to_start") and not is_rest("stand_up")
    s = simple_smp()  # raise 0.3, circle 0.5, lower 0.2 -> the longest
    assert central_primitive_index(s) == 1
    flat = make_smp(s, **{f"motion_primitives.{i}.relative_duration": "unknown" for i in range(3)})
    assert central_primitive_index(flat) == 1  # the middle one
    rests = make_smp(s, primitive_sequence=["stand", "rest", "stand"],
                     **{f"motion_primitives.{i}.name": n for i, n in enumerate(["stand", "rest", "stand"])})
    assert central_primitive_index(rests) == 1


def test_repetitions_need_a_repetitive_activity():
    once = simple_smp(**{"temporal_structure.is_repetitive": False})
    with pytest.raises(ValidationError, match="not repetitive"):
        intervene(once, "repetitions", 6)
    assert intervene(simple_smp(), "repetitions", "9").temporal_structure.repetition_count == 9


@pytest.mark.parametrize("attribute,level,allowed", [
    ("speed", "fast", "tempo, amplitude, repetitions, duration, symmetry"),
    ("tempo", "zoom", "slow, medium, fast"),
    ("amplitude", "huge", "small, medium, large"),
    ("symmetry", "mirrored", "symmetric, asymmetric"),
    ("repetitions", "2.5", "integer"),
    ("repetitions", "0", "integer"),
    ("duration", "0", "factor"),
    ("duration", "fast", "factor"),
])
def test_invalid_attribute_or_level_lists_allowed_values(attribute, level, allowed):
    with pytest.raises(ValidationError) as err:
        intervene(simple_smp(), attribute, level)
    assert allowed in err.value.render()


def test_a_factor_past_600_s_is_refused_naming_the_factors_this_smp_allows():
    long = simple_smp(**{"primitive_durations.type": "absolute", "primitive_durations.values": [600, 160, 600]})
    with pytest.raises(ValidationError) as err:
        intervene(long, "duration", 4)  # circle_arms 160 s -> 640 s
    assert err.value.field == "level"
    assert "factor 4 makes 'circle_arms' last 640 s" in err.value.message
    assert err.value.allowed.startswith("a factor from 6.25e-09 to 3.75 for this SMP ('circle_arms' is 160 s")
    assert intervene(long, "duration", 3.75).primitive_durations.values == [600, 600, 600]


def test_a_smaller_duration_factor_never_lengthens_the_phase():
    """A factor below ~1e-6 once wrote 0, which reads as unknown: the phase took the mean share."""
    s = simple_smp()
    factors = [1.25, 1.0, 0.5, 0.01, 1e-4, 1e-5, 2e-6]
    shares = [intervene(s, "duration", f).relative_durations()[1] for f in factors]
    assert shares == sorted(shares, reverse=True) and shares[-1] < 1e-5
    with pytest.raises(ValidationError) as err:
        intervene(s, "duration", 1e-9)
    assert "below the smallest duration written (1e-06)" in err.value.message
    assert err.value.allowed.startswith("a factor from 2e-06 to 4 for this SMP ('circle_arms' is 0.5;")


def test_a_zero_duration_is_filled_like_an_unknown_one():
    """0 reads as unknown; scaling it would leave every factor with the same (mean) share."""
    s = simple_smp(**{"primitive_durations.values": [0.3, 0, 0.2]})
    shares = [intervene(s, "duration", f).relative_durations()[1] for f in (0.75, 1.0, 1.25)]
    assert shares[0] < shares[1] < shares[2]
