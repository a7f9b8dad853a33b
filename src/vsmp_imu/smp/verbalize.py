"""SMP verbalization T_HY(S): a deterministic HY-Motion-style prompt (paper, "SMP
Verbalization" and "Matched caption--SMP prompt construction").

A prompt has three parts:

    A person performs jumping jacks in place. They stand upright with feet
    together, then jump while spreading the legs apart, then jump while
    bringing the legs together, at a moderate pace, using a medium range of
    motion, moving both sides symmetrically, and repeating the complete
    movement eight times.

1. the opening: the activity label, the objects the SMP lists ("using the
   dumbbells") and "in place" for a stationary activity;
2. the primitives in order, from their descriptions (or names), joined by
   "then"; descriptions are written as verb phrases ("jump while ...");
3. the attribute phrase A (`attribute_phrase`): tempo, amplitude, side,
   symmetry, displacement for a mobile activity, repetitions, and, on request,
   the central phase's share of the movement.

Text fields come from a model's answer, so each goes in only as far as it
describes: its first sentence, without symbols, at most a few dozen characters
(`_field_text`), and not at all when it holds a control character or an
instruction word (`INSTRUCTION_WORDS`: "ignore", "system", "prompt", ...); a
description that does not go in is replaced by the primitive's name.

Only known fields are verbalized; nothing is invented (no scenery, clothing,
camera, or objects the SMP does not list). Prompts stay under 60 words: when
they would not, the longest primitive phrase is condensed first, one step at
a time (its first clause, then one word less, never below three words nor
ending on a function word); then names are used. The room kept for A depends only
on which attributes are known, never on their values, so prompts of a matched
intervention set differ only in the tested phrase. Matched phrases follow the
paper: "at a deliberately slow pace" / "at a moderate pace" / "at a
deliberately fast pace", "using a small / medium / large range of motion".
Numbers on the 0..2 scale (augmented variants) fall in five bins; the two
in-between bins read "at a somewhat slow/fast pace" and "using a reduced /
an enlarged range of motion".
"""

from __future__ import annotations

import re

from vsmp_imu.errors import ValidationError
from vsmp_imu.smp._text import INSTRUCTION_WORDS, number_word, words
from vsmp_imu.smp.bodyparts import side_of
from vsmp_imu.smp.intervene import central_primitive_index
from vsmp_imu.smp.library import ActivityLibrary, LibraryEntry
from vsmp_imu.smp.schema import SMP, UNKNOWN, displacement_word

MAX_WORDS = 59  # "under 60 words"

# Paper, "Matched intervention prompts" (exact phrases for the three levels).
TEMPO_PHRASES = {
    "slow": "at a deliberately slow pace",
    "medium": "at a moderate pace",
    "fast": "at a deliberately fast pace",
}
AMPLITUDE_PHRASES = {
    "small": "using a small range of motion",
    "medium": "using a medium range of motion",
    "large": "using a large range of motion",
}
# in-between bins for numeric levels (0.25 < |level - 1| < 0.75)
TEMPO_BETWEEN = ("at a somewhat slow pace", "at a somewhat fast pace")
AMPLITUDE_BETWEEN = ("using a reduced range of motion", "using an enlarged range of motion")
SYMMETRY_PHRASES = {
    "symmetric": "moving both sides symmetrically",
    "asymmetric": "moving both sides asymmetrically",
}
# words kept for each attribute category (its longest phrase)
_RESERVE = {"tempo": 5, "amplitude": 6, "side": 5, "symmetry": 4, "displacement": 4,
            "repetitions": 6}

# At most this many characters of each text field (the library's longest: label 40,
# description 134, object 14, name 26).
MAX_LABEL_CHARS = 60
MAX_DESCRIPTION_CHARS = 200
MAX_NAME_CHARS = 40
GENERIC_LABEL = "a movement"  # the opening's label when the SMP's may not go in

