"""`vsmp_imu.zero_phase.filtfilt` is scipy's `sosfiltfilt` to the bit, with its state kept per design."""

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from vsmp_imu import zero_phase
from vsmp_imu.zero_phase import filtfilt

DESIGNS = {
    "texture HF band": butter(4, [3.0, 12.0], btype="band", fs=50.0, output="sos"),
    "texture LF band": butter(4, [0.3, 3.0], btype="band", fs=50.0, output="sos"),
    "motion low-pass": butter(2, 0.3, output="sos"),
}


@pytest.mark.parametrize("design", DESIGNS)
@pytest.mark.parametrize(("shape", "axis"), [((200,), 0), ((200, 6), 0), ((6, 200), -1), ((4, 200, 6), 1)])
@pytest.mark.parametrize("padlen", [None, 0, 7, 40])
def test_equals_sosfiltfilt_to_the_bit(design, shape, axis, padlen):
    sos = DESIGNS[design]
    x = np.random.default_rng(len(shape) + (padlen or 0)).standard_normal(shape) * 3.0 + 9.81
    expected = sosfiltfilt(sos, x, axis=axis, padlen=padlen)
    got = filtfilt(sos, x, axis=axis, padlen=padlen)
    assert got.shape == expected.shape
    assert np.array_equal(got, expected)


def test_the_state_is_solved_once_per_design(monkeypatch):
    sos = butter(3, [1.0, 5.0], btype="band", fs=40.0, output="sos")
    zero_phase._STATES.clear()
    solved = []
    real = zero_phase.sosfilt_zi
    monkeypatch.setattr(zero_phase, "sosfilt_zi", lambda s: solved.append(s) or real(s))
    x = np.random.default_rng(0).standard_normal((120, 3))
    first = filtfilt(sos, x, axis=0)
    assert np.array_equal(filtfilt(sos, x, axis=0), first)
    filtfilt(butter(2, 0.2, output="sos"), x, axis=0)
    assert len(solved) == 2


def test_a_signal_shorter_than_the_padding_is_refused_as_scipy_does():
    sos = DESIGNS["motion low-pass"]
    with pytest.raises(ValueError, match="greater than padlen"):
        sosfiltfilt(sos, np.zeros(10), padlen=10)
    with pytest.raises(ValueError, match="greater than padlen, which is 10"):
        filtfilt(sos, np.zeros(10), padlen=10)
