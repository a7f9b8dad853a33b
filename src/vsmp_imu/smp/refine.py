"""Semantic refinement: the paper's four consistency checks (appendix "SMP Constraint
Rules"). A field that fails a hard check is corrected when a correction is
possible, otherwise its uncertainty is raised to at least `MARK_UNCERTAIN`.
Every change is recorded as a `Correction`.

Checks run in this order (the primitive list must be coherent before it is
compared with the library):

3. temporal coherence - `motion_primitives` follow `primitive_sequence`
   (order_index renumbered 0..n-1; a sequence that skips primitives is
   completed from them, otherwise the primitive list is rebuilt along the
   sequence); is_repetitive / periodicity / repetition_count agree by majority
   (the minority is corrected, a 1-1 tie is marked uncertain); a cyclic
   activity cannot be `unordered` (marked uncertain).
1. label-primitive compatibility - when the label names a library entry as a
   whole (`ActivityLibrary.identify`: exact, or a close match of the whole label;
   never a name inside a sentence, nor a label with a negation or instruction word),
   its primitives are matched one-to-one to the SMP's by rapidfuzz
   token_sort_ratio >= `PRIMITIVE_MATCH_MIN`. All matched: in library order
   (a rotation counts for cyclic activities) or marked uncertain. At least
   `COMPATIBLE_MIN` matched: the missing ones are inserted in library order (a name
   the SMP has in another spelling takes the SMP's).
   Fewer: the primitives, sequence and durations are replaced by the library's.
   A label that resolves to no entry cannot be checked.
2. body-part consistency - every body-part list is normalized to the paper's
   17-part vocabulary ("arms" -> upper arms, forearms, hands); names that
   match no part are dropped. Parts named by primitives (their `body_parts`,
   names and descriptions, plus the segments distal to them) support the
   claims: unsupported dominant segments are removed, unsupported mandatory
   parts mark `body_parts` uncertain, an empty mandatory set is filled with the
   parts most primitives name. A left/right dominant side contradicted by one-sided
   dominant segments is set to that side; `bilateral` with one-sided segments
   is marked uncertain.
4. object/contact consistency - every required contact appears among objects,
   body or environment contacts (added to the fitting list if not). With a
   library entry: its required contacts are added, required contacts the
   activity never involves are dropped, and objects foreign to the activity
   mark `object_contact` uncertain.
"""

from __future__ import annotations

import copy
from dataclasses import asdict, dataclass, field
from typing import Any

from rapidfuzz import fuzz

from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.bodyparts import (
    BODY_PARTS,
    normalize_body_part,
    normalize_body_parts,
    parts_mentioned,
    side_of,
)
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry
from vsmp_imu.smp.schema import MAX_PRIMITIVES, SMP, UNKNOWN

MARK_UNCERTAIN = 0.8  # uncertainty of a field that failed a check and could not be corrected
PRIMITIVE_MATCH_MIN = 75.0  # rapidfuzz token_sort_ratio for "same primitive"
COMPATIBLE_MIN = 0.5  # share of library primitives matched to repair rather than replace
CONTACT_MATCH_MIN = 80.0  # rapidfuzz token_set_ratio for "same contact"

CHECKS = ("label_primitive", "body_part", "temporal", "object_contact")
ENVIRONMENT_WORDS = {"floor", "ground", "chair", "seat", "bed", "wall", "stairs", "stair", "step",
                     "steps", "bench", "mat", "table", "sofa", "couch", "desk", "grass", "field",
                     "road", "track", "treadmill", "pool", "water"}
# distal limb segments that move with a segment (the limb chains of the vocabulary)
_CHILDREN = {
    "left_shoulder": ("left_upper_arm",), "right_shoulder": ("right_upper_arm",),
    "left_upper_arm": ("left_forearm",), "right_upper_arm": ("right_forearm",),
    "left_forearm": ("left_hand",), "right_forearm": ("right_hand",),
    "left_thigh": ("left_lower_leg",), "right_thigh": ("right_lower_leg",),
    "left_lower_leg": ("left_foot",), "right_lower_leg": ("right_foot",),
}


