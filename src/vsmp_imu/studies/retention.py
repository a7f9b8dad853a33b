"""Activity-label retention: does a controlled motion still resolve to its activity?

The paper has two annotators judge each generated motion blind to the
requested condition. Here that judgement is replaced by a nearest-template
classifier on motion features: templates are default executions (the library
SMP, medium tempo and amplitude) of every candidate activity with held-out
seeds, and a motion retains its label when its nearest template belongs to
its own activity. It measures whether an intervention moved a motion closer
to another activity than to its own, not whether a person would still name
it correctly.

The features describe *what* moves and *where*, not how fast or how far:
the mean posture of every joint (pelvis-relative, in the body's heading
frame, divided by body height) and the share of the total movement carried
by each joint axis (per-axis standard deviations normalized to sum 1), so
a slower, larger or longer execution of the same activity keeps them
(amplitude changes the posture somewhat: a very small execution may come
closer to a neighbouring activity, which is what the measure should see).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from vsmp_imu.errors import ValidationError
from vsmp_imu.har.windows import window_geometry, window_starts
from vsmp_imu.motion.measure import joint_trajectories
from vsmp_imu.motion.motion import Motion


def motion_signature(motion: Motion) -> np.ndarray:
    """(2 * J * 3,) mean posture and movement shares of every joint, body-size free.

    The first half is the posture block, the second the movement-share block.
    """
    traj = joint_trajectories(motion, motion.joint_names) / max(motion.body_height_m(), 1e-6)
    posture = traj.mean(axis=0).ravel()
    spread = traj.std(axis=0).ravel()
    shares = spread / max(float(spread.sum()), 1e-12)
    return np.concatenate([posture, shares])


class NearestTemplate:
    """fit(templates, labels) then predict(features): the label of the nearest template.

    Features come in `n_blocks` equal blocks (posture, movement shares). Each
    block is divided by the mean distance between templates of different
    labels within that block, so every block weighs the same however its
    units are; distances are Euclidean. Nothing is fitted on the motions to
    be classified.
    """

    def __init__(self, n_blocks: int = 2) -> None:
        self.n_blocks = n_blocks

    def _blocks(self, features: np.ndarray) -> list[np.ndarray]:
        if features.shape[1] % self.n_blocks:
            raise ValidationError(f"{features.shape[1]} features do not split into {self.n_blocks} "
                                  "equal blocks", field="features")
        return np.split(features, self.n_blocks, axis=1)

    def fit(self, features: np.ndarray, labels: Sequence[str]) -> NearestTemplate:
        features = np.asarray(features, dtype=float)
        if features.ndim != 2 or len(features) != len(labels) or len(features) == 0:
            raise ValidationError("need one feature row per template label", field="templates")
        self.labels_ = np.asarray(list(labels))
        if len(set(self.labels_.tolist())) < 2:
            raise ValidationError("templates of at least two activities are needed", field="templates")
        other = self.labels_[:, None] != self.labels_[None, :]
        self.block_scale_ = []
        for block in self._blocks(features):
            dist = np.linalg.norm(block[:, None, :] - block[None, :, :], axis=-1)
            self.block_scale_.append(1.0 / max(float(dist[other].mean()), 1e-12))
        self.templates_ = self._scaled(features)
        return self

    def _scaled(self, features: np.ndarray) -> np.ndarray:
        blocks = self._blocks(np.atleast_2d(np.asarray(features, dtype=float)))
        return np.concatenate([b * w for b, w in zip(blocks, self.block_scale_, strict=True)], axis=1)

    def distances(self, features: np.ndarray) -> np.ndarray:
        """(N, n_templates) distances in block-scaled units."""
        z = self._scaled(features)
        return np.linalg.norm(z[:, None, :] - self.templates_[None, :, :], axis=-1)

    def predict(self, features: np.ndarray) -> np.ndarray:
        return self.labels_[np.argmin(self.distances(features), axis=1)]


def cut_windows(x: np.ndarray, fs_hz: float, window_s: float, overlap: float = 0.5) -> np.ndarray:
    """(N, T, C) windows of a (T, C) recording; a recording shorter than one window gives one,
    padded by repeating its last sample (as the UTD-MHAD loader does)."""
    size, step = window_geometry(fs_hz, window_s, overlap)
    x = np.asarray(x, dtype=float)
    if len(x) < size:
        x = np.concatenate([x, np.repeat(x[-1:], size - len(x), axis=0)])
    starts = window_starts(len(x), size, step)
    return np.stack([x[s: s + size] for s in starts])
