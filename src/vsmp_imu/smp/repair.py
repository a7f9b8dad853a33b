"""Deterministic repair of raw model text into an SMP (paper, "Video-Grounded SMP
Extraction with a Pretrained VLM").

`parse_response(text)` never raises. It ends in a valid SMP or a rejection with
a reason, and reports what it did:

1. Find the object: the whole text as JSON; else ``` fences and balanced
   `{...}` spans in prose (the most SMP-like one wins, then the longest);
   broken JSON is repaired with `json_repair`; key-value (YAML) text is the
   last resort. Text beyond `MAX_CHARS` is cut.
2. Map keys, at every nesting level, to the schema: exact (after snake_case),
   a synonym table, then the closest valid key by rapidfuzz ratio
   >= `KEY_MATCH_MIN`. Unknown keys are dropped and recorded. A section key
   written at the top level (e.g. "tempo") is moved into its section.
3. Coerce values. Same-meaning spellings ("Fast", "8", "true") are normalized
   and logged as repairs, not as invalid values. Other incompatible values are
   mapped through a synonym table ("quick" -> fast, "both" -> bilateral,
   "eight" -> 8) or a close fuzzy match, else reinitialized with the conservative default
   (`unknown`, or the schema default where no `unknown` exists); both count
   as invalid values. Uncertainty: a value in [0, 1] is kept, a value above 1
   is clipped to 1 (the conservative end: least perturbation), "20%" is 0.2,
   words map to low 0.2 / medium 0.5 / high 0.8, anything else (negative, not
   a number) becomes 0.5. A number outside the schema's bounds (durations,
   displacement, repetition count, ordinal levels) becomes `unknown` alone, so
   its section keeps its other fields. Missing optional fields take `unknown`
   (or the schema default).
4. Mandatory fields: `activity_label`, and the primitives, given as
   `motion_primitives` or `primitive_sequence` (either one is rebuilt from
   the other; a sequence name that no primitive has gets a bare primitive).
   A response without a label or without any primitive is rejected, and so is
   one with more than `MAX_PRIMITIVES` primitives or sequence items (an invalid
   value: an SMP has a handful).
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass, field
from typing import Any

import json_repair
import pydantic
from rapidfuzz import fuzz, process

from vsmp_imu.io import load_yaml
from vsmp_imu.smp._text import NUMBER_WORDS, first_spellings, norm_key, norm_name
from vsmp_imu.smp.schema import (
    INVARIANT_FIELDS,
    MAX_DISPLACEMENT_M,
    MAX_PRIMITIVE_DURATION,
    MAX_PRIMITIVES,
    MAX_REPETITIONS,
    SCHEMA_VERSION,
    SMP,
    STRUCTURAL_NAMES,
    UNCERTAINTY_FIELDS,
    UNKNOWN,
    VARIANT_FIELDS,
    BodyParts,
    ConstraintRules,
    ExecutionAttributes,
    MotionPrimitive,
    ObjectContact,
    PrimitiveDurations,
    TemporalStructure,
)

MAX_CHARS = 100_000  # an SMP is a few kB; longer text is cut before searching
KEY_MATCH_MIN = 80.0  # rapidfuzz ratio for mapping a malformed key
VALUE_MATCH_MIN = 80.0  # rapidfuzz ratio for mapping a misspelled category word
DEFAULT_UNCERTAINTY = 0.5

MANDATORY = ("activity_label", "motion_primitives", "primitive_sequence")


@dataclass
class RepairReport:
    """What the repair found and did (JSON-serializable through `to_dict`)."""

    malformed_json: bool = False
    json_found: bool = False
    missing_mandatory: list[str] = field(default_factory=list)
    invalid_values: list[str] = field(default_factory=list)
    repairs: list[str] = field(default_factory=list)
    rejected: bool = False
    reason: str | None = None

    @property
    def valid(self) -> bool:
        return not self.rejected

    @property
    def repaired(self) -> bool:
        return bool(self.repairs)

    def to_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["valid"] = self.valid
        out["repaired"] = self.repaired
        return out


@dataclass
class RepairResult:
    """The repaired SMP (None when rejected) and its report."""

    smp: SMP | None
    report: RepairReport

    @property
    def valid(self) -> bool:
        return self.smp is not None

    @property
    def repaired(self) -> bool:
        return self.report.repaired

    def to_dict(self) -> dict[str, Any]:
        return {"smp": None if self.smp is None else self.smp.model_dump(mode="json"),
                "report": self.report.to_dict()}


# ---------------------------------------------------------------------------
# key tables
# ---------------------------------------------------------------------------
TOP_SYNONYMS = {
    "label": "activity_label", "activity": "activity_label", "activity_name": "activity_label",
    "action": "activity_label", "action_label": "activity_label", "class": "activity_label",
    "class_label": "activity_label", "activity_type": "activity_label",
    "primitives": "motion_primitives", "steps": "motion_primitives", "phases": "motion_primitives",
    "motion_steps": "motion_primitives",
    "sequence": "primitive_sequence", "primitive_order": "primitive_sequence",
    "ordered_primitives": "primitive_sequence", "primitives_sequence": "primitive_sequence",
    "motion_sequence": "primitive_sequence",
    "durations": "primitive_durations", "phase_durations": "primitive_durations",
    "primitive_duration": "primitive_durations", "relative_durations": "primitive_durations",
    "body_part_involvement": "body_parts", "involved_body_parts": "body_parts",
    "body_parts_involved": "body_parts", "bodyparts": "body_parts",
    "temporal": "temporal_structure", "temporal_organization": "temporal_structure",
    "temporal_pattern": "temporal_structure", "repetition_pattern": "temporal_structure",
    "timing": "temporal_structure",
    "attributes": "execution_attributes", "execution": "execution_attributes",
    "execution_attribute": "execution_attributes",
    "object": "object_contact", "objects_contact": "object_contact",
    "object_contacts": "object_contact", "contact": "object_contact", "contacts": "object_contact",
    "object_and_contact": "object_contact", "objects_and_contacts": "object_contact",
    "constraint": "constraints", "augmentation_constraints": "constraints",
    "uncertainties": "uncertainty", "field_uncertainty": "uncertainty",
    "uncertainty_scores": "uncertainty", "field_uncertainties": "uncertainty",
}

SECTION_SYNONYMS: dict[str, dict[str, str]] = {
    "motion_primitives": {
        "primitive": "name", "primitive_name": "name", "label": "name", "action": "name",
        "step": "name", "order": "order_index", "index": "order_index", "idx": "order_index",
        "position": "order_index", "step_index": "order_index", "desc": "description",
        "text": "description", "details": "description", "parts": "body_parts",
        "body_part": "body_parts", "bodyparts": "body_parts", "joints": "body_parts",
        "segments": "body_parts", "duration": "relative_duration",
        "rel_duration": "relative_duration", "relative_length": "relative_duration",
        "phase_length": "relative_duration", "fraction": "relative_duration",
        "proportion": "relative_duration", "contacts": "contact", "contact_points": "contact",
    },
    "primitive_durations": {"unit": "type", "kind": "type", "duration_type": "type",
                            "value": "values", "durations": "values", "list": "values"},
    "body_parts": {
        "required": "mandatory", "primary": "mandatory", "main": "mandatory",
        "essential": "mandatory", "secondary": "optional", "auxiliary": "optional",
        "supporting": "optional", "dominant": "dominant_moving_segments",
        "dominant_segments": "dominant_moving_segments",
        "moving_segments": "dominant_moving_segments",
        "dominant_moving": "dominant_moving_segments",
        "dominant_moving_segment": "dominant_moving_segments",
    },
    "temporal_structure": {
        "repetitive": "is_repetitive", "periodic": "is_repetitive", "is_periodic": "is_repetitive",
        "repeated": "is_repetitive", "is_cyclic": "is_repetitive",
        "repetitions": "repetition_count", "reps": "repetition_count", "count": "repetition_count",
        "num_repetitions": "repetition_count", "number_of_repetitions": "repetition_count",
        "repeat_count": "repetition_count", "n_repetitions": "repetition_count",
        "cycles": "repetition_count", "period": "periodicity", "periodic_pattern": "periodicity",
        "pattern": "periodicity", "order": "ordering", "transitions": "transition_type",
        "transition": "transition_type",
    },
    "execution_attributes": {
        "speed": "tempo", "pace": "tempo", "rate": "tempo", "range": "amplitude",
        "range_of_motion": "amplitude", "rom": "amplitude", "magnitude": "amplitude",
        "extent": "amplitude", "side": "dominant_side", "handedness": "dominant_side",
        "dominant_hand": "dominant_side", "laterality": "dominant_side",
        "dominant_limb": "dominant_side", "symmetric": "symmetry",
        "displacement": "global_displacement", "locomotion": "global_displacement",
        "travel": "global_displacement",
    },
    "object_contact": {
        "object": "objects", "items": "objects", "equipment": "objects", "props": "objects",
        "objects_used": "objects", "body": "body_contact", "self_contact": "body_contact",
        "environment": "environment_contact", "environmental_contact": "environment_contact",
        "surface": "environment_contact", "surfaces": "environment_contact",
        "support": "environment_contact", "support_surface": "environment_contact",
        "required": "required_contact", "required_contacts": "required_contact",
        "mandatory_contact": "required_contact",
    },
    "constraints": {
        "invariants": "invariant_fields", "invariant": "invariant_fields",
        "fixed_fields": "invariant_fields", "invariant_field": "invariant_fields",
        "variants": "variant_fields", "variant": "variant_fields",
        "variable_fields": "variant_fields", "augmentable_fields": "variant_fields",
        "augmentable": "variant_fields", "variant_field": "variant_fields", "rule": "rules",
    },
    "rules": {},
    "uncertainty": {
        "primitives": "motion_primitives", "primitive_sequence": "motion_primitives",
        "sequence": "motion_primitives", "label": "activity_label", "activity": "activity_label",
        "durations": "primitive_duration", "primitive_durations": "primitive_duration",
        "repetitions": "repetition_count", "reps": "repetition_count", "side": "dominant_side",
        "displacement": "global_displacement", "contact": "object_contact",
        "objects": "object_contact", "temporal": "temporal_structure",
    },
}

SECTION_FIELDS: dict[str, tuple[str, ...]] = {
    "motion_primitives": tuple(MotionPrimitive.model_fields),
    "primitive_durations": tuple(PrimitiveDurations.model_fields),
    "body_parts": tuple(BodyParts.model_fields),
    "temporal_structure": tuple(TemporalStructure.model_fields),
    "execution_attributes": tuple(ExecutionAttributes.model_fields),
    "object_contact": tuple(ObjectContact.model_fields),
    "constraints": ("invariant_fields", "variant_fields", "rules"),
    "rules": tuple(ConstraintRules.model_fields),
    "uncertainty": UNCERTAINTY_FIELDS,
}
TOP_FIELDS = tuple(SMP.model_fields)

# Top-level keys that belong in a section (e.g. "tempo" -> execution_attributes).
_RELOCATABLE = ("temporal_structure", "execution_attributes", "object_contact", "body_parts",
                "constraints")


def _relocation_table() -> dict[str, tuple[str, str]]:
    seen: dict[str, list[tuple[str, str]]] = {}
    for section in _RELOCATABLE:
        names = {f: f for f in SECTION_FIELDS[section]} | SECTION_SYNONYMS[section]
        for key, target in names.items():
            if key in TOP_FIELDS or key in TOP_SYNONYMS:
                continue
            seen.setdefault(key, []).append((section, target))
    return {k: v[0] for k, v in seen.items() if len(v) == 1}


RELOCATE = _relocation_table()

# ---------------------------------------------------------------------------
# value tables
# ---------------------------------------------------------------------------
UNKNOWN_WORDS = {"unknown", "n/a", "na", "null", "unclear", "not visible", "unsure", "?",
                 "uncertain", "not applicable", "undetermined", "cannot tell", "not sure", "none"}
TEMPO_SYNONYMS = {
    "quick": "fast", "quickly": "fast", "rapid": "fast", "rapidly": "fast", "high": "fast",
    "brisk": "fast", "vigorous": "fast", "fast paced": "fast", "faster": "fast", "energetic": "fast",
    "moderate": "medium", "normal": "medium", "average": "medium", "steady": "medium",
    "regular": "medium", "mid": "medium", "moderately": "medium", "natural": "medium",
    "low": "slow", "slowly": "slow", "leisurely": "slow", "deliberate": "slow",
    "controlled": "slow", "gentle": "slow", "slower": "slow",
}
AMPLITUDE_SYNONYMS = {
    "low": "small", "minimal": "small", "slight": "small", "narrow": "small", "limited": "small",
    "tiny": "small", "short": "small", "subtle": "small",
    "moderate": "medium", "normal": "medium", "mid": "medium", "average": "medium",
    "high": "large", "big": "large", "wide": "large", "full": "large", "maximal": "large",
    "exaggerated": "large", "broad": "large", "huge": "large", "extended": "large",
}
SIDE_SYNONYMS = {
    "both": "bilateral", "two": "bilateral", "both sides": "bilateral", "bilaterally": "bilateral",
    "symmetric": "bilateral", "alternating": "bilateral", "l": "left", "r": "right",
    "left hand": "left", "right hand": "right", "n/a": "none", "na": "none", "neither": "none",
    "not applicable": "none", "no": "none",
}
SYMMETRY_SYNONYMS = {
    "symmetrical": "symmetric", "sym": "symmetric", "mirrored": "symmetric",
    "asymmetrical": "asymmetric", "unilateral": "asymmetric", "one sided": "asymmetric",
    "true": "symmetric", "false": "asymmetric",
}
DISPLACEMENT_SYNONYMS = {
    "none": "stationary", "in place": "stationary", "static": "stationary", "no": "stationary",
    "stationary in place": "stationary", "still": "stationary", "zero": "stationary",
    "on the spot": "stationary", "moderate": "small", "bounded": "small", "local": "small",
    "slight": "small", "short": "small", "minimal": "small", "bounded local": "small",
    "travelling": "large", "traveling": "large", "locomotion": "large", "mobile": "large",
    "forward": "large", "moving": "large", "long": "large", "high": "large",
}
PERIODICITY_SYNONYMS = {
    "periodic": "cyclic", "cyclical": "cyclic", "repetitive": "cyclic", "repeated": "cyclic",
    "repeating": "cyclic", "continuous": "cyclic", "cycle": "cyclic",
    "once": "single", "one off": "single", "single cycle": "single", "one time": "single",
    "aperiodic": "none", "non periodic": "none", "nonperiodic": "none", "static": "none",
    "no": "none",
}
ORDERING_SYNONYMS = {
    "strict": "ordered", "sequential": "ordered", "strictly ordered": "ordered",
    "fixed": "ordered", "partial": "weakly_ordered", "partially ordered": "weakly_ordered",
    "loosely ordered": "weakly_ordered", "loose": "weakly_ordered", "random": "unordered",
    "any": "unordered", "none": "unordered",
}
TRANSITION_SYNONYMS = {
    "smooth": "continuous", "fluid": "continuous", "flowing": "continuous",
    "abrupt": "discrete", "distinct": "discrete", "separate": "discrete", "stepwise": "discrete",
}
DURATION_TYPE_SYNONYMS = {
    "rel": "relative", "relative phase": "relative", "fraction": "relative",
    "fractions": "relative", "proportion": "relative", "proportions": "relative",
    "percent": "relative", "percentage": "relative", "ratio": "relative",
    "seconds": "absolute", "second": "absolute", "s": "absolute", "sec": "absolute",
    "absolute seconds": "absolute", "time": "absolute",
}
INVARIANT_SYNONYMS = {
    "label": "activity_label", "activity": "activity_label",
    "core_primitive_order": "primitive_sequence", "primitive_order": "primitive_sequence",
    "motion_primitives": "primitive_sequence", "primitives": "primitive_sequence",
    "body_parts": "mandatory_body_parts", "mandatory_body_part_set": "mandatory_body_parts",
    "contact": "required_contact", "object_contact": "required_contact",
    "required_object_contact": "required_contact",
    "stationary_mobile": "stationary_or_mobile", "stationary_vs_mobile": "stationary_or_mobile",
    "global_displacement_category": "stationary_or_mobile",
}
VARIANT_SYNONYMS = {
    "repetitions": "repetition_count", "reps": "repetition_count",
    "repetition": "repetition_count", "durations": "primitive_duration",
    "primitive_durations": "primitive_duration", "duration": "primitive_duration",
    "side": "dominant_side", "displacement": "global_displacement",
    "global_displacement_extent": "global_displacement", "speed": "tempo",
    "range_of_motion": "amplitude",
}
UNCERTAINTY_WORDS = {"none": 0.0, "zero": 0.0, "very low": 0.1, "low": 0.2, "medium": 0.5,
                     "moderate": 0.5, "high": 0.8, "very high": 0.9}
BOOL_WORDS = {"true": True, "yes": True, "y": True, "1": True, "false": False, "no": False,
              "n": False, "0": False}
_EMPTY_LIST_WORDS = {"none", "n/a", "na", "null", "nothing", "no", "unknown", "-", ""}

_FENCE = re.compile(r"```[ \t]*[A-Za-z0-9_\-]*[ \t]*\r?\n?(.*?)(?:```|\Z)", re.S)
_SPLIT_SEQ = re.compile(r"\s*(?:->|=>|→|⟶|,|;|\n|\|)\s*|\s+then\s+")
_SPLIT_LIST = re.compile(r"\s*(?:,|;|\n|\band\b)\s*")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


class _Ctx:
    """The report being written, with short helpers for recording."""

    def __init__(self, report: RepairReport) -> None:
        self.report = report

    def repair(self, text: str) -> None:
        self.report.repairs.append(text)

    def invalid(self, path: str, text: str) -> None:
        if path not in self.report.invalid_values:
            self.report.invalid_values.append(path)
        self.report.repairs.append(text)

    def fill(self, path: str, value: Any) -> None:
        self.report.repairs.append(f"filled missing '{path}' with {value!r}")


def _short(value: Any, limit: int = 60) -> str:
    try:
        text = repr(value)
    except Exception:  # noqa: BLE001 - repr of deeply nested input may fail
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[: limit - 3] + "..."


# ---------------------------------------------------------------------------
# 1. finding the object
# ---------------------------------------------------------------------------
def _smp_likeness(obj: Any) -> int:
    if not isinstance(obj, dict):
        return -1
    score = 0
    for key in obj:
        k = norm_key(str(key))
        if k in TOP_FIELDS or k in TOP_SYNONYMS or k in RELOCATE:
            score += 1
    return score


def _best_dict(obj: Any) -> dict | None:
    """The most SMP-like dict in a parsed value (itself, or an item of a list)."""
    if isinstance(obj, dict):
        return obj
    if isinstance(obj, list):
        dicts = [o for o in obj if isinstance(o, dict)]
        if dicts:
            return max(dicts, key=lambda d: (_smp_likeness(d), len(d)))
    return None


MAX_DEPTH = 64  # an SMP nests ~5 levels; deeper spans are not SMPs (and slow to repair)


def _balanced_objects(text: str, limit: int = 20) -> list[str]:
    """Top-level {...} spans, string-aware, longest first; an unclosed last one runs
    to the end. Spans nesting deeper than MAX_DEPTH are skipped."""
    spans: list[str] = []
    depth = deepest = 0
    start = -1
    in_str = esc = False
    for i, ch in enumerate(text):
        if in_str:
            if esc:
                esc = False
            elif ch == "\\":
                esc = True
            elif ch == '"':
                in_str = False
        elif ch == '"':
            in_str = depth > 0
        elif ch in "{[" and (ch == "{" or depth > 0):
            if depth == 0:
                start, deepest = i, 0
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "}]" and depth > 0:
            depth -= 1
            if depth == 0 and deepest <= MAX_DEPTH:
                spans.append(text[start:i + 1])
    if depth > 0 and start >= 0 and deepest <= MAX_DEPTH:
        spans.append(text[start:])
    spans.sort(key=len, reverse=True)
    return spans[:limit]


def _loads(text: str) -> Any:
    try:
        return json.loads(text)
    except (ValueError, RecursionError):
        return None


def _repair_loads(text: str) -> Any:
    try:
        return json_repair.loads(text)
    except Exception:  # noqa: BLE001 - json_repair raises on pathological nesting
        return None


MAX_YAML_CHARS = 20_000  # key-value answers are short; pure-Python YAML is slow on long text


def _yaml_loads(text: str) -> Any:
    """Block key-value text only (no braces: those went through the JSON repair)."""
    if "{" in text or len(text) > MAX_YAML_CHARS:
        return None
    try:
        return load_yaml(text)  # the safe loader, with the alias budget of every YAML we read
    except Exception:  # noqa: BLE001 - any YAML failure means "not key-value text"
        return None


def _find_object(text: str, ctx: _Ctx) -> dict | None:
    stripped = text.strip().lstrip("\ufeff").strip()
    whole = _loads(stripped) if len(stripped) <= 20 * MAX_CHARS else None
    if isinstance(whole, dict):
        return whole
    ctx.report.malformed_json = True
    found = _best_dict(whole)
    if found is not None and _smp_likeness(found) > 0:
        ctx.repair("took the object out of a top-level JSON list")
        return found
    if len(stripped) > MAX_CHARS:
        stripped = stripped[:MAX_CHARS]
        ctx.repair(f"cut the input to its first {MAX_CHARS} characters")

    candidates: list[tuple[int, int, int, dict, str]] = []  # (likeness, kind, size, obj, note)
    blocks = [m.group(1) for m in _FENCE.finditer(stripped)] if "```" in stripped else []
    sources = [(b, "a ``` fence") for b in blocks] + [(stripped, "the surrounding text")]
    seen: set[str] = set()
    for source, where in sources:
        for span in _balanced_objects(source):
            if span in seen:
                continue
            seen.add(span)
            obj = _loads(span)
            note = f"extracted the JSON object from {where}"
            if obj is None:
                obj = _repair_loads(span)
                note = f"repaired broken JSON from {where} with json_repair"
            obj = _best_dict(obj)
            if obj:
                candidates.append((_smp_likeness(obj), 1, len(span), obj, note))
    if not any(c[0] > 0 for c in candidates):
        for source, where in sources:
            obj = _best_dict(_yaml_loads(source))
            if obj and _smp_likeness(obj) > 0:
                candidates.append((_smp_likeness(obj), 0, len(source), obj,
                                   f"parsed key-value (YAML) text from {where}"))
    if not candidates:
        return None
    likeness, _, _, obj, note = max(candidates, key=lambda c: (c[0], c[1], c[2]))
    ctx.repair(note)
    return obj


# ---------------------------------------------------------------------------
# 2. keys
# ---------------------------------------------------------------------------
def _map_keys(data: dict, section: str | None, path: str, ctx: _Ctx) -> dict[str, Any]:
    """Rename keys of one mapping to the schema's; unknown ones are dropped."""
    valid = TOP_FIELDS if section is None else SECTION_FIELDS[section]
    synonyms = TOP_SYNONYMS if section is None else SECTION_SYNONYMS[section]
    where = f" in '{path}'" if path else ""
    out: dict[str, Any] = {}
    pending: list[tuple[str, str, Any]] = []
    for raw, value in data.items():
        key = norm_key(str(raw))
        if key in valid and key not in out:
            if str(raw) != key:
                ctx.repair(f"renamed key '{raw}' -> '{key}'{where}")
            out[key] = value
        else:
            pending.append((str(raw), key, value))
    moved: dict[str, dict[str, Any]] = {}
    for raw, key, value in pending:
        target = synonyms.get(key)
        if target is None and section is None and key in RELOCATE:
            sec, sub = RELOCATE[key]
            box = moved.setdefault(sec, {})
            if sub not in box:
                box[sub] = value
                ctx.repair(f"moved top-level key '{raw}' into '{sec}.{sub}'")
                continue
        if target is None and key:
            hit = process.extractOne(key, valid, scorer=fuzz.ratio, score_cutoff=KEY_MATCH_MIN)
            target = hit[0] if hit else None
        if target is None:
            ctx.repair(f"dropped unknown key '{raw}'{where}")
        elif target in out:
            ctx.repair(f"dropped duplicate key '{raw}' (already have '{target}'){where}")
        else:
            ctx.repair(f"renamed key '{raw}' -> '{target}'{where}")
            out[target] = value
    for sec, box in moved.items():
        current = out.get(sec)
        if current is None:
            out[sec] = box
        elif isinstance(current, dict):
            for sub, value in box.items():
                current.setdefault(sub, value)
    return out


