"""Movement texture (grounding.texture): ratios from real windows, texture only where it lacks."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.signal import butter, sosfiltfilt

from vsmp_imu.errors import ValidationError
from vsmp_imu.grounding.texture import (
    HF_BAND_HZ,
    LF_BAND_HZ,
    TextureModel,
    _unit_band_noise,
    add_texture,
    band_energies,
    bands,
    missing_amplitude,
)
from vsmp_imu.zero_phase import filtfilt

FS = 50.0


@pytest.fixture
def rng():
    return np.random.default_rng(0)


def _sines(n: int, t: int, lf_amp: float, hf_amp: float, rng) -> np.ndarray:
    """(n, t, 2) windows: a 1 Hz sine of lf_amp plus a 6 Hz sine of hf_amp, random phases."""
    time = np.arange(t) / FS
    phase = rng.uniform(0, 2 * np.pi, size=(n, 1, 2))
    return (lf_amp * np.sin(2 * np.pi * 1.0 * time[None, :, None] + phase)
            + hf_amp * np.sin(2 * np.pi * 6.0 * time[None, :, None] + 2 * phase))


def _band_std(x: np.ndarray, band) -> np.ndarray:
    sos = butter(4, band, btype="band", fs=FS, output="sos")
    return sosfiltfilt(sos, x, axis=0).std(axis=0)


def test_kappa_is_the_hf_to_lf_amplitude_ratio_per_class_and_pooled(rng):
    a = _sines(30, 200, 1.0, 0.5, rng)  # class 0: ratio 0.5
    b = _sines(30, 200, 2.0, 0.4, rng)  # class 1: ratio 0.2
    c = _sines(5, 200, 1.0, 1.0, rng)  # class 2: too few windows for its own
    model = TextureModel(FS, min_class_windows=20).fit(np.concatenate([a, b, c]), np.repeat([0, 1, 2], [30, 30, 5]))
    assert model.kappa(0) == pytest.approx([0.5, 0.5], rel=0.05)
    assert model.kappa(1) == pytest.approx([0.2, 0.2], rel=0.05)
    # pooled: energy-weighted, so the class with the larger motion (b) weighs more
    pooled = np.sqrt((30 * 0.25 + 30 * 0.16 + 5 * 1.0) / (30 * 1 + 30 * 4 + 5 * 1))
    assert model.kappa(2) == pytest.approx([pooled, pooled], rel=0.05)
    assert model.kappa(7) is model.pooled_  # a class never seen (the unseen protocol)
    assert [model.mapping(i) for i in (0, 1, 2, 7)] == ["class", "class", "pooled", "pooled"]


def test_band_energies_in_blocks_and_threads_are_those_of_all_windows_at_once(rng):
    x = rng.normal(size=(600, 120, 3)).astype(np.float32)  # more windows than one block
    x64 = x.astype(np.float64)
    whole = [(filtfilt(butter(4, band, btype="band", fs=FS, output="sos"), x64, axis=1) ** 2).sum(axis=1)
             for band in (LF_BAND_HZ, HF_BAND_HZ)]
    for threads in (1, 2):
        blocks = band_energies(x, FS, threads)
        assert all(np.array_equal(b, w) for b, w in zip(blocks, whole, strict=True))
    labels = np.repeat([0, 1], 300)
    one, two = TextureModel(FS).fit(x, labels), TextureModel(FS).fit(x, labels, threads=2)
    assert one.as_dict(["a", "b"]) == two.as_dict(["a", "b"])
    assert np.array_equal(one.pooled_, two.pooled_) and np.array_equal(one.kappa(1), two.kappa(1))


def test_a_smooth_motion_gets_the_hf_share_the_real_windows_have(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    smooth = _sines(1, 1000, 1.0, 0.0, rng)[0]
    out = model.apply(smooth, 0, np.random.default_rng(1))
    ratio = _band_std(out, HF_BAND_HZ) / _band_std(out, LF_BAND_HZ)
    np.testing.assert_allclose(ratio, 0.5, rtol=0.15)
    # the motion itself is kept: what was added lies above it
    assert (_band_std(out - smooth, (0.3, 1.5)) < 0.05 * _band_std(smooth, (0.3, 1.5))).all()


def test_nothing_is_added_to_a_still_signal_or_to_one_with_texture_enough(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.3, rng), np.zeros(40, int))
    still = np.full((500, 2), 9.81)
    assert np.abs(model.apply(still, 0, np.random.default_rng(0)) - still).max() < 1e-6
    rough = _sines(1, 500, 1.0, 0.6, rng)[0]  # HF above kappa x LF everywhere
    assert np.abs(model.apply(rough, 0, np.random.default_rng(0)) - rough).max() < 0.02


def test_the_texture_follows_the_motion_in_time(rng):
    """A posture, then a movement: texture only where the movement is."""
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    signal = np.zeros((1000, 2))
    signal[500:] = _sines(1, 500, 1.0, 0.0, rng)[0]
    added = model.apply(signal, 0, np.random.default_rng(0)) - signal
    assert np.abs(added[:400]).max() < 0.01 * np.abs(added[600:]).max()


def test_same_generator_same_bytes_and_unfitted_or_unfilterable_left_alone(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    x = _sines(1, 400, 1.0, 0.0, rng)[0]
    one = model.apply(x, 0, np.random.default_rng(5))
    assert one.tobytes() == model.apply(x, 0, np.random.default_rng(5)).tobytes()
    assert one.tobytes() != model.apply(x, 0, np.random.default_rng(6)).tobytes()
    assert np.array_equal(TextureModel(FS).apply(x, 0, rng), x)  # nothing fitted
    assert TextureModel(FS).mapping(0) == "none"
    assert np.array_equal(model.apply(x[:20], 0, rng), x[:20])  # too short to filter
    slow = TextureModel(6.0).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))  # no HF band at 6 Hz
    assert bands(6.0) is None and slow.pooled_ is None
    assert bands(20.0)[1][1] == pytest.approx(9.0)  # the HF band stops below the Nyquist rate


def test_nothing_fitted_says_why(rng):
    """No room for the band below 8 Hz (its top stays under 0.45 x the rate), windows too short to
    filter, or none: no ratio, and the summary says which."""
    labels = np.zeros(30, int)
    assert "that needs 8 Hz" in TextureModel(7.9).fit(rng.normal(size=(30, 40, 2)), labels).as_dict(["a"])["reason"]
    assert "reason" not in TextureModel(8.0).fit(rng.normal(size=(30, 40, 2)), labels).as_dict(["a"])
    assert "too short" in TextureModel(FS).fit(rng.normal(size=(30, 10, 2)), labels).as_dict(["a"])["reason"]
    assert TextureModel(FS).fit(np.zeros((0, 100, 2)), labels[:0]).as_dict(["a"])["reason"] == "no real windows"


def test_channel_and_shape_errors_name_the_field(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    with pytest.raises(ValidationError, match="channels"):
        model.apply(np.zeros((400, 3)), 0, rng)
    with pytest.raises(ValidationError, match=r"\(N, T, C\)"):
        TextureModel(FS).fit(np.zeros((40, 200)), np.zeros(40, int))


def test_the_shortest_window_is_the_one_the_zero_phase_filter_takes(rng):
    """At 50 Hz the order-4 band-passes have 4 sections: sosfiltfilt pads 3 x 9 = 27 samples and needs
    a longer signal, so 28 samples fit and get texture and 27 are too short (the summary says 28)."""
    sos = butter(4, LF_BAND_HZ, btype="band", fs=FS, output="sos")
    sosfiltfilt(sos, np.zeros((28, 2)), axis=0)  # the filter takes 28 samples ...
    with pytest.raises(ValueError):
        sosfiltfilt(sos, np.zeros((27, 2)), axis=0)  # ... and not 27
    labels = np.zeros(40, int)
    fitted = TextureModel(FS).fit(_sines(40, 28, 1.0, 0.5, rng), labels)
    assert fitted.reason_ is None and fitted.mapping(0) == "class"
    short = TextureModel(FS).fit(_sines(40, 27, 1.0, 0.5, rng), labels)
    assert short.reason_ == "windows of 27 samples are too short to filter: that needs 28"
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), labels)
    smooth = _sines(1, 28, 1.0, 0.0, rng)[0]
    assert np.abs(model.apply(smooth, 0, np.random.default_rng(2)) - smooth).max() > 1e-3
    assert np.array_equal(model.apply(smooth[:27], 0, np.random.default_rng(2)), smooth[:27])


def test_the_summary_section_lists_the_ratios_to_four_decimals_under_the_class_names(rng):
    """`as_dict` is what the generation summary and provenance show: the pooled ratios and each class
    with its own ratios, by label name, to 4 decimals (JSON lists); classes without their own are absent."""
    a = _sines(20, 200, 1.0, 0.5, rng)
    b = _sines(5, 200, 1.0, 0.3, rng)
    model = TextureModel(FS, min_class_windows=20).fit(np.concatenate([a, b]), np.repeat([1, 0], [20, 5]))
    report = json.loads(json.dumps(model.as_dict(["sit", "walk"])))
    assert set(report) == {"pooled", "classes"}
    assert list(report["classes"]) == ["walk"]  # class 1 by its name; "sit" (5 windows) has none
    for shown, fitted in ((report["pooled"], model.pooled_), (report["classes"]["walk"], model.kappa(1))):
        assert len(shown) == 2
        for value, kappa in zip(shown, fitted, strict=True):
            assert abs(value - kappa) <= 5e-5  # the fitted ratio ...
            assert value == round(value, 4) and value != round(float(kappa), 5)  # ... to 4 decimals, not 5
    assert report["classes"]["walk"] != report["pooled"]


def test_a_class_with_exactly_the_floor_of_windows_gets_its_own_ratio(rng):
    windows = np.concatenate([_sines(20, 200, 1.0, 0.5, rng), _sines(19, 200, 1.0, 0.2, rng)])
    model = TextureModel(FS, min_class_windows=20).fit(windows, np.repeat([0, 1], [20, 19]))
    assert model.mapping(0) == "class" and model.kappa(0) == pytest.approx([0.5, 0.5], rel=0.05)
    assert model.mapping(1) == "pooled"


def test_no_band_just_below_8_hz_and_the_reason_names_the_band():
    """The band needs a top above 1.2 x 3 Hz = 0.45 x 8 Hz: at the largest rate below 8 Hz the top is
    exactly 3.6 Hz (in floating point) and no band is left; at 8 Hz there is one."""
    below = float(np.nextafter(8.0, 0.0))
    assert bands(below) is None
    assert bands(8.0) is not None
    reason = TextureModel(7.5).fit(np.zeros((30, 100, 2)), np.zeros(30, int)).reason_
    assert reason == "a sampling rate of 7.5 Hz leaves no room for the 3-12 Hz band: that needs 8 Hz"


def test_the_errors_name_the_field_to_fix(rng):
    model = TextureModel(FS).fit(_sines(40, 200, 1.0, 0.5, rng), np.zeros(40, int))
    with pytest.raises(ValidationError) as err:
        model.apply(np.zeros((400, 3)), 0, rng)
    assert err.value.field == "channels" and "expected 2 channels, got 3" in str(err.value)
    assert "field 'channels'" in str(err.value)
    with pytest.raises(ValidationError) as err:
        TextureModel(FS).fit(np.zeros((40, 200)), np.zeros(40, int))
    assert err.value.field == "windows" and "expected windows (N, T, C), got shape (40, 200)" in str(err.value)
    assert "field 'windows'" in str(err.value)


def test_the_ratios_do_not_depend_on_the_units(rng):
    """kappa is a ratio: windows in mm/s^2-sized numbers or in km/s^2-sized ones give the same."""
    windows = _sines(40, 200, 1.0, 0.5, rng)
    labels = np.zeros(40, int)
    ref = TextureModel(FS).fit(windows, labels).pooled_
    np.testing.assert_allclose(TextureModel(FS).fit(windows * 1e-3, labels).pooled_, ref, rtol=1e-9)
    np.testing.assert_allclose(TextureModel(FS).fit(windows * 1e3, labels).pooled_, ref, rtol=1e-9)


def test_the_results_depend_on_the_values_not_the_dtype_they_arrive_in(rng):
    """float32 windows, signals and ratios give what their values give in float64, and the output is
    float64 on every path (textured, nothing fitted, too short to filter)."""
    windows = _sines(40, 200, 1.0, 0.5, rng).astype(np.float32)
    labels = np.zeros(40, int)
    model = TextureModel(FS).fit(windows, labels)
    assert np.array_equal(model.pooled_, TextureModel(FS).fit(windows.astype(np.float64), labels).pooled_)
    signal = (10 * _sines(1, 300, 1.0, 0.0, rng)[0]).astype(np.float32)
    kappa = model.pooled_.astype(np.float32)
    ref = add_texture(signal.astype(np.float64), kappa.astype(np.float64), FS, np.random.default_rng(3))
    out = add_texture(signal, kappa, FS, np.random.default_rng(3))
    assert out.dtype == np.float64 and np.array_equal(out, ref)
    for unchanged in (add_texture(signal, None, FS, rng), add_texture(signal[:20], kappa, FS, rng)):
        assert unchanged.dtype == np.float64


def test_the_added_noise_has_unit_std_in_every_channel(rng):
    """Each channel's texture is scaled by its own missing amplitude: the unit noise is unit per channel."""
    noise = _unit_band_noise((120, 3), bands(FS)[1], FS, np.random.default_rng(4))
    np.testing.assert_allclose(noise.std(axis=0), 1.0, rtol=1e-12)


def test_the_envelopes_hold_the_edge_value_at_the_ends_of_the_signal(rng):
    """The 1 s envelopes (moving means of the band energies) treat the signal as continuing at its end
    values: the missing amplitude at every sample, the first and last half-second included."""
    signal = np.cumsum(rng.normal(size=(300, 2)), axis=0) + rng.normal(size=(300, 2))
    kappa = np.array([0.8, 1.5])
    edges = bands(FS)
    n = int(FS)  # 1 s

    def envelope(band):
        energy = filtfilt(butter(4, band, btype="band", fs=FS, output="sos"), signal, axis=0) ** 2
        padded = np.pad(energy, ((n // 2, n - 1 - n // 2), (0, 0)), mode="edge")
        return np.stack([np.convolve(padded[:, c], np.ones(n) / n, mode="valid") for c in range(2)], axis=1)

    expected = np.sqrt(np.maximum(kappa ** 2 * envelope(edges[0]) - envelope(edges[1]), 0.0))
    np.testing.assert_allclose(missing_amplitude(signal, kappa, edges, FS), expected, rtol=1e-9, atol=1e-12)
