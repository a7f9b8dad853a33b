"""Deterministic aggregation of several parsed responses for one clip (paper appendix
"VLM-Based SMP Extraction": five queries, majority vote, medians, maximum pairwise
agreement for the primitive sequence, fewer than three valid -> discard).

Rules:
- Activity: the responses must name one activity by a strict majority of the
  valid ones (labels compared by `activity_of`, default case/space/underscore-
  insensitive; `library_activity(lib)` also counts a name and its alias, or a
  typo, as one activity); else the clip is discarded. Every other field is
  aggregated over the responses that name the majority's activity only, so
  fields of different activities are never mixed.
- Primitive sequence: the response whose primitive-name sequence has the highest
  mean normalized edit similarity to the others (`edit_similarity`); ties go to
  the earliest response. Its `motion_primitives` come with it (the "anchor").
- Categorical fields (label, dominant side, symmetry, periodicity, ordering,
  transition type, is_repetitive, duration type, constraint rules): majority
  vote among the responses that give a value other than `unknown`; a tie goes
  to the anchor's value when it is among the tied ones, else to the value seen
  first. The label is the majority's spelling (ties to the anchor's).
- Ordinal and numeric fields: the median of the known values. When every value
  is a category word (tempo, amplitude, displacement) or an integer (repetition
  count), the lower median keeps the result on the scale; otherwise the plain
  median of the numbers. Primitive durations: element-wise median over the
  responses whose sequence has the anchor's length.
- Sets (body parts, contacts, invariant and variant fields): an item is kept
  when strictly more than half of the valid responses list it. Body parts are
  first normalized to the 17-part vocabulary ("arms" and "both arms" are the
  same claim), and a response with an empty body-part list abstains (every
  activity moves some body part; an empty list means "not given").
- Uncertainty: u_f = min(1, mean reported u_f + KAPPA * d_f), where d_f is the
  fraction of the agreeing responses that differ from the aggregate in field f
  (for the label: the fraction of all valid responses that name another activity).
"""

from __future__ import annotations

import statistics
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

from rapidfuzz.distance import Levenshtein

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.bodyparts import normalize_body_parts
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.schema import (
    AMPLITUDE_LEVELS,
    DISPLACEMENTS,
    SMP,
    TEMPO_LEVELS,
    UNCERTAINTY_FIELDS,
    UNKNOWN,
    displacement_word,
    ordinal_word,
)

KAPPA = 0.5  # uncertainty added per unit of disagreement
DURATION_TOLERANCE = 0.10  # relative difference under which two durations agree

# uncertainty field -> the aggregate fields whose disagreement raises it (max is used)
UNCERTAINTY_SOURCES: dict[str, tuple[str, ...]] = {
    "activity_label": ("activity_label",),
    "motion_primitives": ("primitive_sequence",),
    "primitive_duration": ("primitive_durations",),
    "body_parts": ("body_parts.mandatory", "body_parts.optional",
                   "body_parts.dominant_moving_segments"),
    "temporal_structure": ("temporal_structure.is_repetitive", "temporal_structure.periodicity",
                           "temporal_structure.ordering", "temporal_structure.transition_type"),
    "repetition_count": ("temporal_structure.repetition_count",),
    "tempo": ("execution_attributes.tempo",),
    "amplitude": ("execution_attributes.amplitude",),
    "dominant_side": ("execution_attributes.dominant_side",),
    "symmetry": ("execution_attributes.symmetry",),
    "global_displacement": ("execution_attributes.global_displacement",),
    "object_contact": ("object_contact.objects", "object_contact.body_contact",
                       "object_contact.environment_contact", "object_contact.required_contact"),
}


@dataclass
class AggregationResult:
    """The aggregated SMP (None when discarded) and how the responses agreed."""

    smp: SMP | None
    n_total: int
    n_valid: int
    discarded: bool = False
    reason: str | None = None
    disagreement: dict[str, float] = field(default_factory=dict)
    anchor_index: int | None = None  # input index of the response giving the sequence
    n_agreeing: int | None = None  # valid responses naming the majority's activity

    @property
    def any_disagreement(self) -> bool:
        return any(v > 0 for v in self.disagreement.values())

    def to_dict(self) -> dict[str, Any]:
        return {
            "smp": None if self.smp is None else self.smp.model_dump(mode="json"),
            "n_total": self.n_total, "n_valid": self.n_valid, "discarded": self.discarded,
            "reason": self.reason, "disagreement": dict(self.disagreement),
            "any_disagreement": self.any_disagreement, "anchor_index": self.anchor_index,
            "n_agreeing": self.n_agreeing,
        }


