"""Training-window weights that keep the real windows' say (`evaluate --synthetic-weight`).

With `--class-weight balanced` alone a class's windows weigh the inverse of their count, real
and synthetic alike, so synthetic windows dilute the few real windows of their class: 30 real
sit-to-stand windows and 200 synthetic ones leave the real ones 13 % of the class's weight.
`source_weights` balances the classes per source instead: each class's real windows together
weigh as much as every other class's, and its synthetic windows together weigh `share` times
that, however many there are. A class without real windows (an unseen class) has only its
synthetic windows, at a full class's weight. Measured on HAPT12 in docs/results.md
"Synthetic windows that never outweigh the real ones".
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from vsmp_imu.errors import ConfigError

# `evaluate`'s default: the classes balanced, each class's synthetic windows together half its
# real ones: the setting that measured best (docs/results.md, "Synthetic windows that never
# outweigh the real ones"); `--class-weight none` is the paper's unweighted training
DEFAULT_CLASS_WEIGHT = "balanced"
# each class's synthetic windows weigh half its real windows: the best of 1, 0.5 and 0.25 in an
# offline probe on HAPT12 at 1 % and 5 % (docs/results.md)
DEFAULT_SYNTHETIC_WEIGHT = 0.5


def takes_sample_weight(backbone: type) -> bool:
    """Whether a backbone class's `fit` takes per-window weights."""
    return "sample_weight" in inspect.signature(backbone.fit).parameters


def parse_synthetic_weight(text: str) -> float | None:
    """`--synthetic-weight` as typed: 'off' (None) or a finite share > 0."""
    if text.strip().lower() == "off":
        return None
    try:
        share = float(text)
    except ValueError:
        raise ConfigError(f"synthetic weight '{text}' is not a number", field="--synthetic-weight",
                          allowed="a finite share > 0, or off") from None
    check_synthetic_weight(share)
    return share


def check_synthetic_weight(share: float | None) -> None:
    """None (off) or a finite share > 0."""
    if share is not None and not (math.isfinite(share) and share > 0):
        raise ConfigError(f"synthetic weight {share:g} out of range", field="--synthetic-weight",
                          allowed="a finite share > 0 (0.5: a class's synthetic windows weigh half its real ones)")


def source_weights(y: np.ndarray, is_real: np.ndarray, n_classes: int, share: float) -> np.ndarray:
    """Per window: classes weigh alike; within a class the synthetic windows together weigh
    `share` times the real ones (a full class's weight where the class has no real window).
    Scaled to a mean of 1, as scikit-learn's balanced weights are."""
    check_synthetic_weight(share)
    y, is_real = np.asarray(y), np.asarray(is_real, bool)
    if len(y) != len(is_real):
        raise ValueError(f"{len(y)} labels and {len(is_real)} source flags")
    weights = np.zeros(len(y))
    for c in range(n_classes):
        real, synthetic = is_real & (y == c), ~is_real & (y == c)
        n_real, n_synthetic = int(real.sum()), int(synthetic.sum())
        if n_real:
            weights[real] = 1.0 / n_real
        if n_synthetic:
            weights[synthetic] = (share if n_real else 1.0) / n_synthetic
    return weights * len(y) / weights.sum() if len(y) else weights
