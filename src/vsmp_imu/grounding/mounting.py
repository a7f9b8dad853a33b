"""The nominal dataset mounting frame R_target of the grounding prior, from training data.

Paper, appendix "Rank-Based Sensor Grounding": the target mounting transform
is the "nominal dataset mounting frame" with bounded Euler perturbations.
Datasets declare which way their axes point, but not how a phone sits on the
belt (tilted, turned to the side). That nominal frame is estimated here from
the fold's D_stat only: the rotation that best maps the mean specific force
of each class in synthetic motions (segment frame) onto the mean of the real
windows of the same class (expressed in the segment frame through the declared
axes) - Wahba's problem, solved with scipy's Kabsch implementation. Class
means are dominated by gravity, so static and quasi-static classes anchor it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

MIN_MEAN_NORM = 3.0  # m/s^2: a class mean weaker than this carries no gravity direction


def mounting_classes(items: list, single) -> list:
    """The classes a mounting is fitted on: those that hold a posture or repeat a rhythm where at
    least two have evidence, else every class. `single(item)`: the class is one execution of a
    discrete activity (a transition), whose mean depends on how long each of its phases lasts."""
    held = [item for item in items if not single(item)]
    return held if len(held) >= 2 else list(items)


def estimate_mounting(synthetic_means: np.ndarray, real_means: np.ndarray,
                      weights: np.ndarray | None = None) -> tuple[Rotation, float]:
    """Rotation R with R @ synthetic ~ real (both (C, 3), segment frame) and its rms residual angle (deg).

    Classes whose means are weaker than MIN_MEAN_NORM on either side are left
    out; with fewer than two usable classes the identity is returned.
    """
    syn = np.asarray(synthetic_means, dtype=float)
    real = np.asarray(real_means, dtype=float)
    w = np.ones(len(syn)) if weights is None else np.asarray(weights, dtype=float)
    use = (np.linalg.norm(syn, axis=1) > MIN_MEAN_NORM) & (np.linalg.norm(real, axis=1) > MIN_MEAN_NORM) & (w > 0)
    if use.sum() < 2:
        return Rotation.identity(), float("nan")
    a = real[use] / np.linalg.norm(real[use], axis=1, keepdims=True)
    b = syn[use] / np.linalg.norm(syn[use], axis=1, keepdims=True)
    rot, _ = Rotation.align_vectors(a, b, weights=w[use])
    cos = np.clip(np.sum(rot.apply(b) * a, axis=1), -1.0, 1.0)
    rms = float(np.sqrt(np.average(np.degrees(np.arccos(cos)) ** 2, weights=w[use])))
    return rot, rms
