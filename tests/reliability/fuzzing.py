"""Byte-level mutations for fuzzing file readers (hypothesis strategies)."""

from __future__ import annotations

import re

from hypothesis import HealthCheck, settings
from hypothesis import strategies as st

# values that break naive parsers: special floats, overflow, empty, text, control bytes
SPECIAL_TOKENS = (b"nan", b"NaN", b"inf", b"-inf", b"1e309", b"-1e309", b"", b"abc", b"-1", b"0", b"1e-320",
                  b"99999999999999999999", b"\x00", b"\xff\xfe", b"null", b"[]", b"{}", b"true", b'"', b",",
                  b"\n", b"- ", b": ", b"&a [*a, *a]", b"\xe2\x80\xae")
NUMBER = re.compile(rb"-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")
FAST_EXAMPLES = 30
SLOW_EXAMPLES = 10_000


def fuzz_settings(n: int):
    # the fast run draws the same cases every time (a reproducible CI); the slow run explores
    return settings(max_examples=n, deadline=None, database=None, print_blob=True,
                    derandomize=n <= FAST_EXAMPLES,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.function_scoped_fixture,
                                           HealthCheck.filter_too_much])


@st.composite
def mutated(draw, original: bytes, max_ops: int = 4) -> bytes:
    """`original` after 1..max_ops random edits: bit flips, deletions, insertions,
    duplications, truncation, a number token replaced by a special value."""
    data = bytearray(original)
    for _ in range(draw(st.integers(1, max_ops))):
        kind = draw(st.sampled_from(("flip", "delete", "insert", "duplicate", "truncate", "token", "token")))
        n = len(data)
        pos = draw(st.integers(0, max(n - 1, 0)))
        if kind == "flip" and n:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif kind == "delete" and n:
            del data[pos:pos + draw(st.integers(1, 64))]
        elif kind == "insert":
            data[pos:pos] = draw(st.one_of(st.binary(min_size=1, max_size=16), st.sampled_from(SPECIAL_TOKENS)))
        elif kind == "duplicate" and n:
            span = bytes(data[pos:pos + draw(st.integers(1, 256))])
            data[pos:pos] = span * draw(st.integers(1, 3))
        elif kind == "truncate":
            del data[pos:]
        elif kind == "token":
            numbers = list(NUMBER.finditer(bytes(data)))
            if numbers:
                m = numbers[draw(st.integers(0, len(numbers) - 1))]
                data[m.start():m.end()] = draw(st.sampled_from(SPECIAL_TOKENS))
    return bytes(data)
