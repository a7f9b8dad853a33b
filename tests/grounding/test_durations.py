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


def _runs(runs: list[int], recordings: list[str] | None = None, hop: int = STEP) -> Windows:
    """Class-1 windows in runs of the given lengths, one hop apart, each run followed by a class-0
    window; the runs in recording r0 unless `recordings` names one per run."""
    recordings = recordings or ["r0"] * len(runs)
    ys, recs, starts, pos = [], [], [], {}
    for n, rec in zip(runs, recordings, strict=True):
        p = pos.get(rec, hop)
        ys += [1] * n + [0]
        starts += [p + i * hop for i in range(n + 1)]
        recs += [rec] * (n + 1)
        pos[rec] = p + (n + 1) * hop
    n = len(ys)
    return Windows(np.zeros((n, SIZE, 1)), np.array(ys), np.full(n, "1"), ("rest", "event"), ("acc_x",), FS,
                   meta={"recording": np.array(recs), "start": np.array(starts)})


def _meta(start: list[int], recording: list[str]) -> Windows:
    n = len(start)
    return Windows(np.zeros((n, SIZE, 1)), np.zeros(n, int), np.full(n, "1"), ("rest", "event"), ("acc_x",), FS,
                   meta={"recording": np.array(recording), "start": np.array(start)})


def test_the_hop_needs_two_windows_and_a_window_past_its_recordings_start():
    assert dur.window_hop(_meta([192], ["r0"])) is None  # one window: its start is no hop
    assert dur.window_hop(_meta([128, 192], ["r0", "r0"])) == 64
    # windows that all open their recordings carry no hop (not a hop of 0)
    assert dur.window_hop(_meta([0, 0, 0], ["r0", "r1", "r2"])) is None
    # a hop of one sample, read from scattered windows whose other starts share a factor 2
    assert dur.window_hop(_meta([0, 1, 4, 6], ["r0"] * 4)) == 1


def test_a_class_with_no_windows_no_recordings_or_one_window_has_that_many_events():
    w = _runs([3, 1, 2])
    assert list(dur.event_runs(w, 1, STEP)) == [3, 1, 2]
    absent = w[w.y == 0]
    assert len(dur.event_runs(absent, 1, STEP)) == 0
    assert dur.event_durations(absent, 1, STEP, SIZE, 0.5, FS)[1].startswith("0 event(s)")
    one = w[np.r_[np.flatnonzero(w.y == 0), 0]]
    assert list(dur.event_runs(one, 1, STEP)) == [1]
    assert dur.event_durations(one, 1, STEP, SIZE, 0.5, FS)[1].startswith("1 event(s)")
    for meta in ({"start": w.meta["start"]}, {"recording": w.meta["recording"]}, {}):
        bare = Windows(w.X, w.y, w.subjects, w.label_names, w.channel_names, FS, meta=meta)
        assert len(dur.event_runs(bare, 1, STEP)) == 0
        assert dur.event_durations(bare, 1, STEP, SIZE, 0.5, FS)[1].startswith("0 event(s)")


def test_exactly_min_events_events_are_enough():
    runs = list(range(2, 2 + dur.MIN_EVENTS))
    seconds, reason = dur.event_durations(_runs(runs), 1, STEP, SIZE, 0.5, FS)
    assert reason == f"{dur.MIN_EVENTS} events"
    # at share 0.5 an event of n windows lasts n hops
    assert seconds == pytest.approx(np.array(runs) * STEP / FS)


def test_runs_of_two_count_and_half_the_windows_in_runs_is_enough():
    runs = [2, 2, 1, 1, 1, 1]  # 4 of 8 windows in runs of two
    seconds, reason = dur.event_durations(_runs(runs), 1, STEP, SIZE, 1.0, FS)
    assert reason == "6 events"
    # at share 1 every window lies wholly inside: an event of n windows lasts n hops and one window
    assert seconds == pytest.approx((np.array(runs) * STEP + SIZE) / FS)


def test_a_class_mostly_of_lone_windows_says_how_many_stand_alone():
    seconds, reason = dur.event_durations(_runs([2, 1, 1, 1, 1, 1, 1]), 1, STEP, SIZE, 0.5, FS)
    assert len(seconds) == 0
    assert reason == ("75 % of its windows stand alone: sampled window by window, "
                      "not recorded as events")


def test_a_draw_picks_an_event_and_a_place_in_its_hop_from_the_stream():
    durations, hop_s = np.array([2.0, 3.5, 5.0]), 1.28
    for seed in range(20):
        stream = np.random.default_rng(seed)
        event = durations[stream.integers(3)]
        offset = stream.uniform(-0.5, 0.5)
        assert dur.draw_duration(durations, hop_s, np.random.default_rng(seed)) == pytest.approx(
            event + offset * hop_s)


def test_the_shortest_event_spreads_over_its_hop():
    """event_durations returns at least one hop; a draw of that covers half a hop either side."""
    hop_s = 0.4
    rng = np.random.default_rng(2)
    draws = np.array([dur.draw_duration(np.array([hop_s]), hop_s, rng) for _ in range(200)])
    assert draws.min() >= 0.5 * hop_s - 1e-12 and draws.max() <= 1.5 * hop_s + 1e-12
    assert draws.min() < 0.55 * hop_s and draws.max() > 1.45 * hop_s
    # an event shorter than half a hop is drawn as half a hop
    assert dur.draw_duration(np.array([0.0]), hop_s, rng) == pytest.approx(0.5 * hop_s)


def test_the_scale_of_a_short_active_span():
    assert dur.scale_for(1.0, 0.5) == pytest.approx(2.0)
    assert dur.scale_for(0.3, 0.25) == pytest.approx(1.2)


def test_the_summary_keeps_count_median_and_quantiles_in_milliseconds():
    values = np.array([1.00049, 2.00049, 3.00049, 4.00049, 5.00049])
    assert dur.summary(values, "5 events") == {"used": True, "events": 5, "median_s": 3.0,
                                               "q10_s": 1.4, "q90_s": 4.6}
    assert np.median(values) == pytest.approx(3.00049)  # the 4th decimal the rounding drops
