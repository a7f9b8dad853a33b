"""Backbones that record what they are given: the leakage tests' spies.

A test module subclasses `Spy` with a backbone and sets `seen` (where to record) and
`marks` (which marked windows an array holds).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from vsmp_imu.har.synthetic import FoldContext
from vsmp_imu.har.windows import Windows

MARK = -7.0  # channel 0 of every marked synthetic window (no subject fingerprint)


class Spy:
    """Records what `fit` trains and validates on and what is predicted after fitting (the
    early-stopping predictions on validation windows inside `fit` count as validation)."""

    seen: dict[str, set]
    marks: Callable[[np.ndarray], set]

    def fit(self, X, y, X_val=None, y_val=None):
        self.seen["fit"] |= self.marks(X)
        if X_val is not None:
            self.seen["val"] |= self.marks(X_val)
        self._fitting = True
        try:
            return super().fit(X, y, X_val, y_val)
        finally:
            self._fitting = False

    def predict_proba(self, X):
        self.seen["val_predict" if getattr(self, "_fitting", False) else "predict"] |= self.marks(X)
        return super().predict_proba(X)


class MarkedSource:
    """Copies of the context's training windows (as many per class as the budget asks) with
    channel 0 overwritten by MARK, so a spy can tell them from real windows."""

    name = "marked"

    def generate(self, context: FoldContext) -> Windows:
        picks = np.concatenate([np.flatnonzero(context.train.y == c)[:n]
                                for c, n in enumerate(context.budget_vector())])
        out = context.train[picks]
        X = out.X.copy()
        X[:, :, 0] = MARK
        return Windows(X, out.y, np.full(len(out), "synthetic"), out.label_names, out.channel_names, out.fs_hz)
