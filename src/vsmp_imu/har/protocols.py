"""LOPO protocols (paper, Experimental Setup, Protocols): standard, low-resource,
long-tail and `unseen` (classes with no real training window); validation subjects
drawn from the training subjects of each fold. `tstr` (train on synthetic, test on
real) splits as `lopo` without validation subjects: the synthetic source sees every
training subject, and the model trains on its windows only; with a label budget the
source sees the same share of each class's windows as low-resource would."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from vsmp_imu.errors import ConfigError, ValidationError
from vsmp_imu.har.windows import Windows, natural_key
from vsmp_imu.seeding import rng_for

PROTOCOLS = ("lopo", "low-resource", "long-tail", "unseen", "tstr")
# `--unseen each`: every class unseen in turn (leave-one-class-out).
EACH_CLASS = "each"
# Label budgets of the low-resource protocol, percent of labelled training windows.
DEFAULT_BUDGETS = (1.0, 5.0, 10.0, 25.0, 50.0)
# Protocols that take label budgets (tstr: none by default, the whole pool).
BUDGETED = ("low-resource", "tstr")
# The smallest label budget, percent. A class keeps at least one window whatever the budget, and
# below 0.01 % only a class of over 5000 windows (none of the datasets we load) keeps more: every
# smaller budget is this one under another name (on HAPT12 every class is down to 1 window).
MIN_BUDGET = 0.01
BUDGETS_ALLOWED = f"percentages in [{MIN_BUDGET:g}, 100], e.g. 1,5,10,25,50"
# Maximum head-to-tail imbalance ratio of the long-tail protocol.
DEFAULT_RHO = 10.0
# The largest ratio: a class keeps at least one window, so a ratio above the largest class's
# windows is not delivered (HAPT12's largest pool class has ~2450; at 1e12 six classes of a fold
# are down to their 1 window and 26 of 30 folds train without some class). At 1000 HAPT12's
# tail keeps 2 windows; a dataset with fewer windows reaches the 1-window floor sooner.
MAX_RHO = 1000.0
DEFAULT_VAL_FRACTION = 0.2


def require_two_subjects(subjects: list[str], dataset) -> None:
    """Leave-one-subject-out needs a subject to hold out and at least one to train on."""
    if len(subjects) < 2:
        info = dataset.info
        raise ValidationError(
            f"dataset '{info.name}' has {len(subjects)} subject(s) with labelled windows "
            f"({', '.join(subjects) or 'none'}); leave-one-subject-out evaluation holds one out and "
            "trains on the others", file=getattr(dataset, "yaml_path", None), field="subject",
            allowed="a dataset with at least 2 subjects")


def require_two_classes(windows: Windows, dataset) -> None:
    """A classifier needs windows of at least two classes to tell apart."""
    names = [n for n, c in zip(windows.label_names, windows.class_counts(), strict=True) if c > 0]
    if len(names) < 2:
        raise ValidationError(
            f"dataset '{dataset.info.name}' has labelled windows of {len(names)} class(es) "
            f"({', '.join(names) or 'none'}); a classifier needs at least 2 classes to tell apart",
            file=getattr(dataset, "yaml_path", None), field="labels",
            allowed="a dataset with windows of at least 2 classes")


@dataclass
class FoldSplit:
    """The windows of one fold: `fit` (trains the model), `val` (early stopping and
    threshold selection; subjects disjoint from `fit`), `test` (the held-out subject).
    `head`/`tail` are class indices (long-tail protocol only); `unseen` the class indices
    without any real training window (unseen protocol only: their windows are in `test` only)."""

    fold: str
    fit: Windows
    val: Windows
    test: Windows
    val_subjects: tuple[str, ...]
    head: tuple[int, ...] | None = None
    tail: tuple[int, ...] | None = None
    unseen: tuple[int, ...] | None = None


def check_protocol(protocol: str, field: str = "protocol") -> str:
    if protocol not in PROTOCOLS:
        raise ConfigError(
            f"unknown protocol '{protocol}'", field=field, allowed=", ".join(PROTOCOLS)
        )
    return protocol


def subsample_per_class(windows: Windows, keep: np.ndarray, rng: np.random.Generator) -> Windows:
    """Keep `keep[c]` windows of each class c, drawn without replacement; order preserved."""
    chosen = []
    for c, k in enumerate(keep):
        idx = np.flatnonzero(windows.y == c)
        k = int(min(k, len(idx)))
        if k > 0:
            chosen.append(rng.choice(idx, size=k, replace=False))
    sel = np.sort(np.concatenate(chosen)) if chosen else np.zeros(0, np.int64)
    return windows[sel]


def low_resource_counts(counts: np.ndarray, budget_percent: float) -> np.ndarray:
    """Windows kept per class: round(budget% of the class), at least 1 for present classes."""
    keep = np.round(counts * budget_percent / 100.0).astype(np.int64)
    return np.where(counts > 0, np.maximum(keep, 1), 0)


def rank_classes(counts: np.ndarray) -> np.ndarray:
    """Class indices of present classes by decreasing count (ties: lower index first)."""
    present = np.flatnonzero(counts > 0)
    order = sorted(present.tolist(), key=lambda c: (-counts[c], c))
    return np.asarray(order, dtype=np.int64)


def long_tail_counts(counts: np.ndarray, rho: float = DEFAULT_RHO) -> np.ndarray:
    """n_r = n_max * rho^(-(r-1)/(C-1)) for the class of rank r (paper, Long-tail LOPO),
    rounded, at least 1, never more than the class has."""
    ranked = rank_classes(counts)
    keep = np.zeros_like(counts)
    n_classes = len(ranked)
    if n_classes == 0:
        return keep
    n_max = counts[ranked[0]]
    for r, c in enumerate(ranked, start=1):
        exponent = (r - 1) / (n_classes - 1) if n_classes > 1 else 0.0
        keep[c] = min(counts[c], max(1, int(round(n_max * rho ** (-exponent)))))
    return keep


def head_tail(counts: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
    """Head = upper half of the ranked classes (floor(C/2)), tail = the rest."""
    ranked = rank_classes(counts).tolist()
    n_head = len(ranked) // 2
    return tuple(ranked[:n_head]), tuple(ranked[n_head:])


def choose_val_subjects(
    subjects: list[str], seed: int, fold: str, val_fraction: float = DEFAULT_VAL_FRACTION
) -> tuple[str, ...]:
    """Validation subjects drawn (seeded) from the training subjects: round(fraction x n),
    at least 1, never all of them. None when fewer than 2 training subjects."""
    subjects = sorted(set(subjects), key=natural_key)
    if len(subjects) < 2 or val_fraction <= 0:
        return ()
    n_val = min(len(subjects) - 1, max(1, int(round(val_fraction * len(subjects)))))
    rng = rng_for(seed, "validation-subjects", fold)
    return tuple(sorted(rng.choice(subjects, size=n_val, replace=False).tolist(), key=natural_key))


def split_fold(
    windows: Windows,
    fold: str,
    protocol: str,
    seed: int,
    budget_percent: float | None = None,
    rho: float = DEFAULT_RHO,
    val_fraction: float = DEFAULT_VAL_FRACTION,
    unseen: Sequence[int] | None = None,
) -> FoldSplit:
    """The windows of one LOPO fold under a protocol.

    1. test = the held-out subject's windows; the pool = every other subject's.
    2. The protocol subsamples the pool (low-resource, and tstr with a budget: budget% per class;
       long-tail: n_r per class rank), seeded per (seed, fold, budget);
       unseen: every window of the `unseen` classes leaves the pool.
    3. Validation subjects are drawn from the pool's subjects; fit = the rest
       (tstr: none, fit = the whole pool).
    The held-out subject's windows appear in `test` only.
    """
    check_protocol(protocol)
    val_fraction = 0.0 if protocol == "tstr" else val_fraction
    fold = str(fold)
    test = windows.where_subjects([fold])
    pool = windows.where_subjects([fold], keep=False)
    head = tail = None
    counts = pool.class_counts()
    if protocol == "low-resource" or (protocol == "tstr" and budget_percent is not None):
        if budget_percent is None or not MIN_BUDGET <= budget_percent <= 100:
            raise ConfigError(
                f"label budget {budget_percent} out of range",
                field="budgets",
                allowed=f"{MIN_BUDGET:g} <= budget <= 100 (percent)",
            )
        rng = rng_for(seed, "low-resource", fold, f"{budget_percent:g}")
        pool = subsample_per_class(pool, low_resource_counts(counts, budget_percent), rng)
    elif protocol == "long-tail":
        rng = rng_for(seed, "long-tail", fold)
        pool = subsample_per_class(pool, long_tail_counts(counts, rho), rng)
        head, tail = head_tail(pool.class_counts())
    elif protocol == "unseen":
        unseen = check_unseen_indices(unseen, windows.label_names)
        pool = pool[~np.isin(pool.y, unseen)]
    val_subjects = choose_val_subjects(pool.unique_subjects(), seed, fold, val_fraction)
    val = pool.where_subjects(val_subjects)
    fit = pool.where_subjects(val_subjects, keep=False)
    return FoldSplit(
        fold=fold, fit=fit, val=val, test=test, val_subjects=val_subjects, head=head, tail=tail,
        unseen=tuple(unseen) if protocol == "unseen" else None,
    )


def check_unseen_indices(unseen: Sequence[int] | None, label_names: Sequence[str]) -> tuple[int, ...]:
    """The unseen protocol's class indices: at least one, never every class."""
    unseen = tuple(sorted({int(c) for c in unseen or ()}))
    if not unseen or len(unseen) >= len(label_names) or unseen[0] < 0 or unseen[-1] >= len(label_names):
        raise ConfigError(
            f"the unseen protocol needs between 1 and {len(label_names) - 1} unseen classes "
            f"(got {len(unseen)})", field="--unseen", allowed=", ".join(label_names))
    return unseen


