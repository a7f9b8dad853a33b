"""Zero-phase filtering: scipy's `sosfiltfilt` (odd padding), the filter's initial state kept per design.

`sosfiltfilt` solves a linear system per section (`sosfilt_zi`) on every call; the texture stage
and the motion measures filter every sample with the same few designs, and that solve was more
than half of the filtering's time. The passes are scipy's `sosfilt`, in the same order on the
same padded signal, so the result is `sosfiltfilt`'s to the bit (tested).
"""

from __future__ import annotations

import numpy as np
from scipy.signal import sosfilt, sosfilt_zi

_STATES: dict[bytes, np.ndarray] = {}  # sos bytes -> sosfilt_zi(sos)
_MAX_STATES = 64


def _state(sos: np.ndarray) -> np.ndarray:
    key = sos.tobytes() + repr(sos.shape).encode()
    zi = _STATES.get(key)
    if zi is None:
        if len(_STATES) >= _MAX_STATES:
            _STATES.clear()
        zi = _STATES[key] = sosfilt_zi(sos)
    return zi


def filtfilt(sos: np.ndarray, x: np.ndarray, axis: int = -1, padlen: int | None = None) -> np.ndarray:
    """`scipy.signal.sosfiltfilt(sos, x, axis=axis, padlen=padlen)` with odd padding."""
    sos = np.asarray(sos, dtype=np.float64)
    x = np.moveaxis(np.asarray(x), axis, 0)
    n_sections = sos.shape[0]
    ntaps = 2 * n_sections + 1 - min(int((sos[:, 2] == 0).sum()), int((sos[:, 5] == 0).sum()))
    edge = 3 * ntaps if padlen is None else int(padlen)
    if x.shape[0] <= edge:
        raise ValueError(f"The length of the input vector x must be greater than padlen, which is {edge}.")
    ext = _odd_ext(x, edge)
    zi = _state(sos).reshape(n_sections, 2, *([1] * (x.ndim - 1)))
    y, _ = sosfilt(sos, ext, axis=0, zi=zi * ext[:1])
    y, _ = sosfilt(sos, y[::-1], axis=0, zi=zi * y[-1:])
    y = y[::-1]
    if edge > 0:
        y = y[edge:-edge]
    return np.moveaxis(y, 0, axis)


def _odd_ext(x: np.ndarray, n: int) -> np.ndarray:
    """`x` extended by `n` samples at each end of axis 0, point-mirrored about its end samples."""
    if n < 1:
        return x
    left = 2 * x[:1] - x[n:0:-1]
    right = 2 * x[-1:] - x[-2:-(n + 2):-1]
    return np.concatenate((left, x, right), axis=0)
