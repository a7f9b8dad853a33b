"""Plots of IMU recordings: accelerometer and gyroscope panels per location.

`plot_imu(rec, "imu.png")` draws one recording; a list overlays several
(e.g. real vs synthetic), each drawn with its own line style and label.
Plain arrays work too, with `channel_names` and `fs_hz`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from vsmp_imu.errors import ValidationError  # noqa: E402
from vsmp_imu.imu.channels import CHANNELS, split_channel  # noqa: E402
from vsmp_imu.imu.recording import ImuRecording  # noqa: E402
from vsmp_imu.io import IMAGE_SUFFIXES, check_image_path, write_figure  # noqa: E402,F401

AXIS_COLORS = {"x": "tab:red", "y": "tab:green", "z": "tab:blue"}
LINE_STYLES = ("-", "--", ":", "-.")
SENSORS = {"acc": ("accelerometer", "m/s²"), "gyr": ("gyroscope", "rad/s")}
# 16 sensor locations x (acc, gyr) = 32 panels; a figure of many more is metres tall
MAX_PANELS = 40
@dataclass
class _Series:
    label: str
    times: np.ndarray
    values: np.ndarray
    names: tuple[str, ...]


def _one(item, label: str, channel_names, fs_hz, start_s: float) -> _Series:
    if isinstance(item, ImuRecording):
        return _Series(label, item.times, item.data, item.channel_names)
    values = np.asarray(item, dtype=float)
    if values.ndim != 2:
        raise ValidationError(f"expected a (T, C) array, got shape {values.shape}", field="data")
    names = tuple(channel_names) if channel_names is not None else (
        CHANNELS if values.shape[1] == len(CHANNELS) else None)
    if names is None or len(names) != values.shape[1]:
        raise ValidationError(f"a (T, {values.shape[1]}) array needs {values.shape[1]} channel names",
                              field="channel_names")
    if fs_hz is None or fs_hz <= 0:
        raise ValidationError("a plain array needs fs_hz > 0", field="fs_hz")
    return _Series(label, start_s + np.arange(len(values)) / fs_hz, values, names)


def _series(data, labels, channel_names, fs_hz, start_s) -> list[_Series]:
    items = list(data) if isinstance(data, list | tuple) else [data]
    if not items:
        raise ValidationError("nothing to plot", field="data")
    if labels is None:
        labels = [f"recording {i + 1}" for i in range(len(items))] if len(items) > 1 else [""]
    if len(labels) != len(items):
        raise ValidationError(f"{len(items)} recordings but {len(labels)} labels", field="labels")
    return [_one(item, str(lab), channel_names, fs_hz, start_s) for item, lab in zip(items, labels, strict=True)]


def _panels(series: list[_Series]) -> list[tuple[str, str]]:
    """(location, 'acc' | 'gyr') in first-seen order."""
    seen: dict[tuple[str, str], None] = {}
    for s in series:
        for name in s.names:
            loc, base = split_channel(name)
            kind = base.split("_")[0]
            seen.setdefault((loc, kind if kind in SENSORS else base), None)
    return list(seen)


def _check_panels(panels: list[tuple[str, str]]) -> None:
    if len(panels) > MAX_PANELS:
        others = [kind for _, kind in panels if kind not in SENSORS]
        named = f" ({len(others)} of them for columns that are not acc_/gyr_ channels: " \
                f"{', '.join(others[:3])}, ...)" if others else ""
        raise ValidationError(f"{len(panels)} panels to draw, one per location and sensor{named}",
                              field="channels", allowed=f"at most {MAX_PANELS} panels (channels named "
                              "like waist_acc_x .. waist_gyr_z)")


def check_plottable(recording: ImuRecording) -> None:
    """Refuse a recording whose figure would have more than MAX_PANELS panels."""
    _check_panels(_panels([_one(recording, "", None, None, 0.0)]))


def _draw_panel(ax, series: list[_Series], location: str, kind: str) -> None:
    for k, s in enumerate(series):
        for i, name in enumerate(s.names):
            loc, base = split_channel(name)
            if loc != location or not (base.startswith(kind + "_") or base == kind):
                continue
            axis = base.rsplit("_", 1)[-1]
            ax.plot(s.times, s.values[:, i], color=AXIS_COLORS.get(axis), lw=1.0,
                    ls=LINE_STYLES[k % len(LINE_STYLES)], alpha=1.0 if k == 0 else 0.85,
                    label=axis if k == 0 else None)
    what, unit = SENSORS.get(kind, (kind, ""))
    ax.set_title(f"{location.replace('_', ' ')} {what}".strip(), fontsize=10, loc="left")
    ax.set_ylabel(f"{kind} ({unit})" if unit else kind, fontsize=9)
    ax.grid(True, alpha=0.3)
    ax.margins(x=0.01)
    ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=8, frameon=False, handlelength=1.5)


def imu_figure(data, *, title: str | None = None, labels: Sequence[str] | None = None,
               channel_names: Sequence[str] | None = None, fs_hz: float | None = None,
               start_s: float = 0.0) -> Figure:
    """The figure (caller closes it); see `plot_imu`."""
    series = _series(data, labels, channel_names, fs_hz, start_s)
    panels = _panels(series)
    _check_panels(panels)
    fig, axes = plt.subplots(len(panels), 1, figsize=(10, 0.6 + 2.2 * len(panels)), sharex=True,
                             squeeze=False, layout="constrained")
    for ax, (location, kind) in zip(axes[:, 0], panels, strict=True):
        _draw_panel(ax, series, location, kind)
    axes[-1, 0].set_xlabel("time (s)")
    if len(series) > 1:
        handles = [Line2D([], [], color="0.2", ls=LINE_STYLES[k % len(LINE_STYLES)], label=s.label)
                   for k, s in enumerate(series)]
        fig.legend(handles=handles, loc="outside upper right", ncol=len(series), fontsize=9, frameon=False)
    if title:
        fig.suptitle(title, x=0.01, ha="left", fontsize=11)
    return fig


def plot_imu(data, path: str | Path, *, title: str | None = None, labels: Sequence[str] | None = None,
             channel_names: Sequence[str] | None = None, fs_hz: float | None = None,
             start_s: float = 0.0) -> Path:
    """Draw one recording, or overlay several, and write the image atomically.

    data: an ImuRecording, a (T, C) array (with `channel_names`, `fs_hz`), or a
    list of them (overlay; `labels` names each one).
    """
    path = Path(path)
    check_image_path(path)
    fig = imu_figure(data, title=title, labels=labels, channel_names=channel_names, fs_hz=fs_hz,
                     start_s=start_s)
    try:
        return write_figure(fig, path, dpi=110)
    finally:
        plt.close(fig)
