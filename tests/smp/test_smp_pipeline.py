"""The SMP steps chained on damaged model output: repair -> aggregate -> refine ->
augment / intervene -> verbalize never fail on whatever repair lets through."""

from __future__ import annotations

import json
import random

import pytest
from smp_helpers import mutate_response

from vsmp_imu.smp.aggregate import aggregate, library_activity
from vsmp_imu.smp.augment import SMPAugmenter
from vsmp_imu.smp.intervene import intervene
from vsmp_imu.smp.library import ActivityLibrary
from vsmp_imu.smp.refine import refine
from vsmp_imu.smp.repair import parse_response
from vsmp_imu.smp.verbalize import attribute_phrase, verbalize


def _repaired(jj, n: int, seed: int):
    rng = random.Random(seed)
    raw = jj.model_dump(mode="json")
    text = json.dumps(raw, indent=2)
    out = []
    while len(out) < n:
        result = parse_response(mutate_response(rng, text, raw))
        if result.smp is not None:
            out.append(result.smp)
    return out


def _chain(smps, library):
    discarded = 0
    for i in range(0, len(smps) - 4, 5):
        agg = aggregate(smps[i:i + 5], activity_of=library_activity(library))
        if agg.smp is None:  # mutated labels may leave no activity a majority
            assert agg.reason.startswith("no activity is named by a majority"), agg.reason
            discarded += 1
            continue
        first = refine(agg.smp, library)
        again = refine(first.smp, library)
        assert again.corrections == [], [c.to_dict() for c in again.corrections]
        s = first.smp
        for v in SMPAugmenter().augment(s, 2, seed=i):
            assert v.primitive_sequence == s.primitive_sequence
            prompt = verbalize(v)
            assert len(prompt.split()) < 60 and attribute_phrase(v) in prompt
        for level in ("slow", "fast"):
            assert intervene(s, "tempo", level).execution_attributes.tempo == level
        assert intervene(s, "duration", 1.25).primitive_sequence == s.primitive_sequence
    assert discarded * 10 <= len(smps) // 5  # typos of the label still name the activity


def test_damaged_responses_flow_through_every_step(jj, library):
    lib = ActivityLibrary([library.get("jumping_jacks")])
    smps = _repaired(jj, 150, seed=5)
    for s in smps:
        result = refine(s, lib)
        assert refine(result.smp, lib).corrections == []
        assert len(verbalize(result.smp, phase_durations=True).split()) < 60
    _chain(smps, lib)


@pytest.mark.slow
def test_damaged_responses_flow_through_every_step_long(jj, library):
    _chain(_repaired(jj, 3000, seed=6), library)
