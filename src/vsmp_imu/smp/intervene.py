"""Deterministic one-factor-at-a-time interventions I_a^l(S) for the controllability
study (paper, "Deterministic interventions for controllability evaluation").

Exactly one attribute changes; everything else in the SMP stays as it was.

| attribute | level | what changes |
| --- | --- | --- |
| tempo | slow, medium, fast | execution_attributes.tempo |
| amplitude | small, medium, large | execution_attributes.amplitude |
| repetitions | an integer >= 1 (repetitive activities only) | temporal_structure.repetition_count |
| duration | a factor in (0, 4] | the central primitive's duration only |
| symmetry | symmetric, asymmetric | execution_attributes.symmetry |

Duration: the central primitive's value in `primitive_durations.values` is
multiplied by the factor and the other values keep theirs (no
renormalization), so the backend can lengthen or shorten only that phase. When
the durations are incomplete (a value unknown or 0) they are first filled with
`SMP.relative_durations()` (type `relative`), the same way for every factor, so
the 1.00 condition differs from the others only in that one value. A factor
that would scale the value below MIN_SCALED_DURATION (written as 0, which reads
as unknown) or above the schema's 600 is refused, naming the factors this SMP
allows. The primitives themselves (names, order, nominal `relative_duration`)
are invariant and stay as they are.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.schema import (
    AMPLITUDE_LEVELS,
    MAX_PRIMITIVE_DURATION,
    SMP,
    SYMMETRIES,
    TEMPO_LEVELS,
    UNKNOWN,
)
from vsmp_imu.validation import validate_model

# Paper, "End-to-End SMP Controllability Protocol": the levels of each control.
INTERVENTION_LEVELS: dict[str, tuple[Any, ...]] = {
    "tempo": TEMPO_LEVELS,
    "amplitude": AMPLITUDE_LEVELS,
    "repetitions": (3, 6, 9),
    "duration": (0.75, 1.0, 1.25),
    "symmetry": SYMMETRIES,
}
ATTRIBUTES = tuple(INTERVENTION_LEVELS)
MAX_DURATION_FACTOR = 4.0
# Scaled durations are written with 6 decimals; a smaller value would be written as 0 and read
# as unknown (filled with the mean), so a tiny factor would lengthen the phase.
MIN_SCALED_DURATION = 1e-6
MAX_REPETITIONS = 1000
# A primitive whose name is made only of these words is a rest/preparation phase.
REST_WORDS = {"stand", "standing", "rest", "resting", "idle", "pause", "neutral", "start",
              "ready", "return", "returning", "recover", "recovery", "still", "wait", "to",
              "upright", "position", "pose", "initial", "final", "end", "hold", "starting"}


def is_rest(name: str) -> bool:
    """A preparation/rest phase such as 'stand' or 'return_to_start'."""
    words = norm_name(name).split()
    return bool(words) and all(w in REST_WORDS for w in words)


def central_primitive_index(smp: SMP, central: str | None = None) -> int:
    """The sequence position a duration intervention scales.

    `central` names it when known (a library entry's `central_primitive`, the
    activity's principal phase). Otherwise, among the non-rest primitives (all of them when every one is a rest phase),
    those with the largest nominal `motion_primitives[].relative_duration`, and
    of these the middle one (the earlier of two middles); unknown nominal
    durations count as equal. The nominal durations belong to the invariant
    primitives, not to `primitive_durations`, so the choice does not move when
    an intervention or augmentation changes the durations.
    """
    names = smp.primitive_sequence
    if central is not None and central in names:
        return names.index(central)
    nominal = [smp.primitive_duration(n) for n in names]
    candidates = [i for i, n in enumerate(names) if not is_rest(n)] or list(range(len(names)))
    known = [nominal[i] for i in candidates if nominal[i] is not None]
    if len(known) == len(candidates):
        top = max(known)
        candidates = [i for i in candidates if nominal[i] >= top - 1e-9]
    return candidates[(len(candidates) - 1) // 2]


def _allowed(attribute: str) -> str:
    if attribute == "repetitions":
        return "an integer from 1 to 1000 (protocol: 3, 6, 9)"
    if attribute == "duration":
        return f"a factor in (0, {MAX_DURATION_FACTOR:g}] (protocol: 0.75, 1.00, 1.25)"
    return ", ".join(INTERVENTION_LEVELS[attribute])


def _word_level(attribute: str, level: Any) -> str:
    text = norm_name(str(level)).replace(" ", "_")
    if text not in INTERVENTION_LEVELS[attribute]:
        raise ValidationError(f"invalid {attribute} level {level!r}", field="level",
                              allowed=_allowed(attribute))
    return text


def _number(attribute: str, level: Any) -> float:
    if isinstance(level, bool):
        level = "invalid"
    try:
        return float(level)
    except (TypeError, ValueError):
        raise ValidationError(f"invalid {attribute} level {level!r}", field="level",
                              allowed=_allowed(attribute)) from None


def intervene(smp: SMP, attribute: str, level: Any, central_primitive: str | None = None) -> SMP:
    """A copy of `smp` with only `attribute` set to `level`.

    `central_primitive` names the phase a duration intervention scales (see
    `central_primitive_index`); library callers pass the entry's.
    """
    attribute = norm_name(str(attribute)).replace(" ", "_")
    if attribute not in INTERVENTION_LEVELS:
        raise ValidationError(f"unknown attribute {attribute!r}", field="attribute",
                              allowed=", ".join(ATTRIBUTES))
    d = smp.model_dump(mode="json")
    if attribute in ("tempo", "amplitude", "symmetry"):
        d["execution_attributes"][attribute] = _word_level(attribute, level)
    elif attribute == "repetitions":
        count = _number(attribute, level)
        if not count.is_integer() or not 1 <= count <= MAX_REPETITIONS:
            raise ValidationError(f"invalid repetitions level {level!r}", field="level",
                                  allowed=_allowed(attribute))
        if not smp.temporal_structure.is_repetitive:
            raise ValidationError(
                f"'{smp.activity_label}' is not repetitive; a repetition-count intervention "
                "applies to repetitive activities only", field="temporal_structure.is_repetitive")
        d["temporal_structure"]["repetition_count"] = int(count)
    else:
        factor = _number(attribute, level)
        if not 0 < factor <= MAX_DURATION_FACTOR:
            raise ValidationError(f"invalid duration level {level!r}", field="level",
                                  allowed=_allowed(attribute))
        _scale_central(smp, d, factor, central_primitive)
    return validate_model(SMP, d)


def _scale_central(smp: SMP, d: dict[str, Any], factor: float, central: str | None) -> None:
    c = central_primitive_index(smp, central)
    values, kind = _complete_durations(smp)
    _check_factor(factor, values[c], kind, smp.primitive_sequence[c])
    values[c] = round(values[c] * factor, 6)
    d["primitive_durations"] = {"type": kind, "values": values}


def _complete_durations(smp: SMP) -> tuple[list[float], str]:
    """The SMP's duration values and type, filled as relative shares when any is unknown or 0."""
    dur = smp.primitive_durations
    if dur.values and all(v != UNKNOWN and float(v) > 0 for v in dur.values):
        return [float(v) for v in dur.values], dur.type if dur.type != UNKNOWN else "relative"
    return [round(v, 6) for v in smp.relative_durations()], "relative"


def _check_factor(factor: float, value: float, kind: str, name: str) -> None:
    """Refuse a factor that scales `value` out of MIN_SCALED_DURATION..MAX_PRIMITIVE_DURATION."""
    scaled = value * factor
    if MIN_SCALED_DURATION <= scaled <= MAX_PRIMITIVE_DURATION:
        return
    unit = " s" if kind == "absolute" else ""
    if scaled > MAX_PRIMITIVE_DURATION:
        problem = f"makes '{name}' last {scaled:g}{unit}, more than a primitive may ({MAX_PRIMITIVE_DURATION:g})"
    else:
        problem = f"shrinks '{name}' to {scaled:.3g}{unit}, below the smallest duration written ({MIN_SCALED_DURATION:g})"
    raise ValidationError(f"duration factor {factor:g} {problem}", field="level",
                          allowed=_factor_range(value, unit, name))


def _factor_range(value: float, unit: str, name: str) -> str:
    """The factors that keep `value` within bounds, rounded inwards to 3 significant digits."""
    if value <= 0:
        return f"none for this SMP ('{name}' is 0)"
    low = _round_to_3(MIN_SCALED_DURATION / value, math.ceil)
    high = _round_to_3(min(MAX_DURATION_FACTOR, MAX_PRIMITIVE_DURATION / value), math.floor)
    if low > high:
        return f"none for this SMP ('{name}' is {value:g}{unit})"
    return (f"a factor from {low:g} to {high:g} for this SMP ('{name}' is {value:g}{unit}; "
            f"a scaled duration is {MIN_SCALED_DURATION:g}..{MAX_PRIMITIVE_DURATION:g})")


def _round_to_3(x: float, direction: Callable[[float], int]) -> float:
    scale = 10.0 ** (2 - math.floor(math.log10(x)))
    return direction(x * scale) / scale
