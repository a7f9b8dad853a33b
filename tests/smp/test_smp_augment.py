"""Constrained augmentation: invariants never change, variant fields stay in range,
uncertainty shrinks the perturbation, same seed -> same bytes."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from smp_helpers import make_smp, simple_smp

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.smp import augment
from vsmp_imu.smp.augment import SMPAugmenter, augment_variant, check_output_size
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import SMP, UNCERTAINTY_FIELDS, VARIANT_FIELDS, displacement_word

LIBRARY_NAMES = ActivityLibrary.load().names()


def _invariants(s: SMP) -> dict:
    """Everything augmentation must never change."""
    return {
        "label": s.activity_label,
        "sequence": s.primitive_sequence,
        "primitives": [p.model_dump() for p in s.motion_primitives],
        "body_parts": s.body_parts.model_dump(),
        "contacts": s.object_contact.model_dump(),
        "stationary": displacement_word(s.execution_attributes.global_displacement) == "stationary",
        "mobile_unknown": s.execution_attributes.global_displacement == "unknown",
        "temporal": s.temporal_structure.model_dump(exclude={"repetition_count"}),
        "constraints": s.constraints.model_dump(),
        "uncertainty": s.uncertainty.model_dump(),
    }


def _assert_valid_variant(src: SMP, var: SMP, conditioned: bool = True) -> None:
    assert _invariants(var) == _invariants(src)
    variant = set(src.constraints.variant_fields)
    ea, ev = src.execution_attributes, var.execution_attributes

    def u(name):
        return getattr(src.uncertainty, name) if conditioned else 0.0

    for name, level in (("tempo", src.tempo_level()), ("amplitude", src.amplitude_level())):
        new = getattr(var, f"{name}_level")()
        if name not in variant or level is None:
            assert getattr(ev, name) == getattr(ea, name)
        else:
            assert 0.0 <= new <= 2.0
            assert abs(new - level) <= (1 - u(name)) * 1.0 + 1e-4
    count, new_count = src.repetition_count(), var.repetition_count()
    if "repetition_count" in variant and src.temporal_structure.is_repetitive and count is not None:
        assert isinstance(new_count, int) and new_count >= 1
        assert abs(new_count - count) <= (1 - u("repetition_count")) * 5 + 1e-9 or new_count == 1
    else:
        assert new_count == count
    if "primitive_duration" not in variant:
        assert var.primitive_durations == src.primitive_durations
    else:
        assert len(var.primitive_durations.values) in (0, len(src.primitive_sequence))
        old, new = src.primitive_durations.values, var.primitive_durations.values
        if old and new and src.primitive_durations.type == "absolute":
            r = (1 - u("primitive_duration")) * 0.25
            for a, b in zip(old, new, strict=True):
                if a != "unknown" and a > 0:
                    assert (1 - r) * a - 1e-3 <= b <= (1 + r) * a + 1e-3
    for name in ("dominant_side", "symmetry"):
        before, after = getattr(ea, name), getattr(ev, name)
        if name not in variant:
            assert after == before
        elif after != before:
            pairs = {("left", "right"), ("right", "left"), ("symmetric", "asymmetric"),
                     ("asymmetric", "symmetric")}
            assert (before, after) in pairs
    extent, new_extent = src.displacement_extent_m(), var.displacement_extent_m()
    if "global_displacement" not in variant or extent in (None, 0.0):
        assert ev.global_displacement == ea.global_displacement
    else:
        r = (1 - u("global_displacement")) * 0.25
        assert (1 - r) * extent - 1e-3 <= new_extent <= (1 + r) * extent + 1e-3
        assert new_extent > 0


def test_jumping_jacks_200_variants(jj):
    aug = SMPAugmenter()
    variants = aug.augment(jj, 200, seed=0)
    assert len(variants) == 200 == len(aug.changes_)
    for v in variants:
        _assert_valid_variant(jj, v)
    # the variant fields really vary
    assert len({v.execution_attributes.tempo for v in variants}) > 100
    assert len({v.temporal_structure.repetition_count for v in variants}) >= 7
    changed = {f for c in aug.changes_ for f in c["changed"]}
    assert changed == {"execution_attributes.tempo", "execution_attributes.amplitude",
                       "temporal_structure.repetition_count", "primitive_durations"}
    assert aug.changes_[0]["source_smp_id"] == jj.smp_id
    assert aug.changes_[0]["smp_id"] == variants[0].smp_id


def test_relative_durations_keep_their_sum_and_order(jj):
    for v in SMPAugmenter().augment(jj, 50, seed=3):
        values = v.primitive_durations.values
        assert sum(values) == pytest.approx(1.0, abs=1e-3)
        assert len(values) == 3 and all(x > 0 for x in values)
        # per-primitive factor within +-25 %, then renormalized: ratios stay within (0.75/1.25)..(1.25/0.75)
        for a, b in zip(jj.primitive_durations.values, values, strict=True):
            assert 0.6 - 1e-3 <= b / a <= 1 / 0.6 + 1e-3


def test_same_seed_same_bytes_and_index_independent_of_k(jj):
    a = [v.canonical_json() for v in SMPAugmenter().augment(jj, 20, seed=7)]
    b = [v.canonical_json() for v in SMPAugmenter().augment(jj, 20, seed=7)]
    c = [v.canonical_json() for v in SMPAugmenter().augment(jj, 5, seed=7)]
    d = [v.canonical_json() for v in SMPAugmenter().augment(jj, 20, seed=8)]
    assert a == b and a[:5] == c and a != d
    assert augment_variant(jj, 7, 3)[0].canonical_json() == a[3]


def test_full_uncertainty_freezes_every_field():
    s = simple_smp(**{f"uncertainty.{f}": 1.0 for f in UNCERTAINTY_FIELDS},
                   **{"constraints.variant_fields": list(VARIANT_FIELDS),
                      "execution_attributes.dominant_side": "left"})
    for v in SMPAugmenter().augment(s, 30, seed=0):
        assert v == s
    # the ablation ignores uncertainty: the same SMP now varies
    varied = SMPAugmenter(uncertainty_conditioned=False).augment(s, 30, seed=0)
    assert any(v != s for v in varied)
    for v in varied:
        _assert_valid_variant(s, v, conditioned=False)


def test_uncertainty_shrinks_the_radius():
    spread = {}
    for u in (0.0, 0.5, 0.9):
        s = simple_smp(**{"uncertainty.tempo": u})
        levels = [v.tempo_level() for v in SMPAugmenter().augment(s, 300, seed=1)]
        spread[u] = max(abs(x - 1.0) for x in levels)
        assert spread[u] <= (1 - u) + 1e-4
    assert spread[0.0] > 0.9 and spread[0.5] > 0.4 and spread[0.9] < 0.11


def test_categorical_change_probability():
    s = simple_smp(**{"constraints.variant_fields": ["symmetry", "dominant_side"],
                      "execution_attributes.dominant_side": "right",
                      "uncertainty.symmetry": 0.0, "uncertainty.dominant_side": 0.5})
    variants = SMPAugmenter().augment(s, 2000, seed=2)
    flips = sum(v.execution_attributes.symmetry == "asymmetric" for v in variants) / 2000
    swaps = sum(v.execution_attributes.dominant_side == "left" for v in variants) / 2000
    assert flips == pytest.approx(0.3, abs=0.04)  # (1 - 0) * 0.3
    assert swaps == pytest.approx(0.25, abs=0.04)  # (1 - 0.5) * 0.5


def test_side_swap_only_for_side_agnostic_and_not_bilateral():
    bilateral = simple_smp(**{"constraints.variant_fields": ["dominant_side"]})
    assert all(v == bilateral for v in SMPAugmenter().augment(bilateral, 50, seed=0))
    fixed_side = simple_smp(**{"execution_attributes.dominant_side": "right",
                               "constraints.variant_fields": ["tempo"]})
    assert all(v.execution_attributes.dominant_side == "right"
               for v in SMPAugmenter().augment(fixed_side, 50, seed=0))


def test_displacement_keeps_stationary_or_mobile():
    stationary = simple_smp(**{"constraints.variant_fields": ["global_displacement"]})
    assert all(v == stationary for v in SMPAugmenter().augment(stationary, 20, seed=0))
    mobile = make_smp(stationary, **{"execution_attributes.global_displacement": "large",
                                     "uncertainty.global_displacement": 0.0})
    for v in SMPAugmenter().augment(mobile, 100, seed=0):
        extent = v.displacement_extent_m()
        assert 3.0 - 1e-6 <= extent <= 5.0 + 1e-6  # 4 m nominal +-25 %
        _assert_valid_variant(mobile, v)


def test_only_listed_variant_fields_change():
    s = simple_smp(**{"constraints.variant_fields": ["amplitude"]})
    for v in SMPAugmenter().augment(s, 30, seed=0):
        d1, d2 = s.model_dump(), v.model_dump()
        d1["execution_attributes"].pop("amplitude")
        d2["execution_attributes"].pop("amplitude")
        assert d1 == d2


def test_negative_k_is_an_error(jj):
    with pytest.raises(ValidationError):
        SMPAugmenter().augment(jj, -1, seed=0)
    assert SMPAugmenter().augment(jj, 0, seed=0) == []


@pytest.mark.parametrize("name", LIBRARY_NAMES)
@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                HealthCheck.function_scoped_fixture])
@given(seed=st.integers(0, 2**32 - 1),
       u=st.lists(st.sampled_from([0.0, 0.2, 0.5, 0.9, 1.0]), min_size=12, max_size=12),
       fields=st.sets(st.sampled_from(VARIANT_FIELDS)),
       conditioned=st.booleans())
def test_invariants_hold_for_every_library_activity(name, library, seed, u, fields, conditioned):
    entry = library.get(name)
    src = make_smp(entry.smp, **{"constraints.variant_fields": sorted(fields)},
                   **{f"uncertainty.{f}": x for f, x in zip(UNCERTAINTY_FIELDS, u, strict=True)})
    aug = SMPAugmenter(uncertainty_conditioned=conditioned)
    for v in aug.augment(src, 4, seed):
        _assert_valid_variant(src, v, conditioned)
    # the library's own constraints
    for v in SMPAugmenter().augment(entry.smp, 3, seed):
        _assert_valid_variant(entry.smp, v)


def test_full_uncertainty_leaves_empty_durations_and_a_displacement_word():
    """u = 1 means radius 0: the nominal durations are not copied in, "small" stays a word."""
    s = simple_smp(**{"primitive_durations": {"type": "unknown", "values": []},
                      "execution_attributes.global_displacement": "small",
                      "constraints.variant_fields": ["primitive_duration", "global_displacement"],
                      "uncertainty.primitive_duration": 1.0, "uncertainty.global_displacement": 1.0})
    for i in range(5):
        v, changed = augment_variant(s, 0, i)
        assert v == s and changed == {}


def test_a_single_repetition_stays_single_below_one_cycle_of_radius():
    # u = 0.9: radius 0.5 cycles, so 1 can move to no other integer
    s = simple_smp(**{"temporal_structure.repetition_count": 1, "uncertainty.repetition_count": 0.9})
    assert {v.repetition_count() for v in SMPAugmenter().augment(s, 30, seed=0)} == {1}
    # u = 0: radius 5 cycles around 2, clipped at 1
    s = make_smp(s, **{"temporal_structure.repetition_count": 2, "uncertainty.repetition_count": 0.0})
    counts = {v.repetition_count() for v in SMPAugmenter().augment(s, 60, seed=0)}
    assert min(counts) == 1 and max(counts) <= 7


def test_percent_durations_keep_their_sum_of_100():
    s = simple_smp(**{"primitive_durations.values": [30.0, 50.0, 20.0],
                      "constraints.variant_fields": ["primitive_duration"]})
    for v in SMPAugmenter().augment(s, 20, seed=1):
        values = v.primitive_durations.values
        assert sum(values) == pytest.approx(100.0, abs=1e-3) and values != [30.0, 50.0, 20.0]


def test_unknown_relative_durations_stay_and_the_known_keep_their_sum():
    s = simple_smp(**{"primitive_durations.values": [0.3, "unknown", 0.2],
                      "constraints.variant_fields": ["primitive_duration"]})
    for v in SMPAugmenter().augment(s, 20, seed=1):
        first, middle, last = v.primitive_durations.values
        assert middle == "unknown" and first + last == pytest.approx(0.5, abs=1e-3)


def test_all_zero_relative_durations_stay_zero():
    s = simple_smp(**{"primitive_durations.values": [0.0, 0.0, 0.0],
                      "constraints.variant_fields": ["primitive_duration"]})
    for i in range(5):
        v, changed = augment_variant(s, 0, i)
        assert v.primitive_durations.values == [0.0, 0.0, 0.0] and changed == {}


def _smp_of_size(size: int) -> SMP:
    """simple_smp padded so that its canonical line (with its newline) is `size` bytes."""
    s = simple_smp(**{"motion_primitives.0.description": ""})
    pad = size - 1 - len(s.canonical_json())
    return make_smp(s, **{"motion_primitives.0.description": "x" * pad})


def test_output_size_limit_allows_exactly_the_count_it_names(monkeypatch):
    s = _smp_of_size(2500)
    monkeypatch.setattr(augment, "MAX_OUTPUT_BYTES", 1_500_000)
    check_output_size(s, 600)  # 600 x 2500 bytes is the limit itself
    with pytest.raises(ConfigError) as err:
        check_output_size(s, 601)
    assert err.value.field == "k" and err.value.allowed == "at most 600 variants of this SMP"
    with pytest.raises(ConfigError) as err:
        check_output_size(s, 1400, field="-k")
    assert err.value.field == "-k"
    assert err.value.message == ("1400 variants of this 2,500-byte SMP would write about 4 MB, "
                                 "more than the 2 MB limit")  # 3.5 and 1.5 MB, rounded


def test_output_size_allows_one_variant_of_an_smp_near_the_limit(monkeypatch):
    s = _smp_of_size(2500)
    monkeypatch.setattr(augment, "MAX_OUTPUT_BYTES", 4000)
    check_output_size(s, 1)
    with pytest.raises(ConfigError) as err:
        check_output_size(s, 2)
    assert err.value.allowed == "at most 1 variants of this SMP"


def test_output_size_default_limit_is_200_mb():
    s = _smp_of_size(2500)
    assert augment.MAX_OUTPUT_BYTES == 200 * 10**6
    check_output_size(s, 80_000)
    with pytest.raises(ConfigError, match="about 200 MB, more than the 200 MB limit"):
        check_output_size(s, 80_001)
