"""Event durations from the real training windows, and a sample's motion timed to one of them.

A discrete event (a postural transition, a single gesture) lasts as long as the person takes,
and how many windows it yields, and how much of the motion each window holds, follows from that
duration. The real windows carry it: the consecutive windows (one hop apart) of a class in one
recording are one event, and a window belongs to an event when at least `share` of it lies
inside (the dataset's labelling rule), so an event of D seconds yields about
(D - (2 share - 1) L) / hop windows of length L. Inverting that over the training subjects'
events gives the class's real durations.

A class sampled window by window (the low-resource protocol keeps a few windows per class) has
no events: its windows rarely sit next to one another. Such a class, or one with fewer than
`MIN_EVENTS` events, gets no durations, and its samples keep the SMP's timing.

A timed sample of a class with durations (every other round of its SMP variants,
`pipeline.fold.sample_tasks`) draws one (a real event's, de-quantized by a uniform draw over one
hop) and its motion is generated a second time with every primitive's duration scaled so that
its active span (`pipeline.sample.active_span`) lasts that long; the scale is clipped to
`SCALE_BOUNDS`.
"""

from __future__ import annotations

import numpy as np

from vsmp_imu.grounding import floors
from vsmp_imu.har.windows import Windows

MIN_EVENTS = floors.EVENT_DURATIONS.floor  # events a class needs before its durations are used
# a class whose windows mostly stand alone (no same-class neighbour one hop away) was sampled
# window by window, not recorded as events
MIN_RUN_SHARE = 0.5
SCALE_BOUNDS = (0.5, 2.5)  # the factor a sample's primitive durations may be scaled by


def window_hop(windows: Windows) -> int | None:
    """The hop between the real windows in samples: every window starts a whole number of hops into
    its recording, so the hop is the starts' greatest common divisor (also where only a few scattered
    windows are kept, as in the low-resource protocol, whose commonest step is many hops)."""
    if "start" not in windows.meta or "recording" not in windows.meta or len(windows) < 2:
        return None
    start = np.asarray(windows.meta["start"]).astype(np.int64)
    start = start[start > 0]
    return int(np.gcd.reduce(start)) if len(start) else None


def event_runs(windows: Windows, label_index: int, hop: int) -> np.ndarray:
    """Window counts of the class's events: runs of its windows one hop apart in one recording."""
    if "recording" not in windows.meta or "start" not in windows.meta:
        return np.zeros(0, dtype=int)
    mask = windows.y == label_index
    rec = np.asarray(windows.meta["recording"])[mask].astype(str)
    start = np.asarray(windows.meta["start"])[mask].astype(np.int64)
    if len(start) == 0:
        return np.zeros(0, dtype=int)
    order = np.lexsort((start, rec))
    rec, start = rec[order], start[order]
    breaks = (rec[1:] != rec[:-1]) | (np.diff(start) != hop)
    edges = np.r_[0, np.flatnonzero(breaks) + 1, len(start)]
    return np.diff(edges)


def event_durations(windows: Windows, label_index: int, hop: int, length: int, share: float,
                    fs_hz: float) -> tuple[np.ndarray, str]:
    """The class's real event durations in seconds (empty when it has none), and why."""
    runs = event_runs(windows, label_index, hop)
    if len(runs) < MIN_EVENTS:
        return np.zeros(0), f"{len(runs)} event(s) in the training windows, fewer than {MIN_EVENTS}"
    in_runs = float(runs[runs >= 2].sum()) / float(runs.sum())
    if in_runs < MIN_RUN_SHARE:
        return np.zeros(0), (f"{100 * (1 - in_runs):.0f} % of its windows stand alone: sampled window "
                             "by window, not recorded as events")
    seconds = (runs * hop + (2.0 * share - 1.0) * length) / fs_hz
    return np.maximum(seconds, hop / fs_hz), f"{len(runs)} events"


def draw_duration(durations: np.ndarray, hop_s: float, rng: np.random.Generator) -> float:
    """One real event's duration, spread uniformly over the hop its window count resolves."""
    value = float(durations[rng.integers(len(durations))]) + rng.uniform(-0.5, 0.5) * hop_s
    return max(value, 0.5 * hop_s)


def scale_for(target_s: float, active_s: float) -> float:
    """The duration factor that makes an active span of `active_s` last `target_s`, clipped."""
    return float(np.clip(target_s / max(active_s, 1e-3), *SCALE_BOUNDS))


def summary(durations: np.ndarray, reason: str) -> dict:
    """What the generation summary (and `generate`'s report) keeps of a class's durations."""
    return spread_summary(durations, reason, "events", "s")


def spread_summary(values: np.ndarray, reason: str, count: str, unit: str) -> dict:
    """Whether a class's real values are used, how many (`count`), their median and 10 and 90 %
    quantiles (keys suffixed by `unit`); or why not."""
    if len(values) == 0:
        return {"used": False, "reason": reason}
    return {"used": True, count: len(values), f"median_{unit}": round(float(np.median(values)), 3),
            f"q10_{unit}": round(float(np.quantile(values, 0.1)), 3),
            f"q90_{unit}": round(float(np.quantile(values, 0.9)), 3)}
