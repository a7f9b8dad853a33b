"""Write pose measurements into an SMP: replace (pose mode) or check and override (fused mode).

Measured field -> SMP field (and its uncertainty entry):
tempo -> execution_attributes.tempo (tempo); amplitude -> .amplitude;
symmetry, dominant_side, global_displacement -> the same execution attribute;
repetition_count -> temporal_structure.repetition_count; body_parts ->
body_parts.dominant_moving_segments (the mandatory parts are invariant and
never touched).

Modes:
- "replace" (pose extractor): every measured value is written with its
  uncertainty.
- "fuse": a measurement with uncertainty below `threshold` is confident.
  Confident, and the SMP field is unknown or not confident -> replaced.
  Confident, the SMP field confident and agreeing -> kept, uncertainty the
  smaller of the two. Confident, the SMP field confident and disagreeing ->
  replaced (the clip was observed), uncertainty raised to at least
  `DISAGREE_U` and the conflict recorded. A measurement that is not confident
  changes nothing.
In both modes global displacement never crosses the stationary / mobile line
of the SMP (an invariant): such a measurement only raises the uncertainty.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from vsmp_imu.errors import ConfigError
from vsmp_imu.extract.posemeasure import Measurement, PoseMeasurements
from vsmp_imu.smp.schema import (
    AMPLITUDE_LEVELS,
    SMP,
    TEMPO_LEVELS,
    UNKNOWN,
    displacement_word,
    ordinal_level,
)

FUSE_THRESHOLD = 0.35
DISAGREE_U = 0.6
TARGETS = {
    "tempo": ("execution_attributes", "tempo", "tempo"),
    "amplitude": ("execution_attributes", "amplitude", "amplitude"),
    "symmetry": ("execution_attributes", "symmetry", "symmetry"),
    "dominant_side": ("execution_attributes", "dominant_side", "dominant_side"),
    "global_displacement": ("execution_attributes", "global_displacement", "global_displacement"),
    "repetition_count": ("temporal_structure", "repetition_count", "repetition_count"),
    "body_parts": ("body_parts", "dominant_moving_segments", "body_parts"),
}


@dataclass(frozen=True)
class FieldChange:
    """What happened to one SMP field."""

    field: str
    action: str  # replaced | confirmed | conflict_replaced | conflict_uncertain | kept | not_measured
    before: Any
    after: Any
    uncertainty_before: float
    uncertainty_after: float
    measured: Any
    measured_uncertainty: float
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def agree(name: str, a: Any, b: Any) -> bool:
    """Whether an SMP value and a measured value say the same thing."""
    if a == UNKNOWN or b == UNKNOWN or a is None or b is None:
        return False
    if name == "tempo":
        la, lb = ordinal_level(a, TEMPO_LEVELS), ordinal_level(b, TEMPO_LEVELS)
        return la is not None and lb is not None and abs(la - lb) < 0.5
    if name == "amplitude":
        la, lb = ordinal_level(a, AMPLITUDE_LEVELS), ordinal_level(b, AMPLITUDE_LEVELS)
        return la is not None and lb is not None and abs(la - lb) < 0.5
    if name == "repetition_count":
        return abs(int(a) - int(b)) <= 1
    if name == "global_displacement":
        return displacement_word(a) == displacement_word(b)
    if name == "body_parts":
        sa, sb = set(a), set(b)
        return not sa or not sb or len(sa & sb) / len(sa | sb) >= 0.5
    return a == b


def _mobile(value: Any) -> bool | None:
    if value == UNKNOWN or value is None:
        return None
    return displacement_word(value) != "stationary"


def apply_measurements(smp: SMP, measurements: PoseMeasurements, mode: str = "replace",
                       threshold: float = FUSE_THRESHOLD) -> tuple[SMP, list[FieldChange]]:
    """The SMP with the measurements written in (see module docs) and every decision."""
    if mode not in ("replace", "fuse"):
        raise ValueError(f"mode must be 'replace' or 'fuse', got {mode!r}")
    if not (isinstance(threshold, int | float) and 0.0 <= threshold <= 1.0):  # NaN fails too
        raise ConfigError(f"{threshold} is out of range", field="threshold", allowed="a number in 0..1")
    data = smp.model_dump(mode="json")
    changes: list[FieldChange] = []
    for name, (section, key, ukey) in TARGETS.items():
        m: Measurement | None = measurements.get(name)
        before = data[section][key]
        u_before = float(data["uncertainty"][ukey])
        if m is None or not m.measured:
            changes.append(FieldChange(name, "not_measured", before, before, u_before, u_before,
                                       None, 1.0, m.note if m is not None else ""))
            continue
        after, u_after, action, reason = _decide(name, before, u_before, m, mode, threshold)
        data[section][key] = after
        data["uncertainty"][ukey] = round(u_after, 4)
        changes.append(FieldChange(name, action, before, after, u_before, round(u_after, 4),
                                   m.value, m.uncertainty, reason))
    return SMP.model_validate(data), changes


def _decide(name: str, before: Any, u_before: float, m: Measurement, mode: str,
            threshold: float) -> tuple[Any, float, str, str]:
    value, u_m = m.value, m.uncertainty
    if name == "global_displacement":
        was, now = _mobile(before), _mobile(value)
        if was is not None and now is not None and was != now:
            side = "mobile" if now else "stationary"
            return (before, max(u_before, DISAGREE_U), "conflict_uncertain",
                    f"measured {side}, but stationary/mobile is invariant: kept, uncertainty raised")
    if mode == "replace":
        return value, u_m, "replaced", "measured on the clip"
    if u_m >= threshold:
        return before, u_before, "kept", f"measurement not confident (u={u_m:.2f} >= {threshold:g})"
    confident_before = before != UNKNOWN and u_before < threshold
    if not confident_before:
        return value, u_m, "replaced", "confident measurement over an uncertain or unknown field"
    if agree(name, before, value):
        return before, min(u_before, u_m), "confirmed", "measurement agrees"
    return (value, max(u_before, u_m, DISAGREE_U), "conflict_replaced",
            f"confident measurement disagrees with the confident value {before!r}")
