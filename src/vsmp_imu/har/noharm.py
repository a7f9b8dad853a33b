"""Do no harm: whether to mix a method's synthetic windows, decided on the validation subjects.

Before the final fit of a (method, backbone, fold, seed, budget) the backbone
is fitted twice on the fit subjects: on their real windows alone and with
all the synthetic windows. For every validation window the change in the
probability given to its true class, d = p_with(y) - p_without(y), is the
evidence. Synthetic windows are dropped only where they measurably hurt: the
class-balanced mean of d (each class weighs the same, as in Macro-F1) is
negative and a one-sided paired sign-flip test gives p < `HARM_P`; a handful
of validation windows can therefore never drop anything (noise is not harm).

- `method`: one decision for all classes, over
  all validation windows; the synthetic windows are kept or dropped together.
- `class`: one decision per class c, one-vs-rest: the evidence is the change
  of p(c) on c's validation windows and minus the change of p(c) on the other
  windows (synthetic windows of c that pull other classes' windows into c do
  harm too), the two sides weighted equally. A class is judged only where the
  validation subjects hold `MIN_OWN_VALIDATION` windows of it: without its own
  side, the others' side charges a class for being learnt at all (windows of
  a class the real data barely has raise p(c) everywhere), and on HAPT12 with
  1 % of the labels that dropped the transitions' windows that helped most
  (docs/results.md, "The guard judges a class on its own windows"). Where no
  class reaches it, nothing is fitted. Every class's synthetic windows are in
  the fitted model at once, so a class can be charged with a change that
  another class's windows caused.
- `amount`: how many, not whether: the backbone is fitted on the real windows
  plus each share in `AMOUNTS` of every class's synthetic windows (the first
  windows of each class, as the final fit takes them), and the share whose
  model gives the validation windows the highest class-balanced mean
  probability of their true class is kept (0 allowed; a tie goes to the
  larger share). More synthetic windows are not always better: with 5 % of
  HAPT12's labels, a smaller α measured better on the held-out subjects than
  the default, but the validation subjects' choice did not find it
  (docs/results.md, "How many synthetic windows at 5 %").

`evaluate` uses `class` by default under lopo, long-tail and unseen where
every chosen backbone is a forest (`cli.har.share_default`): on HAPT12 it
takes the long tail's tail from significantly below Real-only to level with
it, leaves 1 % untouched (no class holds 10 validation windows) and is level
at 5 % (so low-resource leaves it off: it costs time there for nothing
measured). `method` dropped windows that helped at 1 % and changed nothing
at 5 %, and `amount` was level with mixing everything at both
(docs/results.md). The Python API (`EvalConfig`)
mixes everything unless asked, as the paper does.

The held-out subject takes no part: only the fold's fit and validation
windows are used. A backbone that trains on the validation subjects too (the
Random Forest) is fitted for this choice on the fit subjects only and scored
on the validation subjects; its final fit then adds them as usual.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

from vsmp_imu.errors import ConfigError
from vsmp_imu.har.windows import Windows, concat_windows

SELECTION_MODES = ("off", "method", "class", "amount")
AMOUNTS = (0.0, 0.125, 0.25, 0.5, 1.0)  # shares of the synthetic windows `amount` chooses from
HARM_P = 0.05  # one-sided level at which a fall in validation probability counts as harm
# `class` judges a class only on this many validation windows of its own (the class filter's
# floor, grounding.floors.VALIDATOR)
MIN_OWN_VALIDATION = 10
N_FLIPS = 2000  # random sign flips of the paired test (seeded: same data, same p)


@dataclass(frozen=True)
class ClassShare:
    """The share of one class's synthetic windows kept, and why."""

    share: float
    offered: int  # synthetic windows of the class before the choice
    kept: int
    n_val: int  # validation windows of the class
    mean_change: float | None  # mean d over the class's validation windows
    reason: str
    judged: bool = True  # False: kept without a decision (too few validation windows)


