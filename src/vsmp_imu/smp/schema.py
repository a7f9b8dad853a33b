"""The Semantic Motion Program (SMP) schema.

Field names, types and allowed values follow the paper's JSON schema
(appendix "VLM-Based SMP Extraction") exactly, plus `schema_version`.

The paper's Table 1 types tempo, amplitude and global displacement as
"scalar / categorical": each accepts its category word or a number.
Tempo and amplitude numbers are positions on the ordinal scale
(0 = slow/small, 1 = medium, 2 = fast/large); a global-displacement number is
the travelled extent in metres (0 = stationary). Constrained augmentation
writes numbers; the verbalizer rounds them back to words.
"""

from __future__ import annotations

import hashlib
import json
from typing import Annotated, Any, Literal, get_args

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StrictBool,
    StrictInt,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from vsmp_imu.smp._text import first_spellings, norm_name
from vsmp_imu.validation import SHOWN_INPUT_CHARS

SCHEMA_VERSION = "1.0"

UNKNOWN = "unknown"
Unknown = Literal["unknown"]

# Physical bounds of the numeric fields, so that validation, augmentation and synthesis agree
# on what an SMP may ask for. A motion lasts at most MAX_MOTION_S (the `motion synth
# --duration-s` limit, the recipes' `default_duration_s` limit), so:
MAX_MOTION_S = 600.0
# - a primitive's duration (seconds, or a relative share written as a fraction or a percent)
#   is at most the whole motion;
MAX_PRIMITIVE_DURATION = MAX_MOTION_S
# - a clip holds at most 1000 repetitions: 10 minutes at 1.7 cycles/s, about the cadence of
#   brisk walking steps; the library counts at most 12 and a counted clip tens;
MAX_REPETITIONS = 1000
# - the travelled extent is at most 2000 m: 10 minutes at a running pace of 3.3 m/s (the
#   library's "large" is 4 m).
MAX_DISPLACEMENT_M = 2000.0
MAX_ORDER_INDEX = 1000  # an order position; an SMP has a handful of primitives
# At most this many motion primitives and sequence items: the library's longest activity has
# 6, and refinement compares items pairwise, so an answer with thousands would stall it.
MAX_PRIMITIVES = 64
# At most this many characters in any text of an SMP (a label, a name, a description): the
# library's longest is a 134-character description. Labels and names are matched against the
# library's and the lexicon's, so a label of megabytes once stalled `motion synth` for minutes.
MAX_TEXT_CHARS = 1000


def _number(lo: float, hi: float):
    """A finite number in lo..hi; strict: true/false and numeric text are refused, not coerced."""
    return Annotated[float, Field(ge=lo, le=hi, strict=True, allow_inf_nan=False)]


Unit = _number(0.0, 1.0)
OrdinalLevel = _number(0.0, 2.0)
Duration = _number(0.0, MAX_PRIMITIVE_DURATION)
Extent = _number(0.0, MAX_DISPLACEMENT_M)

TEMPO_LEVELS = ("slow", "medium", "fast")
AMPLITUDE_LEVELS = ("small", "medium", "large")
DOMINANT_SIDES = ("left", "right", "bilateral", "none")
SYMMETRIES = ("symmetric", "asymmetric")
DISPLACEMENTS = ("stationary", "small", "large")
PERIODICITIES = ("none", "single", "cyclic")
ORDERINGS = ("ordered", "weakly_ordered", "unordered")
TRANSITION_TYPES = ("discrete", "continuous")
DURATION_TYPES = ("absolute", "relative")

InvariantField = Literal[
    "activity_label",
    "primitive_sequence",
    "mandatory_body_parts",
    "required_contact",
    "stationary_or_mobile",
]
VariantField = Literal[
    "tempo",
    "amplitude",
    "repetition_count",
    "primitive_duration",
    "dominant_side",
    "symmetry",
    "global_displacement",
]
INVARIANT_FIELDS = get_args(InvariantField)
VARIANT_FIELDS = get_args(VariantField)
UNCERTAINTY_FIELDS = (
    "activity_label",
    "motion_primitives",
    "primitive_duration",
    "body_parts",
    "temporal_structure",
    "repetition_count",
    "tempo",
    "amplitude",
    "dominant_side",
    "symmetry",
    "global_displacement",
    "object_contact",
)

