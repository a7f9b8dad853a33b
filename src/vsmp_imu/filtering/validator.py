"""The lightweight HAR validator of the quality filter.

Paper, "Quality filtering": a validator trained only on the fold's real
training windows, separate from the downstream model. Here it is a small
multilayer perceptron on the ECDF window features (fast to train on a CPU,
deterministic), whose last hidden layer is the penultimate-layer embedding
phi(.) used by the redundancy filter.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.exceptions import ConvergenceWarning
from sklearn.neural_network import MLPClassifier
from sklearn.preprocessing import StandardScaler

from vsmp_imu.har.features import ecdf_features


class HarValidator:
    """fit(X, y) on real windows (N, T, C); predict_proba, embed (penultimate features).

    Each method has a `*_features` twin taking the ECDF features of the windows
    (`vsmp_imu.har.features.ecdf_features`), so a caller that needs them several
    times computes them once.
    """

    def __init__(self, hidden: tuple[int, ...] = (64, 32), max_iter: int = 200, seed: int = 0) -> None:
        self.hidden = hidden
        self.max_iter = max_iter
        self.seed = seed

    def fit(self, X: np.ndarray, y: np.ndarray, n_classes: int | None = None) -> HarValidator:
        return self.fit_features(ecdf_features(X), y, n_classes)

    def fit_features(self, feats: np.ndarray, y: np.ndarray, n_classes: int | None = None) -> HarValidator:
        y = np.asarray(y)
        self.n_classes_ = int(n_classes if n_classes is not None else y.max() + 1)
        self.scaler_ = StandardScaler().fit(feats)
        self.model_ = MLPClassifier(
            hidden_layer_sizes=self.hidden, max_iter=self.max_iter, random_state=self.seed,
            alpha=1e-3, early_stopping=False,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            self.model_.fit(self.scaler_.transform(feats), y)
        return self

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """(N, n_classes) probabilities; classes absent from training get 0."""
        return self.predict_proba_features(ecdf_features(X))

    def predict_proba_features(self, feats: np.ndarray) -> np.ndarray:
        proba = self.model_.predict_proba(self.scaler_.transform(feats))
        out = np.zeros((len(proba), self.n_classes_))
        if len(self.model_.classes_) == 1:  # sklearn gives two columns here; the one class it knows is certain
            out[:, self.model_.classes_[0]] = 1.0
        else:
            out[:, self.model_.classes_] = proba
        return out

    def embed(self, X: np.ndarray) -> np.ndarray:
        """Last hidden-layer activations (ReLU), (N, hidden[-1])."""
        return self.embed_features(ecdf_features(X))

    def embed_features(self, feats: np.ndarray) -> np.ndarray:
        h = self.scaler_.transform(feats)
        for w, b in zip(self.model_.coefs_[:-1], self.model_.intercepts_[:-1], strict=True):
            h = np.maximum(h @ w + b, 0.0)
        return h
