"""Randomness has one owner: a SeedSequence at the top, spawned per sample.

Children are derived from stable keys (not from call order), so the same seed
gives the same bytes on any number of workers and in any order.
"""

from __future__ import annotations

import hashlib

import numpy as np


def key_entropy(*keys: object) -> int:
    """A stable 64-bit integer from any printable keys."""
    digest = hashlib.sha256("\x1f".join(str(k) for k in keys).encode()).digest()
    return int.from_bytes(digest[:8], "little")


def child_seed(seed: int, *keys: object) -> np.random.SeedSequence:
    """The SeedSequence for one named unit of work under a top-level seed."""
    return np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFFFFFF, key_entropy(*keys)])


def rng_for(seed: int, *keys: object) -> np.random.Generator:
    """A Generator for one named unit of work under a top-level seed."""
    return np.random.default_rng(child_seed(seed, *keys))
