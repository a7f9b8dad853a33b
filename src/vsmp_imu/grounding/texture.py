"""Movement texture: the 3-12 Hz content that procedural motion lacks.

Procedural motion is smooth (eased keyframes, a filtered simulator), human
motion is not: a body sitting down shakes, a phone on a belt wobbles. On
HAPT12 the synthetic windows' 0.3-3 Hz energy is about the real one's, their
3-12 Hz energy far below it, most of all the gyroscope's (docs/results.md,
"Movement texture"; tests/pipeline/test_fold.py checks the gyroscope's share).

The model is a ratio per channel, kappa = sqrt(sum HF^2 / sum LF^2) over real
windows (HF: 3-12 Hz, LF: 0.3-3 Hz band-passed signals; energy-weighted, so
windows with motion decide it, not the sensor noise of a posture). A class
with `min_class_windows` real windows gets its own kappa, every other class
the pooled one (a class with few real windows, or none: the unseen protocol).

`apply` adds band-limited Gaussian noise where the signal's own HF falls
short of kappa times its local LF amplitude (1 s envelopes): the texture
follows the motion (none in a still posture), and a signal that already has
enough (the accelerometer of a gait with heel strikes) gets nothing.

Below 8 Hz no HF band fits under the Nyquist rate: nothing is fitted or added, and the
summary's `reason` says so (as it does for windows too short to filter, or none).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter

from vsmp_imu.errors import ValidationError
from vsmp_imu.executor import thread_map
from vsmp_imu.grounding import floors
from vsmp_imu.zero_phase import filtfilt

LF_BAND_HZ = (0.3, 3.0)
HF_BAND_HZ = (3.0, 12.0)
ENVELOPE_S = 1.0
ORDER = 4
# the HF band's top edge stays below this share of the sample rate
NYQUIST_SHARE = 0.45
BLOCK_WINDOWS = 256  # windows filtered at a time when fitting


def bands(fs_hz: float) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """The (LF, HF) bands at `fs_hz`, HF cut below the Nyquist rate; None when no HF band is left."""
    top = min(HF_BAND_HZ[1], NYQUIST_SHARE * fs_hz)
    if top <= HF_BAND_HZ[0] * 1.2:
        return None
    return LF_BAND_HZ, (HF_BAND_HZ[0], top)


@functools.lru_cache(maxsize=16)
def _sos(band: tuple[float, float], fs_hz: float) -> np.ndarray:
    """The band-pass filter (designed once per band and rate: every sample uses the same few)."""
    return butter(ORDER, band, btype="band", fs=fs_hz, output="sos")


def _band(x: np.ndarray, band: tuple[float, float], fs_hz: float, axis: int) -> np.ndarray:
    return filtfilt(_sos(band, fs_hz), x, axis=axis)


def _min_length(fs_hz: float) -> int:
    """Shortest signal the zero-phase filters take (scipy's default padding, plus one)."""
    return 3 * (2 * len(_sos(LF_BAND_HZ, fs_hz)) + 1) + 1


def unfitted(n_windows: int, length: int, fs_hz: float) -> str | None:
    """Why no ratio can be fitted on `n_windows` windows of `length` samples at `fs_hz` (None: it can)."""
    if bands(fs_hz) is None:
        return (f"a sampling rate of {fs_hz:g} Hz leaves no room for the {HF_BAND_HZ[0]:g}-{HF_BAND_HZ[1]:g} Hz "
                f"band: that needs {HF_BAND_HZ[0] * 1.2 / NYQUIST_SHARE:g} Hz")
    if length < _min_length(fs_hz):
        return f"windows of {length} samples are too short to filter: that needs {_min_length(fs_hz)}"
    if n_windows == 0:
        return "no real windows"
    return None


@dataclass
class TextureModel:
    """Per-channel HF/LF ratios from real windows, and the texture they ask for (see module doc)."""

    fs_hz: float
    min_class_windows: int = floors.TEXTURE.floor
    pooled_: np.ndarray | None = None  # (C,) kappa of all windows
    per_class_: dict[int, np.ndarray] = field(default_factory=dict)
    reason_: str | None = None  # why nothing was fitted

    def fit(self, windows: np.ndarray, labels: np.ndarray, threads: int = 1) -> TextureModel:
        """kappa from real windows (N, T, C) and their labels; nothing is fitted (`mapping` says
        'none') when there are no windows, they are too short to filter, or no HF band fits the rate.
        `threads` filter blocks of windows side by side (same result)."""
        windows = np.asarray(windows)
        if windows.ndim != 3:
            raise ValidationError(f"expected windows (N, T, C), got shape {windows.shape}", field="windows")
        self.reason_ = unfitted(len(windows), windows.shape[1], self.fs_hz)
        if self.reason_:
            return self
        lf_energy, hf_energy = band_energies(windows, self.fs_hz, threads)
        self.pooled_ = _ratio(hf_energy, lf_energy)
        labels = np.asarray(labels)
        for cls in np.unique(labels):
            mask = labels == cls
            if mask.sum() >= self.min_class_windows:
                self.per_class_[int(cls)] = _ratio(hf_energy[mask], lf_energy[mask])
        return self

    def kappa(self, label: int) -> np.ndarray | None:
        """The class's ratios (its own, else the pooled ones); None when the model has none."""
        return self.per_class_.get(int(label), self.pooled_)

    def mapping(self, label: int) -> str:
        """'class' (its own kappa), 'pooled' or 'none' (nothing fitted: signals left as they are)."""
        if self.pooled_ is None:
            return "none"
        return "class" if int(label) in self.per_class_ else "pooled"

    def apply(self, signal: np.ndarray, label: int, rng: np.random.Generator) -> np.ndarray:
        """`signal` (T, C) with the texture it lacks; unchanged when too short or nothing is fitted."""
        return add_texture(signal, self.kappa(label), self.fs_hz, rng)

    def as_dict(self, label_names: list[str]) -> dict:
        """The fitted ratios, for a generation summary."""
        out = {"pooled": None if self.pooled_ is None else np.round(self.pooled_, 4).tolist(),
               "classes": {label_names[c]: np.round(k, 4).tolist() for c, k in sorted(self.per_class_.items())}}
        return out | ({"reason": self.reason_} if self.reason_ else {})


def band_energies(windows: np.ndarray, fs_hz: float, threads: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Per window and channel (N, C): the LF and the HF band's energy of windows (N, T, C).

    Each window is filtered on its own, so blocks of windows give the same values as all at once;
    small blocks keep the filters' temporaries in cache, and `threads` run blocks side by side
    (scipy's filter loop releases the GIL)."""
    edges = bands(fs_hz)

    def block(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        x = np.asarray(x, dtype=np.float64)
        return tuple((_band(x, edge, fs_hz, axis=1) ** 2).sum(axis=1) for edge in edges)

    parts = thread_map(block, [windows[i:i + BLOCK_WINDOWS] for i in range(0, len(windows), BLOCK_WINDOWS)],
                       threads)
    return tuple(np.concatenate([p[k] for p in parts]) for k in (0, 1))


def add_texture(signal: np.ndarray, kappa, fs_hz: float, rng: np.random.Generator) -> np.ndarray:
    """`signal` (T, C) with the texture the ratios `kappa` (C,) ask for; unchanged when `kappa` is
    None or the signal too short to filter (what `TextureModel.apply` does with a class's kappa)."""
    signal = np.asarray(signal, dtype=np.float64)
    edges = bands(fs_hz)
    if kappa is None or edges is None or signal.shape[0] < _min_length(fs_hz):
        return signal
    kappa = np.asarray(kappa, dtype=np.float64)
    if signal.shape[1] != len(kappa):
        raise ValidationError(f"expected {len(kappa)} channels, got {signal.shape[1]}", field="channels")
    amp = missing_amplitude(signal, kappa, edges, fs_hz)
    noise = _unit_band_noise(signal.shape, edges[1], fs_hz, rng)
    return signal + amp * noise


def missing_amplitude(signal: np.ndarray, kappa: np.ndarray, edges, fs_hz: float) -> np.ndarray:
    """(T, C): the HF amplitude short of kappa x the local LF amplitude (0 where enough)."""
    n = max(1, int(round(ENVELOPE_S * fs_hz)))
    lf = uniform_filter1d(_band(signal, edges[0], fs_hz, axis=0) ** 2, n, axis=0, mode="nearest")
    hf = uniform_filter1d(_band(signal, edges[1], fs_hz, axis=0) ** 2, n, axis=0, mode="nearest")
    return np.sqrt(np.maximum(kappa ** 2 * lf - hf, 0.0))


def _ratio(hf_energy: np.ndarray, lf_energy: np.ndarray) -> np.ndarray:
    return np.sqrt(hf_energy.sum(axis=0) / np.maximum(lf_energy.sum(axis=0), 1e-12))


def _unit_band_noise(shape: tuple[int, int], band: tuple[float, float], fs_hz: float,
                     rng: np.random.Generator) -> np.ndarray:
    """Gaussian noise band-passed to `band`, unit standard deviation per channel, shape (T, C)."""
    pad = _min_length(fs_hz)
    raw = rng.standard_normal((shape[0] + 2 * pad, shape[1]))
    noise = _band(raw, band, fs_hz, axis=0)[pad:-pad]
    return noise / np.maximum(noise.std(axis=0), 1e-12)