def _section(data: dict, name: str, section: str, path: str,
             ctx: _Ctx) -> tuple[dict[str, Any], _Ctx]:
    """The key-mapped mapping of a nested section ({} when missing or not a mapping),
    and the context for its fields (quiet about fills when the whole section was missing)."""
    value = data.get(name)
    if value is None:
        ctx.fill(path, "defaults")
        return {}, _Quiet(ctx.report)
    if not isinstance(value, dict):
        ctx.invalid(path, f"replaced non-mapping {_short(value)} at '{path}' with defaults")
        return {}, _Quiet(ctx.report)
    return _map_keys(value, section, path, ctx), ctx


# ---------------------------------------------------------------------------
# 3. values
# ---------------------------------------------------------------------------
def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _to_float(value: Any) -> float | None:
    """A finite float from a number or a numeric string ('0.3', '30%', '2 m'); else None."""
    if _is_number(value):
        x = float(value)
    elif isinstance(value, str):
        text = value.strip().lower()
        m = _NUMBER.match(text)
        if not m:
            return None
        try:
            x = float(m.group(0))
        except ValueError:
            return None
        if text[m.end():].strip().startswith("%"):
            x /= 100.0
    else:
        return None
    return x if math.isfinite(x) else None


def _word(value: Any, allowed: tuple[str, ...], synonyms: dict[str, str], default: str,
          path: str, ctx: _Ctx) -> str:
    """One category word: exact, synonym, a synonym token, fuzzy, else `default`."""
    if value is None or (isinstance(value, str) and not value.strip()):
        ctx.fill(path, default)
        return default
    if isinstance(value, bool):
        value = "true" if value else "false"
    if isinstance(value, str):
        text = norm_name(value)
        key = text.replace(" ", "_")
        if key in allowed:
            if value != key:
                ctx.repair(f"normalized {_short(value)} -> '{key}' at '{path}'")
            return key
        if text in synonyms and synonyms[text] in allowed:
            ctx.invalid(path, f"mapped {_short(value)} -> '{synonyms[text]}' at '{path}'")
            return synonyms[text]
        if text in UNKNOWN_WORDS and UNKNOWN in allowed:
            ctx.repair(f"normalized {_short(value)} -> 'unknown' at '{path}'")
            return UNKNOWN
        for token in text.split()[:20]:
            hit = token if token in allowed else synonyms.get(token)
            if hit in allowed:
                ctx.invalid(path, f"mapped {_short(value)} -> '{hit}' at '{path}'")
                return hit
        if len(key) <= 40:
            match = process.extractOne(key, [a for a in allowed if a != UNKNOWN],
                                       scorer=fuzz.ratio, score_cutoff=VALUE_MATCH_MIN)
            if match:
                ctx.invalid(path, f"mapped {_short(value)} -> '{match[0]}' at '{path}'")
                return match[0]
    ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with '{default}'")
    return default


