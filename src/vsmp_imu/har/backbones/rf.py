"""Random Forest on ECDF features (paper: RF backbone, appendix ECDF features),
and the same forest with the window's segment means added (`rf-seg`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.ensemble import RandomForestClassifier

from vsmp_imu.har.features import N_LEVELS, ecdf_features, segment_means


@dataclass(eq=False, repr=False)
class RandomForestECDF(ClassifierMixin, BaseEstimator):
    """scikit-learn Random Forest on K ECDF levels per channel.

    `fit(X, y, X_val=None, y_val=None, sample_weight=None)`: the validation windows
    are not needed by a forest and are ignored; `sample_weight` weighs each window
    in the splits, on top of `class_weight`. `embed(X)` returns the ECDF features, the
    representation the forest sees. `uses_validation = False`: the harness
    gives a forest the validation subjects' windows as training data.
    """

    uses_validation = False

    n_levels: int = N_LEVELS
    n_estimators: int = 100
    max_features: str | float = "sqrt"
    min_samples_leaf: int = 1
    class_weight: str | None = None
    n_jobs: int | None = -1
    random_state: int = 0

    @classmethod
    def _get_test_params(cls) -> dict:
        return {"n_estimators": 10, "n_jobs": 1}

    def fit(
        self,
        X: np.ndarray,
        y: np.ndarray,
        X_val: np.ndarray | None = None,
        y_val: np.ndarray | None = None,
        sample_weight: np.ndarray | None = None,
    ) -> RandomForestECDF:
        self.forest_ = RandomForestClassifier(
            n_estimators=self.n_estimators,
            max_features=self.max_features,
            min_samples_leaf=self.min_samples_leaf,
            class_weight=self.class_weight,
            n_jobs=self.n_jobs,
            random_state=self.random_state,
        )
        self.forest_.fit(self.embed(X), np.asarray(y), sample_weight=sample_weight)
        self.classes_ = self.forest_.classes_
        return self

    def embed(self, X: np.ndarray) -> np.ndarray:
        return ecdf_features(X, self.n_levels)

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        return self.forest_.predict_proba(self.embed(X))

    def predict(self, X: np.ndarray) -> np.ndarray:
        return self.classes_[np.argmax(self.predict_proba(X), axis=1)]


# Eight parts of a 2 s window, 0.25 s each: the best of 2, 4 and 8 in an offline
# probe on the unseen transitions (docs/results.md "A forest that sees the
# window's course").
SEGMENTS = 8


@dataclass(eq=False, repr=False)
class RandomForestSegments(RandomForestECDF):
    """`rf-seg`: the ECDF forest with each channel's means over 8 parts of the
    window, so the order of a window's values (stand-to-sit against
    sit-to-stand) is visible to it."""

    n_segments: int = SEGMENTS

    def embed(self, X: np.ndarray) -> np.ndarray:
        return np.concatenate([ecdf_features(X, self.n_levels), segment_means(X, self.n_segments)], axis=1)
