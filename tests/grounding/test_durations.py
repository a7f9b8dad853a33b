"""Real event durations read back from windows cut by the dataset's labelling rule."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.grounding import durations as dur
from vsmp_imu.har.windows import Windows, label_windows, window_starts

FS, SIZE, STEP = 50.0, 128, 64


def _windows(events_s: list[float], share: float, gap_s: float = 6.0, recordings: int = 1) -> Windows:
    """Recordings of class 0 (rest) with class-1 events of the given durations, windowed by the rule."""
    ys, recs, starts = [], [], []
    per = np.array_split(np.asarray(events_s, float), recordings)
    for r, chunk in enumerate(per):
        labels = [np.zeros(int(gap_s * FS), np.int64)]
        for d in chunk:
            labels += [np.ones(int(round(d * FS)), np.int64), np.zeros(int(gap_s * FS), np.int64)]
        labels = np.concatenate(labels)
        s = window_starts(len(labels), SIZE, STEP)
        y = label_windows(labels, s, SIZE, np.array([1.0, share]))
        keep = y >= 0
        ys.append(y[keep])
        starts.append(s[keep])
        recs += [f"r{r}"] * int(keep.sum())
    y = np.concatenate(ys)
    return Windows(np.zeros((len(y), SIZE, 1)), y, np.full(len(y), "1"), ("rest", "event"), ("acc_x",), FS,
                   meta={"recording": np.array(recs), "start": np.concatenate(starts)})


def test_the_hop_is_read_from_the_starts_even_of_scattered_windows():
    w = _windows([3.0] * 6, 0.5, recordings=2)
    assert dur.window_hop(w) == STEP
    scattered = w[np.arange(0, len(w), 7)]  # no two windows one hop apart
    assert (np.diff(scattered.meta["start"]) != STEP).all() and dur.window_hop(scattered) == STEP
    no_meta = Windows(w.X, w.y, w.subjects, w.label_names, w.channel_names, FS)
    assert dur.window_hop(no_meta) is None
    no_recording = Windows(w.X, w.y, w.subjects, w.label_names, w.channel_names, FS, meta={"start": w.meta["start"]})
    assert dur.window_hop(no_recording) is None


def test_runs_are_consecutive_windows_of_the_class_in_one_recording():
    w = _windows([2.6, 3.9, 5.1, 2.6, 3.9, 5.1], 0.5, recordings=2)
    runs = dur.event_runs(w, 1, STEP)
    assert len(runs) == 6 and runs.sum() == int((w.y == 1).sum())
    assert list(runs[:3]) == sorted(runs[:3])  # longer events give more windows


@pytest.mark.parametrize("share", [0.5, 1.0])
def test_durations_read_back_within_a_hop_of_the_truth(share):
    rng = np.random.default_rng(0)
    truth = rng.uniform(4.0, 7.0, 40)  # each long enough for a whole window
    w = _windows(list(truth), share)
    seconds, reason = dur.event_durations(w, 1, STEP, SIZE, share, FS)
    assert reason == "40 events" and len(seconds) == 40
    assert np.abs(seconds - truth).max() <= STEP / FS + 1e-9
    assert abs(np.mean(seconds) - np.mean(truth)) < 0.25 * STEP / FS


def test_a_class_sampled_window_by_window_or_with_few_events_has_no_durations():
    w = _windows([4.0] * 30, 0.5)
    idx = np.flatnonzero(w.y == 1)[::4]  # a few windows per class, as a low-resource budget keeps
    sparse = w[np.r_[np.flatnonzero(w.y == 0), idx]]
    seconds, reason = dur.event_durations(sparse, 1, STEP, SIZE, 0.5, FS)
    assert len(seconds) == 0 and "stand alone" in reason
    few = _windows([4.0] * (dur.MIN_EVENTS - 1), 0.5)
    seconds, reason = dur.event_durations(few, 1, STEP, SIZE, 0.5, FS)
    assert len(seconds) == 0 and f"fewer than {dur.MIN_EVENTS}" in reason
    assert dur.summary(seconds, reason) == {"used": False, "reason": reason}


def test_a_draw_is_a_real_duration_spread_over_one_hop():
    durations = np.array([2.0, 4.0])
    rng = np.random.default_rng(1)
    draws = np.array([dur.draw_duration(durations, 1.28, rng) for _ in range(400)])
    near = np.minimum(np.abs(draws - 2.0), np.abs(draws - 4.0))
    assert near.max() <= 0.64 + 1e-9
    assert ((draws > 3.0).mean() > 0.4) and ((draws < 3.0).mean() > 0.4)  # both events drawn


def test_the_scale_times_the_active_span_to_the_target_within_its_bounds():
    assert dur.scale_for(3.0, 2.0) == pytest.approx(1.5)
    assert dur.scale_for(30.0, 2.0) == dur.SCALE_BOUNDS[1]
    assert dur.scale_for(0.1, 2.0) == dur.SCALE_BOUNDS[0]
