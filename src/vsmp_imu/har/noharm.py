"""Do no harm: how much of each class's synthetic windows to mix, chosen on validation subjects.

Before the final fit of a (method, backbone, fold, seed, budget), the backbone
is fitted once per candidate share s (default 0 and 1): on the fit subjects'
real windows plus the share s of every class's synthetic windows. Each class
then keeps the largest share whose validation score for that class is within
`tolerance` of the best share's. The score is a soft per-class F1 on the
validation subjects' windows (from predicted probabilities, so one window that
tips over does not decide):

    TP_c = sum_{y=c} p_c,  FP_c = sum_{y!=c} p_c,  FN_c = sum_{y=c} (1 - p_c),
    soft F1_c = 2 TP_c / (2 TP_c + FP_c + FN_c).

The held-out subject takes no part: only `fit` and `val` of the fold are used.
A class without validation windows cannot be judged and keeps all of its
synthetic windows (its record says so). A backbone that trains on the
validation subjects too (the Random Forest) is fitted for the choice on the
fit subjects only and scored on the validation subjects; its final fit then
adds the validation subjects as usual.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.windows import Windows, concat_windows

DEFAULT_SHARES = (0.0, 1.0)
DEFAULT_TOLERANCE = 0.0


@dataclass(frozen=True)
class ClassShare:
    """The share of one class's synthetic windows kept, and why."""

    share: float
    offered: int  # synthetic windows of the class before the choice
    kept: int
    n_val: int  # validation windows of the class
    scores: dict[str, float] | None  # soft F1 per candidate share ("0", "1", ...)
    reason: str


def check_shares(shares: Sequence[float], tolerance: float) -> tuple[float, ...]:
    """Sorted candidate shares in [0, 1] that include 0 (Real-only for that class)."""
    values = tuple(sorted({float(s) for s in shares}))
    if not values or values[0] != 0.0 or values[-1] > 1.0 or values[0] < 0:
        raise ConfigError(
            f"synthetic shares {', '.join(f'{s:g}' for s in shares) or 'none'} not allowed",
            field="no_harm_shares",
            allowed="values in [0, 1], 0 among them (e.g. 0,1 or 0,0.5,1)",
        )
    if not 0 <= tolerance < 1:
        raise ConfigError(f"tolerance {tolerance:g} out of range", field="no_harm_tolerance",
                          allowed="0 <= tolerance < 1")
    return values


def soft_f1(proba: np.ndarray, y: np.ndarray, n_classes: int) -> np.ndarray:
    """Soft F1 per class from probabilities `(n, n_classes)` (NaN where a class has no window)."""
    onehot = np.eye(n_classes)[y]
    tp = (proba * onehot).sum(axis=0)
    fp = (proba * (1 - onehot)).sum(axis=0)
    fn = ((1 - proba) * onehot).sum(axis=0)
    denom = 2 * tp + fp + fn
    out = np.divide(2 * tp, denom, out=np.zeros(n_classes), where=denom > 0)
    out[onehot.sum(axis=0) == 0] = np.nan
    return out


def full_proba(model, X: np.ndarray, n_classes: int) -> np.ndarray:
    """`model.predict_proba(X)` with one column per class index (absent classes: 0)."""
    out = np.zeros((len(X), n_classes))
    out[:, np.asarray(model.classes_, dtype=np.int64)] = model.predict_proba(X)
    return out


def take_shares(synthetic: Windows, shares: np.ndarray) -> Windows:
    """The first round(share_c x n_c) synthetic windows of each class c (order kept)."""
    keep = np.zeros(len(synthetic), bool)
    for c, share in enumerate(shares):
        idx = np.flatnonzero(synthetic.y == c)
        keep[idx[: int(round(share * len(idx)))]] = True
    return synthetic[np.flatnonzero(keep)]


Fit = Callable[[Windows], object]  # trains the backbone on windows, returns the fitted model


def _reason(share: float, scores: dict[float, float], best: float) -> str:
    top = max(scores)
    if share == top:
        gain = scores[top] - scores[0.0]
        return f"kept: validation soft F1 {scores[top]:.3f} vs {scores[0.0]:.3f} without ({gain:+.3f})"
    if share == 0.0:
        return f"hurt validation soft F1 by {scores[0.0] - scores[top]:.3f} ({scores[top]:.3f} vs {scores[0.0]:.3f})"
    return f"share {share:g} scored best ({best:.3f}; all: {scores[top]:.3f}, none: {scores[0.0]:.3f})"


@dataclass
class ShareSelector:
    """Chooses per class the share of synthetic windows to mix (see the module docstring)."""

    shares: tuple[float, ...] = DEFAULT_SHARES
    tolerance: float = DEFAULT_TOLERANCE

    def choose(self, fit: Fit, real: Windows, synthetic: Windows, val: Windows) -> dict[int, ClassShare]:
        """Per class index with synthetic windows: the share kept and why."""
        shares = check_shares(self.shares, self.tolerance)
        n_classes = len(real.label_names)
        offered = np.bincount(synthetic.y, minlength=n_classes)
        n_val = np.bincount(val.y, minlength=n_classes)
        judged = [c for c in range(n_classes) if offered[c] > 0 and n_val[c] > 0]
        scores: dict[float, np.ndarray] = {}
        if judged:
            for share in shares:
                mixed = take_shares(synthetic, np.full(n_classes, share))
                model = fit(_concat(real, mixed))
                scores[share] = soft_f1(full_proba(model, val.X, n_classes), val.y, n_classes)
        out = {}
        for c in np.flatnonzero(offered):
            c = int(c)
            if n_val[c] == 0:
                out[c] = ClassShare(1.0, int(offered[c]), int(offered[c]), 0, None,
                                    "no validation windows: kept all (harm cannot be measured)")
                continue
            per_share = {s: float(scores[s][c]) for s in shares}
            best = max(per_share.values())
            share = max(s for s in shares if per_share[s] >= best - self.tolerance)
            kept = int(round(share * offered[c]))
            out[c] = ClassShare(share, int(offered[c]), kept, int(n_val[c]),
                                {f"{s:g}": round(v, 6) for s, v in per_share.items()},
                                _reason(share, per_share, best))
        return out


def _concat(real: Windows, synthetic: Windows) -> Windows:
    return concat_windows([real, synthetic]) if len(synthetic) else real


def shares_vector(choice: dict[int, ClassShare], n_classes: int) -> np.ndarray:
    out = np.ones(n_classes)
    for c, share in choice.items():
        out[c] = share.share
    return out


def choice_record(choice: dict[int, ClassShare], label_names: Sequence[str]) -> dict[str, dict]:
    """The choice as a record field: class name -> share, counts, scores and reason."""
    return {label_names[c]: asdict(share) for c, share in sorted(choice.items())}


def dropped_summary(records: Sequence[dict]) -> dict[str, dict]:
    """Per class: in how many records its synthetic windows were dropped (share 0) or cut,
    and the reasons' kinds counted."""
    out: dict[str, dict] = {}
    for r in records:
        for name, s in (r.get("synthetic_shares") or {}).items():
            row = out.setdefault(name, {"runs": 0, "none": 0, "reduced": 0, "unjudged": 0})
            row["runs"] += 1
            if s["n_val"] == 0:
                row["unjudged"] += 1
            if s["share"] == 0:
                row["none"] += 1
            elif s["share"] < 1:
                row["reduced"] += 1
    return out