def _ordinal(value: Any, levels: tuple[str, ...], synonyms: dict[str, str], path: str,
             ctx: _Ctx) -> str | float:
    """Tempo/amplitude: a word or a number on the 0..2 ordinal scale."""
    number = None
    if _is_number(value):
        number = float(value)
    elif isinstance(value, str) and _NUMBER.fullmatch(value.strip()):
        number = float(value.strip())
        ctx.repair(f"converted {_short(value)} to a number at '{path}'")
    if number is None:
        return _word(value, (*levels, UNKNOWN), synonyms, UNKNOWN, path, ctx)
    if math.isfinite(number) and 0.0 <= number <= 2.0:
        return number
    ctx.invalid(path, f"replaced out-of-range {_short(value)} at '{path}' with 'unknown' "
                      "(numbers lie on the 0..2 ordinal scale)")
    return UNKNOWN


def _displacement(value: Any, path: str, ctx: _Ctx) -> str | float:
    """A category word or a non-negative extent in metres ('2 m' -> 2.0)."""
    if _is_number(value) or (isinstance(value, str) and _NUMBER.match(value.strip())):
        number = _to_float(value)
        if number is not None and 0 <= number <= MAX_DISPLACEMENT_M:
            if not _is_number(value):
                ctx.repair(f"converted {_short(value)} to {number:g} m at '{path}'")
            return number
        ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with 'unknown' "
                          f"(an extent is 0..{MAX_DISPLACEMENT_M:g} m)")
        return UNKNOWN
    return _word(value, ("stationary", "small", "large", UNKNOWN), DISPLACEMENT_SYNONYMS,
                 UNKNOWN, path, ctx)