@dataclass(frozen=True)
class Harm:
    """The evidence over a set of validation windows."""

    n: int
    mean_change: float
    p: float

    @property
    def hurts(self) -> bool:
        return self.n > 0 and self.mean_change < 0 and self.p < HARM_P

    def text(self) -> str:
        return (f"validation p(true class) {self.mean_change:+.3f} on average over {self.n} windows, "
                f"classes weighted equally (one-sided sign-flip p = {self.p:.2g})")


def check_mode(mode: str) -> str:
    if mode not in SELECTION_MODES:
        raise ConfigError(f"unknown share selection '{mode}'", field="--share-selection",
                          allowed=", ".join(SELECTION_MODES))
    return mode


def harm(change: np.ndarray, labels: np.ndarray | None = None) -> Harm:
    """Class-balanced mean change (each label weighs the same; all windows alike without labels)
    and the one-sided p of a paired sign-flip test that it is below zero (1 without evidence)."""
    change = np.asarray(change, dtype=float)
    if len(change) == 0:
        return Harm(0, float("nan"), 1.0)
    if labels is None:
        weights = np.full(len(change), 1.0 / len(change))
    else:
        _, inverse, counts = np.unique(labels, return_inverse=True, return_counts=True)
        weights = 1.0 / (counts[inverse] * len(counts))
    observed = float(weights @ change)
    size = weights * np.abs(change)
    if not size.any():
        return Harm(len(change), observed, 1.0)
    rng = np.random.default_rng(0)
    below = 0
    for start in range(0, N_FLIPS, 250):  # chunks keep the sign matrix small
        signs = rng.choice((-1.0, 1.0), size=(min(250, N_FLIPS - start), len(change)))
        below += int(np.sum(signs @ size <= observed + 1e-12))
    return Harm(len(change), observed, (1 + below) / (1 + N_FLIPS))


def true_class_score(proba: np.ndarray, labels: np.ndarray) -> float:
    """Mean probability given to the true class, each class's windows weighing the same."""
    labels = np.asarray(labels)
    p = proba[np.arange(len(labels)), labels]
    return float(np.mean([p[labels == c].mean() for c in np.unique(labels)]))


def full_proba(model, windows: Windows, n_classes: int) -> np.ndarray:
    """`model.predict_proba` with one column per class index (0 for a class it never saw)."""
    full = np.zeros((len(windows), n_classes))
    full[:, np.asarray(model.classes_, dtype=np.int64)] = model.predict_proba(windows.X)
    return full


def take_shares(synthetic: Windows, shares: np.ndarray) -> Windows:
    """The first round(share_c x n_c) synthetic windows of each class c (order kept)."""
    keep = np.zeros(len(synthetic), bool)
    for c, share in enumerate(shares):
        idx = np.flatnonzero(synthetic.y == c)
        keep[idx[: int(round(share * len(idx)))]] = True
    return synthetic[np.flatnonzero(keep)]


Fit = Callable[[Windows], object]  # trains the backbone on windows, returns the fitted model