@dataclass(frozen=True)
class Correction:
    """One change made by a check."""

    check: str
    field: str
    before: Any
    after: Any
    action: str  # "corrected" or "marked_uncertain"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class RefineResult:
    smp: SMP
    corrections: list[Correction] = field(default_factory=list)
    entry: str | None = None  # name of the library entry the label resolved to

    @property
    def corrected(self) -> bool:
        return bool(self.corrections)

    def to_dict(self) -> dict[str, Any]:
        return {"smp": self.smp.model_dump(mode="json"), "entry": self.entry,
                "corrections": [c.to_dict() for c in self.corrections]}


class _Work:
    """The SMP as a mutable dict plus the corrections log."""

    def __init__(self, smp: SMP) -> None:
        self.d: dict[str, Any] = smp.model_dump(mode="json")
        self.log: list[Correction] = []

    def correct(self, check: str, path: str, before: Any, after: Any) -> None:
        self.log.append(Correction(check, path, copy.deepcopy(before), copy.deepcopy(after),
                                   "corrected"))

    def mark(self, check: str, ufield: str) -> None:
        before = self.d["uncertainty"][ufield]
        if before < MARK_UNCERTAIN:
            self.d["uncertainty"][ufield] = MARK_UNCERTAIN
            self.log.append(Correction(check, f"uncertainty.{ufield}", before, MARK_UNCERTAIN,
                                       "marked_uncertain"))


class Refiner:
    """Run the four consistency checks on an SMP.

    `library`: the activity library used by checks 1 and 4; None means the
    built-in library.
    """

    def __init__(self, library: ActivityLibrary | None = None) -> None:
        self.library = library

    def refine(self, smp: SMP) -> RefineResult:
        library = self.library if self.library is not None else ActivityLibrary.load()
        entry = _resolve(library, smp.activity_label)
        w = _Work(smp)
        _check_temporal(w)
        if entry is not None:
            _check_label_primitives(w, entry)
        _check_body_parts(w)
        _check_contacts(w, entry)
        result = SMP.model_validate(w.d)
        return RefineResult(result, w.log, entry.name if entry is not None else None)


def refine(smp: SMP, library: ActivityLibrary | None = None) -> RefineResult:
    """`Refiner(library).refine(smp)`."""
    return Refiner(library).refine(smp)


def _resolve(library: ActivityLibrary, label: str) -> LibraryEntry | None:
    """The entry the label names as a whole (`identify`): a negated label, an instruction or a
    name inside a sentence picks none, so no activity is forced onto the SMP."""
    return library.identify(label)


def _bare(name: str, index: int) -> dict[str, Any]:
    return {"name": name, "order_index": index, "description": "", "body_parts": [],
            "relative_duration": UNKNOWN, "contact": []}


def _is_subsequence(short: list[str], long: list[str]) -> bool:
    it = iter(long)
    return all(any(x == y for y in it) for x in short)


# ---------------------------------------------------------------------------
# 3. temporal coherence
# ---------------------------------------------------------------------------
def _check_temporal(w: _Work) -> None:
    _reconcile_primitives(w)
    _check_repetition(w)
    ts = w.d["temporal_structure"]
    if ts["periodicity"] == "cyclic" and ts["ordering"] == "unordered":
        w.mark("temporal", "temporal_structure")