def _count(value: Any, path: str, ctx: _Ctx) -> int | str:
    """repetition_count: a non-negative integer or 'unknown' ('8', 'eight', '8-10' -> 9)."""
    if value is None:
        ctx.fill(path, UNKNOWN)
        return UNKNOWN
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= MAX_REPETITIONS:
        return value
    guess: float | None = None
    exact = False
    if _is_number(value):
        guess, exact = float(value), float(value).is_integer()
    elif isinstance(value, str):
        text = norm_name(value)
        if not text or text in UNKNOWN_WORDS:
            if text != UNKNOWN:
                ctx.repair(f"normalized {_short(value)} -> 'unknown' at '{path}'")
            return UNKNOWN
        numbers = [float(x) for x in _NUMBER.findall(text)[:2]]
        numbers = numbers or [float(NUMBER_WORDS.index(w)) for w in text.split()[:20]
                              if w in NUMBER_WORDS][:2]
        if numbers:
            guess = sum(numbers) / len(numbers)
            exact = _NUMBER.fullmatch(text) is not None and guess.is_integer()
    if guess is not None and math.isfinite(guess) and 0 <= guess <= MAX_REPETITIONS:
        n = int(round(guess))
        if exact:
            ctx.repair(f"converted {_short(value)} to {n} at '{path}'")
        else:
            ctx.invalid(path, f"read {_short(value)} as {n} at '{path}'")
        return n
    ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with 'unknown'")
    return UNKNOWN