def resolve_unseen(
    text: str | Sequence[str], label_names: Sequence[str], groups: Mapping[str, Sequence[str]]
) -> tuple[tuple[str, ...], ...]:
    """The unseen class sets of `--unseen`: classes and group names (comma-separated) make one
    set; `each` makes one set per class (leave-one-class-out). Names in dataset order."""
    items = [t.strip() for t in (text.split(",") if isinstance(text, str) else text) if t.strip()]
    names = list(label_names)
    allowed = ", ".join([EACH_CLASS, *groups, *names])
    if items == [EACH_CLASS]:
        return tuple((name,) for name in names)
    chosen: set[str] = set()
    for item in items:
        if item == EACH_CLASS:
            raise ConfigError("'each' cannot be combined with class names", field="--unseen",
                              allowed=allowed)
        if item in groups:
            chosen.update(groups[item])
        elif item in names:
            chosen.add(item)
        else:
            raise ConfigError(f"unknown class or group '{item}'", field="--unseen", allowed=allowed)
    check_unseen_indices([names.index(n) for n in chosen if n in names], names)
    return (tuple(n for n in names if n in chosen),)


def parse_budgets(text: str | None, protocol: str) -> tuple[float | None, ...]:
    """Budgets for a protocol: percent values for low-resource (the defaults when none are given)
    and for tstr (none given: the whole pool, (None,)); (None,) otherwise."""
    if protocol not in BUDGETED or (protocol == "tstr" and not text):
        return (None,)
    if not text:
        return DEFAULT_BUDGETS
    values = []
    for item in text.split(","):
        item = item.strip().rstrip("%")
        if not item:
            continue
        try:
            value = float(item)
        except ValueError:
            raise ConfigError(
                f"'{item}' is not a number",
                field="--budgets",
                allowed=BUDGETS_ALLOWED,
            ) from None
        if not MIN_BUDGET <= value <= 100:  # NaN fails it
            raise ConfigError(
                f"label budget {item} out of range",
                field="--budgets",
                allowed=BUDGETS_ALLOWED,
            )
        values.append(value)
    if not values:
        raise ConfigError(
            "no label budget given",
            field="--budgets",
            allowed=BUDGETS_ALLOWED,
        )
    return tuple(dict.fromkeys(values))
