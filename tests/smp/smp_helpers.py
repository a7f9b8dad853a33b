"""Small SMP builders shared by the SMP tests."""

from __future__ import annotations

import copy
import json
import random
from typing import Any

from vsmp_imu.smp.schema import SMP


def make_smp(base: SMP, **changes: Any) -> SMP:
    """`base` with dotted-path changes, e.g. make_smp(s, **{"execution_attributes.tempo": "fast"})."""
    d = copy.deepcopy(base.model_dump(mode="json"))
    for path, value in changes.items():
        target = d
        keys = path.split(".")
        for key in keys[:-1]:
            target = target[int(key)] if isinstance(target, list) else target[key]
        target[keys[-1]] = value
    return SMP.model_validate(d)


def simple_smp(**changes: Any) -> SMP:
    """A small hand-made SMP (not in the library) with every field known."""
    base = SMP.model_validate({
        "activity_label": "arm circles",
        "motion_primitives": [
            {"name": "raise_arms", "order_index": 0, "description": "raise both arms to the sides",
             "body_parts": ["left_upper_arm", "right_upper_arm"], "relative_duration": 0.3},
            {"name": "circle_arms", "order_index": 1, "description": "circle the arms forward",
             "body_parts": ["left_upper_arm", "right_upper_arm", "left_forearm", "right_forearm"],
             "relative_duration": 0.5},
            {"name": "lower_arms", "order_index": 2, "description": "lower the arms",
             "body_parts": ["left_upper_arm", "right_upper_arm"], "relative_duration": 0.2},
        ],
        "primitive_sequence": ["raise_arms", "circle_arms", "lower_arms"],
        "primitive_durations": {"type": "relative", "values": [0.3, 0.5, 0.2]},
        "body_parts": {"mandatory": ["left_upper_arm", "right_upper_arm"], "optional": ["torso"],
                       "dominant_moving_segments": ["left_forearm", "right_forearm"]},
        "temporal_structure": {"is_repetitive": True, "repetition_count": 6,
                               "periodicity": "cyclic", "ordering": "ordered",
                               "transition_type": "continuous"},
        "execution_attributes": {"tempo": "medium", "amplitude": "large",
                                 "dominant_side": "bilateral", "symmetry": "symmetric",
                                 "global_displacement": "stationary"},
        "object_contact": {"environment_contact": ["floor"], "required_contact": ["floor"]},
        "constraints": {"variant_fields": ["tempo", "amplitude", "repetition_count",
                                           "primitive_duration", "symmetry"]},
        "uncertainty": dict.fromkeys(
            ["activity_label", "motion_primitives", "primitive_duration", "body_parts",
             "temporal_structure", "repetition_count", "tempo", "amplitude", "dominant_side",
             "symmetry", "global_displacement", "object_contact"], 0.2),
    })
    return make_smp(base, **changes) if changes else base


_JUNK = [None, 7, -3.5, "weird", [], {}, True, [1, {"a": 2}], "1e999", float("nan"), "∞", "8-10",
         {"name": 3}, [[["deep"]]], "", " ", "unknown"]


def mutate_response(rng: random.Random, text: str, obj: dict) -> str | bytes:
    """A damaged version of a model response: truncated, characters deleted, inserted or
    swapped, keys renamed, fields dropped or given wrong types, random bytes, junk."""
    kind = rng.randrange(9)
    chars = list(text)
    if kind == 0:
        return text[: rng.randrange(len(text) + 1)]
    if kind == 1:
        for _ in range(rng.randrange(1, 30)):
            if chars:
                del chars[rng.randrange(len(chars))]
        return "".join(chars)
    if kind == 2:
        for _ in range(rng.randrange(1, 30)):
            chars.insert(rng.randrange(len(chars) + 1), rng.choice('{}[]",:\\ \nabz09.eE-'))
        return "".join(chars)
    if kind == 3:
        for _ in range(rng.randrange(1, 30)):
            i, j = rng.randrange(len(chars)), rng.randrange(len(chars))
            chars[i], chars[j] = chars[j], chars[i]
        return "".join(chars)
    if kind == 4:
        return bytes(rng.getrandbits(8) for _ in range(rng.randrange(3000)))
    if kind in (5, 6):
        data = json.loads(json.dumps(obj))

        def walk(node):
            if isinstance(node, dict):
                for key in list(node):
                    r = rng.random()
                    if r < 0.08:
                        del node[key]
                    elif r < 0.16:
                        node[key[: rng.randrange(1, len(key) + 1)] + rng.choice(["", "x", "_"])] = \
                            node.pop(key)
                    elif r < 0.24:
                        node[key] = rng.choice(_JUNK)
                    else:
                        walk(node[key])
            elif isinstance(node, list):
                for i in range(len(node)):
                    if rng.random() < 0.15:
                        node[i] = rng.choice(_JUNK)
                    else:
                        walk(node[i])

        walk(data)
        out = json.dumps(data)
        return out if kind == 5 else f"Answer:\n```json\n{out[: rng.randrange(len(out) + 1)]}"
    if kind == 7:
        return "".join(rng.choice(["{", "}", "[", "]", '"', ":", ",", "a", " ", "\n", "```"])
                       for _ in range(rng.randrange(400)))
    return rng.choice(["", "{", "null", "42", '"str"', "[]", "[{}]", "```", "\x00" * 50,
                       "{" * 3000 + "}" * 10, '{"activity_label": "x", "primitive_sequence": "a"}'])