def edit_similarity(a: Sequence[Hashable], b: Sequence[Hashable]) -> float:
    """Sim = 1 - d_edit(a, b) / max(|a|, |b|) over whole items (appendix "SMP audit metrics")."""
    longest = max(len(a), len(b))
    if longest == 0:
        return 1.0
    return 1.0 - Levenshtein.distance(list(a), list(b)) / longest


def _names(smp: SMP) -> list[str]:
    return [norm_name(n) for n in smp.primitive_sequence]


def _anchor(smps: list[SMP]) -> int:
    seqs = [_names(s) for s in smps]
    n = len(seqs)
    if n == 1:
        return 0
    scores = [sum(edit_similarity(seqs[i], seqs[j]) for j in range(n) if j != i) / (n - 1)
              for i in range(n)]
    best = max(scores)
    return next(i for i, s in enumerate(scores) if s == best)


def _vote(values: list[Any], anchor: int, key: Callable[[Any], Any] = lambda v: v,
          skip_unknown: bool = True) -> Any:
    """Majority value (see the module rules); UNKNOWN when nothing is known."""
    keyed = [(key(v), v) for v in values]
    if skip_unknown:
        known = [(k, v) for k, v in keyed if v != UNKNOWN]
        if not known:
            return values[0] if values else UNKNOWN
    else:
        known = keyed
    counts: dict[Any, int] = {}
    first: dict[Any, Any] = {}
    for k, v in known:
        counts[k] = counts.get(k, 0) + 1
        first.setdefault(k, v)
    top = max(counts.values())
    tied = [k for k in counts if counts[k] == top]
    anchor_key = keyed[anchor][0]
    winner = anchor_key if anchor_key in tied else tied[0]
    return first[winner]


def _ordinal(values: list[str | float], levels: tuple[str, ...]) -> str | float:
    known = [v for v in values if v != UNKNOWN]
    if not known:
        return UNKNOWN
    if all(isinstance(v, str) for v in known):
        return levels[statistics.median_low(levels.index(v) for v in known)]
    numbers = [float(levels.index(v)) if isinstance(v, str) else float(v) for v in known]
    return round(float(statistics.median(numbers)), 6)


def _displacement(values: list[str | float]) -> str | float:
    known = [v for v in values if v != UNKNOWN]
    if not known:
        return UNKNOWN
    if all(not isinstance(v, str) for v in known):
        return round(float(statistics.median(float(v) for v in known)), 6)
    words = [displacement_word(v) for v in known]
    return DISPLACEMENTS[statistics.median_low(DISPLACEMENTS.index(w) for w in words)]


def _count(values: list[int | str]) -> int | str:
    known = [int(v) for v in values if v != UNKNOWN]
    return statistics.median_low(known) if known else UNKNOWN


def _parts(items: list[str]) -> list[str]:
    """Body parts in the vocabulary; words that name no part are kept as given."""
    parts, unknown = normalize_body_parts(items)
    return parts + unknown


def _set(lists: list[list[str]]) -> list[str]:
    """Items listed by strictly more than half of the responses, in first-seen order."""
    n = len(lists)
    counts: dict[str, int] = {}
    first: dict[str, str] = {}
    for items in lists:
        for key in dict.fromkeys(norm_name(i) for i in items):
            counts[key] = counts.get(key, 0) + 1
        for item in items:
            first.setdefault(norm_name(item), item)
    return [first[k] for k in first if counts[k] * 2 > n]


def _durations(smps: list[SMP], anchor: int) -> dict[str, Any]:
    length = len(smps[anchor].primitive_sequence)
    pool = [s.primitive_durations for s in smps
            if len(s.primitive_sequence) == length and s.primitive_durations.values]
    if not pool:
        return smps[anchor].primitive_durations.model_dump(mode="json")
    anchor_type = smps[anchor].primitive_durations.type
    types = [d.type for d in pool]
    anchor_pos = types.index(anchor_type) if anchor_type in types else 0
    kind = _vote(types, anchor_pos)
    chosen = [d for d in pool if d.type == kind]
    values: list[float | str] = []
    for j in range(length):
        known = [float(d.values[j]) for d in chosen if d.values[j] != UNKNOWN]
        values.append(round(float(statistics.median(known)), 6) if known else UNKNOWN)
    return {"type": kind, "values": values}


