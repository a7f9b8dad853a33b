"""The plug-in point for synthetic data.

A method is either real-only (`real`) or a *synthetic source*: an object
with a `name` and a `generate(context) -> Windows` method. The harness calls
it once per fold (and seed, and label budget) with a `FoldContext` holding
only what the training side of that fold may see: the (subsampled) real
training windows, the training subjects, the dataset's declared sensor
conventions, a seed and the synthetic budget per class. The source returns
labelled `Windows` with the dataset's channels, rate and window length. The
harness never looks at how they were made: it checks them, trims each class
to its budget and mixes them into the training windows.

Sources register under a short name with `register_method(name, factory)`;
the command line fills the registry (`real`, `classical`, and later
`vsmp`, `imutube`, `imugpt`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.dataset import DatasetInfo
from vsmp_imu.har.protocols import head_tail
from vsmp_imu.har.windows import Windows, check_compatible, concat_windows

BUDGET_POLICIES = ("uniform", "tail", "scarcity")
# Synthetic-to-real ratio range (paper, Implementation Details: alpha in [0.1, 2.0]).
ALPHA_RANGE = (0.1, 2.0)
# The paper's setting, the harness's default (the studies reproduce it). `generate` and `evaluate`
# default to GenerationSpec's alpha and policy: the settings that measured a gain here.
PAPER_ALPHA = 0.5


@dataclass(frozen=True)
class FoldContext:
    """What a synthetic source may see in one fold.

    `train` holds the real windows the model is trained on in this fold
    (after the protocol's subsampling, without the validation subjects and
    never the held-out subject). `budget` maps class names to the number of
    synthetic windows wanted. `unseen` names the classes without any real
    training window (unseen protocol): `train` holds none of them.
    """

    dataset: DatasetInfo
    fold: str
    held_out_subject: str
    train: Windows
    train_subjects: tuple[str, ...]
    seed: int
    budget: dict[str, int]
    alpha: float
    protocol: str
    label_budget: float | None = None
    unseen: tuple[str, ...] = ()

    @property
    def total_budget(self) -> int:
        return int(sum(self.budget.values()))

    def budget_vector(self) -> np.ndarray:
        """The budget as counts per class index."""
        return np.array([self.budget.get(n, 0) for n in self.train.label_names], dtype=np.int64)


@runtime_checkable
class SyntheticSource(Protocol):
    """A method that makes labelled synthetic windows for one fold."""

    name: str

    def generate(self, context: FoldContext) -> Windows: ...


# name -> factory(**params) returning a SyntheticSource; None marks real-only.
METHODS: dict[str, Callable[..., SyntheticSource] | None] = {"real": None}
# Display names used in result tables.
METHOD_DISPLAY = {"real": "Real-only"}
# Methods that can make windows of a class with no real window (the unseen protocol).
UNSEEN_CAPABLE: set[str] = set()
# Method parameters that decide where a source runs, not what it gives (the same seed gives the
# same windows whatever they are): a run records them but a record need not match them to be reused.
RUN_PARAMS = ("executor", "workers", "address", "cache_dir", "gpus_per_task")


def register_method(
    name: str,
    factory: Callable[..., SyntheticSource] | None,
    display: str | None = None,
    unseen_classes: bool = False,
) -> None:
    """Make a synthetic source available under `name` (e.g. for `--methods`); `unseen_classes`:
    it can make windows of a class that has no real training window."""
    METHODS[name] = factory
    METHOD_DISPLAY[name] = display or name
    if unseen_classes:
        UNSEEN_CAPABLE.add(name)
    else:
        UNSEEN_CAPABLE.discard(name)


def make_method(name: str, **params: Any) -> SyntheticSource | None:
    """The source registered as `name` (None for real-only)."""
    if name not in METHODS:
        raise ConfigError(f"unknown method '{name}'", field="methods", allowed=", ".join(METHODS))
    factory = METHODS[name]
    return None if factory is None else factory(**params)


def apportion(total: int, weights: np.ndarray) -> np.ndarray:
    """Integers proportional to `weights` summing to `total` (largest remainder)."""
    weights = np.asarray(weights, dtype=float)
    if total <= 0 or weights.sum() <= 0:
        return np.zeros(len(weights), np.int64)
    exact = total * weights / weights.sum()
    base = np.floor(exact).astype(np.int64)
    rest = total - base.sum()
    order = np.argsort(-(exact - base), kind="stable")
    base[order[:rest]] += 1
    return base


def synthetic_budget(
    counts: np.ndarray, alpha: float, policy: str = "uniform", tail: tuple[int, ...] | None = None
) -> np.ndarray:
    """Synthetic windows per class: round(alpha x real windows) in total, spread by policy.

    uniform: like the real class distribution; tail: evenly over the tail
    classes (the lower half of classes ranked by count, unless given);
    scarcity: proportional to 1 / (real windows of the class). Classes with
    no real training window get none.
    """
    counts = np.asarray(counts, dtype=np.int64)
    if policy not in BUDGET_POLICIES:
        raise ConfigError(
            f"unknown budget policy '{policy}'", field="policy", allowed=", ".join(BUDGET_POLICIES)
        )
    total = int(round(alpha * counts.sum()))
    present = counts > 0
    if policy == "uniform":
        weights = counts.astype(float)
    elif policy == "tail":
        tail = tail if tail is not None else head_tail(counts)[1]
        weights = np.zeros(len(counts))
        weights[list(tail)] = 1.0
        weights = weights * present
    else:
        weights = np.where(present, 1.0 / np.maximum(counts, 1), 0.0)
    return apportion(total, weights)


def unseen_budget(
    counts: np.ndarray, alpha: float, policy: str, unseen: tuple[int, ...]
) -> np.ndarray:
    """The synthetic budget of the unseen protocol. Seen classes: `synthetic_budget` of their
    real windows (none with the `tail` policy: the unseen classes are the tail). Each unseen
    class (no real window): round(alpha x the median real windows of a seen class), as many
    as a typical seen class would get under the uniform policy."""
    counts = np.asarray(counts, dtype=np.int64).copy()
    counts[list(unseen)] = 0
    seen = counts[counts > 0]
    budget = (np.zeros(len(counts), np.int64) if policy == "tail"
              else synthetic_budget(counts, alpha, policy))
    if len(seen):
        budget[list(unseen)] = int(round(alpha * float(np.median(seen))))
    return budget


def take_budget(synthetic: Windows, budget: np.ndarray, rng: np.random.Generator) -> Windows:
    """At most `budget[c]` windows of each class c (a seeded subset when a source made more)."""
    keep = []
    for c, n in enumerate(budget):
        idx = np.flatnonzero(synthetic.y == c)
        if len(idx) > n:
            idx = np.sort(rng.choice(idx, size=int(n), replace=False))
        keep.append(idx)
    return synthetic[np.sort(np.concatenate(keep))] if keep else synthetic[:0]


def check_synthetic(real: Windows, synthetic: Windows, method: str) -> None:
    """Raise unless a source's windows fit the dataset (channels, rate, length, labels)."""
    if not isinstance(synthetic, Windows):
        raise ValidationError(
            f"method '{method}' returned {type(synthetic).__name__}, expected Windows",
            field="methods",
        )
    check_compatible(real, synthetic, what=f"synthetic windows of method '{method}'")
    if len(synthetic) and not np.isfinite(synthetic.X).all():
        raise ValidationError(
            f"synthetic windows of method '{method}' contain NaN or inf", field="methods"
        )


# `mix` gives every synthetic window the subject `synthetic:<method>`
SYNTHETIC_TAG = "synthetic:"


def is_synthetic(windows: Windows) -> np.ndarray:
    """Per window: whether `mix` tagged it synthetic (its subject is `synthetic:<method>`)."""
    return np.char.startswith(windows.subjects.astype(str), SYNTHETIC_TAG)


def mix(real: Windows, synthetic: Windows, method: str) -> Windows:
    """Real training windows followed by synthetic ones (subjects tagged `synthetic:<method>`)."""
    tagged = Windows(
        synthetic.X,
        synthetic.y,
        np.full(len(synthetic), f"{SYNTHETIC_TAG}{method}"),
        synthetic.label_names,
        synthetic.channel_names,
        synthetic.fs_hz,
        meta={"source": np.full(len(synthetic), method)},
    )
    real = real.with_meta(source=np.full(len(real), "real"))
    return concat_windows([real, tagged])