def _reconcile_primitives(w: _Work) -> None:
    d = w.d
    prims, seq = d["motion_primitives"], d["primitive_sequence"]
    order = sorted(range(len(prims)), key=lambda j: (prims[j]["order_index"], j))
    ordered = [prims[j] for j in order]
    names_p = [norm_name(p["name"]) for p in ordered]
    names_s = [norm_name(s) for s in seq]
    if names_p == names_s:
        if [p["order_index"] for p in prims] != list(range(len(prims))):
            before = [p["order_index"] for p in prims]
            d["motion_primitives"] = [{**p, "order_index": i} for i, p in enumerate(ordered)]
            w.correct("temporal", "motion_primitives.order_index", before, list(range(len(prims))))
        return
    if _is_subsequence(names_s, names_p):
        # the sequence skipped primitives: complete it from the primitives
        new_seq = [p["name"] for p in ordered]
        _align_durations(w, names_s, [norm_name(n) for n in new_seq], ordered)
        d["primitive_sequence"] = new_seq
        d["motion_primitives"] = [{**p, "order_index": i} for i, p in enumerate(ordered)]
        w.correct("temporal", "primitive_sequence", seq, new_seq)
        return
    # rebuild the primitive list along the sequence (the sequence is the declared order)
    pool = list(ordered)
    new: list[dict[str, Any]] = []
    for i, name in enumerate(seq):
        k = next((j for j, p in enumerate(pool) if norm_name(p["name"]) == norm_name(name)), None)
        if k is not None:
            p = pool.pop(k)
        else:
            prev = next((q for q in new if norm_name(q["name"]) == norm_name(name)), None)
            p = copy.deepcopy(prev) if prev is not None else _bare(name, i)
        new.append({**p, "order_index": i})
    d["motion_primitives"] = new
    w.correct("temporal", "motion_primitives", [p["name"] for p in ordered], [p["name"] for p in new])


def _align_durations(w: _Work, old: list[str], new: list[str], prims: list[dict]) -> None:
    """Re-index primitive_durations.values from the old to the new (longer) sequence."""
    dur = w.d["primitive_durations"]
    if not dur["values"]:
        return
    values: list[Any] = []
    k = 0
    for name, p in zip(new, prims, strict=True):
        if k < len(old) and old[k] == name:
            values.append(dur["values"][k])
            k += 1
        else:
            rel = p.get("relative_duration", UNKNOWN)
            values.append(rel if dur["type"] == "relative" else UNKNOWN)
    w.correct("temporal", "primitive_durations.values", dur["values"], values)
    dur["values"] = values


def _check_repetition(w: _Work) -> None:
    ts = w.d["temporal_structure"]
    count = ts["repetition_count"]
    signals: dict[str, bool] = {"is_repetitive": bool(ts["is_repetitive"])}
    if ts["periodicity"] != UNKNOWN:
        signals["periodicity"] = ts["periodicity"] == "cyclic"
    if count != UNKNOWN:
        signals["repetition_count"] = int(count) >= 2
    votes = list(signals.values())
    if all(votes) or not any(votes):
        return
    yes = sum(votes)
    if len(votes) == 2:  # a 1-1 tie: cannot tell which one is wrong
        w.mark("temporal", "temporal_structure")
        return
    repetitive = yes * 2 > len(votes)
    for name, says in signals.items():
        if says == repetitive:
            continue
        path = f"temporal_structure.{name}"
        if name == "is_repetitive":
            w.correct("temporal", path, ts[name], repetitive)
            ts[name] = repetitive
        elif name == "periodicity":
            after = "cyclic" if repetitive else "single"
            w.correct("temporal", path, ts[name], after)
            ts[name] = after
        else:
            after = UNKNOWN if repetitive else 1
            w.correct("temporal", path, ts[name], after)
            ts[name] = after


# ---------------------------------------------------------------------------
# 1. label - primitive compatibility
# ---------------------------------------------------------------------------
def _match_primitives(lib: list[str], got: list[str]) -> dict[int, int]:
    """One-to-one greedy matching library index -> SMP index by name similarity."""
    pairs = []
    for i, a in enumerate(lib):
        for j, b in enumerate(got):
            score = fuzz.token_sort_ratio(norm_name(a), norm_name(b))
            if score >= PRIMITIVE_MATCH_MIN:
                pairs.append((-score, i, j))
    pairs.sort()
    out: dict[int, int] = {}
    used: set[int] = set()
    for _, i, j in pairs:
        if i not in out and j not in used:
            out[i] = j
            used.add(j)
    return out