def _bool(value: Any, default: bool | None, path: str, ctx: _Ctx) -> bool | None:
    if value is None:
        if default is not None:
            ctx.fill(path, default)
        return default
    if isinstance(value, bool):
        return value
    key = norm_name(str(value)) if isinstance(value, str | int) else None
    if key in BOOL_WORDS:
        ctx.repair(f"converted {_short(value)} to {BOOL_WORDS[key]} at '{path}'")
        return BOOL_WORDS[key]
    if default is not None:
        ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with {default}")
    else:
        ctx.invalid(path, f"dropped invalid {_short(value)} at '{path}'")
    return default


def _string(value: Any) -> str | None:
    """A clean one-line string from a string or a number; None otherwise."""
    if isinstance(value, str):
        text = " ".join(value.split())
        return text or None
    if _is_number(value):
        return str(value)
    if isinstance(value, dict):
        for key in ("name", "label", "value"):
            if isinstance(value.get(key), str):
                return _string(value[key])
    return None


def _str_list(value: Any, path: str, ctx: _Ctx, splitter: re.Pattern = _SPLIT_LIST) -> list[str]:
    """A list of strings from a list, a comma-separated string, or None."""
    if value is None:
        ctx.fill(path, [])
        return []
    if isinstance(value, str):
        if norm_name(value) in _EMPTY_LIST_WORDS:
            return []
        items = [s for s in splitter.split(value) if s and s.strip()]
        if len(items) > 1:
            ctx.repair(f"split the string at '{path}' into {len(items)} items")
        value = items
    if isinstance(value, dict):
        value = [value]
    if not isinstance(value, list | tuple):
        ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with []")
        return []
    out: list[str] = []
    bad = 0
    for item in value:
        if isinstance(item, list):
            item = item[0] if item else None
        text = _string(item)
        if text is None:
            bad += 1
        elif norm_name(text) not in _EMPTY_LIST_WORDS:
            out.append(text)
    if bad:
        ctx.invalid(path, f"dropped {bad} invalid item(s) at '{path}'")
    return list(dict.fromkeys(out))


def _field_list(value: Any, allowed: tuple[str, ...], synonyms: dict[str, str], path: str,
                ctx: _Ctx) -> list[str] | None:
    """constraints.invariant_fields / variant_fields; None when missing."""
    if value is None:
        return None
    out: list[str] = []
    for item in _str_list(value, path, ctx):
        key = norm_key(item)
        target = key if key in allowed else synonyms.get(key)
        if target is None:
            hit = process.extractOne(key, allowed, scorer=fuzz.ratio, score_cutoff=KEY_MATCH_MIN)
            target = hit[0] if hit else None
        if target is None:
            ctx.invalid(path, f"dropped {_short(item)} from '{path}' (not an allowed field)")
        else:
            if target != item:
                ctx.repair(f"mapped {_short(item)} -> '{target}' in '{path}'")
            if target not in out:
                out.append(target)
    return out


