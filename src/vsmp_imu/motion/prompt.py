"""Read a free-text prompt back into an SMP for the procedural backend.

The activity is found by fuzzy matching (rapidfuzz) against the library's
names, aliases, SMP labels and captions; the execution attributes are read
from the phrases the verbalizer writes ("at a deliberately slow pace",
"using a large range of motion", "repeating the complete movement eight
times", "moving both sides asymmetrically", "leading with the left arm",
"covering about 3 meters") and from common variants ("quickly", "slowly",
"6 times", "twice", "with the left hand"). What the prompt does not say
keeps the library's value. A prompt that names no known activity is a
`ValidationError` listing the activities.
"""

from __future__ import annotations

import re
from typing import Any

from rapidfuzz import fuzz

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp._text import NUMBER_WORDS, norm_name
from vsmp_imu.smp.schema import SMP

ACTIVITY_MIN_SCORE = 80.0  # rapidfuzz score (0..100) for a prompt to name an activity
MIN_KEY_CHARS = 4

# ordered: the first pattern that matches wins (specific phrases before general words)
TEMPO_PATTERNS: tuple[tuple[str, float], ...] = (
    (r"somewhat slow|slightly slow|a bit slow", 0.5),
    (r"somewhat fast|slightly fast|a bit fast|somewhat quick", 1.5),
    (r"deliberately slow|very slow|slow pace|slowly|at a slow|leisurely|unhurried", 0.0),
    (r"deliberately fast|very fast|fast pace|quick pace|quickly|rapidly|briskly|at a fast|fast", 2.0),
    (r"moderate pace|medium pace|normal pace|steady pace|moderately|moderate speed", 1.0),
    (r"\bslow\b", 0.0),
)
AMPLITUDE_PATTERNS: tuple[tuple[str, float], ...] = (
    (r"reduced range|slightly smaller range", 0.5),
    (r"enlarged range|slightly larger range", 1.5),
    (r"\b(?:small|tiny|minimal|limited)\s+(?:range of motion|range|amplitude|movements?|motions?)", 0.0),
    (r"\b(?:large|big|wide|full|maximal|exaggerated)\s+(?:range of motion|range|amplitude|movements?|motions?)", 2.0),
    (r"\b(?:medium|moderate|normal)\s+(?:range of motion|range|amplitude)", 1.0),
)
_NUMBER = "|".join(sorted(NUMBER_WORDS, key=len, reverse=True))
REPETITION_PATTERN = re.compile(
    rf"\b(\d+|{_NUMBER})\s+(?:times|repetitions|reps|cycles|rounds)\b", re.I)
ONCE_TWICE = {"once": 1, "twice": 2, "thrice": 3}
SIDE_PATTERN = re.compile(
    r"\b(?:leading with|with|using|on)\s+(?:the|their|his|her)\s+(left|right)\s+"
    r"(?:arm|hand|leg|foot|side|fist)|\b(left|right)[- ]handed\b"
    r"|\bturning\s+(?:to\s+the\s+)?(left|right)\s+at\s+(?:each|every|the)\s+landings?\b", re.I)
DISPLACEMENT_PATTERNS: tuple[tuple[str, Any], ...] = (
    (r"covering about ([0-9.]+)\s*(?:m|meters|metres)\b", "metres"),
    (r"moving a short distance", "small"),
    (r"travell?ing a longer distance", "large"),
)


def _keys(entry: Any) -> list[str]:
    """The normalized names an entry answers to: name, aliases, SMP label."""
    keys = [norm_name(entry.name), *(norm_name(a) for a in entry.aliases), norm_name(entry.smp.activity_label)]
    return [k for k in dict.fromkeys(keys) if len(k) >= MIN_KEY_CHARS]


_PERFORMS = re.compile(r"\bperforms?\s+([^.]+)\.", re.I)


def _stem(word: str) -> str:
    """A crude stem so 'waves', 'waving' and 'wave' (or 'claps', 'clapping') compare equal."""
    for suffix in ("ing", "ed", "es", "s", "e"):
        if word.endswith(suffix) and len(word) - len(suffix) >= 3:
            word = word[: -len(suffix)]
    if len(word) > 3 and word[-1] == word[-2] and word[-1] not in "aeiou":
        word = word[:-1]
    return word


def _stems(text: str) -> str:
    return " ".join(_stem(w) for w in re.findall(r"[a-z0-9]+", text))


def _key_score(key: str, text: str, text_stems: str) -> float:
    """90..100 when the key appears as whole words (longer keys higher), 88..98 when its word
    stems do ('waves' for 'wave'), else below 90."""
    if re.search(rf"(?<![a-z0-9]){re.escape(key)}(?![a-z0-9])", text):
        return 90.0 + min(len(key), 30) / 3.0
    if re.search(rf"(?<![a-z0-9]){re.escape(_stems(key))}(?![a-z0-9])", text_stems):
        return 88.0 + min(len(key), 30) / 3.0
    return 0.9 * fuzz.partial_ratio(key, text)


