"""Windows: the labelling rule, geometry, slicing and concatenation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from vsmp_imu.errors import ValidationError
from vsmp_imu.har.windows import (
    Windows,
    concat_windows,
    label_windows,
    window_geometry,
    window_starts,
)


def _windows(n=6, t=10, c=3, n_classes=3, subject="1"):
    rng = np.random.default_rng(0)
    return Windows(
        rng.normal(size=(n, t, c)),
        np.arange(n) % n_classes,
        [subject] * n,
        [f"c{i}" for i in range(n_classes)],
        [f"ch{i}" for i in range(c)],
        10.0,
        meta={"start": np.arange(n)},
    )


def test_pure_windows_need_every_sample():
    labels = np.array([0] * 10 + [1] * 10)
    starts = window_starts(len(labels), 5, 5)
    y = label_windows(labels, starts, 5, np.array([1.0, 1.0]))
    assert y.tolist() == [0, 0, 1, 1]
    # a window straddling the change is dropped when every sample must agree
    y = label_windows(labels, np.array([8]), 5, np.array([1.0, 1.0]))
    assert y.tolist() == [-1]


def test_transition_share_rule():
    # activity 0 needs all samples, transition 1 needs half of them
    labels = np.array([0] * 6 + [1] * 4 + [-1] * 2)
    share = np.array([1.0, 0.5])
    assert label_windows(labels, np.array([2]), 8, share).tolist() == [1]  # 4 of 8 transition
    assert label_windows(labels, np.array([0]), 8, share).tolist() == [-1]  # 2 of 8
    assert label_windows(labels, np.array([0]), 6, share).tolist() == [0]
    # unlabelled samples never make a class
    assert label_windows(np.full(8, -1), np.array([0]), 8, share).tolist() == [-1]


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 500), size=st.integers(2, 60), overlap=st.floats(0, 0.95))
def test_window_starts_cover_recording(n, size, overlap):
    step = max(1, int(round(size * (1 - overlap))))
    starts = window_starts(n, size, step)
    assert len(starts) == (0 if n < size else (n - size) // step + 1)
    assert (starts + size <= n).all()


def test_window_geometry_and_errors():
    assert window_geometry(50, 2.0, 0.5) == (100, 50)
    assert window_geometry(100, 2.0, 0.0) == (200, 200)
    with pytest.raises(ValidationError, match="overlap"):
        window_geometry(50, 2.0, 1.0)
    with pytest.raises(ValidationError, match="positive"):
        window_geometry(50, 0, 0.5)


def test_slicing_keeps_everything_aligned():
    w = _windows()
    sub = w[w.y == 1]
    assert len(sub) == 2 and (sub.y == 1).all()
    assert sub.meta["start"].tolist() == [1, 4]
    assert sub.label_names == w.label_names and sub.fs_hz == 10.0
    assert w[2:4].X.shape == (2, 10, 3)
    assert w.class_counts().tolist() == [2, 2, 2]


def test_concat_fills_missing_meta_and_checks_compatibility():
    a = _windows(subject="1")
    b = Windows(a.X[:2], a.y[:2], ["2", "2"], a.label_names, a.channel_names, a.fs_hz)
    both = concat_windows([a, b])
    assert len(both) == 8 and both.unique_subjects() == ["1", "2"]
    assert both.meta["start"].tolist()[-2:] == [-1, -1]
    other = Windows(a.X[:2], a.y[:2], ["2", "2"], a.label_names, a.channel_names, 20.0)
    with pytest.raises(ValidationError, match="sampling rate"):
        concat_windows([a, other])


def test_invalid_windows_are_refused():
    with pytest.raises(ValidationError, match="index label_names"):
        Windows(np.zeros((2, 4, 1)), [0, 5], ["1", "1"], ["a", "b"], ["x"], 10)
    with pytest.raises(ValidationError, match="channel names"):
        Windows(np.zeros((2, 4, 2)), [0, 1], ["1", "1"], ["a", "b"], ["x"], 10)