def _unit(value: Any, path: str, ctx: _Ctx) -> float:
    """An uncertainty in [0, 1]: above 1 is clipped to 1 (the conservative end);
    negative or not a number becomes 0.5; words and percent strings are read."""
    if value is None:
        ctx.fill(path, DEFAULT_UNCERTAINTY)
        return DEFAULT_UNCERTAINTY
    if isinstance(value, str) and norm_name(value) in UNCERTAINTY_WORDS:
        x = UNCERTAINTY_WORDS[norm_name(value)]
        ctx.invalid(path, f"mapped {_short(value)} -> {x} at '{path}'")
        return x
    x = None if isinstance(value, bool) else _to_float(value)
    if x is not None and 0.0 <= x <= 1.0:
        if not _is_number(value):
            ctx.repair(f"converted {_short(value)} to {x:g} at '{path}'")
        return x
    if x is not None and x > 1.0:
        ctx.invalid(path, f"clipped {_short(value)} at '{path}' to 1.0")
        return 1.0
    ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with {DEFAULT_UNCERTAINTY}")
    return DEFAULT_UNCERTAINTY


def _duration_value(value: Any, path: str, ctx: _Ctx) -> float | str:
    if value is None or (isinstance(value, str) and norm_name(value) in UNKNOWN_WORDS):
        return UNKNOWN
    x = None if isinstance(value, bool) else _to_float(value)
    if x is not None and 0 <= x <= MAX_PRIMITIVE_DURATION:
        if not _is_number(value):
            ctx.repair(f"converted {_short(value)} to {x:g} at '{path}'")
        return x
    ctx.invalid(path, f"replaced invalid {_short(value)} at '{path}' with 'unknown' "
                      f"(a duration is 0..{MAX_PRIMITIVE_DURATION:g})")
    return UNKNOWN


# ---------------------------------------------------------------------------
# sections
# ---------------------------------------------------------------------------
def _label(data: dict, ctx: _Ctx) -> str | None:
    value = data.get("activity_label")
    if isinstance(value, list) and value:
        ctx.invalid("activity_label", "took the first item of a list at 'activity_label'")
        value = value[0]
    text = _string(value)
    if text is None and value is not None:
        ctx.invalid("activity_label", f"rejected invalid {_short(value)} at 'activity_label'")
    if text is not None and isinstance(value, str) and text != value:
        ctx.repair("normalized whitespace in 'activity_label'")
    return text


def _primitive(item: Any, i: int, ctx: _Ctx) -> dict[str, Any] | None:
    path = f"motion_primitives[{i}]"
    if isinstance(item, str | int | float) and not isinstance(item, bool):
        name = _string(item)
        if name is None:
            return None
        ctx.repair(f"expanded the bare name at '{path}' into a primitive")
        return {"name": name, "order_index": i}
    if not isinstance(item, dict):
        ctx.invalid(path, f"dropped invalid primitive {_short(item)} at '{path}'")
        return None
    data = _map_keys(item, "motion_primitives", path, ctx)
    name = _string(data.get("name"))
    if name is None:
        ctx.invalid(f"{path}.name", f"dropped the primitive at '{path}': it has no name")
        return None
    order = data.get("order_index")
    index = _count(order, f"{path}.order_index", _Ctx(RepairReport()))
    if order is None or index == UNKNOWN:
        if order is not None:
            ctx.invalid(f"{path}.order_index", f"replaced invalid order_index at '{path}' with {i}")
        index = i
    description = data.get("description")
    desc = _string(description) if not isinstance(description, list) else " ".join(
        s for s in (_string(d) for d in description) if s)
    rel = data.get("relative_duration")
    return {
        "name": name,
        "order_index": index,
        "description": desc or "",
        "body_parts": _str_list(data.get("body_parts"), f"{path}.body_parts", _quiet(ctx)),
        "relative_duration": _duration_value(rel, f"{path}.relative_duration", ctx),
        "contact": _str_list(data.get("contact"), f"{path}.contact", _quiet(ctx)),
    }


class _Quiet(_Ctx):
    """Records invalid values but not fills (primitive sub-fields are often omitted)."""

    def fill(self, path: str, value: Any) -> None:
        return None


def _quiet(ctx: _Ctx) -> _Ctx:
    return _Quiet(ctx.report)


def _primitives(data: dict, ctx: _Ctx) -> tuple[list[dict], list[str]]:
    raw_prims = data.get("motion_primitives")
    raw_seq = data.get("primitive_sequence")
    prims: list[dict] = []
    if raw_prims is not None:
        if isinstance(raw_prims, dict):
            raw_prims = [raw_prims]
        if isinstance(raw_prims, str):
            raw_prims = [s for s in _SPLIT_SEQ.split(raw_prims) if s.strip()]
        if isinstance(raw_prims, list):
            for i, item in enumerate(raw_prims):
                p = _primitive(item, i, ctx)
                if p is not None:
                    prims.append(p)
        else:
            ctx.invalid("motion_primitives", f"ignored invalid {_short(raw_prims)} at 'motion_primitives'")
    seq: list[str] = []
    if isinstance(raw_seq, str):
        seq = [s.strip() for s in _SPLIT_SEQ.split(raw_seq) if s and s.strip()]
        if len(seq) > 1:
            ctx.repair(f"split the string at 'primitive_sequence' into {len(seq)} names")
    elif isinstance(raw_seq, list):
        seq = [s for s in (_string(x) for x in raw_seq) if s]  # repeats are kept
        if len(seq) != len(raw_seq):
            ctx.invalid("primitive_sequence", f"dropped {len(raw_seq) - len(seq)} invalid "
                                              "item(s) at 'primitive_sequence'")
    elif raw_seq is not None:
        ctx.invalid("primitive_sequence", f"ignored invalid {_short(raw_seq)} at 'primitive_sequence'")
    for name in ("motion_primitives", "primitive_sequence"):
        if data.get(name) is None:
            ctx.report.missing_mandatory.append(name)
    if not prims and seq:
        prims = [{"name": s, "order_index": i} for i, s in enumerate(seq)]
        ctx.repair("rebuilt 'motion_primitives' from 'primitive_sequence'")
    elif prims and not seq:
        ordered = sorted(range(len(prims)), key=lambda j: (prims[j]["order_index"], j))
        seq = [prims[j]["name"] for j in ordered]
        ctx.repair("rebuilt 'primitive_sequence' from 'motion_primitives'")
    _one_spelling(prims, ctx)
    _add_missing_primitives(prims, seq, ctx)
    return prims, seq


