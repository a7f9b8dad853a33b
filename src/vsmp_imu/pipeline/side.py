"""Which way a class turns, from its real training windows (the side from evidence).

An SMP that lists `dominant_side` among its variant fields leaves the side to
the augmenter: each variant swaps it with probability (1 - u) * 0.5, so about
half of the variants move to each side. Where the side shows in the sensor
(a quarter turn to lie along a bed reads as a net rotation about the trunk's
long axis, one sign per side) and the class has real training windows, those
windows say which way the dataset's people moved. Per class and base SMP:

1. two probes: the SMP's motion with the side set to left and to right, same
   seed, no noise, no calibration, at the class's locations and nominal
   mountings, aligned to the dataset's convention;
2. d = half the difference of the probes' mean gyroscope vectors (all
   locations with a gyroscope, stacked). When |d| is below
   `MIN_SEPARATION` of the probes' gyroscope RMS, the side does not show in
   the sensor and the SMP keeps its side;
3. each real training window of the class votes for the side whose probe its
   mean gyroscope vector leans towards (projection on d beyond
   `VOTE_FRACTION` x |d|; the others do not vote);
4. p(right) = (right votes + 1) / (votes + 2) (no window: 1/2), the SMP's side
   becomes the more likely one and its `dominant_side` uncertainty becomes
   1 - 2 min(p, 1 - p), so its variants swap to the other side with the
   other side's probability.

A class without real windows (an unseen class) keeps the SMP's side and its
50/50 variants. The record of each decision goes into the fold's summary.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from vsmp_imu.seeding import rng_for
from vsmp_imu.smp import SMP

SIDES = ("left", "right")
MIN_SEPARATION = 0.1  # |d| / probes' gyroscope RMS below which the side does not show
VOTE_FRACTION = 0.2  # a window votes when its projection on d-hat exceeds this fraction of |d|
DECIMALS = 4


def side_is_free(smp: SMP) -> bool:
    """The SMP names a side and lets its variants change it."""
    return ("dominant_side" in smp.constraints.variant_fields
            and smp.execution_attributes.dominant_side in SIDES)


def with_side(smp: SMP, side: str, uncertainty: float | None = None) -> SMP:
    """The SMP with `side` (and, when given, its `dominant_side` uncertainty)."""
    d = smp.model_dump(mode="json")
    d["execution_attributes"]["dominant_side"] = side
    if uncertainty is not None:
        d["uncertainty"]["dominant_side"] = round(float(uncertainty), DECIMALS)
    return SMP.model_validate(d)


def probe_seed(seed: int, fold: str, label: str) -> int:
    return int(rng_for(seed, fold, label, "side-probe").integers(2**31))


def mean_rates(signals: list[np.ndarray]) -> np.ndarray:
    """One window's (or probe's) mean gyroscope vector, locations stacked: [(T, >=6) per location]."""
    return np.concatenate([np.asarray(s)[:, 3:6].mean(axis=0) for s in signals])


@dataclass(frozen=True)
class SideEvidence:
    """The probes' mean gyroscope vectors and the real windows' (one row per window)."""

    left: np.ndarray  # (3 L,)
    right: np.ndarray  # (3 L,)
    rms: float  # the probes' gyroscope RMS (all channels, both probes)
    windows: np.ndarray  # (n, 3 L)

    def decide(self, smp: SMP) -> tuple[SMP, dict[str, Any]]:
        """The SMP with the side the windows support, and the record of why."""
        d = 0.5 * (self.right - self.left)
        size = float(np.linalg.norm(d))
        record: dict[str, Any] = {"smp_side": smp.execution_attributes.dominant_side,
                                  "windows": int(len(self.windows)),
                                  "separation": round(size / max(self.rms, 1e-12), DECIMALS)}
        if size < MIN_SEPARATION * self.rms:
            return smp, {**record, "used": False, "reason": "the side does not show in the sensor"}
        if not len(self.windows):
            return smp, {**record, "used": False, "reason": "no real window of the class"}
        proj = self.windows @ (d / size)
        right = int(np.sum(proj > VOTE_FRACTION * size))
        left = int(np.sum(proj < -VOTE_FRACTION * size))
        p_right = (right + 1) / (right + left + 2)
        side = smp.execution_attributes.dominant_side if p_right == 0.5 else ("right" if p_right > 0.5 else "left")
        uncertainty = 1.0 - 2.0 * min(p_right, 1.0 - p_right)
        record.update({"used": True, "votes_right": right, "votes_left": left,
                       "p_right": round(p_right, DECIMALS), "side": side,
                       "uncertainty": round(uncertainty, DECIMALS)})
        return with_side(smp, side, uncertainty), record
