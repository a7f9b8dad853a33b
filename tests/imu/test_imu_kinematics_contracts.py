"""Exact contracts of the kinematics stage and its splines: output clock, input checks by field,
what the kinematics record, quaternion continuity and end padding, the body rate of a smoothed
rotation, and the smoothing spline against independent computations."""

from __future__ import annotations

import numpy as np
import pytest
from imu_motions import make_motion, spin, walking
from scipy.spatial.transform import Rotation

from vsmp_imu.errors import ValidationError
from vsmp_imu.imu.kinematics import (
    check_settings,
    continuous_quaternions,
    output_times,
    reflect_ends,
    simulate_kinematics,
    smooth_rotations,
)
from vsmp_imu.imu.placement import get_placement, location_names
from vsmp_imu.imu.sensor import VirtualSensor
from vsmp_imu.imu.spline import _gram_bands, smoothing_spline
from vsmp_imu.motion import Motion


@pytest.fixture(scope="module")
def motion():
    root, local = walking()
    return make_motion(2.0, 30.0, root, local)


# -- clock and checks ------------------------------------------------------------------------
def test_the_last_sample_never_passes_the_trimmed_end():
    """A span a hair short of a whole number of samples still gets that sample (the 1e-9 guard),
    clipped onto the trimmed end."""
    duration = 0.4 + 10 / 50 - 1e-12
    times = output_times(duration, 50.0, 0.2)
    assert len(times) == 11 and times[-1] == duration - 0.2
    assert np.all(np.diff(times) > 0)


def test_kinematics_check_their_settings_and_the_motion(motion):
    with pytest.raises(ValidationError) as err:
        simulate_kinematics(motion, "waist", 50.0, smoothing_hz=-2.0)
    assert err.value.field == "smoothing_hz"
    broken = Motion(motion.positions.copy(), motion.rotations.copy(), motion.fps)
    broken.positions[3, 0, 1] = np.nan
    with pytest.raises(ValidationError) as err:
        simulate_kinematics(broken, "waist", 50.0)
    assert (err.value.message, err.value.field) == ("motion has non-finite positions or rotations", "motion")
    with pytest.raises(ValidationError) as err:
        simulate_kinematics(make_motion(1 / 30, 30.0), "waist", 50.0, trim_s=0.0)  # two frames
    assert (err.value.message, err.value.field) == ("motion has 2 frame(s); the simulator needs at least 3",
                                                    "motion")


def test_slow_rates_and_cutoffs_and_three_frames_are_enough():
    check_settings(0.5, 0.5, 0.0)  # any positive rate and cutoff
    kin = simulate_kinematics(make_motion(2 / 30, 30.0), "waist", 50.0, trim_s=0.0)  # three frames
    assert kin.n_samples == 4 and np.isfinite(kin.gyr_seg).all()


def test_kinematics_record_how_they_were_made(motion):
    kin = simulate_kinematics(motion, "left_foot", 50, trim_s=0.25)
    assert kin.fs_hz == 50.0 and isinstance(kin.fs_hz, float)
    assert kin.meta == {
        "motion_fps": 30.0, "motion_frames": motion.n_frames, "smoothing_hz": 15.0, "trim_s": 0.25,
        "position_spline": "quintic P-spline, knots at frames, 3rd-difference penalty",
        "rotation_spline": "quintic P-spline through sign-continuous quaternions, same cutoff, renormalized",
    }


# -- quaternions -----------------------------------------------------------------------------
def test_only_quaternions_in_the_opposite_hemisphere_flip():
    q = Rotation.from_euler("y", np.linspace(0, 170, 6)[:, None], degrees=True).as_quat()
    flipped = q * np.array([1, -1, 1, -1, -1, 1])[:, None]
    assert np.allclose(continuous_quaternions(flipped), q)
    # at right angles (a half turn apart) neither sign is nearer: nothing flips
    ortho = np.array([[0.0, 0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0]])
    assert np.array_equal(continuous_quaternions(ortho), ortho)


def test_end_padding_continues_a_constant_rate_and_handles_short_input():
    rate = spin([0, 1, 0], 2.0)
    frames = rate(np.arange(4) / 30.0).as_quat()
    padded = reflect_ends(frames, 10)  # at most len - 1 = 3 frames each side
    assert padded.shape == (10, 4)
    expected = rate(np.arange(-3, 7) / 30.0)
    assert np.allclose(np.abs(np.sum(padded * expected.as_quat(), axis=1)), 1.0, atol=1e-12)
    two = reflect_ends(frames[:2], 5)
    assert two.shape == (4, 4)
    one = reflect_ends(np.array([[0, 0, 0, 1]]), 5)
    assert one.dtype == np.float64 and one.tolist() == [[0.0, 0.0, 0.0, 1.0]]