# Words a primitive_sequence may hold without a motion primitive of that name: they mark the
# cycle's repetition, and the motion backends skip them (normalized, see norm_name).
STRUCTURAL_NAMES = ("repeat", "repetition", "repeat cycle", "loop", "repeat sequence")

# Nominal travelled extent (metres) of the displacement categories; used to
# turn a category into a number before a bounded +-25 % perturbation.
DISPLACEMENT_EXTENT_M = {"stationary": 0.0, "small": 1.0, "large": 4.0}
# Extents below this are "small", at or above it "large" (mobile either way).
LARGE_DISPLACEMENT_M = 2.5


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", validate_assignment=True, str_max_length=MAX_TEXT_CHARS)


class MotionPrimitive(_Strict):
    name: str = Field(min_length=1)
    order_index: StrictInt = Field(ge=0, le=MAX_ORDER_INDEX)
    description: str = ""
    body_parts: list[str] = Field(default_factory=list)
    relative_duration: Duration | Unknown = UNKNOWN
    contact: list[str] = Field(default_factory=list)


def _not_blank(name: str) -> str:
    if not name.strip():
        raise PydanticCustomError("blank_name", "must not be empty")
    return name


SequenceName = Annotated[str, AfterValidator(_not_blank)]


class PrimitiveDurations(_Strict):
    type: Literal["absolute", "relative", "unknown"] = UNKNOWN
    values: list[Duration | Unknown] = Field(default_factory=list)


class BodyParts(_Strict):
    mandatory: list[str] = Field(default_factory=list)
    optional: list[str] = Field(default_factory=list)
    dominant_moving_segments: list[str] = Field(default_factory=list)


class TemporalStructure(_Strict):
    is_repetitive: StrictBool = False
    repetition_count: Annotated[StrictInt, Field(ge=0, le=MAX_REPETITIONS)] | Unknown = UNKNOWN
    periodicity: Literal["none", "single", "cyclic", "unknown"] = UNKNOWN
    ordering: Literal["ordered", "weakly_ordered", "unordered"] = "ordered"
    transition_type: Literal["discrete", "continuous", "unknown"] = UNKNOWN


class ExecutionAttributes(_Strict):
    tempo: Literal["slow", "medium", "fast", "unknown"] | OrdinalLevel = UNKNOWN
    amplitude: Literal["small", "medium", "large", "unknown"] | OrdinalLevel = UNKNOWN
    dominant_side: Literal["left", "right", "bilateral", "none", "unknown"] = UNKNOWN
    symmetry: Literal["symmetric", "asymmetric", "unknown"] = UNKNOWN
    global_displacement: Literal["stationary", "small", "large", "unknown"] | Extent = UNKNOWN


class ObjectContact(_Strict):
    objects: list[str] = Field(default_factory=list)
    body_contact: list[str] = Field(default_factory=list)
    environment_contact: list[str] = Field(default_factory=list)
    required_contact: list[str] = Field(default_factory=list)


class ConstraintRules(_Strict):
    preserve_activity_label: StrictBool = True
    preserve_core_primitive_order: StrictBool = True
    preserve_mandatory_body_parts: StrictBool = True
    preserve_required_contact: StrictBool = True
    dominant_side_swap_allowed_only_if_side_agnostic: StrictBool = True
    symmetry_change_allowed_only_if_label_preserving: StrictBool = True
    global_displacement_change_must_preserve_stationary_or_mobile_semantics: StrictBool = True


class Constraints(_Strict):
    invariant_fields: list[InvariantField] = Field(default_factory=lambda: list(INVARIANT_FIELDS))
    variant_fields: list[VariantField] = Field(default_factory=list)
    rules: ConstraintRules = Field(default_factory=ConstraintRules)


