"""Text from files, labels or model answers, made safe to print on a terminal."""

from __future__ import annotations

import re

__all__ = ["safe_text"]

# C0/C1 controls but newline and tab, and the bidirectional overrides and isolates
_CONTROL = re.compile(r"[\x00-\x08\x0b-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")


def safe_text(text: object) -> str:
    """`text` with terminal control characters (ANSI/OSC escapes, bidi overrides, NUL, ...)
    shown as \\xNN / \\uNNNN: text from files, labels or model answers cannot drive the terminal.
    Newlines and tabs stay."""
    return _CONTROL.sub(lambda m: m.group().encode("unicode_escape").decode("ascii"), str(text))