@dataclass
class ShareSelector:
    """Decides which synthetic windows to mix (see the module docstring)."""

    mode: str = "method"

    def choose(self, fit: Fit, real: Windows, synthetic: Windows, val: Windows) -> dict[int, ClassShare]:
        """Per class index with synthetic windows: the share kept (0 or 1; one of AMOUNTS with
        `amount`) and why."""
        check_mode(self.mode)
        n_classes = len(real.label_names)
        offered = np.bincount(synthetic.y, minlength=n_classes)
        if self.mode == "amount":
            return self._amount(fit, real, synthetic, val, offered)
        n_own = np.bincount(val.y, minlength=n_classes)
        judged = self._judged(offered, n_own)
        change = np.zeros((len(val), n_classes))
        if len(val) and len(synthetic) and judged.any():
            without = full_proba(fit(real), val, n_classes)
            change = full_proba(fit(concat_windows([real, synthetic])), val, n_classes) - without
        overall = harm(change[np.arange(len(val)), val.y], val.y)
        out = {}
        for c in (int(c) for c in np.flatnonzero(offered)):
            if not judged[c]:
                out[c] = ClassShare(1.0, int(offered[c]), int(offered[c]), int(n_own[c]), None,
                                    self._unjudged(int(n_own[c])), judged=False)
                continue
            own = val.y == c
            mean = round(float(change[own, c].mean()), 6) if own.any() else None
            mine = harm(np.where(own, change[:, c], -change[:, c]), own)
            drop, reason = self._decide(overall, mine)
            out[c] = ClassShare(0.0 if drop else 1.0, int(offered[c]), 0 if drop else int(offered[c]),
                                int(n_own[c]), mean, reason, judged=bool(own.any()))
        return out

    def _judged(self, offered: np.ndarray, n_own: np.ndarray) -> np.ndarray:
        """Per class: whether its windows get a decision (`method`: every offered class, on the
        whole validation set; `class`: those with MIN_OWN_VALIDATION windows of their own)."""
        if self.mode == "method":
            return offered > 0
        return (offered > 0) & (n_own >= MIN_OWN_VALIDATION)

    @staticmethod
    def _unjudged(n_own: int) -> str:
        return (f"kept unjudged: {n_own} validation window{'s' if n_own != 1 else ''} of the class, "
                f"fewer than {MIN_OWN_VALIDATION} (the others' windows alone would charge the class "
                "for being learnt at all)")

    @staticmethod
    def _amount(fit: Fit, real: Windows, synthetic: Windows, val: Windows,
                offered: np.ndarray) -> dict[int, ClassShare]:
        """One share of AMOUNTS for every class: the one the validation windows score best."""
        n_classes = len(offered)
        if len(val) and len(synthetic):
            scores = {}
            for share in AMOUNTS:
                part = take_shares(synthetic, np.full(n_classes, share))
                model = fit(concat_windows([real, part]) if len(part) else real)
                scores[share] = true_class_score(full_proba(model, val, n_classes), val.y)
            best = max(AMOUNTS, key=lambda s: (round(scores[s], 12), s))
            told = ", ".join(f"{s:g}: {v:.4f}" for s, v in scores.items())
            reason = f"share {best:g} chosen: validation p(true class), classes weighted equally, per share {told}"
        else:
            best, reason = 1.0, "no validation windows: kept all (the amount cannot be chosen)"
        out = {}
        for c in (int(c) for c in np.flatnonzero(offered)):
            n_own = int(np.sum(val.y == c))
            out[c] = ClassShare(best, int(offered[c]), int(round(best * offered[c])), n_own, None, reason,
                                judged=n_own > 0)
        return out

    def _decide(self, overall: Harm, mine: Harm) -> tuple[bool, str]:
        if overall.n == 0:
            return False, "no validation windows: kept all (harm cannot be measured)"
        if self.mode == "method":
            return overall.hurts, ("dropped with the method's other synthetic windows: " if overall.hurts
                                   else "kept: no measured harm, ") + overall.text()
        verdict = "dropped: hurt one-vs-rest, " if mine.hurts else "kept: no measured harm one-vs-rest, "
        return mine.hurts, verdict + mine.text().replace("p(true class)", "p(class) for the class, -p(class) "
                                                        "for the others,")


def shares_vector(choice: dict[int, ClassShare], n_classes: int) -> np.ndarray:
    out = np.ones(n_classes)
    for c, share in choice.items():
        out[c] = share.share
    return out


def choice_record(choice: dict[int, ClassShare], label_names: Sequence[str]) -> dict[str, dict]:
    """The choice as a record field: class name -> share, counts, mean change and reason."""
    return {label_names[c]: asdict(share) for c, share in sorted(choice.items())}


def unjudged(share: dict) -> bool:
    """Whether a recorded class share was kept without a decision (records before the field:
    the class had no validation window)."""
    return not share.get("judged", share["n_val"] > 0)


def dropped_summary(records: Sequence[dict]) -> dict[str, dict]:
    """Per class: in how many records it had synthetic windows, got none, or could not be judged."""
    out: dict[str, dict] = {}
    for r in records:
        for name, s in (r.get("synthetic_shares") or {}).items():
            row = out.setdefault(name, {"runs": 0, "none": 0, "unjudged": 0})
            row["runs"] += 1
            row["unjudged"] += int(unjudged(s))
            row["none"] += int(s["share"] == 0)
    return out
