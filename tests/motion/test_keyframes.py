"""Keyframe strips show different phases of a repetitive motion, not the same one."""

from __future__ import annotations

import numpy as np

from vsmp_imu.motion import render
from vsmp_imu.motion.render import keyframe_indices, render_keyframes
from vsmp_imu.pipeline.sample import backend_for
from vsmp_imu.smp.library import ActivityLibrary


def _min_pair_distance(motion, frames) -> float:
    rel = (motion.positions - motion.positions[:, :1]).reshape(motion.n_frames, -1)[frames]
    d = np.linalg.norm(rel[:, None] - rel[None], axis=-1)
    return float(d[np.triu_indices(len(frames), 1)].min())


def test_keyframes_of_curls_show_different_phases(tmp_path, monkeypatch):
    curls = backend_for("procedural", ()).generate(ActivityLibrary.load().get("bicep_curls").smp, 0)
    even = np.linspace(0, curls.n_frames - 1, 6).round().astype(int)
    assert _min_pair_distance(curls, even) < 0.06  # evenly spaced frames repeat a phase (cm apart)
    frames = keyframe_indices(curls, 6)
    assert len(frames) == 6 and np.all(np.diff(frames) > 0)
    assert _min_pair_distance(curls, frames) > 0.15
    drawn = []
    original = render._Scene.draw
    monkeypatch.setattr(render._Scene, "draw", lambda self, frame, title=None: (drawn.append(frame),
                                                                               original(self, frame, title)))
    render_keyframes(curls, tmp_path / "curls.png", n=6, panel_px=80)
    assert drawn == frames.tolist()