def _durations_differ(a: dict[str, Any], b: SMP) -> bool:
    d = b.primitive_durations
    if d.type != a["type"] or len(d.values) != len(a["values"]):
        return True
    for x, y in zip(d.values, a["values"], strict=True):
        if (x == UNKNOWN) != (y == UNKNOWN):
            return True
        if x != UNKNOWN and abs(float(x) - float(y)) > DURATION_TOLERANCE * abs(float(y)) + 1e-9:
            return True
    return False


def _fraction(flags: list[bool]) -> float:
    return round(sum(flags) / len(flags), 6) if flags else 0.0


def library_activity(library: ActivityLibrary) -> Callable[[str], str]:
    """`activity_of` for `aggregate`: the library activity a label names as a whole
    (`ActivityLibrary.identify`), else the normalized label."""
    def activity_of(label: str) -> str:
        entry = library.identify(label)
        return f"library:{entry.name}" if entry is not None else norm_name(label)
    return activity_of


def _majority(labels: list[str], activity_of: Callable[[str], str]) -> tuple[list[int], str | None]:
    """Indexes of the labels naming the majority's activity, or ([], why) without a strict majority."""
    keys = [activity_of(label) for label in labels]
    counts: dict[str, int] = {}
    shown: dict[str, str] = {}
    for key, label in zip(keys, labels, strict=True):
        counts[key] = counts.get(key, 0) + 1
        shown.setdefault(key, label)
    top = max(counts, key=counts.__getitem__)
    if counts[top] * 2 > len(labels):
        return [i for i, key in enumerate(keys) if key == top], None
    split = ", ".join(f"'{shown[k]}' {n}" for k, n in sorted(counts.items(), key=lambda kv: -kv[1]))
    return [], f"no activity is named by a majority of the {len(labels)} valid responses ({split})"


