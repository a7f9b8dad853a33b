"""Property-based fuzzing of the SMP's numbers at their extremes, through the whole chain:
validate -> augment -> synthesize (procedural) -> simulate a virtual IMU.

Numbers go in as a user's file would give them: huge, negative, NaN, infinite, true/false,
numeric text, at and just past the schema's bounds. The contract: validation refuses with a
project error naming the field, or accepts; what it accepts augments into valid SMPs, and each
variant synthesizes (or is refused with a project error before any frame is drawn) into a finite
motion of at most MAX_MOTION_S seconds whose simulated IMU readings are finite. Validate,
augment and synthesize agree on what an SMP may ask for.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from fuzzing import fuzz_settings
from hypothesis import given
from hypothesis import strategies as st

from vsmp_imu.errors import ValidationError, VsmpError
from vsmp_imu.smp import smp_from_dict
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import (
    MAX_DISPLACEMENT_M,
    MAX_MOTION_S,
    MAX_PRIMITIVE_DURATION,
    MAX_REPETITIONS,
    SMP,
)

FAST, SLOW = 12, 400
ACTIVITIES = ("jumping_jacks", "walking", "sitting", "bicep_curls")


def _inside(lo: float, hi: float, integer: bool = False) -> st.SearchStrategy:
    """Extreme values the schema accepts: the bounds, next to them, tiny, and anything between."""
    if integer:
        return st.one_of(st.sampled_from([int(lo), int(hi), int(hi) - 1, int(lo) + 1]), st.integers(int(lo), int(hi)))
    return st.one_of(st.sampled_from([lo, hi, hi - 1e-9, lo + 1e-300, 5e-324, 1e-9]),
                     st.floats(lo, hi, allow_nan=False, allow_infinity=False))


def _outside(hi: float) -> st.SearchStrategy:
    """Values it refuses: past the bounds, not finite, not numbers."""
    return st.one_of(
        st.sampled_from([hi + 1e-9, hi * 10, -1e-9, -hi, 1e308, -1e308, 10**30, -(10**30)]),
        st.sampled_from([math.nan, math.inf, -math.inf, True, False, "1", "1e3", None]),
        st.floats(allow_nan=True, allow_infinity=True),
    )


# (schema range, integer?) of each number fuzzed
RANGES = {
    "repetition_count": (0, MAX_REPETITIONS, True),
    "tempo": (0.0, 2.0, False),
    "amplitude": (0.0, 2.0, False),
    "global_displacement": (0.0, MAX_DISPLACEMENT_M, False),
    "duration": (0.0, MAX_PRIMITIVE_DURATION, False),
    "uncertainty": (0.0, 1.0, False),
    "order_index": (0, 1000, True),
}


def numbers(what: str, inside: bool) -> st.SearchStrategy:
    lo, hi, integer = RANGES[what]
    return _inside(lo, hi, integer) if inside else _outside(hi)


@st.composite
def smp_cases(draw, library) -> dict:
    data = library.get(draw(st.sampled_from(ACTIVITIES))).smp.model_dump(mode="json")
    n = len(data["primitive_sequence"])
    inside = draw(st.integers(0, 3)) > 0  # mostly values the schema accepts: they reach synthesis
    for _ in range(draw(st.integers(1, 4))):
        what = draw(st.sampled_from(sorted(RANGES)))
        value = draw(numbers(what, inside))
        if what == "repetition_count":
            data["temporal_structure"]["repetition_count"] = value
            data["temporal_structure"]["is_repetitive"] = True
        elif what in ("tempo", "amplitude", "global_displacement"):
            data["execution_attributes"][what] = value
        elif what == "duration":
            kind = draw(st.sampled_from(("relative", "absolute")))
            values = [draw(numbers("duration", inside)) if draw(st.booleans()) else 0.5 for _ in range(n)]
            data["primitive_durations"] = {"type": kind, "values": values}
        elif what == "uncertainty":
            data["uncertainty"][draw(st.sampled_from(sorted(data["uncertainty"])))] = value
        else:
            data["motion_primitives"][0]["order_index"] = value
    variants = ["tempo", "amplitude", "repetition_count", "primitive_duration", "global_displacement"]
    data["constraints"]["variant_fields"] = draw(st.lists(st.sampled_from(variants), unique=True))
    return data


@pytest.fixture(scope="module")
def library():
    return ActivityLibrary.load()


@pytest.fixture(scope="module")
def backend(library):
    from vsmp_imu.motion.procedural import ProceduralBackend

    return ProceduralBackend(library)


def check_chain(data: dict, backend, seed: int) -> None:
    from vsmp_imu.imu import ImuSimulator

    try:
        smp = smp_from_dict(data, "case.json")
    except ValidationError as exc:
        assert exc.file == "case.json" and exc.field, exc.render()
        return
    variants = SMPAugmenter().augment(smp, 2, seed)
    for variant in (smp, *variants):
        assert SMP.model_validate(variant.model_dump(mode="json")) == variant  # the schema holds
        try:
            motion = backend.generate(variant, seed=seed)
        except VsmpError as exc:  # refused, and said why; never an unbounded run
            assert exc.field, exc.render()
            continue
        assert motion.is_finite() and motion.duration_s <= MAX_MOTION_S + 1e-6
        rec = ImuSimulator(50.0, seed=seed).simulate(motion, "waist")
        assert np.isfinite(rec.data).all() and rec.n_samples > 0


@fuzz_settings(FAST)
@given(data=st.data(), seed=st.integers(0, 2**31 - 1))
def test_smp_numbers_at_their_extremes_through_the_chain(library, backend, data, seed):
    check_chain(data.draw(smp_cases(library)), backend, seed)


@pytest.mark.slow
@fuzz_settings(SLOW)
@given(data=st.data(), seed=st.integers(0, 2**31 - 1))
def test_smp_numbers_at_their_extremes_through_the_chain_many(library, backend, data, seed):
    check_chain(data.draw(smp_cases(library)), backend, seed)


@pytest.mark.parametrize("field,value", [
    ("repetition_count", True), ("repetition_count", 10**30), ("repetition_count", 3.0),
    ("repetition_count", "3"), ("tempo", math.nan), ("amplitude", math.inf), ("global_displacement", 1e9),
])
def test_validation_refuses_what_synthesis_could_not_honour(library, field, value):
    data = library.get("jumping_jacks").smp.model_dump(mode="json")
    section = "temporal_structure" if field == "repetition_count" else "execution_attributes"
    data[section][field] = value
    with pytest.raises(ValidationError) as caught:
        smp_from_dict(data, "mine.json")
    assert caught.value.field == f"{section}.{field}" and caught.value.file == "mine.json"


def test_every_library_smp_is_within_the_bounds(library):
    """The bounds reject no SMP of the activity library (they are re-validated on load too)."""
    for entry in library:
        assert SMP.model_validate(entry.smp.model_dump(mode="json")) == entry.smp