_SENTENCE_END = re.compile(r"[.!?:;](?:\s|$)|[\r\n]")
_NOT_TEXT = re.compile(r"[^\w\s,'()/-]|_")
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")

_SUBJECT = re.compile(r"^(?:the |a |an )?(?:person|individual|subject|man|woman|user|actor|"
                      r"participant|they|he|she)\s+", re.I)
_IRREGULAR = {"is": "are", "has": "have", "does": "do", "goes": "go", "lies": "lie",
              "ties": "tie", "dies": "die"}
_KEEP_S = ("ss", "us", "is", "ys", "os")


def _base_verb(word: str) -> str:
    """Third-person verb -> base form ('raises' -> 'raise', 'pushes' -> 'push')."""
    low = word.lower()
    if low in _IRREGULAR:
        return _IRREGULAR[low]
    if not low.endswith("s") or low.endswith(_KEEP_S) or len(low) <= 3:
        return word
    if low.endswith("ies"):
        return word[:-3] + "y"
    if low.endswith(("shes", "ches", "xes", "zes", "sses")):
        return word[:-2]
    return word[:-1]


def _field_text(text: str, max_chars: int) -> str:
    """What of an SMP text field may go into a prompt: its first sentence without symbols, cut
    to `max_chars` at a word; "" when it holds an instruction word or a control character."""
    end = _SENTENCE_END.search(text)
    text = text[: end.start()] if end else text
    if _CONTROL.search(text) or any(w in INSTRUCTION_WORDS for w in words(text)):
        return ""
    text = " ".join(_NOT_TEXT.sub(" ", text).split())
    if len(text) > max_chars:
        cut = text[: max_chars + 1]
        text = cut.rsplit(" ", 1)[0] if " " in cut else text[:max_chars]
    return text


def _clean(text: str) -> str:
    """A primitive description as a lower-case verb phrase without final punctuation."""
    text = " ".join(text.replace("_", " ").split()).strip().rstrip(".;,!")
    text = _SUBJECT.sub("", text)
    if not text:
        return ""
    words = text.split(" ")
    words[0] = _base_verb(words[0]).lower()
    return " ".join(words)


_STOP_TAIL = {"with", "to", "the", "a", "an", "of", "in", "on", "and", "or", "at", "from", "into",
              "onto", "over", "by", "for", "while", "beside", "across", "toward", "towards",
              "their", "his", "her", "its", "both", "then", "as", "so", "that", "until", "before",
              "after", "through", "behind", "under", "above", "below", "near", "around", "along",
              "keeping", "using", "is", "are", "one", "each"}
MIN_PHRASE_WORDS = 3


def _first_clause(text: str) -> str:
    words = text.split(" ")
    for i, w in enumerate(words):
        if i >= MIN_PHRASE_WORDS and (w in ("and", "or") or words[i - 1].endswith((",", ";"))):
            return _trim(words[:i])
    return text


def _trim(words: list[str]) -> str:
    """Words joined, without trailing punctuation or dangling function words."""
    words = [w.rstrip(",;") for w in words]
    while len(words) > 1 and words[-1].lower() in _STOP_TAIL:
        words.pop()
    return " ".join(words)


def _shorter(text: str) -> str | None:
    """One condensation step: the first clause, else one word less (None: cannot)."""
    clause = _first_clause(text)
    if _words(clause) < _words(text):
        return clause
    words = text.split(" ")
    if len(words) <= MIN_PHRASE_WORDS:
        return None
    return _trim(words[:-1])


def _condense(full: list[str], budget: int) -> list[str] | None:
    """Shorten the longest phrase step by step until all fit in `budget` words (with
    one "then" between phrases); None when they cannot."""
    phrases = list(full)
    while sum(_words(p) for p in phrases) + len(phrases) - 1 > budget:
        order = sorted(range(len(phrases)), key=lambda i: (-_words(phrases[i]), i))
        for i in order:
            shorter = _shorter(phrases[i])
            if shorter is not None:
                phrases[i] = shorter
                break
        else:
            return None
    return phrases


