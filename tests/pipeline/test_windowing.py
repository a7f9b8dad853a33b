"""How a sample's grounded signal is cut into labelled windows (`pipeline.fold.window`)."""

from __future__ import annotations

import numpy as np
import pytest

from vsmp_imu.har.dataset import DatasetInfo, SensorLocation, imu_channel_names
from vsmp_imu.motion.motion import Motion
from vsmp_imu.pipeline.fold import window
from vsmp_imu.pipeline.records import LocationProvenance, MotionSummary, Provenance
from vsmp_imu.pipeline.sample import ACTIVE_SPEED_FRACTION, SampleResult, active_span

FS, LENGTH, HOP = 50.0, 100, 50
NAMES = imu_channel_names(None)
INFO = DatasetInfo(name="postures", fs_hz=FS, label_names=("standing", "stand_to_sit"), channel_names=NAMES,
                   locations=(SensorLocation("waist", NAMES, ("up", "left", "backward"), True, "m/s^2", "rad/s",
                                             "documented"),),
                   min_share={"stand_to_sit": 0.5})


def _sample(label_index: int, duration_s: float, span_s: list[float]) -> SampleResult:
    n = int(duration_s * FS)
    motion = MotionSummary(fps=FS, n_frames=n, duration_s=duration_s, body_height_m=1.7, active_span_s=span_s)
    where = LocationProvenance(0.0, {}, [0, 0, 0, 1], [0, 0, 0, 1], None, {})
    provenance = Provenance("test", INFO.label_names[label_index], 0, "smp", "", "procedural", 0, motion,
                            None, {"waist": where})
    signal = np.tile(np.arange(n, dtype=float)[:, None], (1, 6))  # sample index in every channel
    return SampleResult(f"s{label_index}", label_index, {"waist": signal}, provenance)


def _starts(label_index: int, duration_s: float, span_s: list[float]) -> list[int]:
    result = _sample(label_index, duration_s, span_s)
    windows = window(INFO, [result], [result.signals], LENGTH, HOP)
    return [int(x[0, 0]) for x in windows.X]


def test_a_whole_window_class_is_cut_at_the_hop():
    assert _starts(0, 5.0, [0.0, 5.0]) == [0, 50, 100, 150]


def test_a_transition_keeps_the_windows_its_active_span_covers_for_its_share():
    # active from sample 50 to 175, share 0.5: the windows at 0, 50 and 100 have 50, 100 and
    # 75 of their 100 samples inside it, the one at 150 only 25
    assert _starts(1, 5.0, [1.0, 3.5]) == [0, 50, 100]
    assert _starts(1, 5.0, [3.2, 3.9]) == []  # a span shorter than half a window labels none


def test_the_active_span_is_where_the_body_moves_faster_than_a_share_of_its_peak():
    """A movement whose speed rises and falls as sin^2 between 1 s and 5 s: the span runs
    while the mean joint speed is above ACTIVE_SPEED_FRACTION of its peak."""
    fps = 50.0
    t = np.arange(0, 6, 1 / fps)
    speed = np.where((t > 1) & (t < 5), np.sin(np.pi * (t - 1) / 4) ** 2, 0.0)
    positions = np.zeros((len(t), 22, 3))
    positions[:, 1:, 0] = np.cumsum(speed)[:, None] / fps
    rotations = np.tile([0.0, 0.0, 0.0, 1.0], (len(t), 22, 1))
    start, end = active_span(Motion(positions, rotations, fps))
    onset = 4 / np.pi * np.arcsin(np.sqrt(ACTIVE_SPEED_FRACTION))
    assert start == pytest.approx(1 + onset, abs=0.05)
    assert end == pytest.approx(5 - onset, abs=0.05)
    # the root's own travel does not count
    positions[:, :, 2] += t[:, None]
    assert active_span(Motion(positions, rotations, fps)) == pytest.approx([start, end])
