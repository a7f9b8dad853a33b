"""Uncertainty-conditioned constrained augmentation (paper, "Semantic Refinement and
Constrained Augmentation", appendix table "SMP perturbation ranges").

Only fields named in `constraints.variant_fields` change; the invariant fields
(label, primitive names and order, body parts, contacts, stationary-vs-mobile)
are never touched. For a continuous or ordinal field with uncertainty u the
radius is Delta(u) = (1 - u) * Delta_max and the new value is drawn from
Uniform[f - Delta, f + Delta], clipped to the field's range; a categorical
field changes with probability (1 - u) * rho. With
`uncertainty_conditioned=False` every field uses u = 0 (the "w/o
uncertainty-aware constraints" ablation).

| field | rule |
| --- | --- |
| tempo, amplitude | +-1 level on the 0..2 ordinal scale, stored as a number |
| repetition_count | +-5 cycles, integer 1..1000, repetitive activities only |
| primitive_duration | each known duration x Uniform[1 - 0.25, 1 + 0.25]; relative values are renormalized to their original sum; order kept |
| dominant_side | left <-> right with rho = 0.5, only when the side is left/right |
| symmetry | symmetric <-> asymmetric with rho = 0.3 |
| global_displacement | extent x Uniform[1 - 0.25, 1 + 0.25] in metres; stationary stays stationary |

A field whose value is `unknown`, or whose radius is 0 (u = 1), is left as it is. The primitives (names,
order, descriptions, nominal `relative_duration`) are invariant: duration
augmentation writes `primitive_durations` only (filled from the nominal
durations when it was empty). Each variant i draws from
`rng_for(seed, smp.smp_id, i, field)`: variant i does not depend on k, nor a
field on which other fields are variant.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.seeding import rng_for
from vsmp_imu.smp._text import norm_name
from vsmp_imu.smp.schema import (
    MAX_DISPLACEMENT_M,
    MAX_PRIMITIVE_DURATION,
    MAX_REPETITIONS,
    SMP,
    UNKNOWN,
)

# Appendix "SMP Constraint Rules", table "SMP perturbation ranges".
TEMPO_MAX_LEVELS = 1.0
AMPLITUDE_MAX_LEVELS = 1.0
REPETITION_MAX_CYCLES = 5
DURATION_MAX_FRACTION = 0.25
SIDE_SWAP_PROBABILITY = 0.5
SYMMETRY_CHANGE_PROBABILITY = 0.3
DISPLACEMENT_MAX_FRACTION = 0.25
DECIMALS = 4  # stored numbers are rounded (stable, readable JSON)
MIN_EXTENT_M = 1e-3  # a mobile extent never reaches 0 (that would mean stationary)
# The most a run of variants may write (k x the SMP's canonical size): a library SMP of 5 KB
# allows 40 000 variants, an SMP of the 16 MiB input limit 11.
MAX_OUTPUT_BYTES = 200 * 10**6


def _u(smp: SMP, name: str, conditioned: bool) -> float:
    return float(getattr(smp.uncertainty, name)) if conditioned else 0.0


def _interval(value: float, radius: float, lo: float, hi: float, rng) -> float:
    return round(min(hi, max(lo, rng.uniform(value - radius, value + radius))), DECIMALS)


def _aligned(smp: SMP) -> bool:
    """motion_primitives (by order_index) name the sequence one-to-one."""
    ordered = sorted(smp.motion_primitives, key=lambda p: p.order_index)
    return [norm_name(p.name) for p in ordered] == [norm_name(s) for s in smp.primitive_sequence]


def augment_variant(smp: SMP, seed: int, index: int,
                    uncertainty_conditioned: bool = True) -> tuple[SMP, dict[str, dict[str, Any]]]:
    """Variant `index` of `smp` and the fields it changed ({path: {before, after}})."""
    d = smp.model_dump(mode="json")
    variant = set(smp.constraints.variant_fields)
    changed: dict[str, dict[str, Any]] = {}
    ea, ts = d["execution_attributes"], d["temporal_structure"]

    def rng(name: str):
        return rng_for(seed, smp.smp_id, index, name)

    def record(path: str, before: Any, after: Any) -> None:
        if before != after:
            changed[path] = {"before": before, "after": after}

    for name, level, dmax in (("tempo", smp.tempo_level(), TEMPO_MAX_LEVELS),
                              ("amplitude", smp.amplitude_level(), AMPLITUDE_MAX_LEVELS)):
        radius = (1 - _u(smp, name, uncertainty_conditioned)) * dmax
        if name in variant and level is not None and radius > 0:
            new = _interval(level, radius, 0.0, 2.0, rng(name))
            record(f"execution_attributes.{name}", ea[name], new)
            ea[name] = new

    count = smp.repetition_count()
    if "repetition_count" in variant and smp.temporal_structure.is_repetitive and count is not None:
        radius = (1 - _u(smp, "repetition_count", uncertainty_conditioned)) * REPETITION_MAX_CYCLES
        lo = min(MAX_REPETITIONS, max(1, math.ceil(count - radius)))
        hi = min(MAX_REPETITIONS, max(1, math.floor(count + radius)))
        new_count = int(rng("repetition_count").integers(lo, hi + 1))
        record("temporal_structure.repetition_count", count, new_count)
        ts["repetition_count"] = new_count

    radius = (1 - _u(smp, "primitive_duration", uncertainty_conditioned)) * DURATION_MAX_FRACTION
    if "primitive_duration" in variant and radius > 0:
        _durations(smp, d, radius, rng("primitive_duration"), record)

    for name, (a, b), chance in (("dominant_side", ("left", "right"), SIDE_SWAP_PROBABILITY),
                                 ("symmetry", ("symmetric", "asymmetric"), SYMMETRY_CHANGE_PROBABILITY)):
        old = ea[name]
        if name in variant and old in (a, b):
            p = (1 - _u(smp, name, uncertainty_conditioned)) * chance
            if rng(name).random() < p:
                ea[name] = b if old == a else a
                record(f"execution_attributes.{name}", old, ea[name])

    extent = smp.displacement_extent_m()
    radius = (1 - _u(smp, "global_displacement", uncertainty_conditioned)) * DISPLACEMENT_MAX_FRACTION
    if "global_displacement" in variant and extent is not None and extent > 0 and radius > 0:
        factor = rng("global_displacement").uniform(1 - radius, 1 + radius)
        new_extent = round(min(MAX_DISPLACEMENT_M, max(MIN_EXTENT_M, extent * factor)), DECIMALS)
        record("execution_attributes.global_displacement", ea["global_displacement"], new_extent)
        ea["global_displacement"] = new_extent

    return SMP.model_validate(d), changed


def _durations(smp: SMP, d: dict[str, Any], radius: float, rng, record) -> None:
    dur = d["primitive_durations"]
    values = list(dur["values"])
    kind = dur["type"]
    aligned = _aligned(smp)
    if not values and aligned and all(p.relative_duration != UNKNOWN for p in smp.motion_primitives):
        ordered = sorted(smp.motion_primitives, key=lambda p: p.order_index)
        values, kind = [float(p.relative_duration) for p in ordered], "relative"
    known = [j for j, v in enumerate(values) if v != UNKNOWN]
    if not known:
        return
    factors = rng.uniform(1 - radius, 1 + radius, size=len(values))
    new = [v if v == UNKNOWN else float(v) * float(f) for v, f in zip(values, factors, strict=True)]
    if kind != "absolute":
        old_sum = sum(float(values[j]) for j in known)
        new_sum = sum(float(new[j]) for j in known)
        if new_sum > 0:
            new = [v if v == UNKNOWN else float(v) * old_sum / new_sum for v in new]
    new = [v if v == UNKNOWN else round(min(MAX_PRIMITIVE_DURATION, float(v)), DECIMALS) for v in new]
    before = {"type": dur["type"], "values": dur["values"]}
    dur["type"], dur["values"] = kind, new
    record("primitive_durations", before, {"type": kind, "values": new})


class SMPAugmenter:
    """Draw k constrained variants of an SMP.

    `changes_` (after `augment`): one dict per variant with its index, source
    id, seed and the fields it changed.
    """

    def __init__(self, uncertainty_conditioned: bool = True) -> None:
        self.uncertainty_conditioned = uncertainty_conditioned

    def augment(self, smp: SMP, k: int, seed: int) -> list[SMP]:
        variants: list[SMP] = []
        self.changes_: list[dict[str, Any]] = []
        for variant, change in self.iter_variants(smp, k, seed):
            variants.append(variant)
            self.changes_.append(change)
        return variants

    def iter_variants(self, smp: SMP, k: int, seed: int) -> Iterator[tuple[SMP, dict[str, Any]]]:
        """Variants 0..k-1, one at a time, each with its `changes_` record."""
        if k < 0:
            raise ValidationError(f"k must be >= 0, got {k}", field="k")
        source = smp.smp_id
        for i in range(k):
            variant, changed = augment_variant(smp, seed, i, self.uncertainty_conditioned)
            yield variant, {"index": i, "source_smp_id": source, "seed": seed,
                            "uncertainty_conditioned": self.uncertainty_conditioned,
                            "smp_id": variant.smp_id, "changed": changed}


def check_output_size(smp: SMP, k: int, field: str = "k") -> None:
    """Refuse k variants whose lines would exceed MAX_OUTPUT_BYTES, before any is drawn. A
    variant changes a few numbers only, so it is about as long as `smp` in canonical form."""
    limit = MAX_OUTPUT_BYTES
    size = len(smp.canonical_json().encode("utf-8")) + 1
    if k * size > limit:
        raise ConfigError(f"{k} variants of this {size:,}-byte SMP would write about "
                          f"{k * size / 1e6:,.0f} MB, more than the {limit / 1e6:,.0f} MB limit",
                          field=field, allowed=f"at most {max(1, limit // size)} variants of this SMP")