def _in_order(positions: list[int], cyclic: bool) -> bool:
    if all(a < b for a, b in zip(positions, positions[1:], strict=False)):
        return True
    if not cyclic:
        return False
    k = positions.index(min(positions))
    rotated = positions[k:] + positions[:k]
    return all(a < b for a, b in zip(rotated, rotated[1:], strict=False))


def _check_label_primitives(w: _Work, entry: LibraryEntry) -> None:
    d = w.d
    lib = entry.smp
    lib_prims = sorted(lib.motion_primitives, key=lambda p: p.order_index)
    lib_names = list(lib.primitive_sequence)
    matched = _match_primitives(lib_names, d["primitive_sequence"])
    coverage = len(matched) / len(lib_names)
    if coverage == 1.0:
        positions = [matched[i] for i in range(len(lib_names))]
        if not _in_order(positions, d["temporal_structure"]["periodicity"] == "cyclic"):
            w.mark("label_primitive", "motion_primitives")
        return
    if coverage < COMPATIBLE_MIN:
        before = list(d["primitive_sequence"])
        d["motion_primitives"] = [p.model_dump(mode="json") for p in lib_prims]
        d["primitive_sequence"] = list(lib_names)
        d["primitive_durations"] = lib.primitive_durations.model_dump(mode="json")
        w.correct("label_primitive", "primitive_sequence", before, list(lib_names))
        return
    by_name = {norm_name(p.name): p for p in lib_prims}
    items = [("smp", i) for i in range(len(d["primitive_sequence"]))]
    seq_before = list(d["primitive_sequence"])
    cursor = 0
    for li in range(len(lib_names)):
        if li in matched:
            cursor = max(cursor, items.index(("smp", matched[li])) + 1)
        else:
            items.insert(cursor, ("lib", li))
            cursor += 1
    if len(items) > MAX_PRIMITIVES:  # no room to insert the missing ones
        w.mark("label_primitive", "motion_primitives")
        return
    prims = d["motion_primitives"]
    values = d["primitive_durations"]["values"]
    new_prims, new_seq, new_values = [], [], []
    for kind, k in items:
        if kind == "smp":
            new_prims.append(prims[k])
            new_seq.append(d["primitive_sequence"][k])
            if values:
                new_values.append(values[k])
        else:
            name = lib_names[k]
            src = by_name.get(norm_name(name))
            p = src.model_dump(mode="json") if src is not None else _bare(name, 0)
            p["name"] = _spelled(p["name"], [*prims, *new_prims])
            new_prims.append(p)
            new_seq.append(name)
            if values:
                rel = p["relative_duration"]
                new_values.append(rel if d["primitive_durations"]["type"] == "relative" else UNKNOWN)
    d["motion_primitives"] = [{**p, "order_index": i} for i, p in enumerate(new_prims)]
    d["primitive_sequence"] = new_seq
    if values:
        d["primitive_durations"]["values"] = new_values
    w.correct("label_primitive", "primitive_sequence", seq_before, new_seq)


def _spelled(name: str, prims: list[dict[str, Any]]) -> str:
    """The name of an inserted library primitive, spelled as the primitives already there spell
    it (a library sequence may repeat a name the SMP has): the schema refuses two spellings."""
    return next((p["name"] for p in prims if norm_name(p["name"]) == norm_name(name)), name)


# ---------------------------------------------------------------------------
# 2. body-part consistency
# ---------------------------------------------------------------------------
def _normalized(w: _Work, path: str, items: list[str]) -> list[str]:
    parts, unknown = normalize_body_parts(items)
    if parts != items:
        w.correct("body_part", path, items, parts)
    return parts


def _with_distal(parts: set[str]) -> set[str]:
    out = set(parts)
    stack = list(parts)
    while stack:
        for child in _CHILDREN.get(stack.pop(), ()):
            if child not in out:
                out.add(child)
                stack.append(child)
    return out