def _one_spelling(prims: list[dict], ctx: _Ctx) -> None:
    """A primitive whose name is another spelling of an earlier one's (the schema refuses two
    spellings) takes the earlier spelling: it is that primitive listed again, as an exact repeat is."""
    names = [p["name"] for p in prims]
    for p, j in zip(prims, first_spellings(names), strict=True):
        name = names[j]
        if name != p["name"]:
            ctx.repair(f"renamed the primitive '{p['name']}' to '{name}', the spelling of an earlier one")
            p["name"] = name


def _too_many(name: str, n: int, ctx: _Ctx) -> bool:
    """More than MAX_PRIMITIVES items in `name` is an invalid value that rejects the answer."""
    if n <= MAX_PRIMITIVES:
        return False
    ctx.invalid(name, f"rejected '{name}': {n} items, more than {MAX_PRIMITIVES}")
    ctx.report.rejected = True
    ctx.report.reason = f"'{name}' has {n} items; at most {MAX_PRIMITIVES} are allowed"
    return True


def _raw_count(value: Any) -> int:
    """How many items a raw primitive list or sequence holds (before any is repaired)."""
    if isinstance(value, str):
        return sum(1 for s in _SPLIT_SEQ.split(value) if s and s.strip())
    return len(value) if isinstance(value, list) else 0


def _add_missing_primitives(prims: list[dict], seq: list[str], ctx: _Ctx) -> None:
    """A sequence name that no primitive has (the schema refuses it) gets a bare primitive."""
    known = {norm_name(p["name"]) for p in prims}
    for i, name in enumerate(seq):
        if norm_name(name) not in known and norm_name(name) not in STRUCTURAL_NAMES:
            known.add(norm_name(name))
            prims.append({"name": name, "order_index": i})
            ctx.repair(f"added a primitive for '{name}' at 'primitive_sequence[{i}]': "
                       "no motion primitive had that name")


def _durations(data: dict, seq: list[str], ctx: _Ctx) -> dict[str, Any]:
    path = "primitive_durations"
    raw = data.get(path)
    if raw is None:
        ctx.fill(path, {"type": UNKNOWN, "values": []})
        return {"type": UNKNOWN, "values": []}
    if isinstance(raw, list):
        raw = {"values": raw}
        ctx.repair(f"read the list at '{path}' as its values")
    if isinstance(raw, dict):
        mapped = _map_keys(raw, "primitive_durations", path, _Ctx(RepairReport()))
        if "values" not in mapped and raw and set(map(norm_name, raw)) <= set(map(norm_name, seq)):
            by_name = {norm_name(k): v for k, v in raw.items()}
            mapped = {"values": [by_name.get(norm_name(s)) for s in seq]}
            ctx.repair(f"read '{path}' keyed by primitive names in sequence order")
        else:
            mapped = _map_keys(raw, "primitive_durations", path, ctx)
    else:
        ctx.invalid(path, f"replaced invalid {_short(raw)} at '{path}' with unknown durations")
        return {"type": UNKNOWN, "values": []}
    values_raw = mapped.get("values")
    values_raw = [values_raw] if _is_number(values_raw) else values_raw
    values = ([_duration_value(v, f"{path}.values[{i}]", ctx) for i, v in enumerate(values_raw)]
              if isinstance(values_raw, list) else [])
    if values_raw is not None and not isinstance(values_raw, list):
        ctx.invalid(f"{path}.values", f"replaced invalid {_short(values_raw)} at '{path}.values' with []")
    if values and len(values) != len(seq):
        ctx.invalid(f"{path}.values", f"dropped '{path}.values': {len(values)} values for "
                                      f"{len(seq)} primitives")
        values = []
    kind = mapped.get("type")
    if kind is None:
        known = [v for v in values if v != UNKNOWN]
        kind = "relative" if values and len(known) == len(values) and abs(sum(known) - 1) <= 0.05 \
            else UNKNOWN
        ctx.fill(f"{path}.type", kind)
    else:
        kind = _word(kind, ("absolute", "relative", UNKNOWN), DURATION_TYPE_SYNONYMS, UNKNOWN,
                     f"{path}.type", ctx)
    return {"type": kind, "values": values}


def _body_parts(data: dict, ctx: _Ctx) -> dict[str, Any]:
    raw = data.get("body_parts")
    if isinstance(raw, list | str):
        ctx.repair("read the list at 'body_parts' as 'body_parts.mandatory'")
        raw = {"mandatory": raw}
        data = {**data, "body_parts": raw}
    sec, fctx = _section(data, "body_parts", "body_parts", "body_parts", ctx)
    return {k: _str_list(sec.get(k), f"body_parts.{k}", fctx) for k in SECTION_FIELDS["body_parts"]}


def _temporal(data: dict, ctx: _Ctx) -> dict[str, Any]:
    p = "temporal_structure"
    sec, ctx = _section(data, p, p, p, ctx)
    out: dict[str, Any] = {
        "repetition_count": _count(sec.get("repetition_count"), f"{p}.repetition_count", ctx),
        "periodicity": _word(sec.get("periodicity"), ("none", "single", "cyclic", UNKNOWN),
                             PERIODICITY_SYNONYMS, UNKNOWN, f"{p}.periodicity", ctx),
        "ordering": _word(sec.get("ordering"), ("ordered", "weakly_ordered", "unordered"),
                          ORDERING_SYNONYMS, "ordered", f"{p}.ordering", ctx),
        "transition_type": _word(sec.get("transition_type"), ("discrete", "continuous", UNKNOWN),
                                 TRANSITION_SYNONYMS, UNKNOWN, f"{p}.transition_type", ctx),
    }
    flag = _bool(sec.get("is_repetitive"), None, f"{p}.is_repetitive", ctx)
    if flag is None:
        count = out["repetition_count"]
        flag = out["periodicity"] == "cyclic" or (count != UNKNOWN and count >= 2)
        ctx.repair(f"inferred '{p}.is_repetitive' = {flag} from periodicity and repetition count")
    out["is_repetitive"] = flag
    return out


def _attributes(data: dict, ctx: _Ctx) -> dict[str, Any]:
    p = "execution_attributes"
    sec, ctx = _section(data, p, p, p, ctx)
    side = sec.get("dominant_side")
    return {
        "tempo": _ordinal(sec.get("tempo"), ("slow", "medium", "fast"), TEMPO_SYNONYMS,
                          f"{p}.tempo", ctx),
        "amplitude": _ordinal(sec.get("amplitude"), ("small", "medium", "large"),
                              AMPLITUDE_SYNONYMS, f"{p}.amplitude", ctx),
        "dominant_side": _word(side, ("left", "right", "bilateral", "none", UNKNOWN),
                               SIDE_SYNONYMS, UNKNOWN, f"{p}.dominant_side", ctx),
        "symmetry": _word(sec.get("symmetry"), ("symmetric", "asymmetric", UNKNOWN),
                          SYMMETRY_SYNONYMS, UNKNOWN, f"{p}.symmetry", ctx),
        "global_displacement": _displacement(sec.get("global_displacement"),
                                             f"{p}.global_displacement", ctx),
    }


