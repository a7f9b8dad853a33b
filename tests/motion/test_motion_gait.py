"""Walking stands on its feet: the waist moves once per step up and down and once per stride
from side to side, as a real waist does (HAPT's walking |acc| peaks at the step frequency),
and a walking pelvis carries no constant roll."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from vsmp_imu.imu import ImuSimulator
from vsmp_imu.motion import procedural
from vsmp_imu.motion.procedural import _feet_support, _walks

WALKS = ("walking", "walking_upstairs", "walking_downstairs", "nordic_walking")
SEEDS = (0, 1, 2, 3)


def _peak_hz(x: np.ndarray, fs: float) -> float:
    """Frequency of the largest spectral peak of x between 0.5 and 8 Hz."""
    x = x - x.mean()
    f = np.fft.rfftfreq(len(x), 1.0 / fs)
    p = np.abs(np.fft.rfft(x * np.hanning(len(x)))) ** 2
    band = (f > 0.5) & (f < 8.0)
    return float(f[band][np.argmax(p[band])])


def _step_hz(backend, smp, seed: int) -> float:
    plan = backend.plan(smp, seed, 20.0)
    return 2.0 / plan.cycle_s  # an alternating cycle holds two steps


@pytest.mark.parametrize("name", WALKS)
def test_the_waist_moves_once_per_step(backend, library, name):
    """|acc| at the waist peaks at the step frequency, not at twice it (as it did while the
    body rested on whichever joint was lowest)."""
    smp = library.get(name).smp
    for seed in SEEDS:
        motion = backend.generate(smp, seed=seed, duration_s=20.0)
        rec = ImuSimulator(fs_hz=50.0).simulate(motion, "waist")
        peak = _peak_hz(np.linalg.norm(rec.data[:, :3], axis=1), 50.0)
        step = _step_hz(backend, smp, seed)
        assert abs(peak - step) < 0.2 * step, (name, seed, peak, step)


def test_the_pelvis_sways_toward_the_stance_foot_once_per_stride(backend, library):
    smp = library.get("walking").smp
    for seed in SEEDS:
        m = backend.generate(smp, seed=seed, duration_s=20.0)
        side = m.positions[:, m.joint_names.index("pelvis"), 0]
        inner = side[int(2 * m.fps):-int(2 * m.fps)]
        assert 0.02 < np.ptp(inner) / (m.body_height_m() / 1.70) < 0.07  # 2-7 cm side to side
        stride_hz = _step_hz(backend, smp, seed) / 2.0
        assert abs(_peak_hz(side, m.fps) - stride_hz) < 0.2 * stride_hz


def test_a_walking_pelvis_is_level_on_average(backend, library):
    """The style's constant roll made one leg the longer one (a limp at the stride frequency)."""
    smp = library.get("walking").smp
    for seed in range(8):
        m = backend.generate(smp, seed=seed, duration_s=10.0)
        q = m.rotations[:, m.joint_names.index("pelvis")]
        roll = Rotation.from_quat(q).as_euler("YXZ", degrees=True)[:, 2]
        assert abs(roll.mean()) < 1.5, (seed, roll.mean())


def test_only_walking_stands_on_its_feet(library):
    from vsmp_imu.motion.recipe import recipe_for_entry

    kinds = {name: _walks(recipe_for_entry(library.get(name))) for name in
             ("walking", "walking_upstairs", "nordic_walking", "running", "sitting", "jumping_jacks")}
    assert kinds == {"walking": True, "walking_upstairs": True, "nordic_walking": True,
                     "running": False, "sitting": False, "jumping_jacks": False}


def test_the_lower_foot_carries_the_body_and_a_rising_heel_hands_half_to_the_toe():
    clearance = np.full(22, 0.05)
    names = procedural.SMPL22_JOINTS
    la, ra = names.index("left_ankle"), names.index("right_ankle")
    lf, rf = names.index("left_foot"), names.index("right_foot")
    heights = np.full((3, 22), 0.5)
    heights[:, [lf, rf]] = 0.2
    heights[0, la], heights[0, ra] = -0.90, -0.60  # left heel lower: the left foot carries
    heights[1, la], heights[1, ra] = -0.60, -0.90  # right heel lower
    heights[2, la], heights[2, ra] = -0.85, -0.85  # both: half each
    lift, w = _feet_support(heights, clearance)
    assert lift[0] == pytest.approx(0.95, abs=1e-3) and w[0, 0] > 0.99
    assert lift[1] == pytest.approx(0.95, abs=1e-3) and w[1, 1] > 0.99
    assert w[2].tolist() == pytest.approx([0.5, 0.5])
    toe = heights[:1].copy()
    toe[0, lf] = -0.95  # the left toe 5 cm below its heel: half of that lifts the body
    lift_toe, _ = _feet_support(toe, clearance)
    assert lift_toe[0] == pytest.approx(0.95 + 0.5 * 0.05, abs=1e-3)