def _check_body_parts(w: _Work) -> None:
    d = w.d
    bp = d["body_parts"]
    for key in ("mandatory", "optional", "dominant_moving_segments"):
        bp[key] = _normalized(w, f"body_parts.{key}", bp[key])
    named: list[str] = []
    per_primitive: list[list[str]] = []
    for i, p in enumerate(d["motion_primitives"]):
        p["body_parts"] = _normalized(w, f"motion_primitives[{i}].body_parts", p["body_parts"])
        mentioned = parts_mentioned(f"{p['name'].replace('_', ' ')} {p['description']}")
        own = list(dict.fromkeys(p["body_parts"] + mentioned))
        per_primitive.append(own)
        named.extend(x for x in own if x not in named)
    supported = _with_distal(set(named))
    if not supported:
        if not bp["mandatory"] and not bp["dominant_moving_segments"]:
            w.mark("body_part", "body_parts")
        return
    unsupported_dom = [x for x in bp["dominant_moving_segments"] if x not in supported]
    if unsupported_dom:
        after = [x for x in bp["dominant_moving_segments"] if x in supported]
        w.correct("body_part", "body_parts.dominant_moving_segments",
                  bp["dominant_moving_segments"], after)
        bp["dominant_moving_segments"] = after
    if any(x not in supported for x in bp["mandatory"]):
        w.mark("body_part", "body_parts")
    if not bp["mandatory"]:
        n = len(per_primitive)
        common = [x for x in BODY_PARTS if sum(x in own for own in per_primitive) * 2 >= n]
        if common:
            w.correct("body_part", "body_parts.mandatory", [], common)
            bp["mandatory"] = common
    _check_side(w)


def _check_side(w: _Work) -> None:
    attrs = w.d["execution_attributes"]
    segs = w.d["body_parts"]["dominant_moving_segments"]
    sides = {side_of(x) for x in segs} - {None}
    if len(sides) != 1:
        return
    (side,) = sides
    current = attrs["dominant_side"]
    if current in ("left", "right") and current != side:
        w.correct("body_part", "execution_attributes.dominant_side", current, side)
        attrs["dominant_side"] = side
    elif current == "bilateral":
        w.mark("body_part", "dominant_side")


# ---------------------------------------------------------------------------
# 4. object / contact consistency
# ---------------------------------------------------------------------------
def _same(a: str, b: str) -> bool:
    return fuzz.token_set_ratio(norm_name(a), norm_name(b)) >= CONTACT_MATCH_MIN


def _contains(items: list[str], item: str) -> bool:
    return any(_same(x, item) for x in items)


def _kind(item: str) -> str:
    words = set(norm_name(item).split())
    if words & ENVIRONMENT_WORDS:
        return "environment_contact"
    if normalize_body_part(item):
        return "body_contact"
    return "objects"


def _check_contacts(w: _Work, entry: LibraryEntry | None) -> None:
    oc = w.d["object_contact"]
    if entry is not None:
        lib = entry.smp.object_contact
        lib_all = lib.objects + lib.body_contact + lib.environment_contact + lib.required_contact
        missing = [x for x in lib.required_contact if not _contains(oc["required_contact"], x)]
        foreign = [x for x in oc["required_contact"] if not _contains(lib_all, x)]
        if missing or foreign:
            after = [x for x in oc["required_contact"] if x not in foreign] + missing
            w.correct("object_contact", "object_contact.required_contact",
                      oc["required_contact"], after)
            oc["required_contact"] = after
        if any(not _contains(lib_all, x) for x in oc["objects"]):
            w.mark("object_contact", "object_contact")
        lib_lists = {"objects": lib.objects, "body_contact": lib.body_contact,
                     "environment_contact": lib.environment_contact}
    else:
        lib_lists = {}
    for item in list(oc["required_contact"]):
        if any(_contains(oc[k], item) for k in ("objects", "body_contact", "environment_contact")):
            continue
        key = next((k for k, v in lib_lists.items() if _contains(v, item)), None) or _kind(item)
        after = oc[key] + [item]
        w.correct("object_contact", f"object_contact.{key}", oc[key], after)
        oc[key] = after