def aggregate(smps: Sequence[SMP | None], min_valid: int = 3,
              activity_of: Callable[[str], str] = norm_name) -> AggregationResult:
    """Aggregate parsed responses (None = rejected) into one SMP, or discard the clip.

    `activity_of(label)`: the key by which labels name the same activity (`library_activity`).
    """
    if min_valid < 1:
        raise ValidationError(f"min_valid must be at least 1, got {min_valid}", field="min_valid")
    index = [i for i, s in enumerate(smps) if s is not None]
    every: list[SMP] = [smps[i] for i in index]  # type: ignore[misc]
    n_total, n_valid = len(smps), len(every)
    if n_valid < min_valid:
        return AggregationResult(
            None, n_total, n_valid, discarded=True,
            reason=f"only {n_valid} of {n_total} responses are valid; at least {min_valid} needed")
    agreeing, why = _majority([s.activity_label for s in every], activity_of)
    if why is not None:
        return AggregationResult(None, n_total, n_valid, discarded=True, reason=why)
    valid = [every[i] for i in agreeing]
    a = _anchor(valid)
    anc = valid[a]
    ts = [s.temporal_structure for s in valid]
    ea = [s.execution_attributes for s in valid]
    oc = [s.object_contact for s in valid]
    bp = [s.body_parts for s in valid]

    temporal = {
        "is_repetitive": _vote([t.is_repetitive for t in ts], a),
        "repetition_count": _count([t.repetition_count for t in ts]),
        "periodicity": _vote([t.periodicity for t in ts], a),
        "ordering": _vote([t.ordering for t in ts], a),
        "transition_type": _vote([t.transition_type for t in ts], a),
    }
    attributes = {
        "tempo": _ordinal([e.tempo for e in ea], TEMPO_LEVELS),
        "amplitude": _ordinal([e.amplitude for e in ea], AMPLITUDE_LEVELS),
        "dominant_side": _vote([e.dominant_side for e in ea], a),
        "symmetry": _vote([e.symmetry for e in ea], a),
        "global_displacement": _displacement([e.global_displacement for e in ea]),
    }
    body_lists = {k: [_parts(getattr(b, k)) for b in bp]
                  for k in ("mandatory", "optional", "dominant_moving_segments")}
    body = {k: _set([x for x in lists if x]) for k, lists in body_lists.items()}
    contact = {k: _set([getattr(o, k) for o in oc])
               for k in ("objects", "body_contact", "environment_contact", "required_contact")}
    constraints = {
        "invariant_fields": _set([s.constraints.invariant_fields for s in valid]),
        "variant_fields": _set([s.constraints.variant_fields for s in valid]),
        "rules": {rule: _majority_bool([getattr(s.constraints.rules, rule) for s in valid])
                  for rule in type(anc.constraints.rules).model_fields},
    }
    durations = _durations(valid, a)
    label = _vote([s.activity_label for s in valid], a, key=norm_name, skip_unknown=False)

    seq = _names(anc)
    disagreement: dict[str, float] = {
        "activity_label": _fraction([i not in agreeing for i in range(n_valid)]),
        "primitive_sequence": _fraction([_names(s) != seq for s in valid]),
        "primitive_durations": _fraction([_durations_differ(durations, s) for s in valid]),
    }
    for k, agg in body.items():
        disagreement[f"body_parts.{k}"] = _set_disagreement(body_lists[k], agg)
    for k in ("is_repetitive", "periodicity", "ordering", "transition_type", "repetition_count"):
        disagreement[f"temporal_structure.{k}"] = _fraction(
            [getattr(t, k) != temporal[k] for t in ts])
    disagreement["execution_attributes.tempo"] = _fraction(
        [_word(e.tempo, TEMPO_LEVELS) != _word(attributes["tempo"], TEMPO_LEVELS) for e in ea])
    disagreement["execution_attributes.amplitude"] = _fraction(
        [_word(e.amplitude, AMPLITUDE_LEVELS) != _word(attributes["amplitude"], AMPLITUDE_LEVELS)
         for e in ea])
    for k in ("dominant_side", "symmetry"):
        disagreement[f"execution_attributes.{k}"] = _fraction(
            [getattr(e, k) != attributes[k] for e in ea])
    disagreement["execution_attributes.global_displacement"] = _fraction(
        [_disp(e.global_displacement) != _disp(attributes["global_displacement"]) for e in ea])
    for k, agg in contact.items():
        disagreement[f"object_contact.{k}"] = _set_disagreement([getattr(o, k) for o in oc], agg)
    for k in ("invariant_fields", "variant_fields"):
        disagreement[f"constraints.{k}"] = _set_disagreement(
            [getattr(s.constraints, k) for s in valid], constraints[k])

    uncertainty = {}
    for f in UNCERTAINTY_FIELDS:
        mean_u = statistics.fmean(getattr(s.uncertainty, f) for s in valid)
        d = max(disagreement[src] for src in UNCERTAINTY_SOURCES[f])
        uncertainty[f] = round(min(1.0, mean_u + KAPPA * d), 6)

    smp = SMP.model_validate({
        "activity_label": label,
        "motion_primitives": [p.model_dump(mode="json") for p in anc.motion_primitives],
        "primitive_sequence": list(anc.primitive_sequence),
        "primitive_durations": durations,
        "body_parts": body,
        "temporal_structure": temporal,
        "execution_attributes": attributes,
        "object_contact": contact,
        "constraints": constraints,
        "uncertainty": uncertainty,
    })
    return AggregationResult(smp, n_total, n_valid, disagreement=disagreement,
                             anchor_index=index[agreeing[a]], n_agreeing=len(valid))


def _majority_bool(values: list[bool]) -> bool:
    """Strict majority; a tie keeps the rule on (True is the conservative default)."""
    return sum(values) * 2 >= len(values)


def _word(value: str | float, levels: tuple[str, ...]) -> str:
    return UNKNOWN if value == UNKNOWN else ordinal_word(value, levels)  # type: ignore[arg-type]


def _disp(value: str | float) -> str:
    return UNKNOWN if value == UNKNOWN else displacement_word(value)


def _set_disagreement(lists: list[list[str]], agg: list[str]) -> float:
    target = {norm_name(i) for i in agg}
    return _fraction([{norm_name(i) for i in items} != target for items in lists])
