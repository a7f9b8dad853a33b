"""The body-part vocabulary of the paper's annotation guide and synonym normalization.

`normalize_body_part("arms")` -> the six arm segments; `"left knee"` -> `left_lower_leg`.
Words without a side ("arm", "arms", "both legs") name both sides.
"""

from __future__ import annotations

import re

from rapidfuzz import fuzz, process

from vsmp_imu.smp._text import norm_key

# Appendix "SMP audit annotation guide": the body-part set.
BODY_PARTS = (
    "head", "torso", "left_shoulder", "right_shoulder", "left_upper_arm", "right_upper_arm",
    "left_forearm", "right_forearm", "left_hand", "right_hand", "pelvis", "left_thigh",
    "right_thigh", "left_lower_leg", "right_lower_leg", "left_foot", "right_foot",
)
SIDED = ("shoulder", "upper_arm", "forearm", "hand", "thigh", "lower_leg", "foot")
ARM = ("upper_arm", "forearm", "hand")
LEG = ("thigh", "lower_leg", "foot")

# word (singular, snake_case, no side) -> side-less segments or central parts
_SYNONYMS: dict[str, tuple[str, ...]] = {
    "head": ("head",), "neck": ("head",), "face": ("head",), "eyes": ("head",),
    "torso": ("torso",), "trunk": ("torso",), "chest": ("torso",), "back": ("torso",),
    "upper_back": ("torso",), "lower_back": ("torso",), "spine": ("torso",), "abdomen": ("torso",),
    "abs": ("torso",), "core": ("torso",), "body": ("torso",),
    "pelvis": ("pelvis",), "hip": ("pelvis",), "waist": ("pelvis",), "glute": ("pelvis",),
    "buttock": ("pelvis",), "root": ("pelvis",),
    "shoulder": ("shoulder",), "scapula": ("shoulder",), "clavicle": ("shoulder",),
    "arm": ARM, "upper_arm": ("upper_arm",), "bicep": ("upper_arm",), "biceps": ("upper_arm",),
    "tricep": ("upper_arm",), "triceps": ("upper_arm",), "elbow": ("forearm",),
    "forearm": ("forearm",), "lower_arm": ("forearm",), "wrist": ("hand",), "hand": ("hand",),
    "finger": ("hand",), "palm": ("hand",), "fist": ("hand",),
    "leg": LEG, "thigh": ("thigh",), "upper_leg": ("thigh",), "quad": ("thigh",),
    "quadricep": ("thigh",), "hamstring": ("thigh",), "knee": ("lower_leg",),
    "lower_leg": ("lower_leg",), "shin": ("lower_leg",), "calf": ("lower_leg",),
    "calve": ("lower_leg",), "ankle": ("foot",), "foot": ("foot",), "feet": ("foot",),
    "toe": ("foot",), "heel": ("foot",),
    "upper_body": ("torso", "head", "shoulder", *ARM), "lower_body": ("pelvis", *LEG),
    "whole_body": BODY_PARTS, "full_body": BODY_PARTS, "entire_body": BODY_PARTS,
    "all": BODY_PARTS, "limb": (*ARM, *LEG),
}
_SIDE_WORDS = {"left": ("left",), "l": ("left",), "right": ("right",), "r": ("right",),
               "both": ("left", "right"), "two": ("left", "right"), "bilateral": ("left", "right")}
_FILLER = {"the", "a", "an", "of", "joint", "joints", "segment", "segments", "side", "sides",
           "region", "area", "muscles", "muscle", "and"}


def _singular(word: str) -> str:
    if word in _SYNONYMS:
        return word
    for suffix, repl in (("ves", "f"), ("ies", "y"), ("es", ""), ("s", "")):
        if word.endswith(suffix) and word[: -len(suffix)] + repl in _SYNONYMS:
            return word[: -len(suffix)] + repl
    return word


def normalize_body_part(text: str) -> tuple[str, ...]:
    """The vocabulary parts a body-part word names; () when it names none."""
    key = norm_key(text)
    if key in BODY_PARTS:
        return (key,)
    words = [w for w in key.split("_") if w and w not in _FILLER]
    sides: tuple[str, ...] = ()
    rest: list[str] = []
    for w in words:
        if w in _SIDE_WORDS and not rest:
            sides = tuple(dict.fromkeys(sides + _SIDE_WORDS[w]))
        else:
            rest.append(w)
    base = _singular("_".join(rest))
    parts = _SYNONYMS.get(base)
    if parts is None:
        hit = process.extractOne(key, BODY_PARTS, scorer=fuzz.ratio, score_cutoff=88)
        if hit:
            return (hit[0],)
        last = _singular(rest[-1]) if rest else ""
        parts = _SYNONYMS.get(last)
    if parts is None:
        return ()
    return _expand(parts, sides)


def _expand(parts: tuple[str, ...], sides: tuple[str, ...]) -> tuple[str, ...]:
    """Side-less segments -> the named sides (both when none is named)."""
    out: list[str] = []
    for part in parts:
        if part in SIDED:
            out.extend(f"{s}_{part}" for s in (sides or ("left", "right")))
        elif side_of(part) is None or not sides or side_of(part) in sides:
            out.append(part)
    return tuple(dict.fromkeys(out))


def normalize_body_parts(items: list[str]) -> tuple[list[str], list[str]]:
    """(normalized parts in first-seen order, items that name no part)."""
    out: list[str] = []
    unknown: list[str] = []
    for item in items:
        parts = normalize_body_part(item)
        if parts:
            out.extend(p for p in parts if p not in out)
        else:
            unknown.append(item)
    return out, unknown




def parts_mentioned(text: str) -> list[str]:
    """Body parts named in free text such as a primitive description."""
    words = re.findall(r"[a-z]+", text.lower())
    out: list[str] = []
    i = 0
    while i < len(words):
        side: tuple[str, ...] = ()
        j = i
        if words[j] in ("left", "right", "both") and j + 1 < len(words):
            side = _SIDE_WORDS[words[j]]
            j += 1
        found = None
        for width in (2, 1):
            if j + width <= len(words):
                base = _singular("_".join(words[j:j + width]))
                if base in _SYNONYMS and base not in ("all", "body", "root", "back", "core"):
                    found = (base, width)
                    break
        if found is None:
            i += 1
            continue
        base, width = found
        out.extend(p for p in _expand(_SYNONYMS[base], side) if p not in out)
        i = j + width
    return out


def side_of(part: str) -> str | None:
    """'left', 'right' or None for a vocabulary part."""
    head = part.split("_", 1)[0]
    return head if head in ("left", "right") else None
