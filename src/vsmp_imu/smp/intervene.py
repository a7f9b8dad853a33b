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
the durations are incomplete they are first filled with
`SMP.relative_durations()` (type `relative`), the same way for every factor, so
the 1.00 condition differs from the others only in that one value. The
primitives themselves (names, order, nominal `relative_duration`) are invariant
and stay as they are.
"""

from __future__ import annotations

from typing import Any

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.schema import AMPLITUDE_LEVELS, SMP, SYMMETRIES, TEMPO_LEVELS, UNKNOWN

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
    by_name = {norm_name(p.name): p.relative_duration for p in smp.motion_primitives}
    nominal = [by_name.get(norm_name(n), UNKNOWN) for n in names]
    candidates = [i for i, n in enumerate(names) if not is_rest(n)] or list(range(len(names)))
    known = [float(nominal[i]) for i in candidates if nominal[i] != UNKNOWN]
    if len(known) == len(candidates):
        top = max(known)
        candidates = [i for i in candidates if float(nominal[i]) >= top - 1e-9]
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
    return SMP.model_validate(d)


def _scale_central(smp: SMP, d: dict[str, Any], factor: float, central: str | None) -> None:
    c = central_primitive_index(smp, central)
    dur = smp.primitive_durations
    if dur.values and all(v != UNKNOWN for v in dur.values):
        values = [float(v) for v in dur.values]
        kind = dur.type if dur.type != UNKNOWN else "relative"
    else:
        values, kind = [round(v, 6) for v in smp.relative_durations()], "relative"
    values[c] = round(values[c] * factor, 6)
    d["primitive_durations"] = {"type": kind, "values": values}