def _phrases(smp: SMP, budget: int) -> list[str]:
    """Primitive phrases that fit the budget: condensed descriptions, else names,
    else the first names that fit."""
    full, names = [], []
    for name in smp.primitive_sequence:
        p = smp.primitive(name)
        named = _clean(_field_text(name, MAX_NAME_CHARS))
        described = _clean(_field_text(p.description, MAX_DESCRIPTION_CHARS)) if p is not None else ""
        if named or described:
            names.append(named or described)
            full.append(described or named)
    for candidate in (full, names, [n.split(" ")[0] for n in names]):
        fitted = _condense(candidate, budget)
        if fitted is not None:
            return fitted
    kept: list[str] = []
    for n in names:
        first = n.split(" ")[0]
        if sum(_words(x) for x in kept) + _words(first) + len(kept) > budget:
            break
        kept.append(first)
    return kept


def _words(text: str) -> int:
    return len(text.split())


def _label(smp: SMP) -> str:
    return _field_text(smp.activity_label, MAX_LABEL_CHARS).lower() or GENERIC_LABEL


def _opening(smp: SMP) -> str:
    text = f"A person performs {_label(smp)}"
    objects = [t for t in (_field_text(o, MAX_NAME_CHARS) for o in smp.object_contact.objects) if t]
    if objects:
        text += " using the " + " and the ".join(objects)
    if _displacement_category(smp) == "stationary" and not _label(smp).endswith("in place"):
        text += " in place"
    return text + "."


def _displacement_category(smp: SMP) -> str | None:
    value = smp.execution_attributes.global_displacement
    return None if value == UNKNOWN else displacement_word(value)


def _level_phrase(level: float, phrases: dict[str, str], between: tuple[str, str],
                  words: tuple[str, str, str]) -> str:
    if level <= 0.25:
        return phrases[words[0]]
    if level < 0.75:
        return between[0]
    if level <= 1.25:
        return phrases[words[1]]
    if level < 1.75:
        return between[1]
    return phrases[words[2]]


def _limb(smp: SMP, side: str) -> str:
    segs = [s for s in smp.body_parts.dominant_moving_segments if side_of(s) == side]
    arms = sum(any(k in s for k in ("arm", "hand", "shoulder")) for s in segs)
    legs = sum(any(k in s for k in ("thigh", "leg", "foot")) for s in segs)
    if arms > legs:
        return "arm"
    if legs > arms:
        return "leg"
    return "side"


def _on_stairs(smp: SMP) -> bool:
    """The SMP needs stairs: its side is the way the stairwell turns (the procedural `turns`)."""
    oc = smp.object_contact
    return any("stair" in c for c in (*oc.required_contact, *oc.environment_contact))