class Uncertainty(_Strict):
    activity_label: Unit = 0.5
    motion_primitives: Unit = 0.5
    primitive_duration: Unit = 0.5
    body_parts: Unit = 0.5
    temporal_structure: Unit = 0.5
    repetition_count: Unit = 0.5
    tempo: Unit = 0.5
    amplitude: Unit = 0.5
    dominant_side: Unit = 0.5
    symmetry: Unit = 0.5
    global_displacement: Unit = 0.5
    object_contact: Unit = 0.5


class SMP(_Strict):
    """A Semantic Motion Program S = {y, P, D, B, T, A, O, C, U}."""

    schema_version: str = SCHEMA_VERSION
    activity_label: str = Field(min_length=1)
    motion_primitives: list[MotionPrimitive] = Field(min_length=1, max_length=MAX_PRIMITIVES)
    primitive_sequence: list[SequenceName] = Field(min_length=1, max_length=MAX_PRIMITIVES)
    primitive_durations: PrimitiveDurations = Field(default_factory=PrimitiveDurations)
    body_parts: BodyParts = Field(default_factory=BodyParts)
    temporal_structure: TemporalStructure = Field(default_factory=TemporalStructure)
    execution_attributes: ExecutionAttributes = Field(default_factory=ExecutionAttributes)
    object_contact: ObjectContact = Field(default_factory=ObjectContact)
    constraints: Constraints = Field(default_factory=Constraints)
    uncertainty: Uncertainty = Field(default_factory=Uncertainty)

    @field_validator("activity_label")
    @classmethod
    def _strip_label(cls, value: str) -> str:
        value = value.strip()
        if not value:
            raise ValueError("must not be empty")
        return value

    @field_validator("motion_primitives")
    @classmethod
    def _one_spelling(cls, primitives: list[MotionPrimitive]) -> list[MotionPrimitive]:
        """Two primitives whose names differ only in case, spaces, '_' or '-' are refused: a
        sequence name could not tell them apart. A name repeated exactly is one primitive
        listed per sequence position (refinement writes them so)."""
        for i, j in enumerate(first_spellings([p.name for p in primitives])):
            prim = primitives[i]
            if primitives[j].name != prim.name:
                # the names are put in here, not by pydantic, which would fill '{...}' inside them
                raise PydanticCustomError(
                    "primitive_spellings",
                    f"motion_primitives[{j}] {_quoted(primitives[j].name)} and motion_primitives[{i}] {_quoted(prim.name)} "
                    "differ only in case, spaces, '_' or '-', so a primitive_sequence name cannot tell them apart",
                    {"expected": "one spelling of each primitive name"})
        return primitives

    @field_validator("primitive_sequence")
    @classmethod
    def _names_a_primitive(cls, sequence: list[str], info: ValidationInfo) -> list[str]:
        """Each name is a motion primitive's (case, spaces, '_' and '-' aside) or structural."""
        primitives = info.data.get("motion_primitives")
        if primitives is None:  # invalid itself: that error is reported
            return sequence
        known = {norm_name(p.name) for p in primitives}
        for i, name in enumerate(sequence):
            if norm_name(name) not in known and norm_name(name) not in STRUCTURAL_NAMES:
                raise PydanticCustomError(
                    "unknown_primitive", "item {index} '{name}' is the name of no motion primitive",
                    {"index": i, "name": name, "expected": _sequence_names(primitives)})
        return sequence

    @model_validator(mode="after")
    def _check_lengths(self) -> SMP:
        values = self.primitive_durations.values
        if values and len(values) != len(self.primitive_sequence):
            raise ValueError(
                f"primitive_durations.values has {len(values)} entries but "
                f"primitive_sequence has {len(self.primitive_sequence)}"
            )
        return self

    # -- the primitive a sequence name refers to ---------------------------
    def primitive(self, name: str) -> MotionPrimitive | None:
        """The motion primitive `name` refers to, matched as validation matches it (case, spaces,
        '_' and '-' aside; of a name listed once per sequence position, the first); None for a
        structural word."""
        key = norm_name(name)
        return next((p for p in self.motion_primitives if norm_name(p.name) == key), None)

    def raw_durations(self) -> list[float | None]:
        """Per-primitive relative durations as written (None when unknown), in sequence order:
        `primitive_durations` when it has a known value per sequence entry, else each
        primitive's own `relative_duration`."""
        values = self.primitive_durations.values
        if len(values) == len(self.primitive_sequence) and any(v != UNKNOWN for v in values):
            return [None if v == UNKNOWN else float(v) for v in values]
        return [self.primitive_duration(name) for name in self.primitive_sequence]

    def primitive_duration(self, name: str) -> float | None:
        """The relative duration of the primitive `name` refers to; None when unknown or none."""
        prim = self.primitive(name)
        return None if prim is None or prim.relative_duration == UNKNOWN else float(prim.relative_duration)

    # -- identity ---------------------------------------------------------
    def canonical_json(self) -> str:
        """Key-sorted compact JSON: the bytes that define this SMP's identity."""
        return json.dumps(self.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))

    @property
    def smp_id(self) -> str:
        """A short content hash; equal SMPs have equal ids."""
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()[:16]

    # -- scalar views of "scalar / categorical" fields ----------------------
    def tempo_level(self) -> float | None:
        """Tempo on the ordinal scale 0 (slow) .. 2 (fast); None if unknown."""
        return ordinal_level(self.execution_attributes.tempo, TEMPO_LEVELS)

    def amplitude_level(self) -> float | None:
        """Amplitude on the ordinal scale 0 (small) .. 2 (large); None if unknown."""
        return ordinal_level(self.execution_attributes.amplitude, AMPLITUDE_LEVELS)

    def displacement_extent_m(self) -> float | None:
        """Travelled extent in metres (category -> nominal extent); None if unknown."""
        value = self.execution_attributes.global_displacement
        if isinstance(value, str):
            return DISPLACEMENT_EXTENT_M.get(value)
        return float(value)

    def repetition_count(self) -> int | None:
        value = self.temporal_structure.repetition_count
        return None if value == UNKNOWN else int(value)

    def relative_durations(self) -> list[float]:
        """Per-primitive relative durations in sequence order, normalized to sum 1.

        Unknown entries are filled with the mean of the known ones (or 1 when
        none is known).
        """
        raw = self.raw_durations()
        known = [v for v in raw if v is not None and v > 0]
        fill = sum(known) / len(known) if known else 1.0
        filled = [v if v is not None and v > 0 else fill for v in raw]
        total = sum(filled)
        return [v / total for v in filled]


