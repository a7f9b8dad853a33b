"""Split the fold's real training windows into D_stat and D_rank.

Paper, appendix "Simulation-in-the-Loop Optimization": a stratified 50/50 split
per activity class; classes with too few windows are split as evenly as
possible. The two halves are disjoint.
"""

from __future__ import annotations

import numpy as np

from vsmp_imu.seeding import rng_for


def stat_rank_split(labels: np.ndarray, seed: int, fraction: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Indices (stat_idx, rank_idx) of a per-class stratified split.

    A class with n windows gives ceil(n * fraction) to D_stat and the rest to
    D_rank, so a single-window class lands in D_stat and every other class is
    split as evenly as possible.
    """
    labels = np.asarray(labels)
    stat, rank = [], []
    for cls in np.unique(labels):
        idx = np.flatnonzero(labels == cls)
        idx = idx[rng_for(seed, "stat_rank_split", int(cls)).permutation(idx.size)]
        n_stat = int(np.ceil(idx.size * fraction))
        stat.append(idx[:n_stat])
        rank.append(idx[n_stat:])
    stat_idx = np.sort(np.concatenate(stat)) if stat else np.array([], dtype=int)
    rank_idx = np.sort(np.concatenate(rank)) if rank else np.array([], dtype=int)
    return stat_idx, rank_idx
