"""Small text helpers shared by the SMP modules (names, keys, numbers in words)."""

from __future__ import annotations

import re

_SEPARATORS = re.compile(r"[\s_\-]+")
_CAMEL = re.compile(r"(?<=[a-z0-9])(?=[A-Z])")

NUMBER_WORDS = (
    "zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten",
    "eleven", "twelve", "thirteen", "fourteen", "fifteen", "sixteen", "seventeen", "eighteen",
    "nineteen", "twenty",
)


def norm_name(text: str) -> str:
    """Case-, space-, underscore- and hyphen-insensitive form of a name: 'Jumping-Jacks' -> 'jumping jacks'."""
    return _SEPARATORS.sub(" ", str(text)).strip().lower()


def norm_key(text: str) -> str:
    """snake_case form of a JSON key: 'activityLabel', 'Activity Label' -> 'activity_label'."""
    text = _CAMEL.sub("_", str(text).strip())
    return _SEPARATORS.sub("_", text).strip("_").lower()


def number_word(n: int) -> str:
    """'eight' for 8; digits beyond twenty."""
    return NUMBER_WORDS[n] if 0 <= n < len(NUMBER_WORDS) else str(n)