def _quoted(name: str) -> str:
    """A name in a message, only its start when long (a name may have 1000 characters)."""
    if len(name) <= SHOWN_INPUT_CHARS:
        return f"'{name}'"
    return f"'{name[:SHOWN_INPUT_CHARS]}...' ({len(name)} characters)"


def _sequence_names(primitives: list[MotionPrimitive]) -> str:
    names = ", ".join(dict.fromkeys(p.name for p in primitives))
    return f"a name from motion_primitives ({names}) or a structural word ({', '.join(STRUCTURAL_NAMES)})"


def ordinal_level(value: str | float, levels: tuple[str, str, str]) -> float | None:
    """Map a category word or a number to the 0..2 ordinal scale."""
    if isinstance(value, str):
        return float(levels.index(value)) if value in levels else None
    return float(value)


def ordinal_word(value: str | float, levels: tuple[str, str, str]) -> str:
    """Map a category word or a number back to the nearest category word."""
    if isinstance(value, str):
        return value
    index = int(min(2, max(0, round(float(value)))))
    return levels[index]


def displacement_word(value: str | float) -> str:
    """The category of a displacement value (number in metres or word)."""
    if isinstance(value, str):
        return value
    if value <= 0:
        return "stationary"
    return "large" if value >= LARGE_DISPLACEMENT_M else "small"


def smp_json_schema() -> dict[str, Any]:
    """The JSON Schema of the SMP (what `vsmp-imu smp schema` prints)."""
    schema = SMP.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "Semantic Motion Program"
    return schema
