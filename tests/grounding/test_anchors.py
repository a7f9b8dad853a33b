"""Posture anchors (grounding.anchors): fitting, blending, and one rigid body's gyroscope."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.grounding.anchors import anchor, blend_weights, fit_anchor, frame_rate

G = np.array([0.0, 0.0, 9.81])


def test_an_anchor_turns_the_synthetic_mean_onto_the_real_one():
    real = Rotation.from_euler("x", 12, degrees=True).apply(G)
    a = fit_anchor("SITTING", G, real)
    assert a.angle_deg == pytest.approx(12.0, abs=1e-9)
    assert np.allclose(Rotation.from_rotvec(a.rotvec).apply(G), real)
    assert fit_anchor("WALKING", np.array([0.5, 0, 0.5]), real) is None  # no gravity in the mean


def test_a_signal_held_at_an_anchor_gets_its_rotation():
    real = Rotation.from_euler("y", -8, degrees=True).apply(G)
    a = fit_anchor("STANDING", G, real)
    other = fit_anchor("LAYING", np.array([9.81, 0, 0]), np.array([9.81, 0, 0.5]))
    sig = np.tile(np.r_[G, 0.1, 0.0, 0.0], (200, 1))
    out = anchor(sig, [a, other], 50.0)
    assert np.allclose(out[:, :3].mean(axis=0), real, atol=0.15)
    w = blend_weights(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]), [a, other])
    assert w[0, 0] > 0.99 and w[1, 1] > 0.99 and np.allclose(w.sum(axis=1), 1.0)


def test_the_turning_rotation_shows_in_the_gyroscope_as_a_rigid_body_would():
    fs, t = 50.0, np.arange(300) / 50.0
    body = Rotation.from_euler("z", 0.4 * t[:, None])  # sensor -> world, turning at 0.4 rad/s
    extra = Rotation.from_euler("x", 0.2 * np.sin(t)[:, None])  # D(t): readings turned by it
    turned = body * extra.inv()  # the sensor whose readings are D(t) times the old ones
    rel = (turned[:-1].inv() * turned[1:]).as_rotvec() * fs  # its body rate, finite differences
    gyr = body.inv().apply(np.tile([0, 0, 0.4], (len(t), 1)))
    new = extra.apply(gyr) + frame_rate(extra, fs)
    mid = 0.5 * (new[:-1] + new[1:])
    assert np.abs(mid[5:-5] - rel[5:-5]).max() < 5e-3