def _words(text: str) -> str:
    """Lower-case words only: punctuation is no word boundary of its own."""
    return " ".join(re.findall(r"[a-z0-9']+", text.lower()))


def resolve_activity(text: str, library: Any) -> tuple[Any, float]:
    """(entry, score) of the activity a prompt names; ValidationError when none scores high enough.

    A verbalized prompt ("A person performs <label> ...") resolves by its label;
    other text by the best of: a library caption (token-sort similarity; 100
    when the caption appears word for word, e.g. with attribute phrases
    appended, the longest such caption winning) and a name, alias or label
    found in the text.
    """
    match = _PERFORMS.search(text)
    if match:
        full = match.group(1).strip()
        no_objects = re.sub(r"\s+using the\s.*$", "", full)
        for label in (full, no_objects, re.sub(r"\s+in place$", "", no_objects)):
            try:
                return library.get(label), 100.0
            except ValidationError:
                pass
    norm = norm_name(text)
    norm_stems = _stems(norm)
    words = _words(norm)
    best: tuple[float, int, str, Any] | None = None
    for entry in library:
        score = max((_key_score(k, norm, norm_stems) for k in _keys(entry)), default=0.0)
        contained = 0  # length of the longest caption found word for word in the text
        for caption in entry.captions:
            cap = norm_name(caption)
            score = max(score, float(fuzz.token_sort_ratio(cap, norm)))
            cap_words = _words(cap)
            if cap_words and f" {cap_words} " in f" {words} ":
                score, contained = 100.0, max(contained, len(cap_words))
        if best is None or (score, contained) > best[:2]:
            best = (score, contained, entry.name, entry)
    if best is None or best[0] < ACTIVITY_MIN_SCORE:
        names = [e.name for e in library]
        raise ValidationError(
            f"the prompt names no known activity (best match score "
            f"{0 if best is None else best[0]:.0f} < {ACTIVITY_MIN_SCORE:g}): {text[:80]!r}",
            field="prompt", allowed=", ".join(names))
    return best[3], best[0]


def _first(patterns: tuple[tuple[str, Any], ...], text: str) -> Any:
    for pattern, value in patterns:
        if re.search(pattern, text, re.I):
            return value
    return None


def _repetitions(text: str) -> int | None:
    match = REPETITION_PATTERN.search(text)
    if match:
        word = match.group(1).lower()
        return int(word) if word.isdigit() else NUMBER_WORDS.index(word)
    for word, n in ONCE_TWICE.items():
        if re.search(rf"\b{word}\b", text, re.I):
            return n
    return None


def parse_attributes(text: str) -> dict[str, Any]:
    """The execution attributes a prompt states (only those it states)."""
    out: dict[str, Any] = {}
    tempo = _first(TEMPO_PATTERNS, text)
    if tempo is not None:
        out["tempo"] = tempo
    amplitude = _first(AMPLITUDE_PATTERNS, text)
    if amplitude is not None:
        out["amplitude"] = amplitude
    reps = _repetitions(text)
    if reps is not None:
        out["repetitions"] = reps
    if re.search(r"\basymmetric", text, re.I):
        out["symmetry"] = "asymmetric"
    elif re.search(r"\bsymmetric", text, re.I):
        out["symmetry"] = "symmetric"
    side = SIDE_PATTERN.search(text)
    if side:
        out["dominant_side"] = next(g for g in side.groups() if g).lower()
    for pattern, kind in DISPLACEMENT_PATTERNS:
        match = re.search(pattern, text, re.I)
        if match:
            out["global_displacement"] = float(match.group(1)) if kind == "metres" else kind
            break
    return out


def _level(value: float, words: tuple[str, str, str]) -> str | float:
    return words[int(value)] if float(value).is_integer() else float(value)


def smp_from_prompt(text: str, library: Any) -> tuple[SMP, Any]:
    """(SMP, library entry): the activity's library SMP with the prompt's attributes applied."""
    if not isinstance(text, str) or not text.strip():
        raise ValidationError("the prompt is empty", field="prompt")
    entry, _ = resolve_activity(text, library)
    attrs = parse_attributes(text)
    data = entry.smp.model_dump(mode="json")
    ea = data["execution_attributes"]
    if "tempo" in attrs:
        ea["tempo"] = _level(attrs["tempo"], ("slow", "medium", "fast"))
    if "amplitude" in attrs:
        ea["amplitude"] = _level(attrs["amplitude"], ("small", "medium", "large"))
    if "symmetry" in attrs:
        ea["symmetry"] = attrs["symmetry"]
    if "dominant_side" in attrs and ea["dominant_side"] in ("left", "right"):
        ea["dominant_side"] = attrs["dominant_side"]
    if "global_displacement" in attrs:
        ea["global_displacement"] = attrs["global_displacement"]
    if "repetitions" in attrs and attrs["repetitions"] >= 1:
        data["temporal_structure"]["repetition_count"] = int(attrs["repetitions"])
    return SMP.model_validate(data), entry