def _attribute_items(smp: SMP, phase_durations: bool) -> list[tuple[str, str]]:
    """(category, phrase) in prompt order."""
    items: list[tuple[str, str]] = []
    ea, ts = smp.execution_attributes, smp.temporal_structure
    tempo = smp.tempo_level()
    if tempo is not None:
        items.append(("tempo", _level_phrase(tempo, TEMPO_PHRASES, TEMPO_BETWEEN,
                                             ("slow", "medium", "fast"))))
    amp = smp.amplitude_level()
    if amp is not None:
        items.append(("amplitude", _level_phrase(amp, AMPLITUDE_PHRASES, AMPLITUDE_BETWEEN,
                                                 ("small", "medium", "large"))))
    if ea.dominant_side in ("left", "right") and _on_stairs(smp):
        items.append(("side", f"turning {ea.dominant_side} at each landing"))  # a stairwell's turns
    elif ea.dominant_side in ("left", "right"):
        items.append(("side", f"leading with the {ea.dominant_side} {_limb(smp, ea.dominant_side)}"))
    if ea.symmetry in SYMMETRY_PHRASES:
        items.append(("symmetry", SYMMETRY_PHRASES[ea.symmetry]))
    category = _displacement_category(smp)
    if category in ("small", "large"):
        value = ea.global_displacement
        if isinstance(value, str):
            text = "moving a short distance" if value == "small" else "travelling a longer distance"
        else:
            metres = f"{value:.1f}".rstrip("0").rstrip(".") if value < 10 else f"{value:.0f}"
            text = f"covering about {metres} meters"
        items.append(("displacement", text))
    if phase_durations and len(smp.primitive_sequence) > 1:
        c = central_primitive_index(smp)
        share = round(100 * smp.relative_durations()[c])
        unit = "each repetition" if ts.is_repetitive else "the movement"
        name = _clean(_field_text(smp.primitive_sequence[c], MAX_NAME_CHARS)) or "central"
        items.append(("duration", f"with the {name} phase taking about {share} percent of {unit}"))
    count = smp.repetition_count()
    if ts.is_repetitive and (count is None or count >= 2):
        text = "repeating the complete movement"
        if count is not None:
            text += f" {number_word(count)} times"
        items.append(("repetitions", text))
    return items


def _join(phrases: list[str]) -> str:
    if len(phrases) <= 1:
        return "".join(phrases)
    if len(phrases) == 2:
        return f"{phrases[0]} and {phrases[1]}"
    return ", ".join(phrases[:-1]) + ", and " + phrases[-1]


def attribute_phrase(smp: SMP, phase_durations: bool = False) -> str:
    """The attribute phrase A, e.g. "at a deliberately fast pace, using a large range of
    motion, and repeating the complete movement eight times" ("" when nothing is known)."""
    return _join([p for _, p in _attribute_items(smp, phase_durations)])


def _reserve(items: list[tuple[str, str]]) -> int:
    words = sum(_RESERVE.get(cat, _words(text)) for cat, text in items)
    return words + (1 if len(items) > 1 else 0)  # "and"


def verbalize(smp: SMP, phase_durations: bool = False) -> str:
    """The HY-Motion prompt for an SMP (deterministic, under 60 words)."""
    opening = _opening(smp)
    items = _attribute_items(smp, phase_durations)
    attrs = _join([p for _, p in items])
    budget = MAX_WORDS - _words(opening) - _reserve(items) - 1  # "They"
    phrases = _phrases(smp, budget)
    body = "They " + ", then ".join(phrases) if phrases else ""
    if attrs:
        body = f"{body}, {attrs}" if body else f"They move {attrs}"
    prompt = f"{opening} {body}." if body else opening
    words = prompt.split()
    if len(words) > MAX_WORDS:  # only a label or object list of dozens of words gets here
        prompt = " ".join(words[:MAX_WORDS]).rstrip(".,;") + "."
    return prompt


def generic_caption(source: LibraryEntry | SMP, library: ActivityLibrary | None = None) -> str:
    """The generic caption of condition C0: the library's first caption for the activity
    when there is one, else "A person performs <label>."."""
    entry: LibraryEntry | None = source if isinstance(source, LibraryEntry) else None
    if entry is None:
        lib = library if library is not None else ActivityLibrary.load()
        try:
            entry = lib.resolve(source.activity_label)
        except ValidationError:
            entry = None
    if entry is not None and entry.captions:
        return entry.captions[0]
    smp = source.smp if isinstance(source, LibraryEntry) else source
    return f"A person performs {_label(smp)}."


def caption_plus_attributes(caption: str, phrase: str) -> str:
    """The operator C (+) A: the caption unchanged, then the attribute phrase verbatim."""
    caption = caption.rstrip()
    if not phrase:
        return caption
    sep = " " if caption.endswith((".", "!", "?")) else ". "
    return f"{caption}{sep}They do this {phrase}."