def _contacts(data: dict, ctx: _Ctx) -> dict[str, Any]:
    p = "object_contact"
    raw = data.get(p)
    if isinstance(raw, list | str):
        ctx.repair(f"read the list at '{p}' as '{p}.objects'")
        data = {**data, p: {"objects": raw}}
    sec, fctx = _section(data, p, p, p, ctx)
    return {k: _str_list(sec.get(k), f"{p}.{k}", fctx) for k in SECTION_FIELDS[p]}


def _constraints(data: dict, ctx: _Ctx) -> dict[str, Any]:
    p = "constraints"
    sec, ctx = _section(data, p, p, p, ctx)
    out: dict[str, Any] = {}
    inv = _field_list(sec.get("invariant_fields"), INVARIANT_FIELDS, INVARIANT_SYNONYMS,
                      f"{p}.invariant_fields", ctx)
    if inv is None:
        ctx.fill(f"{p}.invariant_fields", "all invariant fields")
    else:
        out["invariant_fields"] = inv
    var = _field_list(sec.get("variant_fields"), VARIANT_FIELDS, VARIANT_SYNONYMS,
                      f"{p}.variant_fields", ctx)
    if var is None:
        ctx.fill(f"{p}.variant_fields", [])
    else:
        out["variant_fields"] = var
    rules_raw = sec.get("rules")
    if rules_raw is not None:
        rules, _ = _section(sec, "rules", "rules", f"{p}.rules", ctx)
        out["rules"] = {k: _bool(v, True, f"{p}.rules.{k}", ctx) for k, v in rules.items()}
    return out


def _uncertainty(data: dict, ctx: _Ctx) -> dict[str, float]:
    p = "uncertainty"
    raw = data.get(p)
    if raw is not None and not isinstance(raw, dict):
        value = _unit(raw, p, ctx)
        ctx.repair(f"applied the single uncertainty {value:g} to every field")
        return dict.fromkeys(UNCERTAINTY_FIELDS, value)
    sec, ctx = _section(data, p, p, p, ctx)
    return {k: _unit(sec.get(k), f"{p}.{k}", ctx) for k in UNCERTAINTY_FIELDS}


# ---------------------------------------------------------------------------
# 4. assembly
# ---------------------------------------------------------------------------
def _assemble(data: dict, ctx: _Ctx) -> dict[str, Any] | None:
    top = _map_keys(data, None, "", ctx)
    label = _label(top, ctx)
    if top.get("activity_label") is None or label is None:
        ctx.report.missing_mandatory.append("activity_label")
    if any(_too_many(k, _raw_count(top.get(k)), ctx) for k in ("motion_primitives", "primitive_sequence")):
        return None
    prims, seq = _primitives(top, ctx)
    if _too_many("motion_primitives", len(prims), ctx) or _too_many("primitive_sequence", len(seq), ctx):
        return None
    missing = [m for m in ctx.report.missing_mandatory]
    problems = []
    if label is None:
        problems.append("activity_label")
    if not prims or not seq:
        problems.append("motion_primitives/primitive_sequence")
    if problems:
        ctx.report.rejected = True
        ctx.report.reason = f"missing mandatory field(s): {', '.join(problems)}"
        ctx.report.missing_mandatory = list(dict.fromkeys(missing))
        return None
    version = top.get("schema_version")
    if version is not None and version != SCHEMA_VERSION:
        ctx.repair(f"set 'schema_version' {_short(version)} -> '{SCHEMA_VERSION}'")
    return {
        "schema_version": SCHEMA_VERSION,
        "activity_label": label,
        "motion_primitives": prims,
        "primitive_sequence": seq,
        "primitive_durations": _durations(top, seq, ctx),
        "body_parts": _body_parts(top, ctx),
        "temporal_structure": _temporal(top, ctx),
        "execution_attributes": _attributes(top, ctx),
        "object_contact": _contacts(top, ctx),
        "constraints": _constraints(top, ctx),
        "uncertainty": _uncertainty(top, ctx),
    }


def _validate(smp_dict: dict[str, Any], ctx: _Ctx) -> SMP | None:
    """Validate; a section that still fails is reset to its defaults (at most a few times)."""
    for _ in range(len(TOP_FIELDS)):
        try:
            return SMP.model_validate(smp_dict)
        except pydantic.ValidationError as exc:
            loc = exc.errors()[0]["loc"]
            key = str(loc[0]) if loc else ""
            if key in MANDATORY or key not in smp_dict:
                ctx.report.rejected = True
                ctx.report.reason = f"could not build a valid SMP: {exc.errors()[0]['msg']} at '{key}'"
                return None
            ctx.invalid(key, f"reset '{key}' to defaults: {exc.errors()[0]['msg']}")
            smp_dict.pop(key)
    ctx.report.rejected = True
    ctx.report.reason = "could not build a valid SMP"
    return None


def parse_response(text: str | bytes) -> RepairResult:
    """Parse and repair one raw model response; never raises."""
    report = RepairReport()
    ctx = _Ctx(report)
    try:
        return _parse(text, ctx)
    except Exception as exc:  # noqa: BLE001 - the contract is "never raises"
        report.rejected = True
        report.reason = f"internal error while repairing: {type(exc).__name__}: {exc}"[:300]
        return RepairResult(None, report)


def _parse(text: str | bytes, ctx: _Ctx) -> RepairResult:
    report = ctx.report
    if isinstance(text, bytes | bytearray):
        raw = bytes(text)
        text = raw.decode("utf-8", errors="replace")
        if "\ufffd" in text and b"\xef\xbf\xbd" not in raw:
            ctx.repair("replaced bytes that are not UTF-8")
    elif not isinstance(text, str):
        report.rejected = True
        report.reason = f"expected text, got {type(text).__name__}"
        return RepairResult(None, report)
    if not text.strip():
        report.malformed_json = True
        report.rejected = True
        report.reason = "empty response"
        return RepairResult(None, report)
    obj = _find_object(text, ctx)
    if not obj:
        report.rejected = True
        report.reason = "no JSON object found in the response"
        return RepairResult(None, report)
    report.json_found = True
    smp_dict = _assemble(obj, ctx)
    if smp_dict is None:
        return RepairResult(None, report)
    smp = _validate(smp_dict, ctx)
    return RepairResult(smp, report)

