"""What an IMU figure shows: the right samples at the right times, named and in their units."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import to_rgba

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.imu.channels import CHANNELS, prefixed
from vsmp_imu.imu.plot import (
    AXIS_COLORS,
    LINE_STYLES,
    MAX_PANELS,
    check_image_path,
    imu_figure,
    plot_imu,
)
from vsmp_imu.imu.recording import ImuRecording

FS = 25.0


def _signal(n: int = 40, c: int = 6, offset: float = 0.0) -> np.ndarray:
    return offset + np.arange(n * c, dtype=float).reshape(n, c) / 7.0


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def test_a_plain_array_is_drawn_at_its_times_with_one_line_per_channel():
    values = _signal()
    fig = imu_figure(values, fs_hz=FS, start_s=2.0)
    acc, gyr = fig.axes
    for ax, first in ((acc, 0), (gyr, 3)):
        lines = ax.get_lines()
        assert [ln.get_label() for ln in lines] == ["x", "y", "z"]
        for k, ln in enumerate(lines):
            assert np.array_equal(ln.get_xdata(), 2.0 + np.arange(40) / FS)
            assert np.array_equal(ln.get_ydata(), values[:, first + k])
            assert to_rgba(ln.get_color()) == to_rgba(AXIS_COLORS["xyz"[k]])
            assert ln.get_linestyle() == LINE_STYLES[0] and ln.get_alpha() == 1.0
    assert acc.get_title(loc="left") == "accelerometer" and acc.get_ylabel() == "acc (m/s²)"
    assert gyr.get_title(loc="left") == "gyroscope" and gyr.get_ylabel() == "gyr (rad/s)"
    assert gyr.get_xlabel() == "time (s)"
    assert [t.get_text() for t in acc.get_legend().get_texts()] == ["x", "y", "z"]
    assert fig.legends == [] and fig._suptitle is None


def test_named_channels_of_two_locations_get_a_panel_each_in_first_seen_order():
    names = prefixed("right_wrist") + prefixed("waist")
    values = _signal(c=12)
    fig = imu_figure(values, channel_names=names, fs_hz=FS, title="two sensors")
    titles = [ax.get_title(loc="left") for ax in fig.axes]
    assert titles == ["right wrist accelerometer", "right wrist gyroscope", "waist accelerometer",
                      "waist gyroscope"]
    for p, ax in enumerate(fig.axes):
        for k, ln in enumerate(ax.get_lines()):
            assert np.array_equal(ln.get_ydata(), values[:, 3 * p + k])
    assert fig._suptitle.get_text() == "two sensors"


def test_a_channel_outside_acc_and_gyr_gets_its_own_panel_named_as_it_is():
    names = (*CHANNELS, "baro_hpa", "mag_field_x")
    fig = imu_figure(_signal(c=8), channel_names=names, fs_hz=FS)
    baro, mag = fig.axes[-2:]
    assert baro.get_title(loc="left") == "baro_hpa" and baro.get_ylabel() == "baro_hpa"
    assert np.array_equal(baro.get_lines()[0].get_ydata(), _signal(c=8)[:, 6])
    assert mag.get_title(loc="left") == "mag_field_x" and mag.get_lines()[0].get_label() == "x"


def test_the_clock_starts_at_zero_and_any_positive_rate_works():
    fig = imu_figure(_signal(n=4), fs_hz=0.5)
    assert np.array_equal(fig.axes[0].get_lines()[0].get_xdata(), [0.0, 2.0, 4.0, 6.0])


def test_plot_imu_passes_everything_to_the_figure_and_writes_the_format_its_name_says(tmp_path, monkeypatch):
    from vsmp_imu.imu import plot

    seen = {}
    real = plot.imu_figure

    def spy(data, **kwargs):
        seen.update(kwargs)
        return real(data, **kwargs)

    monkeypatch.setattr(plot, "imu_figure", spy)
    plot.plot_imu(_signal(), tmp_path / "a.svg", title="t", fs_hz=FS)
    assert seen == {"title": "t", "labels": None, "channel_names": None, "fs_hz": FS, "start_s": 0.0}
    assert (tmp_path / "a.svg").read_text().lstrip().startswith("<?xml")
    plot.plot_imu(_signal(), tmp_path / "b", fs_hz=FS, start_s=3.0)
    assert seen["start_s"] == 3.0
    assert (tmp_path / "b").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_an_overlay_draws_each_recording_in_its_own_style_with_a_shared_legend():
    a = ImuRecording(_signal(), CHANNELS, FS)
    b = _signal(offset=100.0)
    fig = imu_figure([a, b], labels=["real", "synthetic"], fs_hz=FS)
    acc = fig.axes[0]
    lines = acc.get_lines()
    assert len(lines) == 6
    assert [ln.get_linestyle() for ln in lines] == [LINE_STYLES[0]] * 3 + [LINE_STYLES[1]] * 3
    assert [ln.get_alpha() for ln in lines] == [1.0] * 3 + [0.85] * 3
    assert np.array_equal(lines[3].get_ydata(), b[:, 0])
    # only the first recording names the axes; the figure legend names the recordings
    assert [t.get_text() for t in acc.get_legend().get_texts()] == ["x", "y", "z"]
    (legend,) = fig.legends
    assert [t.get_text() for t in legend.get_texts()] == ["real", "synthetic"]
    assert [h.get_linestyle() for h in legend.legend_handles] == list(LINE_STYLES[:2])
    # the recordings differ by line style only: their swatches share one grey
    assert {to_rgba(h.get_color()) for h in legend.legend_handles} == {to_rgba("0.2")}


def test_an_overlay_without_labels_numbers_its_recordings():
    for n in (2, 3):
        fig = imu_figure([_signal()] * n, fs_hz=FS)
        (legend,) = fig.legends
        assert [t.get_text() for t in legend.get_texts()] == [f"recording {i + 1}" for i in range(n)]


@pytest.mark.parametrize(("kwargs", "field", "message"), [
    (dict(data=np.zeros(5), fs_hz=FS), "data", "expected a (T, C) array, got shape (5,)"),
    (dict(data=np.zeros((5, 4)), fs_hz=FS), "channel_names", "a (T, 4) array needs 4 channel names"),
    (dict(data=np.zeros((5, 2)), channel_names=("a",), fs_hz=FS), "channel_names", "a (T, 2) array needs 2 channel names"),
    (dict(data=np.zeros((5, 6))), "fs_hz", "a plain array needs fs_hz > 0"),
    (dict(data=np.zeros((5, 6)), fs_hz=0.0), "fs_hz", "a plain array needs fs_hz > 0"),
    (dict(data=[]), "data", "nothing to plot"),
    (dict(data=[np.zeros((5, 6))] * 2, labels=["one"], fs_hz=FS), "labels", "2 recordings but 1 labels"),
])
def test_bad_input_names_the_field(kwargs, field, message):
    data = kwargs.pop("data")
    with pytest.raises(ValidationError) as err:
        imu_figure(data, **kwargs)
    assert err.value.field == field and err.value.message == message


def test_more_panels_than_a_figure_holds_are_refused_before_drawing():
    from vsmp_imu.imu.placement import PLACEMENTS

    names = [f"c{k}" for k in range(MAX_PANELS + 1)]
    with pytest.raises(ValidationError, match=f"{MAX_PANELS + 1} panels to draw") as err:
        imu_figure(_signal(c=len(names)), channel_names=names, fs_hz=FS)
    assert err.value.field == "channels" and "c0, c1, c2" in err.value.message
    every = [n for loc in PLACEMENTS for n in prefixed(loc)]  # every location: 32 panels, drawn
    assert len(imu_figure(_signal(n=4, c=len(every)), channel_names=every, fs_hz=FS).axes) == 2 * len(PLACEMENTS)


def test_an_image_suffix_matplotlib_cannot_write_is_refused_before_drawing(tmp_path):
    for name in ("a.png", "a.PDF", "a.svg", "a"):
        check_image_path(tmp_path / name)
    with pytest.raises(ConfigError, match="'.txt' is not an image format") as err:
        plot_imu(_signal(), tmp_path / "a.txt", fs_hz=FS)
    assert err.value.field == "path" and ".png" in err.value.allowed
    assert list(tmp_path.iterdir()) == []