def test_the_body_rate_is_that_of_the_normalized_smoothed_rotation():
    """Smoothing a fast turn shrinks the splined quaternion; the rate must still be the rate of
    the rotation returned (checked by finite differences of that rotation)."""
    turn = spin([0.3, 1.0, 0.2], 9.0)
    frames = turn(np.arange(61) / 30.0).as_quat()
    times = np.linspace(0.5, 1.5, 41)
    rot, rate = smooth_rotations(frames, 30.0, 2.0, times)
    dt = 1e-5
    ahead, _ = smooth_rotations(frames, 30.0, 2.0, times + dt)
    behind, _ = smooth_rotations(frames, 30.0, 2.0, times - dt)
    numeric = (behind.inv() * ahead).as_rotvec() / (2 * dt)
    assert np.allclose(rate, numeric, atol=1e-4 * np.abs(numeric).max())


# -- locations -------------------------------------------------------------------------------
def test_location_words_accept_spaces_and_hyphens():
    assert get_placement("Left Wrist").name == "left_wrist"
    assert get_placement("right-thigh").name == "right_thigh"
    with pytest.raises(ValidationError) as err:
        get_placement("elbow pad")
    assert err.value.allowed == ", ".join(location_names())


def test_a_sensor_stores_its_biases_as_float_tuples():
    sensor = VirtualSensor.at("waist", acc_bias=[1, 2, 3], gyr_bias=np.array([0.5, 0, 0]))
    assert sensor.acc_bias == (1.0, 2.0, 3.0) and isinstance(sensor.acc_bias, tuple)
    assert sensor.gyr_bias == (0.5, 0.0, 0.0) and isinstance(sensor.gyr_bias, tuple)
    tiny = VirtualSensor.at("waist", mounting_xyzw=(1e-9, 0.0, 0.0, 0.0))
    assert tiny.mounting_xyzw == (1.0, 0.0, 0.0, 0.0)


# -- splines ---------------------------------------------------------------------------------
@pytest.mark.parametrize("width", [2, 4, 5, 7])
@pytest.mark.parametrize("bands", [1, 3, 5])
def test_gram_bands_hold_the_upper_bands_of_the_dense_product(width, bands):
    kernel = np.arange(1.0, width + 1.0) * (-1) ** np.arange(width)
    n_cols = 12
    n_rows = n_cols - width + 1
    dense = np.zeros((n_rows, n_cols))
    for i in range(n_rows):
        dense[i, i:i + width] = kernel
    gram = dense.T @ dense
    out = _gram_bands(kernel, n_rows, n_cols, bands)
    for k in range(bands + 1):
        assert np.allclose(out[bands - k, k:], np.diag(gram, k)), k


def test_the_smoothing_spline_halves_a_sinusoid_at_its_cutoff():
    fps, cutoff = 30.0, 4.0
    t = np.arange(600) / fps
    middle = slice(200, 400)
    for f, gain in ((cutoff, 0.5), (cutoff / 4, 1.0)):
        fit = smoothing_spline(np.sin(2 * np.pi * f * t), fps, cutoff)(t[middle])
        amplitude = np.sqrt(2 * np.mean(fit ** 2))
        assert amplitude == pytest.approx(gain, abs=0.02), f


def test_the_spline_keeps_the_shape_of_its_input_and_does_not_extrapolate():
    t = np.arange(5) / 10.0
    for cutoff in (None, 2.0, 8.0):  # three samples are enough, whatever the smoothing
        line = smoothing_spline(3.0 * t[:3], 10.0, cutoff)
        assert line(np.array([0.05])).shape == (1,) and line(0.05) == pytest.approx(0.15)
    curve = smoothing_spline(np.sin(t), 10.0, None)
    assert len(curve.c) == 5 + 4  # one coefficient per frame plus degree - 1, knots at the frames
    assert curve(t).shape == (5,) and np.allclose(curve(t), np.sin(t), atol=1e-6)
    assert np.isnan(curve(-0.01)) and np.isnan(curve(t[-1] + 0.01))
    for n in (1, 2):  # two samples leave the system singular (4 data and penalty rows, 6 coefficients)
        with pytest.raises(ValueError, match=f"^need at least 3 samples, got {n}$"):
            smoothing_spline(np.zeros(n), 10.0, None)
